"""Smart belt: the waist IMU of seed 002 §3.4, its signals and the paper's motion recognition.

Seed 002 §3.4 (User-Motion Recognition) gives the belt two jobs:

* **Movement state** from the z accelerometer (Fig. 8, Table 2). "The periodicity is defined by
  checking the number of sign changes of the values that occur within a valid time period. If the
  periodicity indicates that the user does a periodic action, then the smart belt applies the
  signal magnitude area (SMA). The SMA accumulates the accelerometer values within the
  programmer-defined time." Table 2 then reads (rows *Periodicity / SMA / State*)::

      Movement      3   Run
                    2   Walk
                    1   Rest
      Non-movement  X   Stop

  The SMA is applied only to a periodic signal, and "X" is a don't-care: a non-periodic window is
  Stop whatever its SMA; a periodic one is Run / Walk / Rest by SMA level 3 / 2 / 1. (Reading Rest
  as non-periodic + SMA 1 would overlap the Stop row's "X" and contradict "if periodic, then the
  SMA".) So Rest is a small periodic motion: the user sways or shifts weight in place.
* **Rotation state** from the z gyro: "The gyro sensor value is sampled at 70 ms intervals. It
  minimizes the amount of noise by using a moving-average filter. The robot must know the rotation
  state, angular speed, and accumulated angle of the human."

This module keeps the physics and the recognition apart, as ``comms/ir.py`` does:

* *Signals* (``_synth_*``): the waist's vertical acceleration is gravity plus a gait oscillation
  at the step frequency (cadence grows with speed; walk and run differ) whose amplitude is that of
  a vertical centre-of-mass excursion ``h`` at that frequency, ``(2πf)²·h``; resting is a small,
  irregular sway; standing still gives only sensor noise. The gyro measures the true turn rate
  plus the pelvis' yaw wobble at the stride frequency, a constant bias and noise. Numbers are chosen
  (see ``default.yaml``).
* *Recognition* (:func:`count_sign_changes`, :func:`signal_magnitude_area`, :func:`sma_level`,
  :func:`classify`, and the gyro filter in :class:`SmartBelt`): the paper's rules, run on every
  sample. Recognition latency and errors come out of the window and the filter, not a table.
  Choices where the paper is silent: gravity is removed as the window mean; a sample's sign counts
  only beyond a dead band (else white noise around zero would look highly "periodic"); the rotation
  flag has an on and a lower off threshold; the accumulated angle integrates the gyro samples (an
  integral is its own low-pass: the filter is for the flag and the angular speed) from the oldest
  sample in the filter window when the flag rises — the onset the average was ramping up to — to
  the sample at which it falls, restarts with every rotation and holds its value after it ends.
  Natural consequences: a walk→stop or stop→walk change passes through Rest for a few samples
  (the window holds a fading gait: periodic, small SMA), and a turn's angle carries the gyro's
  bias and noise over the rotation plus the pelvis' yaw wobble when the user turns while walking.

Units: seconds, metres, radians; angular rates in rad/s (``*_dps`` config keys are °/s).
"""

from __future__ import annotations

import math
from array import array

import cython
import numpy as np
from cython.cimports.libc.math import cos as _cos
from cython.cimports.libc.math import floor as _floor
from cython.cimports.libc.math import sin as _sin
from cython.cimports.libc.math import sqrt as _sqrt

from petswarm_env.config import BeltConfig
from petswarm_env.scenarios import ACTIVITIES  # seed 002 Table 2; index = activity code below
from petswarm_env.sim.sensors import NormalStream

if cython.compiled:  # the window statistics' C function (wearables/belt_window.pxd): a C call per control period
    from cython.cimports.petswarm_env.wearables.belt_window import window_stats
else:
    from petswarm_env.wearables.belt_window import window_stats

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

GRAVITY_MPS2 = cython.declare(cython.double, 9.80665)
_EPS_S = cython.declare(cython.double, 1e-9)  # sample times are compared with this slack (float accumulation of 0.1 s steps)
_PI = cython.declare(cython.double, math.pi)  # (math.pi as a C constant: read for every sample chunk)


# --------------------------------------------------------------------------- recognition rules


def count_sign_changes(windows: np.ndarray, deadband: float) -> np.ndarray:
    """Periodicity of seed 002 §3.4: sign changes of the mean-removed values in each window.

    ``windows`` is ``(..., W)``. The mean is removed per window (it holds gravity). A sample's sign
    is + above ``deadband``, − below ``-deadband``; a sample inside the band keeps the last sign, so
    sensor noise around zero is not counted as motion. Returns the count per window.
    """
    return _per_row(windows, deadband)[0]


def signal_magnitude_area(windows: np.ndarray) -> np.ndarray:
    """SMA of seed 002 §3.4: the accumulated |acceleration| over the window, per second (m/s²).

    The window mean (gravity) is removed first, as for the periodicity.
    """
    return _per_row(windows, 0.0)[1]


def _per_row(windows: np.ndarray, deadband: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~.belt_window.window_stats` on every row of ``windows`` (..., W)."""
    x = np.asarray(windows, dtype=np.float64)
    w = x.shape[x.ndim - 1]  # (the compiled core indexes without wrap-around: no negative index)
    shape = x.shape[: x.ndim - 1]
    flat = np.ascontiguousarray(x).reshape(-1)
    rows = [window_stats(flat, k * w, k * w + 1, w, deadband) for k in range(flat.size // w)]
    changes = np.array([r[0][0] for r in rows], dtype=np.intp).reshape(shape)
    return changes, np.array([r[1][0] for r in rows], dtype=np.float64).reshape(shape)


@cython.ccall
def sma_level(sma: cython.double, cfg: BeltConfig) -> cython.int:
    """SMA level 1 / 2 / 3 of one window by the two thresholds (seed 002 Table 2)."""
    return _level(sma, cfg.sma_level2_mps2, cfg.sma_level3_mps2)


@cython.cfunc
@cython.inline
def _level(sma: cython.double, level2: cython.double, level3: cython.double) -> cython.int:
    """:func:`sma_level` with its two thresholds given (read once per control period)."""
    return 1 + (sma >= level2) + (sma >= level3)


@cython.ccall
def classify(periodic: cython.bint, level: cython.int) -> cython.int:
    """Seed 002 Table 2 for one window, as an activity code (index into :data:`ACTIVITIES`).

    Periodic ("Movement"): SMA 3 → Run (3), 2 → Walk (2), 1 → Rest (1).
    Non-periodic ("Non-movement"), any SMA ("X") → Stop (0).
    """
    return level if periodic else 0


# --------------------------------------------------------------------------- the device


@cython.dataclasses.dataclass(frozen=True)
@cython.cclass
class BeltReading:
    """What the belt knows (and sends over BLE): seed 002 §3.4's movement and rotation states."""

    activity: str  # stop | rest | walk | run (Table 2)
    rotating: cython.bint  # rotation state
    angular_speed_rps: cython.double  # moving-average filtered yaw rate, CCW positive
    accumulated_angle_rad: cython.double  # angle of the current (or last finished) rotation, CCW positive
    time_s: cython.double  # time the belt has been advanced to
    activity_since_s: cython.double  # accelerometer sample time at which the current activity was first recognised
    rotation_since_s: cython.double  # gyro sample time at which the rotation flag last changed
    sign_changes: cython.long  # periodicity of the last window
    sma_mps2: cython.double  # SMA of the last window


@cython.cclass
class SmartBelt:
    """The smart belt on the user's waist: IMU sampling and the recognition of seed 002 §3.4.

    ``advance(t_end, ...)`` synthesises and processes every accelerometer and gyro sample up to
    ``t_end`` with the user's true motion held constant since the previous call (the env calls it
    once per control period). ``reading()`` is the belt's current knowledge. Until the first full
    window the activity is Stop (nothing recognised yet).

    A typed class of the compiled core (Cython's pure-Python mode, ``petswarm_env/_core.py``): it
    runs for every control period, advanced and read by the user session by C calls (``belt.pxd``).
    """

    # its typed attributes are declared in ``belt.pxd``

    def __init__(self, cfg: BeltConfig, rng: np.random.Generator, t0_s: float = 0.0):
        self.cfg = cfg
        self._t0 = float(t0_s)
        self._t = float(t0_s)
        # accelerometer: sample k (k = 1, 2, ...) at t0 + k/rate
        self._acc_dt = 1.0 / cfg.accel_rate_hz
        self._w = cfg.window_samples
        self._n_acc = 0
        self._hist = array("d", bytes(8 * (2 * self._w - 1)))  # last W-1 samples, then room for a chunk of up to W
        self._gait_phase = float(rng.uniform(0.0, 2.0 * math.pi))
        # gyro: sample k at t0 + k·period
        self._n_gyro = 0
        self._stride_phase = float(rng.uniform(0.0, 2.0 * math.pi))
        self._bias_rps = math.radians(cfg.gyro_bias_dps) * float(rng.standard_normal())
        self.rng = rng  # every later draw: standard normals, through the stream
        self._ma = [0.0] * cfg.ma_samples  # ring buffer of the moving-average filter
        self._on_rps = math.radians(cfg.rotation_on_dps)
        self._off_rps = math.radians(cfg.rotation_off_dps)
        self._gyro_noise_rps = math.radians(cfg.gyro_noise_dps)
        self._wobble_rad = math.radians(cfg.gait_yaw_wobble_deg)
        self._gyro_dt, self._acc_noise = cfg.gyro_period_s, cfg.accel_noise_mps2
        self._walk_bounce, self._run_bounce, self._gait_jitter = cfg.walk_bounce_m, cfg.run_bounce_m, cfg.gait_phase_jitter
        self._rest_hz, self._rest_amp, self._rest_jitter = cfg.rest_sway_hz, cfg.rest_sway_mps2, cfg.rest_phase_jitter
        self._deadband, self._min_changes = cfg.sign_deadband_mps2, cfg.min_sign_changes
        self._level2, self._level3 = cfg.sma_level2_mps2, cfg.sma_level3_mps2
        self._cadence = (None, math.nan, math.nan)  # (posture, speed, cadence) of the last gait: the user's state holds for many periods
        # the belt's knowledge
        self._activity = 0
        self._activity_since = self._t0
        self._sign_changes = 0
        self._sma = 0.0
        self._rotating = False
        self._rotation_since = self._t0
        self._omega_f = 0.0
        self._angle = 0.0

    # ------------------------------------------------------------------ public API

    @property
    def rng(self) -> np.random.Generator:
        """The belt's noise stream (after its power-on draws, every draw is a standard normal:
        drawn in blocks by :class:`~petswarm_env.sim.sensors.NormalStream`, the same numbers in
        the same order)."""
        return self._normals.rng

    @rng.setter
    def rng(self, rng: np.random.Generator) -> None:
        self._normals = NormalStream(rng)

    @cython.ccall
    def advance(self, t_end: cython.double, speed_mps: cython.double, turn_rate_rps: cython.double, posture: str):
        """Sample and process the IMU up to ``t_end`` (s), the user's state constant since the last call.

        ``speed_mps`` and ``turn_rate_rps`` (CCW positive) are the user's true motion; ``posture`` is
        the user's true activity (stop | rest | walk | run), which selects the gait model.
        """
        if posture not in ACTIVITIES:
            raise ValueError(f"posture '{posture}' is not one of {', '.join(ACTIVITIES)}")
        if t_end < self._t - _EPS_S:
            raise ValueError(f"belt time runs forward: t_end {t_end} < {self._t}")
        n_target: cython.Py_ssize_t = cython.cast(cython.Py_ssize_t, _floor((t_end - self._t0) / self._acc_dt + _EPS_S))
        n: cython.Py_ssize_t
        while self._n_acc < n_target:
            n = min(self._w, n_target - self._n_acc)
            self._accel_chunk(n, speed_mps, posture)
        m_target: cython.Py_ssize_t = cython.cast(cython.Py_ssize_t, _floor((t_end - self._t0) / self._gyro_dt + _EPS_S))
        if m_target > self._n_gyro:
            self._gyro_samples(m_target - self._n_gyro, speed_mps, turn_rate_rps, posture)
        self._t = max(self._t, float(t_end))

    @cython.ccall
    def reading(self):
        """The belt's current knowledge, a :class:`BeltReading`."""
        return BeltReading(
            activity=ACTIVITIES[self._activity],
            rotating=self._rotating,
            angular_speed_rps=self._omega_f,
            accumulated_angle_rad=self._angle,
            time_s=self._t,
            activity_since_s=self._activity_since,
            rotation_since_s=self._rotation_since,
            sign_changes=self._sign_changes,
            sma_mps2=self._sma,
        )

    @cython.cfunc
    def _cadence_hz(self, posture: str, speed_mps: cython.double) -> cython.double:
        """``cfg.cadence_hz``, kept for the last (posture, speed)."""
        last_posture, last_speed, f = self._cadence
        if posture != last_posture or speed_mps != last_speed:
            f = self.cfg.cadence_hz(posture, speed_mps)
            self._cadence = (posture, speed_mps, f)
        return f

    # ------------------------------------------------------------------ accelerometer

    @cython.ccall
    def _synth_accel(self, n: cython.Py_ssize_t, speed_mps: cython.double, posture: str) -> list:
        """n vertical-acceleration samples (m/s², gravity included) of the waist."""
        dt: cython.double = self._acc_dt
        f: cython.double
        amp: cython.double
        jitter: cython.double
        if posture in ("walk", "run"):
            f = self._cadence_hz(posture, speed_mps)
            bounce: cython.double = self._run_bounce if posture == "run" else self._walk_bounce
            amp, jitter = (2.0 * _PI * f) ** 2 * bounce, self._gait_jitter
        elif posture == "rest":
            f, amp, jitter = self._rest_hz, self._rest_amp, self._rest_jitter
        else:  # stop: the body is still
            f, amp, jitter = 0.0, 0.0, 0.0
        # plain Python on the handful of samples of one control period: the same operations, in the
        # same order, as the array expression G + amp·sin(φ0 + cumsum(dφ)) + σ·z (bit-identical)
        z: list = self._normals.standard_normal(2 * n)  # sensor noise, then phase jitter
        step: cython.double = 2.0 * _PI * f * dt
        jitter_step: cython.double = jitter * _sqrt(dt) if jitter > 0.0 and amp > 0.0 else 0.0
        phase0: cython.double = self._gait_phase
        noise: cython.double = self._acc_noise
        out: list = []
        turned: cython.double = 0.0
        dphi: cython.double
        zk: cython.double
        k: cython.Py_ssize_t
        for k in range(n):
            if jitter_step:
                zk = z[n + k]
                dphi = step + jitter_step * zk
            else:
                dphi = step
            turned = turned + dphi if k else dphi
            zk = z[k]
            out.append(GRAVITY_MPS2 + amp * _sin(phase0 + turned) + noise * zk)  # the C library's sin, as math.sin
        self._gait_phase = (phase0 + turned) % (2.0 * _PI)
        return out

    @cython.cfunc
    def _accel_chunk(self, n: cython.Py_ssize_t, speed_mps: cython.double, posture: str):
        """Sample n (≤ W) accelerometer values and run Table 2 on the window ending at each."""
        w: cython.Py_ssize_t = self._w
        h: cython.double[::1] = self._hist
        samples: list = self._synth_accel(n, speed_mps, posture)
        k: cython.Py_ssize_t
        for k in range(n):
            h[w - 1 + k] = samples[k]
        first: cython.Py_ssize_t = self._n_acc  # index (0-based) of the first new sample
        valid_from: cython.Py_ssize_t = max(0, (w - 1) - first)  # windows need W samples since power-on
        if valid_from < n:
            # window j = h[j : j + W], the one ending at new sample j
            changes, sma = window_stats(h, valid_from, n, w, self._deadband)
            t_first: cython.double = self._t0 + self._acc_dt * (first + 1 + valid_from)
            min_changes: cython.int = self._min_changes
            level2: cython.double = self._level2
            level3: cython.double = self._level3
            code: cython.int
            for j in range(len(sma)):  # Table 2 on the window ending at each new sample
                code = classify(changes[j] >= min_changes, _level(sma[j], level2, level3))
                if code != self._activity:
                    self._activity, self._activity_since = code, t_first + self._acc_dt * j
            self._sign_changes = changes[len(changes) - 1]
            self._sma = sma[len(sma) - 1]
        for k in range(w - 1):  # keep the last W-1 samples
            h[k] = h[n + k]
        self._n_acc += n

    # ------------------------------------------------------------------ gyro

    @cython.cfunc
    def _gyro_samples(self, m: cython.Py_ssize_t, speed_mps: cython.double, turn_rate_rps: cython.double, posture: str):
        """Sample m gyro values (every 70 ms, seed 002 §3.4), filter them, update the rotation state."""
        dt: cython.double = self._gyro_dt
        f_stride: cython.double
        wobble_rps: cython.double
        if posture in ("walk", "run"):
            f_stride = 0.5 * self._cadence_hz(posture, speed_mps)  # one stride = two steps
            wobble_rps = self._wobble_rad * 2.0 * _PI * f_stride
        else:
            f_stride, wobble_rps = 0.0, 0.0
        sigma: cython.double = self._gyro_noise_rps
        noise: list = [sigma * z for z in self._normals.standard_normal(m)]
        n_ma: cython.Py_ssize_t = len(self._ma)  # cfg.ma_samples
        k: cython.Py_ssize_t
        filled: cython.Py_ssize_t
        raw: cython.double
        nk: cython.double
        omega: cython.double
        t_k: cython.double
        for k in range(m):
            self._stride_phase = (self._stride_phase + 2.0 * _PI * f_stride * dt) % (2.0 * _PI)
            nk = noise[k]
            raw = turn_rate_rps + wobble_rps * _cos(self._stride_phase) + self._bias_rps + nk  # the C library's cos, as math.cos
            self._ma[self._n_gyro % n_ma] = raw
            self._n_gyro += 1
            filled = min(self._n_gyro, n_ma)
            omega = sum(self._ma[:filled]) / filled  # moving average (shorter until it fills)
            self._omega_f = omega
            t_k = self._t0 + self._n_gyro * dt
            if not self._rotating and abs(omega) > self._on_rps:
                # the rotation starts: its angle so far is the gyro samples in the filter window
                # (the onset the moving average was still ramping up to)
                self._rotating, self._rotation_since = True, t_k
                self._angle = sum(self._ma[:filled]) * dt
            elif self._rotating and abs(omega) < self._off_rps:
                self._rotating, self._rotation_since = False, t_k
            elif self._rotating:
                self._angle += raw * dt  # accumulated angle of the current rotation: the gyro's integral
