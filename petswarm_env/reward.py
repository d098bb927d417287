"""Reward of each slave for one step, from ground truth (the experimenter's view).

    r = − w_formation · e
        − w_heading   · (1 − cos(θ − θ_formation))
        − w_collision · (contacts this robot began this step: robot, user or wall)
        − w_smoothness · ‖a_t − a_{t−1}‖²

``e`` is the distance (m) from the slave's true position to its reference position, θ its true
heading, θ_formation the master's true heading, ``a`` the action in [-1, 1]³. Weights are in the
``reward`` section of the config.
"""

from __future__ import annotations

import math

import numpy as np

from petswarm_env.config import RewardConfig


def slave_rewards(
    cfg: RewardConfig,
    formation_errors_m: list[float],
    heading_errors_rad: list[float],
    new_contacts: list[int],
    actions: np.ndarray,
    last_actions: np.ndarray,
) -> list[float]:
    """The reward of n slaves at once (module docstring): lists of n errors and contact counts,
    ``actions`` and ``last_actions`` (n, 3). The squared action changes by ``np.vecdot``, which sums
    as ``a @ a`` does (``tests/oracles.py`` keeps the one-slave form it equals)."""
    da = np.asarray(actions) - np.asarray(last_actions)
    smooth = np.vecdot(da, da).tolist() if len(da) else []
    return [
        float(-cfg.formation * e - cfg.heading * (1.0 - math.cos(h)) - cfg.collision * c - cfg.smoothness * q)
        for e, h, c, q in zip(formation_errors_m, heading_errors_rad, new_contacts, smooth)
    ]
