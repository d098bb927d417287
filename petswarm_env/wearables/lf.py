"""LF user localisation and wake-up of seed 002 (§3.2, §3.3, §4.2): the 125 kHz field, the belt's
RSSI readings, and the paper's estimator on them.

Seed 002 §3.3 (Figs. 6–7): the robot carries two LF transmit antennas, side by side 20 cm apart,
which send LF bursts in turn every 350 ms. The user's smart belt measures the RSSI of each and
reports it over BLE. The robot converts each RSSI to a distance with an RSSI→distance table it
created beforehand, checks that the two distances and the antenna spacing form a triangle (Eq. 1),
and computes the user's position, distance and direction with Eqs. 2–3. The location is reliable
within 2 m and ±25° of the robot's forward axis (§3.3, §3.5, Figs. 10–11).

The two halves are kept apart, as in :mod:`petswarm_env.comms.ir`:

* :func:`lf_rssi` is the *physics*. At 125 kHz the wavelength is 2.4 km, so at a few metres the belt
  is deep in the near field (r ≪ λ/2π ≈ 380 m) of each antenna, a small magnetic dipole: the field
  amplitude falls as 1/r³, i.e. 60 dB per decade of distance, and an LF wake-up receiver's RSSI is
  logarithmic in it. The antennas stand vertically (§3.3: "placed vertically side-by-side"), so the
  field is the same in every horizontal direction. On top of that: a *common* Gaussian error per
  burst, shared by both readings (the two bursts are milliseconds apart and land on the same belt
  coil, whose orientation and coupling to the body vary from burst to burst); an independent
  Gaussian error per reading (receiver noise); quantisation of the RSSI register; an angular
  distortion outside the reliable half-angle (the robot's own body shadows the far-side antenna
  and scatters the field: a loss on the far antenna and extra noise on both, growing with the
  angle beyond ±25°; seed 002 Fig. 11: "distortion of the LF signal worsens outside this region");
  and no reception at all when the carrier is below the receiver's sensitivity (§3.3: beyond 2 m
  "the RSSI value cannot be calculated"). Detection is decided on the carrier itself, which the
  receiver integrates over the whole wake-up preamble; the per-reading noise acts on the RSSI.
* :func:`estimate` is the *paper's estimator*: table lookup with linear interpolation
  (:func:`rssi_to_distance`), then Eq. 1 and Eqs. 2–3 (:func:`position_from_distances`). Its table
  is the noiseless, undistorted calibration curve, so every noise source and the distortion show up
  as estimation error, as on the paper's hardware.
* :func:`locate` is one burst pair for one belt position (the robot bursts every 350 ms).

The chain runs on Python floats, one belt position at a time (numpy on 1-element arrays costs more
than the arithmetic). ``tests/oracles.py`` keeps it written with numpy arrays, as it was, and
``tests/unit/test_lf.py`` holds this one to it bit for bit, draws included. log10, arctan2, arccos,
arctan, cos, sin and hypot are numpy's, called on floats: numpy may evaluate them with its own
SIMD code (on AVX-512: SVML), whose results differ from ``math``'s in the last bit, and np.hypot is
libm's while math.hypot has its own algorithm. ``math`` is used only for the correctly rounded sqrt
and for degrees/radians (the single products x·(180/π), x·(π/180) of np.rad2deg/np.deg2rad);
``round`` is half-to-even like np.round.

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode: the master's
burst every 350 ms): the same chain on C doubles around the same numpy calls; hypot is the C
library's in the compiled form (numpy's hypot is the C library's), ``math.sqrt`` the C library's sqrt.

Frames. The paper's Eqs. 2–3 use a frame centred between the antennas with x along the baseline
from the left antenna to the right one (the robot's right) and y forward; θ = atan(x/y) is positive
to the right. Our body frame has +x forward and +y left, bearings counter-clockwise from +x. The
single conversion is :func:`_paper_to_body`. The antenna midpoint sits ``antenna_forward_m`` ahead
of the robot's centre; ``distance`` and ``direction`` of a fix are the paper's d and θ (measured
from that midpoint), ``x_fwd``/``y_left`` are relative to the robot's centre.

The estimator cannot tell front from back (y = dl·sin α ≥ 0): a belt behind the robot is reported
mirrored into the front half-plane — and heavily distorted, since it is far outside ±25°.
"""

from __future__ import annotations

import functools
import math
from bisect import bisect_right
from typing import Any, NamedTuple

import cython
import numpy as np
from cython.cimports.libc.math import hypot as _c_hypot
from cython.cimports.libc.math import sqrt as _c_sqrt

from petswarm_env.config import LFConfig
from petswarm_env.sim.geometry import wrap_angle

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

# Distances are clamped to at least this (m) so that log10 of a zero distance cannot occur.
_MIN_DISTANCE_M = 0.01
_round = round  # Python's (half-to-even, to an int), called as it is in both forms


@cython.cfunc
@cython.inline
def _hypot(a: cython.double, b: cython.double) -> cython.double:
    """numpy's hypot, which is the C library's (not Python's ``math.hypot``: the two differ in the
    last bit now and then)."""
    if cython.compiled:
        return _c_hypot(a, b)
    return float(np.hypot(a, b))



class LFFix(NamedTuple):
    """One or many user fixes (arrays, or scalars from :func:`locate` with one position).

    ``x_fwd``, ``y_left``: user position relative to the robot's centre, body frame, m.
    ``distance``: the paper's d (Eq. 3) from the antenna midpoint, m.
    ``direction``: the paper's θ (Eq. 3) from the robot's forward axis, counter-clockwise, rad.
    ``valid``: both bursts received and the triangle check (Eq. 1) passed; otherwise the other
    fields are nan. ``reliable``: valid and inside the reliable region (2 m, ±25°).
    """

    x_fwd: Any
    y_left: Any
    distance: Any
    direction: Any
    valid: Any
    reliable: Any


@cython.final
@cython.cclass
class _Plain:
    """The LF config's values that every burst reads, as C doubles (read once per config: a config is
    frozen; pydantic's field reads cost more than the arithmetic of a burst), and its RSSI table."""

    forward = cython.declare(cython.double)
    half = cython.declare(cython.double)
    spacing = cython.declare(object)  # antenna_spacing_m, the Python float (dw**2 is Python's float power)
    half_angle_deg = cython.declare(cython.double)
    half_angle_rad = cython.declare(cython.double)
    loss = cython.declare(cython.double)
    sensitivity = cython.declare(cython.double)
    common = cython.declare(cython.double)
    scatter = cython.declare(cython.double)
    own = cython.declare(cython.double)
    step = cython.declare(cython.double)
    at_1m = cython.declare(cython.double)
    falloff = cython.declare(cython.double)
    reliable_m = cython.declare(cython.double)
    table = cython.declare(tuple)

    def __init__(self, cfg: LFConfig):
        self.forward, self.spacing = cfg.antenna_forward_m, cfg.antenna_spacing_m
        self.half = 0.5 * cfg.antenna_spacing_m  # antenna_positions(): left at +half, right at -half
        self.half_angle_deg = cfg.reliable_half_angle_deg
        self.half_angle_rad = math.radians(cfg.reliable_half_angle_deg)
        self.loss, self.sensitivity = cfg.distortion_loss_db_per_deg, cfg.sensitivity_db
        self.common, self.scatter, self.own = cfg.noise_common_db, cfg.distortion_noise_db_per_deg, cfg.noise_antenna_db
        self.step, self.at_1m, self.falloff = cfg.rssi_step_db, cfg.rssi_at_1m_db, cfg.falloff_db_per_decade
        self.reliable_m = cfg.reliable_range_m
        self.table = _table(cfg.rssi_at_1m_db, cfg.falloff_db_per_decade, cfg.table_min_m, cfg.table_max_m, cfg.table_step_m)


_plain_of: object = None  # the config whose values _plain_last holds
_plain_last: object = None


@cython.cfunc
def _plain(cfg) -> _Plain:
    """``cfg``'s :class:`_Plain` (made anew for another config)."""
    global _plain_of, _plain_last
    if cfg is not _plain_of:
        _plain_of, _plain_last = cfg, _Plain(cfg)
    return _plain_last


def antenna_positions(cfg: LFConfig) -> tuple[tuple[float, float], tuple[float, float]]:
    """Body-frame positions of the left and the right antenna, m (seed 002 §3.3, Fig. 6)."""
    half = 0.5 * cfg.antenna_spacing_m
    return (cfg.antenna_forward_m, half), (cfg.antenna_forward_m, -half)


def calibration_curve(cfg: LFConfig, distance_m: float) -> float:
    """Noiseless RSSI (dB) at ``distance_m`` from one antenna: 1/r³ near field, 60 dB/decade
    (distances clamped to 1 cm, nan kept)."""
    d: cython.double = _MIN_DISTANCE_M if distance_m < _MIN_DISTANCE_M else distance_m
    p: _Plain = _plain(cfg)
    return p.at_1m - p.falloff * float(np.log10(d))


def lf_rssi(cfg: LFConfig, x: float, y: float, rng: np.random.Generator) -> tuple[float, float, bool]:
    """The belt's RSSI readings (dB) of one burst from each antenna, the belt at ``(x, y)`` relative
    to the robot's centre (body frame, m): ``(rssi_left, rssi_right, received)``, nan and False
    when the carrier is below the sensitivity. Draws 5 normals whatever is received (reproducible):
    [common, own left, own right, scatter left, scatter right]."""
    # seed 002 §3.3: two antennas 20 cm apart send in turn; the belt measures each RSSI.
    p: _Plain = _plain(cfg)
    fwd: cython.double = p.forward
    half: cython.double = p.half  # antenna_positions(): left at +half, right at -half
    dx: cython.double = x - fwd
    d_l: cython.double = _hypot(dx, y - half)
    d_r: cython.double = _hypot(dx, y - -half)
    # Angular distortion beyond the reliable region (seed 002 §3.5, Fig. 11), bearing from the midpoint.
    bearing_deg: cython.double = math.degrees(float(np.arctan2(y, dx)))
    excess_deg: cython.double = abs(bearing_deg) - p.half_angle_deg
    excess_deg = 0.0 if excess_deg <= 0.0 else excess_deg  # max(0, ·), nan kept
    carrier_l: cython.double = calibration_curve(cfg, d_l)
    carrier_r: cython.double = calibration_curve(cfg, d_r)
    loss: cython.double = p.loss
    if bearing_deg > 0.0:  # user on the left → the right antenna is the far one
        carrier_r = carrier_r - loss * excess_deg
    else:
        carrier_l = carrier_l - loss * excess_deg
    # seed 002 §3.3: beyond the receiver's sensitivity the RSSI cannot be calculated.
    sensitivity: cython.double = p.sensitivity
    received: cython.bint = carrier_l >= sensitivity and carrier_r >= sensitivity
    z_common, z_own_l, z_own_r, z_scat_l, z_scat_r = rng.standard_normal(5).tolist()
    if not received:
        return math.nan, math.nan, False
    common: cython.double = p.common * z_common
    scatter_sigma: cython.double = p.scatter * excess_deg
    own: cython.double = p.own
    rssi_l: cython.double = carrier_l + common + own * z_own_l + scatter_sigma * z_scat_l
    rssi_r: cython.double = carrier_r + common + own * z_own_r + scatter_sigma * z_scat_r
    step: cython.double = p.step
    if step > 0.0:  # round() is half-to-even
        rssi_l = _round(rssi_l / step) * step
        rssi_r = _round(rssi_r / step) * step
    return rssi_l, rssi_r, True


@functools.lru_cache(maxsize=16)
def _table(rssi_at_1m_db: float, falloff: float, dmin: float, dmax: float, step: float) -> tuple[tuple, tuple]:
    count = int(np.floor((dmax - dmin) / step + 1e-9)) + 1
    dist = dmin + step * np.arange(count)
    rssi = rssi_at_1m_db - falloff * np.log10(dist)
    # the lookup needs increasing RSSI: strongest RSSI (shortest distance) last
    return tuple(rssi[::-1].tolist()), tuple(dist[::-1].tolist())


def rssi_table(cfg: LFConfig) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The robot's RSSI→distance table (seed 002 §3.3: "We created an RSSI value table using the
    distance"): the noiseless calibration curve on the configured distance grid, built once per
    parameter set and cached. Returns (rssi_db increasing, distance_m decreasing)."""
    p: _Plain = _plain(cfg)
    return p.table


def rssi_to_distance(cfg: LFConfig, rssi_db: float) -> float:
    """Table lookup with linear interpolation; readings beyond the table clamp to its ends. The
    formula of ``np.interp`` (numpy's arr_interp, its result to the bit): the row j with
    xp[j] <= v < xp[j+1], fp[j] on an exact hit, else slope·(v − xp[j]) + fp[j] with
    slope = (fp[j+1] − fp[j]) / (xp[j+1] − xp[j])."""
    xp: tuple
    fp: tuple
    xp, fp = rssi_table(cfg)
    v: cython.double = rssi_db
    last: cython.Py_ssize_t = len(xp) - 1
    if v > xp[last]:
        return fp[last]
    if v < xp[0]:
        return fp[0]
    j: cython.Py_ssize_t = bisect_right(xp, v) - 1
    if j == last or xp[j] == v:
        return fp[j]
    x0: cython.double = xp[j]
    x1: cython.double = xp[j + 1]
    f0: cython.double = fp[j]
    f1: cython.double = fp[j + 1]
    return (f1 - f0) / (x1 - x0) * (v - x0) + f0


def triangle_formed(dl: float, dr: float, dw: float) -> bool:
    """Seed 002, Eq. 1: d_B + d_C > d_A, d_A the longest of the three sides (dl, dr, dw)."""
    longest: cython.double = dl if dl >= dr else dr
    longest = longest if longest >= dw else dw
    return (dl + dr + dw) - longest > longest


def _paper_to_body(cfg: LFConfig, x_p, y_p, theta_p):
    """The paper's frame (x right, y forward, θ clockwise, origin between the antennas) → body frame
    (x forward, y left, direction counter-clockwise, origin at the robot's centre)."""
    p: _Plain = _plain(cfg)
    return y_p + p.forward, -x_p, -theta_p


_NO_FIX = LFFix(math.nan, math.nan, math.nan, math.nan, False, False)


def position_from_distances(cfg: LFConfig, dl: float, dr: float) -> LFFix:
    """Seed 002 Eqs. 1–3 on the distances (m) to the left and the right antenna.

    Triangle check (Eq. 1), failure → no fix; α = acos((dl² + dw² − dr²)/(2·dl·dw)),
    x = dl·cos α − dw/2, y = dl·sin α (Eq. 2); d = √(x² + y²), θ = atan(x/y) (Eq. 3); then the
    paper's frame is mapped to the body frame.
    """
    p: _Plain = _plain(cfg)
    dw = p.spacing  # (a Python float: dw**2 is Python's float power in both forms)
    if not triangle_formed(dl, dr, dw):  # seed 002, Eq. 1
        return _NO_FIX
    # seed 002, Eq. 2 (the clip guards rounding)
    cos_alpha: cython.double = (dl * dl + dw**2 - dr * dr) / (2.0 * dl * dw)
    cos_alpha = -1.0 if cos_alpha < -1.0 else (1.0 if cos_alpha > 1.0 else cos_alpha)
    alpha: cython.double = float(np.arccos(cos_alpha))
    x_p: cython.double = dl * float(np.cos(alpha)) - dw / 2.0
    y_p: cython.double = dl * float(np.sin(alpha))
    # seed 002, Eq. 3 (a formed triangle has sin α > 0, so y > 0; should rounding give y = 0,
    # x/y is ±inf as numpy's division gives it)
    d: cython.double = _c_sqrt(x_p * x_p + y_p * y_p)
    theta_p: cython.double = float(np.arctan(x_p / y_p if y_p != 0.0 else np.float64(x_p) / y_p))
    x_fwd, y_left, direction = _paper_to_body(cfg, x_p, y_p, theta_p)
    reliable: cython.bint = d <= p.reliable_m and abs(direction) <= p.half_angle_rad
    return LFFix(x_fwd, y_left, d, direction, True, reliable)


def estimate(cfg: LFConfig, rssi_left: float, rssi_right: float) -> LFFix:
    """The paper's estimator on the two RSSI readings (a nan reading gives no fix): RSSI → dl, dr by
    the table (§3.3, :func:`rssi_to_distance`), then Eqs. 1–3 (:func:`position_from_distances`)."""
    if not (math.isfinite(rssi_left) and math.isfinite(rssi_right)):
        return _NO_FIX
    return position_from_distances(cfg, rssi_to_distance(cfg, rssi_left), rssi_to_distance(cfg, rssi_right))


def locate(cfg: LFConfig, x: float, y: float, rng: np.random.Generator) -> LFFix:
    """One burst pair and the robot's fix of the belt at ``(x, y)`` (body frame, m):
    :func:`lf_rssi` then :func:`estimate`."""
    rssi_l, rssi_r, received = lf_rssi(cfg, x, y, rng)
    return estimate(cfg, rssi_l, rssi_r) if received else _NO_FIX


def wakes_up(cfg: LFConfig, distance_m: float, pattern_sent: Any, pattern_stored: Any) -> bool:
    """Seed 002 §3.2 (Fig. 5): a belt within the wake range receives the robot's LF wake-up burst;
    it compares the received pattern with the one in its register and wakes its main processor
    only if they are equal."""
    return bool(distance_m <= cfg.wake_range_m and pattern_sent == pattern_stored)
