"""Deprecated: ``petswarm_v0`` is kept importable, as an alias of :mod:`petswarm_env.petswarm_v1`.

v1 changed the swarm's dynamics (the episode's metrics and a policy's results are not comparable
with v0's); the observation, action and state spaces are v0's. Import ``petswarm_v1`` instead.
"""

from __future__ import annotations

import warnings

from petswarm_env.petswarm_v1 import ENV_NAME, env, parallel_env, raw_env, vector_env

__all__ = ["ENV_NAME", "env", "parallel_env", "raw_env", "vector_env"]

warnings.warn("petswarm_env.petswarm_v0 is deprecated: it is an alias of petswarm_v1 (other swarm dynamics than v0); "
              "import petswarm_env.petswarm_v1", DeprecationWarning, stacklevel=2)
