"""IR relative-location module: the physics of the receiver ring plus the paper's estimator.

Seed 000 (Pet-Bot swarm middleware), §3.3: each robot carries an IR module at its centre. IR LEDs
transmit in all directions; a ring of numbered phototransistors receives. The module measures the
strength on every receiver, takes the strongest one and its two side neighbours, estimates the x
and y components (a, b) of the source vector from these three (Eq. 2), then the distance from the
estimated strength r and the direction θ (Eq. 3), adding the strongest receiver's angular offset
when it is not receiver 0.

This module keeps the two halves apart on purpose:

* :func:`received_strengths` is the *physics*: inverse-square fall-off, an angular lobe
  ``max(0, cos Δ)**lobe_exponent`` per receiver, multiplicative and additive noise, occlusion by
  bodies in the line of sight, and ADC saturation.
* :func:`estimate` is the *paper's estimator*, which assumes an ideal cosine lobe
  (exponent 1) and no noise. The configured ``lobe_exponent`` differs from 1, so the estimator
  carries a real model error, as the paper's hardware does.

Both run on Python floats, row by row: an IR slot has 1–9 receivers, and numpy's fixed cost per
call (about 1 µs) outweighs its arithmetic on so few rows. ``tests/oracles.py`` keeps the same two
functions written with numpy arrays; ``tests/unit/test_ir.py`` holds these to them (validity and
distance exactly; the readings and the bearing to the last bit of the lobe's ``pow`` and of
``atan2``, which numpy's SIMD routines on AVX-512 CPUs may round differently from the C library's
used here — so the env's episodes do not depend on numpy's SIMD dispatch).

Frames and units: bearings are in radians in the receiving robot's body frame, counter-clockwise
from the robot's front (+x); receiver k points at ``k·2π/K``. Distances are in metres; strengths
are in arbitrary ADC units."""

from __future__ import annotations

import functools
import math

import cython
import numpy as np
from cython.cimports.libc.math import atan2 as _c_atan2
from cython.cimports.libc.math import cos as _c_cos
from cython.cimports.libc.math import hypot as _c_hypot
from cython.cimports.libc.math import pow as _c_pow
from cython.cimports.libc.math import sqrt as _c_sqrt

from petswarm_env.config import IRConfig

if cython.compiled:  # the project's one angle wrap, of one float, as a C call (sim/geometry.pxd)
    from cython.cimports.petswarm_env.sim.geometry import wrap_float
else:
    from petswarm_env.sim.geometry import wrap_float

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

# Distances are clamped to at least this (m) so a degenerate zero distance cannot produce inf·0.
_MIN_DISTANCE_M = 0.01

_PI = cython.declare(cython.double, math.pi)
_NAN = cython.declare(cython.double, math.nan)


@cython.cfunc
@cython.inline
def _hypot(a: cython.double, b: cython.double) -> cython.double:
    """The C library's hypot (numpy's), not Python's ``math.hypot``: the two differ in the last bit
    now and then."""
    if cython.compiled:
        return _c_hypot(a, b)
    return float(np.hypot(a, b))


@functools.cache
def _ring(num_receivers: int) -> tuple[tuple[float, ...], float, float, float]:
    """Receiver axes (rad) of a ring of ``num_receivers``, its spacing Δ, cos Δ and sin Δ."""
    delta = 2.0 * np.pi / num_receivers
    axes = tuple((np.arange(num_receivers) * delta).tolist())
    return axes, delta, float(np.cos(delta)), float(np.sin(delta))


def received_strengths(
    cfg: IRConfig,
    distance_m: list[float],
    bearing_rad: list[float],
    occluded: list[bool],
    rng: np.random.Generator,
) -> list[list[float]]:
    """Simulate the readings of the receiver ring for M transmitter/receiver pairs.

    Args:
        cfg: IR module parameters.
        distance_m: M centre-to-centre distances from transmitter to receiver, m.
        bearing_rad: M bearings of the transmitter in the *receiving* robot's body frame, rad.
        occluded: M flags, True where a body blocks the line of sight.
        rng: random generator for the receiver noise: one draw of (2, M, K) normals, the
            multiplicative then the additive noise of every receiver.

    Returns:
        M rows of K readings in ADC units, within [0, cfg.saturation].

    A receiver facing away from the source (lobe 0, about half the ring) reads the additive noise
    alone, which is what ``on_axis·0·(1 + …) + noise`` gives.
    """
    k = cfg.num_receivers
    z = rng.standard_normal((2, len(distance_m), k))
    out = np.empty((len(distance_m), k))
    ring_readings(cfg, distance_m, bearing_rad, occluded, z, out)
    return out.tolist()


@cython.final
@cython.cclass
class Optics:
    """An IR configuration's constants as C doubles (sections are frozen, so they stay valid), with
    the scratch rows of a slot (:func:`measure_rows`): what the IR channel keeps for its configuration."""

    cfg = cython.declare(object, visibility="readonly")
    k = cython.declare(cython.Py_ssize_t, visibility="readonly")  # receivers on the ring
    delta = cython.declare(cython.double)  # the ring's spacing Δ, cos Δ, sin Δ
    cos_d = cython.declare(cython.double)
    sin_d = cython.declare(cython.double)
    s1 = cython.declare(cython.double)
    att = cython.declare(cython.double)
    far = cython.declare(cython.double)
    exponent = cython.declare(cython.double)
    rel = cython.declare(cython.double)
    add = cython.declare(cython.double)
    sat = cython.declare(cython.double)
    threshold = cython.declare(cython.double)
    rows = cython.declare(cython.Py_ssize_t)  # how many pairs the scratch holds
    strengths = cython.declare(cython.double[:, ::1])  # (rows, K) readings
    est = cython.declare(cython.double[:, ::1])  # (2, rows): distance, bearing
    valid = cython.declare(cython.uchar[::1])  # (rows,)

    def __init__(self, cfg: IRConfig):
        self.cfg = cfg
        self.k = cfg.num_receivers
        _, self.delta, self.cos_d, self.sin_d = _ring(self.k)
        self.s1, self.att, self.far = cfg.strength_at_1m, cfg.occlusion_attenuation, cfg.max_range_m
        self.exponent, self.rel, self.add, self.sat = cfg.lobe_exponent, cfg.noise_rel, cfg.noise_abs, cfg.saturation
        self.threshold = cfg.detect_threshold
        self.rows = 0

    def __reduce__(self):
        return Optics, (self.cfg,)

    @cython.cfunc
    def reserve(self, m: cython.Py_ssize_t) -> cython.void:
        """Scratch for at least ``m`` pairs."""
        if m > self.rows:
            self.rows = max(m, 2 * self.rows, 8)
            self.strengths = np.empty((self.rows, self.k))
            self.est = np.empty((2, self.rows))
            self.valid = np.empty(self.rows, np.uint8)


@cython.ccall
def ring_readings(cfg: IRConfig, distance_m: list, bearing_rad: list, occluded: list, z: cython.double[:, :, ::1],
                  out: cython.double[:, ::1]) -> cython.void:
    """:func:`received_strengths` with its noise given: ``z`` (2, M, K), the multiplicative then the
    additive standard normals of every receiver; the readings written into ``out`` (M, K). Typed
    loops over C arrays (no Python float per reading)."""
    _readings(Optics(cfg), distance_m, bearing_rad, occluded, z, out)


@cython.cfunc
def _readings(o: Optics, distance_m: list, bearing_rad: list, occluded: list, z: cython.double[:, :, ::1],
              out: cython.double[:, ::1]) -> cython.void:
    """:func:`ring_readings` with the configuration's constants in ``o``."""
    k: cython.Py_ssize_t = o.k
    delta: cython.double = o.delta
    s1: cython.double = o.s1
    att: cython.double = o.att
    far: cython.double = o.far
    exponent: cython.double = o.exponent
    rel: cython.double = o.rel
    add: cython.double = o.add
    sat: cython.double = o.sat
    m: cython.Py_ssize_t = len(distance_m)
    i: cython.Py_ssize_t
    j: cython.Py_ssize_t
    d: cython.double
    bearing: cython.double
    on_axis: cython.double
    c: cython.double
    x: cython.double
    for i in range(m):
        d = distance_m[i]
        if d < _MIN_DISTANCE_M:  # max(d, _MIN_DISTANCE_M)
            d = _MIN_DISTANCE_M
        on_axis = s1 / (d * d)  # inverse-square fall-off
        if occluded[i]:
            on_axis = on_axis * att
        if d > far:
            on_axis = 0.0
        bearing = bearing_rad[i]
        for j in range(k):
            c = _c_cos(bearing - j * delta)  # receiver j's axis: j·Δ
            if c > 0.0:
                x = on_axis * _c_pow(c, exponent) * (1.0 + rel * z[0, i, j]) + add * z[1, i, j]
            else:  # the source is behind this receiver: a zero lobe, so the reading is the additive noise
                x = add * z[1, i, j]
            # the clip to [0, sat], as max(x, 0.0) then min(x, sat)
            if x < 0.0:
                x = 0.0
            elif x > sat:
                x = sat
            out[i, j] = x


@cython.ccall
def measure_rows(optics: Optics, distance_m: list, bearing_rad: list, occluded: list,
                 z: cython.double[:, :, ::1]) -> tuple:
    """:func:`ring_readings` then :func:`estimate_rows` for M pairs whose receiver noise is ``z``
    (2, M, K), with the constants and the scratch of ``optics``: their ``(distance_m, bearing_rad,
    valid)``, three lists of M. What the IR channel calls for a slot (one call, no array made)."""
    m: cython.Py_ssize_t = len(distance_m)
    optics.reserve(m)
    strengths: cython.double[:, ::1] = optics.strengths[:m]
    _readings(optics, distance_m, bearing_rad, occluded, z, strengths)
    est: cython.double[:, ::1] = optics.est
    valid: cython.uchar[::1] = optics.valid
    _estimates(optics, strengths, est[0], est[1], valid)
    i: cython.Py_ssize_t
    return ([float(est[0, i]) for i in range(m)], [float(est[1, i]) for i in range(m)],
            [bool(valid[i]) for i in range(m)])


def estimate(cfg: IRConfig, strengths: list[list[float]]) -> tuple[list[float], list[float], list[bool]]:
    """The paper's estimator: distance and direction of the source from the ring readings.

    For the strongest receiver i (strength S0; the first of equals) and its neighbours i+1 (S+,
    counter-clockwise) and i−1 (S−), with ring spacing Δ, the least-squares fit of an ideal cosine
    lobe ``S_j = r·cos(φ − jΔ)`` to the three readings gives the source-vector components in the
    frame of receiver i (exact when the lobe really is a cosine and there is no noise):

        a = (S0 + (S+ + S−)·cos Δ) / (1 + 2·cos²Δ)
        b = (S+ − S−)·sin Δ / (2·sin²Δ)

    Then ``r = hypot(a, b)``, ``d = sqrt(strength_at_1m / r)`` (inverse square) and
    ``θ = atan2(b, a) + i·Δ`` wrapped to (−π, π].

    Args:
        cfg: IR module parameters (ring size, strength_at_1m, detect_threshold).
        strengths: M rows of K readings, ADC units.

    Returns:
        distance_m, bearing_rad (in the receiving robot's body frame) and valid, M each. Rows
        whose strongest reading is below ``cfg.detect_threshold`` are invalid and get nan.
    """
    s = np.asarray(strengths, dtype=np.float64).reshape(len(strengths), cfg.num_receivers)
    distance, bearing, valid = np.empty(len(strengths)), np.empty(len(strengths)), np.empty(len(strengths), np.uint8)
    estimate_rows(cfg, s, distance, bearing, valid)
    return distance.tolist(), bearing.tolist(), valid.view(np.bool_).tolist()


@cython.ccall
def estimate_rows(cfg: IRConfig, strengths: cython.double[:, ::1], distance: cython.double[::1],
                  bearing: cython.double[::1], valid: cython.uchar[::1]) -> cython.void:
    """:func:`estimate` on an (M, K) array of readings, into ``distance``, ``bearing`` and ``valid``
    (M each): typed loops."""
    _estimates(Optics(cfg), strengths, distance, bearing, valid)


@cython.cfunc
def _estimates(o: Optics, strengths: cython.double[:, ::1], distance: cython.double[::1],
               bearing: cython.double[::1], valid: cython.uchar[::1]) -> cython.void:
    """:func:`estimate_rows` with the configuration's constants in ``o``."""
    # seed 000, §3.3, Eqs. 1–3 (text garbled in the extraction; reconstructed as above)
    k: cython.Py_ssize_t = o.k
    delta: cython.double = o.delta
    cos_d: cython.double = o.cos_d
    sin_d: cython.double = o.sin_d
    den_a: cython.double = 1.0 + 2.0 * cos_d**2
    den_b: cython.double = 2.0 * sin_d**2
    threshold: cython.double = o.threshold
    s1: cython.double = o.s1
    i: cython.Py_ssize_t
    j: cython.Py_ssize_t
    s0: cython.double
    sj: cython.double
    a: cython.double
    b: cython.double
    r: cython.double
    theta: cython.double
    m: cython.Py_ssize_t = strengths.shape[0]
    row: cython.Py_ssize_t
    for row in range(m):
        i = 0  # the strongest receiver (the first of equals, as argmax)
        s0 = strengths[row, 0]
        for j in range(1, k):
            sj = strengths[row, j]
            if sj > s0:
                i, s0 = j, sj
        s_plus: cython.double = strengths[row, (i + 1) % k]
        s_minus: cython.double = strengths[row, (i - 1 + k) % k]
        a = (s0 + (s_plus + s_minus) * cos_d) / den_a
        b = (s_plus - s_minus) * sin_d / den_b
        r = _hypot(a, b)
        ok: cython.bint = s0 >= threshold and r > 0.0
        valid[row] = ok
        if ok:
            distance[row] = _c_sqrt(s1 / r)
            theta = _c_atan2(b, a) + i * delta
            w: cython.double = -wrap_float(-theta)  # to (−π, π]: π − (π − θ) mod 2π, to the bit
            bearing[row] = w + 2.0 * _PI if w <= -_PI else w
        else:
            distance[row] = _NAN
            bearing[row] = _NAN
