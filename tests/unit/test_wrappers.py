"""petswarm_env.wrappers.FixedAgents: every possible agent at every step, zeros and ``active=0`` for
the absent, their actions dropped, the episode's end for all at once; on a toy env, then on the
real one."""

import numpy as np
from gymnasium.spaces import Box
from pettingzoo import ParallelEnv
from pettingzoo.test import parallel_api_test

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.env import INFO_DEFAULTS
from petswarm_env.wrappers import FixedAgents


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


def test_fixed_agents_reset_gives_every_possible_agent_zeros_if_absent():
    env = FixedAgents(ThreeRobots())
    obs, infos = env.reset(seed=4)
    assert env.agents == ["a", "b", "c"]
    assert obs["a"].tolist() == [1, 1] and obs["b"].tolist() == [2, 2]
    assert obs["c"].tolist() == [0, 0] and obs["c"].dtype == np.float32
    assert infos["a"] == {**INFO_DEFAULTS, "seed": 4, "active": 1} and infos["b"]["active"] == 1
    assert infos["c"] == {**INFO_DEFAULTS, "active": 0}  # the same keys for every agent


def test_fixed_agents_drops_actions_of_robots_that_are_not_agents_and_gives_them_no_reward():
    inner = ThreeRobots()
    env = FixedAgents(inner)
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


def test_fixed_agents_ends_the_episode_for_every_row_at_once():
    env = FixedAgents(ThreeRobots())
    env.reset()
    for _ in range(3):
        _, _, terms, truncs, _ = env.step(_all_actions())
    assert terms == {"a": False, "b": False, "c": False}  # a terminated two steps earlier, in the env only
    assert truncs == {"a": True, "b": True, "c": True}
    assert env.agents == []



def test_fixed_agents_active_flag_marks_the_robots_own_observations():
    env = FixedAgents(ThreeRobots())
    _, infos = env.reset()
    active = [[infos[a]["active"] for a in "abc"]]
    for _ in range(3):
        _, _, _, _, infos = env.step(_all_actions())
        active.append([infos[a]["active"] for a in "abc"])
    # c joins at step 1; a leaves at step 2 (its last observation), then is padding; the end gives b's and c's last
    assert active == [[1, 1, 0], [1, 1, 1], [1, 1, 1], [0, 1, 1]]


def test_fixed_agents_over_a_mode_change_keeps_every_robot_and_ends_by_truncation():
    """mode_change: a slave becomes the master (the env terminates it), robot_0 joins as a slave;
    the wrapper keeps all five robots from reset to the end, ignores actions of inactive ones."""
    env = FixedAgents(petswarm_env.parallel_env(**{"user.scenario": "mode_change", "max_cycles": 420}))
    obs, infos = env.reset(seed=0)
    # the scripted reference drives the live robots (standing ones would be left beyond the swarm's reach once
    # the user walks, and removed as astray before the mode change: middleware/recovery.py); the inactive
    # ones get a constant action, which the wrapper ignores
    policy = make_policy("scripted", PolicySpec.from_env(env), 0)
    assert env.agents == env.possible_agents == [f"robot_{i}" for i in range(5)]
    assert infos["robot_0"]["active"] == 0 and not obs["robot_0"].any()
    seen_active = {a: set() for a in env.agents}
    space = env.observation_space("robot_0")
    while env.agents:
        acts = {**{a: np.full(3, 0.1, np.float32) for a in env.agents},
                **policy.act_all({a: o for a, o in obs.items() if infos[a]["active"]})}
        was_active = {a for a in env.possible_agents if infos[a]["active"]}
        obs, rewards, terms, truncs, infos = env.step(acts)
        for a in env.possible_agents:
            seen_active[a].add(infos[a]["active"])
            assert space.contains(obs[a]) and type(rewards[a]) is float
            assert set(infos[a]) == {*INFO_DEFAULTS, "active"}
            if not infos[a]["active"]:  # a robot that left in this step gets its last reward (the env's)
                assert not obs[a].any() and (a in was_active or rewards[a] == 0.0)
    assert seen_active["robot_0"] == {0, 1}  # joined mid-episode
    assert sum(seen_active[a] == {0, 1} for a in env.possible_agents[1:]) == 1  # the new master left
    assert all(truncs.values()) and not any(terms.values())
    assert env.unwrapped.episode_summary()["events"]["master_changes"] == 1


def test_fixed_agents_passes_the_pettingzoo_parallel_api_test_and_gives_the_state():
    env = FixedAgents(petswarm_env.parallel_env(**{"user.scenario": "mode_change", "max_cycles": 150}))
    parallel_api_test(env, num_cycles=200)
    env.reset(seed=1)
    assert env.state_space.contains(env.state())
