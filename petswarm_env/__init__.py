"""petswarm: a PettingZoo environment of Pet-Bot swarms accompanying a walking user.

>>> import petswarm_env
>>> env = petswarm_env.parallel_env(swarm__num_slaves=3)  # or parallel_env(**{"swarm.num_slaves": 3})
"""

from __future__ import annotations

from typing import Any

from petswarm_env.config import Config, ConfigError, load_config
from petswarm_env.env import ENV_NAME, PetSwarmEnv

__version__ = "0.1.0"
__all__ = ["ENV_NAME", "Config", "ConfigError", "PetSwarmEnv", "env", "load_config", "parallel_env", "raw_env"]


def _dotted(overrides: dict[str, Any]) -> dict[str, Any]:
    """Keyword overrides: ``swarm__num_slaves=3`` means ``swarm.num_slaves = 3``."""
    return {k.replace("__", "."): v for k, v in overrides.items()}


def parallel_env(config: Config | str | None = None, render_mode: str | None = None, **overrides: Any) -> PetSwarmEnv:
    """The PettingZoo ``ParallelEnv``. ``config``: a :class:`Config`, a YAML path or None (defaults);
    ``overrides``: dotted keys (``**{"radio.loss_prob": 0.1}``) or ``section__key=value``."""
    return PetSwarmEnv(config, render_mode=render_mode, **_dotted(overrides))


raw_env = parallel_env


def env(config: Config | str | None = None, render_mode: str | None = None, **overrides: Any):
    """The AEC version, through PettingZoo's parallel → AEC conversion."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(config, render_mode=render_mode, **overrides))
