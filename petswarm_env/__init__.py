"""petswarm: a PettingZoo environment of Pet-Bot swarms accompanying a walking user.

>>> import petswarm_env
>>> env = petswarm_env.parallel_env(swarm__num_slaves=3)  # or parallel_env(**{"swarm.num_slaves": 3})
>>> env = petswarm_env.make("petswarm_v1", **{"swarm.num_slaves": 3})  # the same, by its versioned id
>>> import pettingzoo
>>> env = pettingzoo.make("parallel", "petswarm/petswarm-v1", **{"swarm.num_slaves": 3})  # PettingZoo's registry

``parallel_env``, ``env`` and ``raw_env`` are :mod:`petswarm_env.petswarm_v1`'s (PettingZoo's
meanings: the ParallelEnv, the wrapped AEC env, the unwrapped AEC env); ``vector_env(num_envs,
...)`` steps ``num_envs`` copies in one process with arrays in and out (:mod:`petswarm_env.vector`). For libraries that need
every possible agent at every step: :class:`petswarm_env.wrappers.FixedAgents`.
"""

from __future__ import annotations

from typing import Any

import pettingzoo

from petswarm_env import _core

_core.load()  # the compiled core, or one line naming the fix (PETSWARM_PURE_PYTHON=1: the interpreted form)

from petswarm_env import petswarm_v1  # noqa: E402
from petswarm_env.config import Config, ConfigError, load_config  # noqa: E402
from petswarm_env.env import ENV_NAME, PetSwarmEnv  # noqa: E402
from petswarm_env.petswarm_v1 import env, parallel_env, raw_env, vector_env  # noqa: E402

__version__ = "1.0.0"
__all__ = ["ENV_NAME", "ENVS", "Config", "ConfigError", "PetSwarmEnv", "env", "load_config", "make", "parallel_env",
           "petswarm_v1", "raw_env", "vector_env"]

ENVS = {ENV_NAME: petswarm_v1}  # versioned id -> module with env / parallel_env / raw_env

# PettingZoo's registry (``pettingzoo.make("parallel", "petswarm/petswarm-v1")`` after ``import petswarm_env``)
REGISTRY_ID = "petswarm/petswarm-v1"
for _api, _maker in (("parallel", "parallel_env"), ("aec", "env")):
    if REGISTRY_ID not in (pettingzoo.parallel_registry if _api == "parallel" else pettingzoo.aec_registry):
        pettingzoo.register(_api, REGISTRY_ID, entry_point=f"petswarm_env.petswarm_v1:{_maker}")


def make(env_id: str = ENV_NAME, *, api: str = "parallel", config: Config | str | None = None, render_mode: str | None = None,
         **overrides: Any):
    """The env of a versioned id: ``api="parallel"`` (default, the ParallelEnv), ``"aec"`` (the
    wrapped AEC env) or ``"raw"`` (the unwrapped AEC env); the other arguments as ``parallel_env``."""
    if env_id not in ENVS:
        raise ValueError(f"unknown env id '{env_id}'; registered: {', '.join(ENVS)}")
    makers = {"parallel": ENVS[env_id].parallel_env, "aec": ENVS[env_id].env, "raw": ENVS[env_id].raw_env}
    if api not in makers:
        raise ValueError(f"unknown api '{api}'; choose parallel, aec or raw")
    return makers[api](config, render_mode=render_mode, **overrides)
