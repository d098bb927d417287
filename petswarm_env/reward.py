"""Reward of each slave for one step, from ground truth (the experimenter's view).

    r = − w_formation · e
        − w_heading   · (1 − cos(θ − θ_formation))
        − w_collision · (contacts this robot began this step: robot, user or wall)
        − w_smoothness · ‖a_t − a_{t−1}‖²

``e`` is the distance (m) from the slave's true position to its reference position, θ its true
heading, θ_formation the master's true heading, ``a`` the action in [-1, 1]³. Weights are in the
``reward`` section of the config.

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): the sum is
C doubles in the order above, as the interpreter computes it in Python floats (no fused multiply-add:
setup.py; ``math.cos`` is the C library's).
"""

from __future__ import annotations

import cython
import numpy as np
from cython.cimports.libc.math import cos as _c_cos

from petswarm_env.config import RewardConfig

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_weights_of: object = None  # the reward config whose weights _weights holds (slave_rewards)
_weights: tuple = (0.0, 0.0, 0.0, 0.0)


def slave_rewards(
    cfg: RewardConfig,
    formation_errors_m,  # n floats (m)
    heading_errors_rad,  # n floats (rad)
    new_contacts,  # n ints
    actions,  # (n, 3) float32
    last_actions,  # (n, 3) float32
) -> list:
    """The reward of n slaves at once (module docstring): lists of n errors and contact counts,
    ``actions`` and ``last_actions`` (n, 3) float32. The squared action change ‖a_t − a_{t−1}‖² is
    numpy's float32 ``da @ da`` (:func:`_smoothness`; ``tests/oracles.py`` keeps the one-slave form
    it equals)."""
    global _weights_of, _weights
    a: cython.float[:, :] = actions
    b: cython.float[:, :] = last_actions
    if cfg is not _weights_of:  # the weights read once per reward config (a config is frozen), not at every step
        _weights_of, _weights = cfg, (cfg.formation, cfg.heading, cfg.collision, cfg.smoothness)
    wf: cython.double
    wh: cython.double
    wc: cython.double
    ws: cython.double
    wf, wh, wc, ws = _weights
    e: cython.double
    h: cython.double
    c: cython.double
    q: cython.double
    k: cython.Py_ssize_t
    n: cython.Py_ssize_t = min(len(formation_errors_m), len(heading_errors_rad), len(new_contacts), a.shape[0], b.shape[0])
    out = []
    for k in range(n):
        e, h, c = formation_errors_m[k], heading_errors_rad[k], new_contacts[k]
        q = _smoothness(a[k, 0] - b[k, 0], a[k, 1] - b[k, 1], a[k, 2] - b[k, 2])
        out.append(float(-wf * e - wh * (1.0 - _c_cos(h)) - wc * c - ws * q))
    return out


@cython.cfunc
@cython.inline
def _smoothness(d0: cython.float, d1: cython.float, d2: cython.float) -> cython.double:
    """‖d‖² of a float32 difference as numpy's float32 ``d @ d`` gives it (its dot of float32 is
    BLAS's sdot, summed in a double): each square a float32 product, their sum in order in a double,
    rounded to float32. (The differences and squares are float32 arithmetic in both forms: C floats
    compiled, numpy float32 scalars interpreted.)"""
    p0: cython.float = d0 * d0
    p1: cython.float = d1 * d1
    p2: cython.float = d2 * d2
    s: cython.double = float(p0) + float(p1) + float(p2)
    if cython.compiled:
        r: cython.float = s  # C's double -> float: round to nearest
        return r
    return float(np.float32(s))
