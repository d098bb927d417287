"""The vector env PPO trains on: the PettingZoo env through SuperSuit, one row per slave.

``make_vec_env`` chains :class:`petswarm_env.wrappers.FixedAgents` (every possible agent at every
step), SuperSuit's
``pettingzoo_env_to_vec_env_v1`` (one vector row per possible slave: parameter sharing) and
``concat_vec_envs_v1`` (``num_envs`` copies over ``num_cpus`` worker processes), then
:class:`SeededVecEnv` (SB3's interface, with ``seed``) and SB3's ``VecMonitor`` (per-row episode
return and length, for ``rollout/ep_rew_mean``).

``training_env`` is the PettingZoo env under the vector: ``PetSwarmEnv`` of the training config, or
with ``randomize:`` pools a :class:`petswarm.training.randomize.RandomizedEnv` (each episode its drawn
config; ``FixedAgents`` over it is sized for the largest draw), with ``residual_of: scripted``
each action a correction of the scripted reference's (:class:`petswarm.training.residual.ResidualActions`),
and with ``ppo.critic: state`` every row followed by the global state
(:class:`petswarm.training.randomize.WithState`, MAPPO's critic input).
"""

from __future__ import annotations

from stable_baselines3.common.vec_env import VecMonitor
from supersuit import concat_vec_envs_v1, pettingzoo_env_to_vec_env_v1
from supersuit.vector.sb3_vector_wrapper import SB3VecEnvWrapper

from petswarm_env.config import Config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.wrappers import FixedAgents
from petswarm.training.randomize import PoolSpaces, RandomizedEnv, WithState
from petswarm.baselines.learned import Residual
from petswarm.training.residual import ResidualActions


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


def training_env(env_cfg: Config, pools: dict | None = None, overrides: dict | None = None, with_state: bool = False,
                 spaces: PoolSpaces | None = None, residual: Residual | None = None):
    """The fixed-agents ParallelEnv of a run (module docstring): ``env_cfg``, or with ``pools`` a
    :class:`RandomizedEnv` over the ``overrides`` (the training config's ``env:``; ``spaces``
    computed once if given); with ``residual`` its actions correct that policy's; with
    ``with_state`` its rows carry the state after the observation."""
    base = RandomizedEnv(overrides or {}, pools, spaces) if pools else PetSwarmEnv(env_cfg)
    env = FixedAgents(base)
    env = ResidualActions(env, residual) if residual else env
    return WithState(env) if with_state else env


def make_vec_env(env_cfg: Config, num_envs: int, num_cpus: int, seed: int, pools: dict | None = None,
                 overrides: dict | None = None, with_state: bool = False, residual: Residual | None = None) -> VecMonitor:
    """SuperSuit pipeline to an SB3 VecEnv (one row per slave per copy), seeded with ``seed``
    (``pools``, ``overrides``, ``with_state``, ``residual``: :func:`training_env`)."""
    spaces = PoolSpaces.of(overrides or {}, pools) if pools else None
    vec = pettingzoo_env_to_vec_env_v1(training_env(env_cfg, pools, overrides, with_state, spaces, residual))
    vec = concat_vec_envs_v1(vec, num_envs, num_cpus=num_cpus, base_class="gymnasium")
    venv = SeededVecEnv(vec)
    venv.seed(seed)
    return VecMonitor(venv)
