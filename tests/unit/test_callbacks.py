"""The SB3 callback of `petswarm train` (training/callbacks.py): its schedule, its checkpoint
files and its evaluation against the scripted reference."""

import json
import math
from types import SimpleNamespace

import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

from stable_baselines3.common.logger import Logger

from petswarm.baselines.learned import read_policy_file
from petswarm_env.env import PetSwarmEnv
from petswarm.training.callbacks import PeriodicCallback, public_log
from petswarm.training.config import load_train_config
from petswarm.training.train import build_model
from petswarm.training.vec_env import make_vec_env

TINY = {"num_envs": 1, "num_cpus": 0, "ppo.n_steps": 16, "ppo.batch_size": 16, "ppo.net_arch": [8], "env.max_cycles": 20,
        "eval.every_steps": 1000, "eval.episodes": 1, "eval.max_cycles": 10, "checkpoint.every_steps": 1500}


def _log(timesteps=0):
    return {"timesteps": timesteps, "wall_time_s": 0.0, "evaluations": [], "scripted_eval_rmse_m": 0.2,
            "wall_time_before_s": 0.0, "_start": 0.0}


def _scheduled(log, until):
    cfg = load_train_config(overrides=TINY)
    cb = PeriodicCallback(cfg, "unused", PetSwarmEnv(cfg.env_config()).layout, log)
    calls = []
    cb.checkpoint = lambda: calls.append(("checkpoint", cb.num_timesteps))
    cb.evaluate = lambda: calls.append(("evaluate", cb.num_timesteps))
    model = SimpleNamespace(num_timesteps=0)
    cb.init_callback(model)
    for n in range(log["timesteps"] + 250, until + 1, 250):
        model.num_timesteps = n
        assert cb.on_step() is True
    return calls


def test_evaluates_and_checkpoints_every_so_many_agent_steps():
    assert _scheduled(_log(), 3000) == [("evaluate", 1000), ("checkpoint", 1500), ("evaluate", 2000),
                                        ("evaluate", 3000), ("checkpoint", 3000)]


def test_a_resumed_run_keeps_the_schedule():
    assert _scheduled(_log(timesteps=1750), 3000) == [("evaluate", 2000), ("evaluate", 3000), ("checkpoint", 3000)]


def test_checkpoint_writes_the_run_files_and_evaluate_logs_against_the_reference(tmp_path):
    cfg = load_train_config(overrides=TINY)
    venv = make_vec_env(cfg.env_config(), 1, 0, cfg.seed)
    try:
        model = build_model(cfg.ppo, venv, cfg.seed)
        model.set_logger(Logger(folder=None, output_formats=[]))
        log = _log()
        cb = PeriodicCallback(cfg, tmp_path, PetSwarmEnv(cfg.env_config()).layout, log)
        cb.init_callback(model)
        cb.num_timesteps = 64
        cb.evaluate()
        cb.checkpoint()
    finally:
        venv.close()
    ev = log["evaluations"]
    assert len(ev) == 1 and ev[0]["timesteps"] == 64 and ev[0]["scripted_rmse_m"] == 0.2
    assert math.isfinite(ev[0]["formation_rmse_m"]) and ev[0]["formation_rmse_m"] > 0
    recorded = model.logger.name_to_value
    assert recorded["eval/formation_rmse_m"] == ev[0]["formation_rmse_m"] and recorded["eval/scripted_rmse_m"] == 0.2
    assert (tmp_path / "checkpoints" / "latest.npz").is_file()
    saved = json.loads((tmp_path / "train_log.json").read_text())
    assert json.dumps(saved) == json.dumps(public_log(log)) and "_start" not in saved and saved["timesteps"] == 64  # NaN != NaN
    assert ev[0]["best"] and log["best"]["timesteps"] == 64  # the first evaluation is the best so far
    for name in ("policy.npz", "last.npz"):  # the best evaluated actor, the last checkpoint's
        meta, layers = read_policy_file(tmp_path / name)
        assert meta["info"]["timesteps"] == 64 and meta["info"]["train_config"]["ppo"]["net_arch"] == [8]
        assert layers[-1][0].shape[0] == 3
    assert sorted(p.name for p in tmp_path.rglob("*") if p.name.startswith(".")) == []  # no temp files


def test_the_median_ratio_counts_a_failed_episode_as_infinitely_worse():
    from petswarm.training.callbacks import median_ratio

    ref = [{"seed": s, "m": 0.2} for s in range(5)] + [{"seed": 9, "m": float("nan")}]
    eps = [{"seed": 0, "m": 0.1}, {"seed": 1, "m": 0.2}, {"seed": 2, "m": float("nan")}, {"seed": 3, "m": 0.3},
           {"seed": 4, "m": 0.1}, {"seed": 9, "m": 0.1}]  # seed 9: the reference has no figure, left out
    assert median_ratio(eps, ref, "m") == pytest.approx(1.0)  # ratios 0.5, 1, inf, 1.5, 0.5
    assert median_ratio([{"seed": 2, "m": float("nan")}], ref, "m") == float("inf")


def test_a_lost_formation_ranks_an_evaluation_behind_one_without():
    from petswarm.training.callbacks import _rank, not_built

    nan = float("nan")
    ref = [{"seed": s, "building_time_s": 8.0} for s in range(3)] + [{"seed": 3, "building_time_s": nan}]
    eps = [{"seed": 0, "building_time_s": 7.0}, {"seed": 1, "building_time_s": nan}, {"seed": 2, "building_time_s": 9.0},
           {"seed": 3, "building_time_s": nan}]  # seed 3: the reference did not build either
    assert not_built(eps, ref) == 1
    assert _rank(1, 0.5) > _rank(0, 1.2) and _rank(0, 0.9) < _rank(0, 1.0) and _rank(0, nan) > _rank(0, 9.0)
