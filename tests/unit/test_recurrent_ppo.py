"""PPO fine-tuning of a distilled recurrent policy (training/recurrent_ppo.py): the distilled file
loads into torch as it acts in numpy, a tiny run exports policies `learned` loads and runs, a run
that cannot move the actor keeps the distilled actions, the anchor pulls toward them, and a bad
config is refused in one line."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from petswarm.baselines.learned import LearnedPolicy, RecurrentPolicy, shipped_policy_path  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm.training import recurrent_ppo as rp  # noqa: E402
from petswarm.training.config import load_train_config  # noqa: E402
from petswarm.training.recurrent import numpy_policy  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402
from petswarm_env.config import ConfigError  # noqa: E402

DISTILLED = "baselines/models/recurrent_long.npz"

TINY = """
algorithm: recurrent_ppo
timesteps: 240
residual_of: scripted
residual_scale: 0.5
env:
  max_cycles: 40
eval:
  episodes: 1
  max_cycles: 40
  metric: formation_hold_rmse_m
finetune:
  policy: {policy}
  rollout_steps: 120
  chunk: 8
  chunks_per_batch: 4
  epochs: 2
  critic_warmup_epochs: 1
  critic_net: [32]
  bc_samples: 60
  learning_rate: {lr}
  log_std_init: -2.3
  eval_every: 1
"""


def _tiny(tmp_path, lr=1e-3, policy=DISTILLED, **extra):
    text = TINY.format(policy=policy, lr=lr)
    path = tmp_path / f"tiny_{lr}.yaml"
    path.write_text(text)
    return load_train_config(path, extra)


@pytest.fixture(scope="module")
def spec():
    return PolicySpec.from_env(parallel_env())


def _observations(steps=30, seed=3):
    """Real observation sequences of a few robots (the scripted reference driving)."""
    from petswarm.baselines.registry import make_policy

    env = parallel_env(max_cycles=steps)
    obs, _ = env.reset(seed=seed)
    driver = make_policy("scripted", PolicySpec.from_env(env))
    out = []
    while env.agents:
        out.append(dict(obs))
        obs, *_ = env.step(driver.act_all(obs))
    env.close()
    return out


def _actions(policy, frames):
    policy.reset(0)
    return [policy.act_all(f) for f in frames]


def _max_diff(a, b):
    return max(float(np.abs(x[k] - y[k]).max()) for x, y in zip(a, b) for k in x)


def test_the_distilled_file_loads_into_torch_and_acts_as_in_numpy(spec):
    actor, meta = rp.load_actor(rp.policy_path(DISTILLED), spec.layout)
    frames = _observations()
    shipped = LearnedPolicy.load(rp.policy_path(DISTILLED), spec)
    again = numpy_policy(actor, spec, rp.residual_of_meta(meta))
    assert isinstance(shipped, RecurrentPolicy) and meta["residual_of"] == "scripted"
    assert _max_diff(_actions(shipped, frames), _actions(again, frames)) < 1e-5
    assert rp.policy_path("learned") == shipped_policy_path()


def test_a_tiny_run_exports_policies_that_load_and_act(tmp_path, spec):
    from petswarm.evaluation.runner import run_episode

    log = rp.train(_tiny(tmp_path), tmp_path / "run", progress=None)
    assert len(log["iterations"]) == 2 and log["timesteps"] >= 240 and log["bc"]["samples"] >= 60
    assert [e["iteration"] for e in log["evaluations"]] == [0, 1, 2]  # the distilled policy competes
    for name in ("policy.npz", "last.npz"):
        policy = LearnedPolicy.load(tmp_path / "run" / name, spec)
        assert isinstance(policy, RecurrentPolicy) and policy.meta["residual_of"] == "scripted"
        env = parallel_env(max_cycles=30)
        summary = run_episode(env, policy, 5)
        assert np.isfinite(summary["formation_rmse_m"])
    moved = _max_diff(_actions(LearnedPolicy.load(tmp_path / "run" / "last.npz", spec), _observations()),
                      _actions(LearnedPolicy.load(rp.policy_path(DISTILLED), spec), _observations()))
    assert moved > 1e-4  # with a learning rate the actor moves (the next test is not vacuous)


def test_a_run_whose_actor_cannot_move_keeps_the_distilled_actions(tmp_path, spec):
    rp.train(_tiny(tmp_path, lr=0.0), tmp_path / "run", progress=None)
    frames = _observations()
    kept = _actions(LearnedPolicy.load(tmp_path / "run" / "last.npz", spec), frames)
    assert _max_diff(kept, _actions(LearnedPolicy.load(rp.policy_path(DISTILLED), spec), frames)) < 1e-6


def test_the_anchor_pulls_the_actor_back_to_the_distilled_mean(tmp_path):
    cfg = _tiny(tmp_path, lr=1e-3)
    env_cfg = cfg.env_config()
    from petswarm.training.vec_env import training_env
    from petswarm_env.env import PetSwarmEnv

    layout = PetSwarmEnv(env_cfg).layout
    anchor, meta = rp.load_actor(rp.policy_path(DISTILLED), layout)
    actor, _ = rp.load_actor(rp.policy_path(DISTILLED), layout)
    with torch.no_grad():
        actor.head[-1].bias.add_(0.3)  # a moved actor
    env = training_env(env_cfg, cfg.randomize, cfg.env, False)
    log_std = torch.nn.Parameter(torch.full((3,), -1.0))
    segs, _ = rp.rollout(env, actor, anchor, log_std, cfg, rp.residual_of_meta(meta), 80, 11, np.random.default_rng(0))
    data = rp.chunks(segs, [np.zeros(len(s.rew), np.float32) for s in segs], [np.zeros(len(s.rew), np.float32) for s in segs], 8)

    def gap():
        with torch.no_grad():
            mu, _ = actor(data.x, data.h0[None])
        return float((((mu - data.mu0) ** 2).sum(-1) * data.mask).sum() / data.mask.sum())

    before = gap()
    opt = torch.optim.Adam(actor.parameters(), lr=1e-3)
    stats = rp.update(actor, log_std, opt, data, cfg, 1.0, [], np.random.default_rng(0))  # zero advantages: the anchor alone
    assert before > 0.2 and gap() < 0.8 * before and stats["policy_loss"] == 0.0


def test_the_anchor_decays_geometrically_from_start_to_end(tmp_path):
    cfg = _tiny(tmp_path, **{"finetune.anchor_start": 1.0, "finetune.anchor_end": 0.01})
    weights = [rp.anchor_weight(cfg, k, 3) for k in range(3)]
    assert weights == pytest.approx([1.0, 0.1, 0.01])


@pytest.mark.parametrize("change,words", [
    ({"timesteps": 100}, "timesteps >= finetune.rollout_steps"),
    ({"finetune.anchor_end": 2.0}, "the anchor decays"),
    ({"finetune.chunk": 0}, "finetune.chunk"),
])
def test_a_bad_finetune_config_is_one_line(tmp_path, change, words):
    with pytest.raises(ConfigError) as err:
        _tiny(tmp_path, **change)
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("policy,change,words", [
    ("no/such/policy.npz", {}, "no policy file"),
    ("baselines/models/mappo_generalize.npz", {}, "not a recurrent action policy"),
    (DISTILLED, {"residual_scale": 1.0}, "set them to the file's"),
])
def test_a_start_policy_that_does_not_fit_is_one_line(tmp_path, policy, change, words):
    with pytest.raises(ConfigError) as err:
        rp.train(_tiny(tmp_path, policy=policy, **change), tmp_path / "run", progress=None)
    assert words in str(err.value) and "\n" not in str(err.value)
    assert not (tmp_path / "run" / "train_log.json").exists()


def test_the_committed_config_fine_tunes_the_distilled_policy_on_its_training_distribution():
    ft = load_train_config("configs/train/recurrent_ppo.yaml")
    long = load_train_config("configs/train/recurrent_long.yaml")
    assert ft.algorithm == "recurrent_ppo" and ft.finetune.policy == DISTILLED
    assert (ft.env, ft.randomize, ft.eval, ft.residual()) == (long.env, long.randomize, long.eval, long.residual())
    assert load_train_config("configs/train/recurrent_long.yaml").algorithm == "recurrent"  # old configs unchanged
