"""The research loop: a short PPO run saves, resumes and loads; policies are interchangeable and
loading refuses what does not fit."""

import json
import zipfile

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

from petswarm.baselines.learned import LearnedPolicy, PolicyLoadError, read_policy_file, save_policy
from petswarm.baselines.policy import PolicySpec
from petswarm.evaluation.evaluate import evaluate
from petswarm_env import parallel_env
from petswarm_env.config import ConfigError, load_config
from petswarm_env.observe import ObservationLayout
from petswarm.training.config import load_train_config
from petswarm.training.train import train

SHORT = {
    "timesteps": 2048,
    "num_envs": 1,
    "num_cpus": 0,
    "ppo.n_steps": 128,
    "ppo.batch_size": 256,
    "ppo.n_epochs": 2,
    "ppo.net_arch": [16, 16],
    "eval.every_steps": 1024,
    "eval.episodes": 1,
    "eval.max_cycles": 20,
    "checkpoint.every_steps": 1024,
    "env.max_cycles": 50,
    "pretrain.samples": 400,
    "pretrain.epochs": 2,
}


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "short"
    log = train(load_train_config(overrides=SHORT), out, progress_bar=False)
    return out, log


def test_short_run_writes_checkpoint_policy_config_and_log(trained):
    out, log = trained
    assert (out / "checkpoints" / "latest.npz").is_file()
    assert (out / "policy.npz").is_file() and (out / "last.npz").is_file()
    assert (out / "train_config.yaml").is_file() and (out / "env_config.yaml").is_file()
    saved_log = json.loads((out / "train_log.json").read_text())
    assert saved_log["timesteps"] >= 2048
    assert saved_log["evaluations"] and saved_log["scripted_eval_rmse_m"] > 0
    assert list((out / "tb").rglob("events.out.tfevents*")), "TensorBoard logs are written"
    assert not list(out.rglob(".*.zip")) and not list(out.rglob(".*.npz")), "no temp files left"


def test_the_best_evaluated_actor_is_policy_npz_and_the_last_is_last_npz(trained):
    """policy.npz is the evaluation with the lowest median ratio to scripted (the warm-started
    actor at agent-step 0 competes); run again on the evaluation episodes it scores exactly what the
    log recorded. last.npz is the last checkpoint's actor."""
    from petswarm.training.callbacks import median_ratio, pool_episodes

    out, log = trained
    evals = log["evaluations"]
    # the warm start, every eval.every_steps (inside a rollout: the weights before its update), the final weights
    assert [e["timesteps"] for e in evals] == [0, 1024, 2048, 2048]
    assert evals[-1]["n_updates"] > evals[-2]["n_updates"]
    rank = [(e["not_built"], e["median_ratio"]) for e in evals]  # fewer lost formations first, then the median ratio
    best = evals[rank.index(min(rank))]  # the first of equals stays
    assert log["best"]["timesteps"] == best["timesteps"] and log["best"]["median_ratio"] == best["median_ratio"]
    assert [e["best"] for e in evals] == [r < min(rank[:k], default=(1 << 30, float("inf"))) for k, r in enumerate(rank)]
    meta, layers = read_policy_file(out / "policy.npz")
    assert meta["info"]["selected"]["timesteps"] == best["timesteps"] == meta["info"]["timesteps"]
    cfg = load_train_config(overrides=SHORT)
    again = pool_episodes(cfg, lambda spec: LearnedPolicy.load(out / "policy.npz", spec))
    assert median_ratio(again, log["scripted_eval_episodes"], cfg.eval.metric) == best["median_ratio"]
    last_meta, last_layers = read_policy_file(out / "last.npz")
    assert last_meta["info"]["timesteps"] == log["timesteps"] >= 2048
    same = all(np.array_equal(a, b) for (a, _), (b, _) in zip(layers, last_layers))
    assert same == (best["timesteps"] == log["timesteps"])


def test_warm_start_imitates_the_scripted_reference_before_ppo(trained):
    _, log = trained
    pre = log["pretrain"]
    assert pre["samples"] == 400
    assert pre["actor_mse"] < 0.5  # regressed toward the reference's actions in [-1, 1]
    assert pre["eval_formation_rmse_m"] > 0


def test_resume_continues_the_run(trained):
    out, log = trained
    cfg = load_train_config(overrides={**SHORT, "timesteps": 3072})
    log2 = train(cfg, out, resume=True, progress_bar=False)
    assert log2["timesteps"] >= 3072 > log["timesteps"]
    assert json.dumps(log2["evaluations"][0]) == json.dumps(log["evaluations"][0])  # (NaN != NaN)
    assert log2["best"]["median_ratio"] <= log["best"]["median_ratio"]  # the best so far is kept across the resume


def test_training_into_an_existing_run_without_resume_is_refused(trained):
    out, _ = trained
    with pytest.raises(ConfigError, match="--resume"):
        train(load_train_config(overrides=SHORT), out, progress_bar=False)


def test_same_seed_same_run(tmp_path):
    cfg = load_train_config(overrides={**SHORT, "timesteps": 1024, "eval.every_steps": 100000, "checkpoint.every_steps": 100000})
    train(cfg, tmp_path / "a", progress_bar=False)
    train(cfg, tmp_path / "b", progress_bar=False)
    _, la = read_policy_file(tmp_path / "a" / "policy.npz")
    _, lb = read_policy_file(tmp_path / "b" / "policy.npz")
    for (wa, ba), (wb, bb) in zip(la, lb):
        assert np.array_equal(wa, wb) and np.array_equal(ba, bb)


def test_saved_policy_loads_and_drives_the_swarm(trained):
    out, _ = trained
    env = parallel_env(max_cycles=10)
    obs, _ = env.reset(seed=0)
    policy = LearnedPolicy.load(out / "policy.npz", PolicySpec.from_env(env))
    while env.agents:
        actions = policy.act_all(obs)
        assert all(a.shape == (3,) and np.all(np.abs(a) <= 1) for a in actions.values())
        obs, *_ = env.step(actions)
    meta, _ = read_policy_file(out / "policy.npz")
    assert meta["env_name"] == "petswarm_v1" and meta["info"]["timesteps"] > 0


def test_mixed_team_runs_and_evaluation_is_deterministic(trained):
    out, _ = trained
    cfg = load_config(overrides={"max_cycles": 30})
    r1 = evaluate(cfg, "scripted", {"robot_2": str(out / "policy.npz")}, ["straight"], episodes=2, seed=5)
    r2 = evaluate(cfg, "scripted", {"robot_2": str(out / "policy.npz")}, ["straight"], episodes=2, seed=5)
    assert r1["label"].startswith("scripted+robot_2=")
    assert [e["formation_rmse_m"] for e in r1["episodes"]] == [e["formation_rmse_m"] for e in r2["episodes"]]
    assert r1["episodes"][0]["error_trace"] == r2["episodes"][0]["error_trace"]
    assert set(r1["scenarios"]) == {"straight"}


def _tiny_layers(n_in):
    rng = np.random.default_rng(0)
    return [(rng.normal(size=(4, n_in)), np.zeros(4)), (rng.normal(size=(3, 4)), np.zeros(3))]


def test_layout_mismatch_is_refused_with_the_field_named(tmp_path):
    layout = ObservationLayout(num_ultrasonic=12)  # trained on robots with 12 ultrasonic sensors
    save_policy(tmp_path / "p.npz", _tiny_layers(layout.size), "tanh", layout)
    env = parallel_env()  # 8 sensors
    with pytest.raises(PolicyLoadError, match="self.ultrasonic"):
        LearnedPolicy.load(tmp_path / "p.npz", PolicySpec.from_env(env))


def test_layout_in_another_order_is_mapped_by_name(tmp_path):
    env = parallel_env()
    layout = env.layout
    save_policy(tmp_path / "p.npz", _tiny_layers(layout.size), "tanh", layout)
    meta, layers = read_policy_file(tmp_path / "p.npz")
    reordered = list(reversed(layout.signature()))
    index = np.concatenate([np.arange(layout.slices[n].start, layout.slices[n].stop) for n, _ in reordered])
    from petswarm.baselines.learned import observation_mapping

    assert np.array_equal(observation_mapping(reordered, layout), index)


@pytest.mark.parametrize("damage", ["truncate", "garbage", "not_a_policy"])
def test_corrupt_policy_file_is_refused(tmp_path, damage):
    env = parallel_env()
    path = tmp_path / "p.npz"
    save_policy(path, _tiny_layers(env.layout.size), "tanh", env.layout)
    data = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        path.write_bytes(b"\x00" * 100)
    else:
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("x.npy", b"hello")
    with pytest.raises(PolicyLoadError, match="p.npz"):
        LearnedPolicy.load(path, PolicySpec.from_env(env))


def test_policy_files_never_unpickle(tmp_path):
    """A file holding a pickled object array is refused instead of executed."""
    env = parallel_env()
    path = tmp_path / "p.npz"
    np.savez(path, meta=np.array([{"format": "petswarm-policy"}], dtype=object))
    with pytest.raises(PolicyLoadError):
        LearnedPolicy.load(path, PolicySpec.from_env(env))


def test_corrupt_checkpoint_on_resume_is_refused(tmp_path):
    out = tmp_path / "run"
    cfg = load_train_config(overrides={**SHORT, "timesteps": 512, "eval.every_steps": 100000, "checkpoint.every_steps": 100000})
    train(cfg, out, progress_bar=False)
    (out / "checkpoints" / "latest.npz").write_bytes(b"not a zip")
    with pytest.raises(ConfigError, match="damaged"):
        train(cfg, out, resume=True, progress_bar=False)
