"""The training vector env's wrappers (training/vec_env.py): BlackDeath keeps a fixed set of
agents, SeededVecEnv gives SB3 its seed(), make_vec_env chains them over the real env."""

import numpy as np
import pytest
from gymnasium.spaces import Box
from pettingzoo import ParallelEnv

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

import petswarm_env
from petswarm_env.config import load_config
from training.vec_env import BlackDeath, SeededVecEnv, make_vec_env


class ThreeRobots(ParallelEnv):
    """a, b, c can be agents; the episode starts with a and b, c joins at step 1, a leaves
    (terminated) at step 2, and the episode ends after step 3."""

    metadata = {"name": "three_robots"}
    possible_agents = ["a", "b", "c"]
    LIVE = [["a", "b"], ["a", "b", "c"], ["b", "c"], []]

    def observation_space(self, agent):
        return Box(-10, 10, (2,), np.float32)

    def action_space(self, agent):
        return Box(-1, 1, (3,), np.float32)

    def reset(self, seed=None, options=None):
        self.t, self.received = 0, []
        self.agents = list(self.LIVE[0])
        return {a: np.full(2, i + 1, np.float32) for i, a in enumerate(self.agents)}, {a: {"seed": seed} for a in self.agents}

    def step(self, actions):
        self.received.append(sorted(actions))
        before = self.agents
        self.t += 1
        self.agents = list(self.LIVE[self.t])
        obs = {a: np.full(2, self.t, np.float32) for a in set(before) | set(self.agents)}
        rewards = {a: float(self.t) for a in before}
        terms = {a: a not in self.agents and a == "a" for a in before}
        truncs = {a: not self.agents and not terms[a] for a in before}
        return obs, rewards, terms, truncs, {a: {} for a in before}


def _all_actions():
    return {a: np.zeros(3, np.float32) for a in ThreeRobots.possible_agents}


def test_black_death_reset_gives_every_possible_agent_zeros_if_absent():
    env = BlackDeath(ThreeRobots())
    obs, infos = env.reset(seed=4)
    assert env.agents == ["a", "b", "c"]
    assert obs["a"].tolist() == [1, 1] and obs["b"].tolist() == [2, 2]
    assert obs["c"].tolist() == [0, 0] and obs["c"].dtype == np.float32
    assert infos == {"a": {"seed": 4}, "b": {"seed": 4}, "c": {}}


def test_black_death_drops_actions_of_robots_that_are_not_agents_and_gives_them_no_reward():
    inner = ThreeRobots()
    env = BlackDeath(inner)
    env.reset()
    obs, rewards, terms, truncs, _ = env.step(_all_actions())
    assert inner.received == [["a", "b"]]  # c is not a slave yet: its action never reaches the env
    assert rewards == {"a": 1.0, "b": 1.0, "c": 0.0}
    assert not any(terms.values()) and not any(truncs.values())
    assert env.agents == ["a", "b", "c"]
    env.step(_all_actions())  # a leaves the swarm: terminated in the env, but stays in the vector
    obs, rewards, terms, truncs, _ = env.step(_all_actions())
    assert inner.received[-1] == ["b", "c"]
    assert rewards["a"] == 0.0 and not terms["a"]


def test_black_death_ends_the_episode_for_every_row_at_once():
    env = BlackDeath(ThreeRobots())
    env.reset()
    for _ in range(3):
        _, _, terms, truncs, _ = env.step(_all_actions())
    assert terms == {"a": False, "b": False, "c": False}  # a terminated two steps earlier, in the env only
    assert truncs == {"a": True, "b": True, "c": True}
    assert env.agents == []


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
