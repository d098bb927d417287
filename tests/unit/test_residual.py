"""Residual policies (``residual_of: scripted``, training/residual.py, baselines/learned.py): the
network's action corrects the scripted reference's; a zero correction is the reference bit for bit,
in training (the env wrapper) and at run time (the policy file), and a run starts there."""

import hashlib

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

from petswarm.baselines.leader_follower import LeaderFollowerPolicy
from petswarm.baselines.learned import LearnedPolicy, Residual, read_policy_file, save_policy
from petswarm.baselines.policy import PolicySpec
from petswarm_env.config import ConfigError, load_config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.wrappers import FixedAgents
from petswarm.training.config import load_train_config
from petswarm.training.export import learned_policy
from petswarm.training.residual import ResidualActions, zero_action_head
from petswarm.training.train import build_model, train
from petswarm.training.vec_env import make_vec_env

CFG = {"max_cycles": 120, "world.num_users": 2}  # two swarms: robots of several members and both users


def _episode_hash(env, choose, seed=3):
    """sha256 of every step's observations of an episode of ``env`` (a FixedAgents env) driven by
    ``choose(observations, infos)``."""
    obs, infos = env.reset(seed=seed)
    h = hashlib.sha256()
    while env.agents:
        obs, _, _, _, infos = env.step(choose(obs, infos))
        for a in sorted(obs):
            h.update(np.asarray(obs[a], np.float32).tobytes())
    return h.hexdigest()


def _scripted_hash():
    env = FixedAgents(PetSwarmEnv(load_config(overrides=CFG)))
    ref = LeaderFollowerPolicy(PolicySpec.from_env(env.env))
    return _episode_hash(env, lambda o, i: {a: ref.act(a, o[a]) for a in o if i[a]["active"]})


def _layers(size, last_bias=(0.0, 0.0, 0.0)):
    rng = np.random.default_rng(0)
    return [(rng.normal(size=(8, size)), rng.normal(size=8)), (np.zeros((3, 8)), np.asarray(last_bias, float))]


def test_a_zero_correction_in_the_training_wrapper_is_the_scripted_episode_bit_for_bit():
    env = ResidualActions(FixedAgents(PetSwarmEnv(load_config(overrides=CFG))))
    zero = _episode_hash(env, lambda o, i: {a: np.zeros(3, np.float32) for a in o})
    assert zero == _scripted_hash()
    push = _episode_hash(env, lambda o, i: {a: np.array([0.3, 0.0, 0.0], np.float32) for a in o})
    assert push != zero  # the correction is applied


def test_the_wrapper_sends_the_clipped_sum_for_live_robots_only():
    # mode_change: the master of the start, a possible agent for when it joins as a slave, is padding now
    env = ResidualActions(FixedAgents(PetSwarmEnv(load_config(overrides={"user.scenario": "mode_change"}))))
    obs, infos = env.reset(seed=5)
    sent = {}
    inner_step = env.env.step
    env.env.step = lambda actions: (sent.update(actions), inner_step(actions))[1]
    live = [a for a in obs if infos[a]["active"]]
    idle = [a for a in obs if not infos[a]["active"]]
    assert live and idle
    env.step({a: np.array([5.0, -5.0, 0.25], np.float32) for a in obs})
    for a in live:
        expected = np.clip(env.base.act(a, obs[a]) + np.array([1.0, -1.0, 0.25], np.float32), -1.0, 1.0)
        assert np.array_equal(sent[a], expected)
    for a in idle:
        assert np.array_equal(sent[a], [5.0, -5.0, 0.25])  # untouched: FixedAgents drops them


def test_a_residual_policy_file_with_a_zero_last_layer_drives_as_the_scripted_reference(tmp_path):
    env = PetSwarmEnv(load_config(overrides=CFG))
    spec = PolicySpec.from_env(env)
    save_policy(tmp_path / "res.npz", _layers(spec.layout.size), "tanh", spec.layout, residual=Residual("scripted"))
    meta, _ = read_policy_file(tmp_path / "res.npz")
    assert meta["residual_of"] == "scripted" and meta["residual_scale"] == 1.0
    policy = LearnedPolicy.load(tmp_path / "res.npz", spec)
    fixed = FixedAgents(PetSwarmEnv(load_config(overrides=CFG)))
    assert _episode_hash(fixed, lambda o, i: policy.act_all({a: o[a] for a in o if i[a]["active"]})) == _scripted_hash()
    # a correction adds to the reference's action, clipped
    save_policy(tmp_path / "bias.npz", _layers(spec.layout.size, (0.5, -3.0, 0.0)), "tanh", spec.layout, residual=Residual("scripted"))
    shifted = LearnedPolicy.load(tmp_path / "bias.npz", spec)
    ref = LeaderFollowerPolicy(spec)
    obs, _ = env.reset(seed=1)
    for a, o in obs.items():
        assert np.array_equal(shifted.act(a, o), np.clip(ref.act(a, o) + np.float32([0.5, -1.0, 0.0]), -1.0, 1.0))
        assert np.array_equal(shifted.act_all({a: o})[a], shifted.act(a, o))
    # the scale bounds the correction: 0.2 x clip(0.5, -3, 0)
    save_policy(tmp_path / "scaled.npz", _layers(spec.layout.size, (0.5, -3.0, 0.0)), "tanh", spec.layout,
                residual=Residual("scripted", 0.2))
    scaled = LearnedPolicy.load(tmp_path / "scaled.npz", spec)
    for a, o in obs.items():
        assert np.array_equal(scaled.act(a, o), np.clip(ref.act(a, o) + np.float32([0.5, -1.0, 0.0]) * np.float32(0.2), -1.0, 1.0))
    # a file without the field is a plain MLP (every file written before it)
    save_policy(tmp_path / "plain.npz", _layers(spec.layout.size), "tanh", spec.layout)
    assert "residual_of" not in read_policy_file(tmp_path / "plain.npz")[0]
    plain = LearnedPolicy.load(tmp_path / "plain.npz", spec)
    assert plain.base is None and np.array_equal(plain.act("robot_1", obs["robot_1"]), np.zeros(3, np.float32))


def test_the_config_refuses_a_warm_start_or_an_unknown_base_for_a_residual_policy():
    with pytest.raises(ConfigError, match=r"residual_of: scripted.*pretrain.samples: 0 \(got 400\)"):
        load_train_config(overrides={"residual_of": "scripted", "pretrain.samples": 400})
    with pytest.raises(ConfigError, match="residual_of"):
        load_train_config(overrides={"residual_of": "random", "pretrain.samples": 0})
    with pytest.raises(ConfigError, match="residual_scale"):
        load_train_config(overrides={"residual_of": "scripted", "pretrain.samples": 0, "residual_scale": 1.5})
    with pytest.raises(ConfigError, match="residual_scale: 0.5 bounds .* residual_of is null"):
        load_train_config(overrides={"residual_scale": 0.5})
    with pytest.raises(ValueError, match="residual_scale"):
        Residual("scripted", 0.0)
    assert load_train_config("configs/train/residual.yaml").residual() == Residual("scripted", 0.2)


TINY = {"timesteps": 96, "num_envs": 1, "num_cpus": 0, "ppo.n_steps": 16, "ppo.batch_size": 32, "ppo.n_epochs": 2,
        "ppo.net_arch": [8], "env.max_cycles": 20, "eval.episodes": 1, "eval.max_cycles": 10, "eval.every_steps": 1000,
        "checkpoint.every_steps": 1000, "pretrain.samples": 0, "residual_of": "scripted", "residual_scale": 0.2,
        "ppo.learning_rate": 0.01}


def test_a_residual_run_starts_at_the_reference_and_exports_a_residual_policy(tmp_path):
    cfg = load_train_config(overrides=TINY)
    log = train(cfg, tmp_path / "run", progress_bar=False)
    assert log["timesteps"] >= 96
    meta, layers = read_policy_file(tmp_path / "run" / "policy.npz")
    assert meta["residual_of"] == "scripted" and meta["residual_scale"] == 0.2 and np.any(layers[-1][0] != 0)  # PPO moved the head off zero
    # the start: a fresh model with the head zeroed (as train() does) acts as the reference
    env_cfg = cfg.env_config()
    venv = make_vec_env(env_cfg, 1, 0, cfg.seed, residual=Residual("scripted", 0.2))
    try:
        model = build_model(cfg.ppo, venv, cfg.seed)
        zero_action_head(model.policy.action_net.weight, model.policy.action_net.bias)
        env = PetSwarmEnv(env_cfg)
        spec = PolicySpec.from_env(env)
        start, ref = learned_policy(model, spec, cfg.ppo.activation, Residual("scripted", 0.2)), LeaderFollowerPolicy(spec)
        obs, _ = env.reset(seed=2)
        assert all(np.array_equal(start.act(a, o), ref.act(a, o)) for a, o in obs.items())
    finally:
        venv.close()
