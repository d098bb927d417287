"""Oracles: the second form of each model the environment runs, kept here to check the shipped one.

The library keeps one implementation per idea, the one the environment runs (mostly plain Python
on the few values of one step, where numpy's fixed cost per call outweighs its arithmetic). The
forms below are the same models written the other way — numpy on whole arrays, or the general
routine the fast path specialises — as they stood in the library before; ``tests/test_fast_paths.py``
and the model tests hold the shipped paths to them, bit for bit where the two forms do the same
operations, and to the last bit of a transcendental where numpy's SIMD routines and the C
library's may round differently (said at each test).

Nothing here is imported by the package.
"""

from __future__ import annotations

import math

import numpy as np

from petswarm_env.config import IRConfig, RewardConfig

# -- IR module (petswarm_env/middleware/ir.py): seed 000 §3.3 ---------------------------------------
_IR_MIN_DISTANCE_M = 0.01


def ir_wrap_angle(angle_rad: np.ndarray) -> np.ndarray:
    """Angles (rad) wrapped to the interval (−π, π] (the IR estimator's convention)."""
    wrapped = np.pi - np.mod(np.pi - np.asarray(angle_rad, dtype=float), 2.0 * np.pi)
    # Rounding can land an angle just above −π exactly on −π; that end of the interval is open.
    return np.where(wrapped <= -np.pi, wrapped + 2.0 * np.pi, wrapped)


def _ir_ring(num_receivers: int) -> tuple[np.ndarray, float, float, float]:
    delta = 2.0 * np.pi / num_receivers
    return np.arange(num_receivers) * delta, delta, float(np.cos(delta)), float(np.sin(delta))


def ir_received_strengths(cfg: IRConfig, distance_m, bearing_rad, occluded, rng: np.random.Generator) -> np.ndarray:
    """:func:`petswarm_env.middleware.ir.received_strengths` on arrays: (M,) in, (M, K) out."""
    d = np.maximum(np.asarray(distance_m, dtype=float).reshape(-1), _IR_MIN_DISTANCE_M)
    bearing = np.asarray(bearing_rad, dtype=float).reshape(-1)
    occ = np.asarray(occluded, dtype=bool).reshape(-1)
    axes = _ir_ring(cfg.num_receivers)[0]
    lobe = np.maximum(0.0, np.cos(bearing[:, None] - axes)) ** cfg.lobe_exponent
    on_axis = cfg.strength_at_1m / d**2  # inverse-square fall-off
    on_axis = np.where(occ, on_axis * cfg.occlusion_attenuation, on_axis)
    on_axis = np.where(d > cfg.max_range_m, 0.0, on_axis)
    signal = on_axis[:, None] * lobe
    # the multiplicative, then the additive noise of every receiver: one draw of both
    z = rng.standard_normal((2, *signal.shape))
    noisy = signal * (1.0 + cfg.noise_rel * z[0])
    noisy = noisy + cfg.noise_abs * z[1]
    return np.minimum(np.maximum(noisy, 0.0), cfg.saturation)  # np.clip(noisy, 0, saturation)


def ir_estimate(cfg: IRConfig, strengths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`petswarm_env.middleware.ir.estimate` on arrays: (M, K) in, three (M,) out."""
    s = np.asarray(strengths, dtype=float).reshape(-1, cfg.num_receivers)
    k = cfg.num_receivers
    _, delta, cos_d, sin_d = _ir_ring(k)
    rows = np.arange(s.shape[0])
    i = np.argmax(s, axis=1)
    s0 = s[rows, i]
    s_plus = s[rows, (i + 1) % k]
    s_minus = s[rows, (i - 1) % k]
    a = (s0 + (s_plus + s_minus) * cos_d) / (1.0 + 2.0 * cos_d**2)
    b = (s_plus - s_minus) * sin_d / (2.0 * sin_d**2)
    r = np.hypot(a, b)
    valid = (s0 >= cfg.detect_threshold) & (r > 0.0)
    safe_r = np.where(valid, r, 1.0)
    distance = np.where(valid, np.sqrt(cfg.strength_at_1m / safe_r), np.nan)
    bearing = np.where(valid, ir_wrap_angle(np.arctan2(b, a) + i * delta), np.nan)
    return distance, bearing, valid
