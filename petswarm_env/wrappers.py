"""Wrappers for MARL libraries that need a fixed set of agents.

The env's agents (:mod:`petswarm_env.env`, the lifecycle of :mod:`petswarm_env.episode`): every
possible agent is an agent from reset on (one not yet in slave-role driving waits with a zero
observation, ``active`` 0), and agents follow the middleware: one that leaves slave-role driving
(in a mode change with master change the farthest slave becomes the master; a dispersed swarm's
slaves; a lost member) waits again, inactive, until it is a slave again; a slave off for good is
terminated. The raw env passes PettingZoo's ``parallel_api_test`` and drives RLlib's
``ParallelPettingZooEnv`` (with RLlib's own episode bookkeeping) and TorchRL's ``PettingZooWrapper``
with ``use_mask=True`` on every scenario and fault kind (tests/env/test_lifecycle.py). Adapters
that assume every possible agent is present until the episode's end need :class:`FixedAgents`:
SuperSuit's vector env, TorchRL's ``PettingZooWrapper`` without ``use_mask``, and BenchMARL over it.

Do not use SuperSuit's ``black_death_v3`` instead: in SuperSuit 3.11 it ends an episode only when
its agents are terminated *and* truncated, so an episode that ends by truncation (every petswarm
episode reaching ``max_cycles``) never resets.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pettingzoo.utils.wrappers import BaseParallelWrapper

from petswarm_env.env import INFO_DEFAULTS
from petswarm_env.inputs import check_actions


class FixedAgents(BaseParallelWrapper):
    """Every possible agent (``env.possible_agents``, in that order) at every step.

    - *Observations*: a robot's own observation while it is in slave-role driving (and on the step
      the episode truncates: its last one); zeros otherwise (the env gives an agent terminated in
      a step no observation: petswarm_env/episode.py). A zero observation is never a real one (a real
      observation has its ``self.yaw_sincos`` on the unit circle), so it needs no flag of its own;
      the observation layout stays the env's, and a policy trained here runs on the env unchanged.
    - *Infos*: the env's flat infos (:data:`~petswarm_env.env.INFO_DEFAULTS`, their defaults for a
      robot the env has none for) plus ``active``: 1 when the observation is the robot's own, 0 for
      padding.
    - *Actions*: passed on only for the env's live agents; those of the other possible agents are
      ignored (missing ones too: standing still); an id that is not a possible agent is refused.
    - *Rewards*: the env's, as Python floats; 0.0 for an inactive robot.
    - *Episode end*: for every agent at once when the env's episode ends (no agent left:
      truncation at ``max_cycles``, or every robot off for good). A robot the env terminated on that
      step is terminated, every other one truncated; a robot that left mid-episode stays in,
      inactive, until then.
    - ``state()``/``state_space``, ``render()`` (with RLlib's positional mode), ``episode_summary()``,
      ``organize_summary()`` and every other public attribute are the env's.
    """

    def __init__(self, env):
        super().__init__(env)
        self.possible_agents = list(env.possible_agents)
        self._possible = frozenset(self.possible_agents)
        self.agents: list[str] = []
        self.state_space = getattr(env, "state_space", None)
        space = env.observation_space(self.possible_agents[0])
        self._zero = np.zeros(space.shape, space.dtype)

    def reset(self, seed: int | None = None, options: dict | None = None):
        obs, infos = self.env.reset(seed=seed, options=options)
        self.agents = list(self.possible_agents)
        return self._fill(obs), self._infos(infos, obs)

    def step(self, actions: dict[str, Any]):
        check_actions(actions, self.possible_agents, "this wrapper's agents")  # as strict as the raw env (inputs.py)
        live = self.env.agents
        obs, rewards, terms, truncs, infos = self.env.step({a: actions[a] for a in live if a in actions})
        done = not self.env.agents
        term = {a: done and bool(terms.get(a, False)) for a in self.agents}
        trunc = {a: done and not term[a] for a in self.agents}
        out = (self._fill(obs), {a: float(rewards.get(a, 0.0)) for a in self.agents}, term, trunc, self._infos(infos, obs))
        if done:
            self.agents = []
        return out

    def _fill(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        zero = self._zero
        return {a: obs[a] if a in obs else zero.copy() for a in self.possible_agents}

    def _infos(self, infos: dict[str, dict], obs: dict[str, np.ndarray]) -> dict[str, dict[str, float | int]]:
        out = {}
        for a in self.possible_agents:
            info = {**INFO_DEFAULTS, **infos[a]} if a in infos else dict(INFO_DEFAULTS)
            # the robot's own observation: the env's "active" (a waiting agent's zeros are padding too)
            info["active"] = int(a in obs and infos.get(a, {}).get("active", 1))
            out[a] = info
        return out

    def render(self, mode: str | None = None):
        return self.env.render() if mode is None else self.env.render(mode)
