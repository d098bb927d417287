"""The examples run: TorchRL's PettingZooWrapper and Collector over the fixed-agents env, with the
shipped policy as a TensorDict actor (examples/torchrl_collect.py; the torchrl extra)."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torchrl")

from petswarm.baselines.learned import LearnedPolicy, feed_forward_policy_path  # noqa: E402
from petswarm.baselines.policy import PolicySpec  # noqa: E402
from petswarm_env import parallel_env  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def _example(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # importable by name: BenchMARL pickles its task's class into its run folder
    spec.loader.exec_module(module)
    return module


def test_torchrl_collector_gathers_every_robot_with_the_state_and_the_shipped_feed_forward_policy():
    example = _example("torchrl_collect")
    out = example.collect(frames=100, frames_per_batch=50, max_cycles=30)
    size = PolicySpec.from_env(parallel_env()).layout.size
    assert out["frames"] == 100 and out["observation_shape"] == (50, 4, size) and out["state_shape"] == (50, 116)
    assert out["episodes_ended"] == 3  # 30-step episodes: done for every robot at once, then reset
    batch = out["batches"][0]
    info = batch["next", "robot", "info"]
    assert set(info.keys()) >= {"active", "formation_error_m", "new_contacts", "joined", "member"}
    assert bool(info["active"].all())  # the default scenario: every robot a slave all along
    env = parallel_env()
    policy = LearnedPolicy.load(feed_forward_policy_path(), PolicySpec.from_env(env))
    obs = batch["robot", "observation"].numpy().reshape(-1, size)
    expected = np.clip(policy.forward(obs), -1, 1)
    assert np.abs(batch["robot", "action"].numpy().reshape(-1, 3) - expected).max() < 1e-4


def test_benchmarl_task_runs_mappo_with_the_state_for_the_critic(tmp_path):
    """Only where benchmarl is installed (its own venv: it pins torchrl < 0.12, examples/benchmarl_task.py)."""
    pytest.importorskip("benchmarl")
    example = _example("benchmarl_task")
    out = example.run_mappo(frames=200, frames_per_batch=100, max_cycles=20, out=str(tmp_path))
    assert out["frames"] == 200 and out["policy_parameters"] > 0
