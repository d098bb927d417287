"""The vector env PPO trains on: the PettingZoo env through SuperSuit, one row per slave.

``make_vec_env`` chains :class:`BlackDeath` (a fixed set of agents), SuperSuit's
``pettingzoo_env_to_vec_env_v1`` (one vector row per possible slave: parameter sharing) and
``concat_vec_envs_v1`` (``num_envs`` copies over ``num_cpus`` worker processes), then
:class:`SeededVecEnv` (SB3's interface, with ``seed``) and SB3's ``VecMonitor`` (per-row episode
return and length, for ``rollout/ep_rew_mean``).
"""

from __future__ import annotations

import numpy as np
from pettingzoo.utils.wrappers import BaseParallelWrapper
from stable_baselines3.common.vec_env import VecMonitor
from supersuit import concat_vec_envs_v1, pettingzoo_env_to_vec_env_v1
from supersuit.vector.sb3_vector_wrapper import SB3VecEnvWrapper

from petswarm_env.config import Config
from petswarm_env.env import PetSwarmEnv


class BlackDeath(BaseParallelWrapper):
    """Keep every possible agent in the vector: a robot that is not (or no longer) a slave of the
    episode gets zero observations and zero reward and its action is dropped; the episode ends for
    all when the env's episode ends (terminated agents stay terminated, the others are truncated).
    (SuperSuit's ``black_death_v3`` in 3.11 only ends an episode whose agents are terminated *and*
    truncated, so a truncated episode never resets.)"""

    def reset(self, seed=None, options=None):
        obs, infos = self.env.reset(seed=seed, options=options)
        self.agents = list(self.env.possible_agents)
        return self._fill(obs), {a: infos.get(a, {}) for a in self.agents}

    def _fill(self, obs):
        zero = np.zeros(self.observation_space(self.agents[0]).shape, np.float32)
        return {a: obs.get(a, zero) for a in self.agents}

    def step(self, actions):
        live = {a: actions[a] for a in self.env.agents if a in actions}
        obs, rews, terms, truncs, infos = self.env.step(live)
        done = not self.env.agents
        term = {a: done and terms.get(a, False) for a in self.agents}
        trunc = {a: done and not term[a] for a in self.agents}
        out = (self._fill(obs), {a: rews.get(a, 0.0) for a in self.agents}, term, trunc,
               {a: infos.get(a, {}) for a in self.agents})
        if done:
            self.agents = []
        return out


class SeededVecEnv(SB3VecEnvWrapper):
    """SuperSuit's SB3 wrapper plus ``seed()`` (SB3 ≥ 2.x calls it; SuperSuit lacks it): the seed
    is kept for the next ``reset``, which passes it on to the vector."""

    def __init__(self, venv):
        super().__init__(venv)
        self._next_seed: int | None = None

    def get_attr(self, attr_name: str, indices=None):
        if attr_name == "render_mode":  # SB3's wrappers ask for it (and warn on stderr without it); the vector has none
            return [None] * self.num_envs
        return super().get_attr(attr_name, indices)

    def seed(self, seed: int | None = None):
        self._next_seed = seed
        return [seed]

    def reset(self, seed=None, options=None):
        seed = self._next_seed if seed is None else seed
        self._next_seed = None
        observations, self.reset_infos = self.venv.reset(seed=seed, options=options)
        return observations


def make_vec_env(env_cfg: Config, num_envs: int, num_cpus: int, seed: int) -> VecMonitor:
    """SuperSuit pipeline to an SB3 VecEnv (one row per slave per copy), seeded with ``seed``."""
    vec = pettingzoo_env_to_vec_env_v1(BlackDeath(PetSwarmEnv(env_cfg)))
    vec = concat_vec_envs_v1(vec, num_envs, num_cpus=num_cpus, base_class="gymnasium")
    venv = SeededVecEnv(vec)
    venv.seed(seed)
    return VecMonitor(venv)
