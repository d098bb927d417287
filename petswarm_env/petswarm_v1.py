"""petswarm_v1, in PettingZoo's layout (``from pettingzoo.butterfly import pistonball_v6`` style)::

    from petswarm_env import petswarm_v1
    env = petswarm_v1.parallel_env(**{"swarm.num_slaves": 3})   # the ParallelEnv (PetSwarmEnv)
    aec = petswarm_v1.env()                                      # the AEC env, wrapped (order enforcing, ...)
    raw = petswarm_v1.raw_env()                                  # the unwrapped AEC env
    venv = petswarm_v1.vector_env(64)                            # 64 copies stepped together, arrays (vector.py)

Every function takes ``config`` (a :class:`~petswarm_env.config.Config`, a YAML path or None),
``render_mode`` and dotted overrides (``**{"radio.loss_prob": 0.1}`` or ``radio__loss_prob=0.1``).
The version suffix changes when the env's dynamics, observation or rewards change in a way that
makes results incomparable.
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils import wrappers
from pettingzoo.utils.conversions import parallel_to_aec_wrapper

from petswarm_env.config import Config
from petswarm_env.config_yaml import dotted_keywords
from petswarm_env.env import ENV_NAME, PetSwarmEnv
from petswarm_env.vector import VectorEnv

__all__ = ["ENV_NAME", "env", "parallel_env", "raw_env", "vector_env"]


_dotted = dotted_keywords  # swarm__num_slaves=3 means swarm.num_slaves = 3 (config_yaml.py)


def parallel_env(config: Config | str | None = None, render_mode: str | None = None, **overrides: Any) -> PetSwarmEnv:
    """The PettingZoo ``ParallelEnv``."""
    return PetSwarmEnv(config, render_mode=render_mode, **_dotted(overrides))


def raw_env(config: Config | str | None = None, render_mode: str | None = None, **overrides: Any):
    """The AEC env without PettingZoo's checking wrappers (PettingZoo's ``raw_env``): the
    ParallelEnv through PettingZoo's ``parallel_to_aec_wrapper``."""
    return parallel_to_aec_wrapper(parallel_env(config, render_mode=render_mode, **overrides))


def env(config: Config | str | None = None, render_mode: str | None = None, **overrides: Any):
    """The AEC env with PettingZoo's standard wrapper (``OrderEnforcingWrapper``: no step or
    render before reset), what ``pettingzoo.utils.conversions.parallel_to_aec`` gives."""
    return wrappers.OrderEnforcingWrapper(raw_env(config, render_mode=render_mode, **overrides))


def vector_env(num_envs: int, config: Config | str | None = None, **overrides: Any) -> VectorEnv:
    """``num_envs`` copies of the ParallelEnv stepped together in one process, arrays in and out
    (:mod:`petswarm_env.vector`)."""
    return VectorEnv(num_envs, config, **_dotted(overrides))
