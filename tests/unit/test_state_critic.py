"""The centralized critic (training/state_critic.py, ``ppo.critic: state``): the actor reads the
observation, the critic the observation and the state; a few PPO steps train, and the exported
policy.npz holds the actor alone, which `petswarm eval` loads."""

import numpy as np
import pytest
import torch

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

from stable_baselines3.common.logger import Logger

from petswarm.baselines.learned import read_policy_file
from petswarm.cli.main import main
from petswarm_env.env import PetSwarmEnv
from petswarm.training.callbacks import PeriodicCallback
from petswarm.training.config import load_train_config
from petswarm.training.train import build_model
from petswarm.training.vec_env import make_vec_env

TINY = {"num_envs": 1, "num_cpus": 0, "ppo.n_steps": 16, "ppo.batch_size": 48, "ppo.n_epochs": 2, "ppo.net_arch": [8],
        "ppo.critic": "state", "env.max_cycles": 20, "eval.episodes": 1, "eval.max_cycles": 10,
        "randomize.swarm.num_slaves": [2, 3], "randomize.swarm.formation": ["wedge", "column"]}


def test_the_state_critic_trains_and_exports_only_its_actor(tmp_path, capsys):
    cfg = load_train_config(overrides=TINY)
    layout = PetSwarmEnv(cfg.env_config()).layout
    venv = make_vec_env(cfg.env_config(), 1, 0, cfg.seed, cfg.randomize, cfg.env, with_state=True)
    try:
        rows = venv.observation_space.shape[0]
        assert rows > layout.size  # observation, then the state
        model = build_model(cfg.ppo, venv, cfg.seed, obs_size=layout.size)
        ex = model.policy.mlp_extractor
        assert ex.policy_net[0].in_features == layout.size and ex.value_net[0].in_features == rows
        before = [p.detach().clone() for p in model.policy.parameters()]
        model.learn(64)
        assert any(not torch.equal(a, b) for a, b in zip(before, model.policy.parameters()))
        # the actor ignores the state: another state, the same action
        x = torch.as_tensor(venv.observation_space.sample()[None], dtype=torch.float32)
        y = x.clone()
        y[:, layout.size:] = 0.0
        with torch.no_grad():
            assert torch.equal(model.policy.get_distribution(x).distribution.mean, model.policy.get_distribution(y).distribution.mean)
            v1, v2 = model.policy.predict_values(x), model.policy.predict_values(y)
        assert not torch.equal(v1, v2)  # … the critic does not
        model.set_logger(Logger(folder=None, output_formats=[]))
        log = {"timesteps": 0, "wall_time_s": 0.0, "evaluations": [], "scripted_eval_rmse_m": 0.2,
               "wall_time_before_s": 0.0, "_start": 0.0}
        cb = PeriodicCallback(cfg, tmp_path, layout, log)
        cb.init_callback(model)
        cb.checkpoint()
        obs = x[0, :layout.size].numpy()
    finally:
        venv.close()
    meta, layers = read_policy_file(tmp_path / "policy.npz")
    assert [w.shape for w, _ in layers] == [(8, layout.size), (3, 8)]  # the actor only: no critic, no state input
    assert meta["info"]["algorithm"].startswith("MAPPO")
    h = np.tanh(layers[0][0] @ obs + layers[0][1])
    with torch.no_grad():
        mean = model.policy.get_distribution(x).distribution.mean[0].numpy()
    assert np.allclose(layers[1][0] @ h + layers[1][1], mean, atol=1e-5)
    assert main(["eval", "--policy", str(tmp_path / "policy.npz"), "--episodes", "1", "--set", "max_cycles=10"]) == 0
    assert "zigzag" in capsys.readouterr().out
