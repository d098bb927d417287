"""The training vector env (training/vec_env.py): SeededVecEnv gives SB3 its seed(), make_vec_env
chains FixedAgents (tests/unit/test_wrappers.py) and SuperSuit over the real env."""

import numpy as np
import pytest
from gymnasium.spaces import Box

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

import petswarm_env
from petswarm_env.config import load_config
from petswarm.training.vec_env import SeededVecEnv, make_vec_env


class _Vector:
    num_envs, render_mode = 2, None
    observation_space = Box(-1, 1, (2,), np.float32)
    action_space = Box(-1, 1, (3,), np.float32)

    def __init__(self):
        self.seeds = []

    def reset(self, seed=None, options=None):
        self.seeds.append(seed)
        return np.zeros((2, 2), np.float32), [{}, {}]


def test_seeded_vec_env_passes_the_seed_to_the_next_reset_only():
    inner = _Vector()
    venv = SeededVecEnv(inner)
    assert venv.seed(7) == [7]
    venv.reset()
    venv.reset()
    venv.reset(seed=3)
    assert inner.seeds == [7, None, 3]
    assert venv.reset_infos == [{}, {}]


def test_make_vec_env_has_one_row_per_possible_slave_and_is_seeded():
    cfg = load_config(overrides={"max_cycles": 5})
    a, b = make_vec_env(cfg, 1, 0, seed=3), make_vec_env(cfg, 1, 0, seed=3)
    try:
        obs_a, obs_b = a.reset(), b.reset()
        rows = a.num_envs
        assert obs_a.shape == (rows, petswarm_env.parallel_env(cfg).layout.size) and rows >= cfg.swarm.num_slaves
        assert np.array_equal(obs_a, obs_b)
        for _ in range(5):
            obs, rewards, dones, infos = a.step(np.zeros((rows, 3), np.float32))
        assert dones.all()  # the 5-step episode ends for every row
    finally:
        a.close()
        b.close()
