"""An estimating recurrent policy: a GRU estimates what the privileged teacher reads, and the
teacher's control law acts on that estimate (``petswarm train --config estimator``,
docs/training.md "An estimating student").

The privileged teacher (training/teacher.py) drives each slave from ground truth: its true
reference point, that point's velocity, the master's heading. A student that imitates the teacher's
*action* must learn the estimate and the control law in one map; this policy splits the two. Its
network — the recurrent actor of :class:`petswarm.baselines.learned.RecurrentPolicy`, an encoder,
a GRU cell (Cho et al. 2014) and a head over the robot's own observation history — outputs an
**estimate** of seven values, each in the unit of :data:`OUTPUTS` after multiplying by the file's
``estimator.scale``:

====================  ==========================================================================
``offset_x, offset_y``  the robot's offset to its reference point, own body frame (m; the label is
                        clipped to a length of ``scale[0]``: beyond it only the direction matters)
``ref_vx, ref_vy``      the reference point's velocity, own body frame (m/s)
``heading_sin, _cos``   sine and cosine of the heading error to the master, ``θ_master − θ``
``turn_rate``           the master's turn rate (rad/s)
====================  ==========================================================================

and :func:`estimate_law` turns it into the action with the teacher's steps 3–5 (training/teacher.py):
a time-optimal approach ``min(v_max, gain·d, √(2·decel·d))`` toward the estimated point on top of its
estimated velocity, the robot's own ultrasonic keep-out (the one avoidance a robot can see: the
teacher's avoidance of other bodies reads their true positions and velocities and has no estimate
here), and the heading error turned at ``heading_gain`` plus the master's turn rate. The law's
constants are in the file (``estimator.law``). A robot with no fresh IR fix of anyone (the
observation says so: :func:`lost_mask`) cannot estimate where its swarm is; it drives by the scripted
reference (its rejoin and search, leader_follower.py steps 1c and 1d), as the teacher's labeller
does. Everything here reads the observation and the network's output only, never ground truth.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from petswarm.baselines.leader_follower import LeaderFollowerPolicy
from petswarm.baselines.learned import PolicyLoadError, Recurrent, RecurrentPolicy
from petswarm.baselines.policy import PolicySpec
from petswarm_env.observe import MAX_LINKS, ObservationLayout

OUTPUTS = ("offset_x", "offset_y", "ref_vx", "ref_vy", "heading_sin", "heading_cos", "turn_rate")
LAW_KEYS = ("gain", "decel_mps2", "heading_gain", "sonar_keep_out_m", "sonar_gain")


def fix_indices(layout: ObservationLayout) -> np.ndarray:
    """(k, 2) indices of each IR fix's ``ir_valid`` and ``ir_age`` (the master's, every link's)."""
    sl = layout.slices
    return np.array([(sl[f"{p}.ir_valid"].start, sl[f"{p}.ir_age"].start)
                     for p in ("master", *(f"link{k}" for k in range(MAX_LINKS)))], dtype=np.intp)


def lost_mask(rows: np.ndarray, fixes: np.ndarray) -> np.ndarray:
    """True for each observation (row of ``rows``) with no IR fix of the master or of a reference
    neighbour younger than the observation's age range (``ir_age`` < 1)."""
    rows = np.atleast_2d(rows)
    fresh = (rows[:, fixes[:, 0]] > 0.5) & (rows[:, fixes[:, 1]] < 1.0)
    return ~fresh.any(axis=1)


def approach_speed(d: np.ndarray | float, vmax: float, gain: float, decel: float):
    """The teacher's step 3: the speed toward a point ``d`` metres away — full speed far away,
    braking at ``decel`` near it, linear (``gain``) at the last centimetres."""
    return np.minimum(np.minimum(vmax, gain * d), np.sqrt(2.0 * decel * np.asarray(d)))


def sonar_keep_off(v: np.ndarray, ranges: np.ndarray, keep_out: float, gain: float) -> np.ndarray:
    """The teacher's step 4 from the robot's own ring (the scripted slave's step 5): every range
    (m, sensor 0 forward, counter-clockwise) shorter than ``keep_out`` pushes the body-frame command
    ``v`` (batch, 2) away from that sensor's direction at ``gain`` per metre inside."""
    ranges = np.atleast_2d(np.asarray(ranges, dtype=np.float64))
    n = ranges.shape[1]
    a = 2.0 * np.pi * np.arange(n) / n
    depth = np.where(ranges < keep_out, keep_out - ranges, 0.0)
    return v - gain * np.stack([depth @ np.cos(a), depth @ np.sin(a)], axis=1)


def estimate_law(est: np.ndarray, ranges: np.ndarray, vmax: float, wmax: float, law: dict[str, float]) -> np.ndarray:
    """Actions in [-1, 1]³ (batch, 3) from estimates ``est`` (batch, 7: :data:`OUTPUTS` in their
    units) and the ultrasonic ranges (batch, sensors; m): the module docstring's law."""
    est = np.atleast_2d(np.asarray(est, dtype=np.float64))
    e = est[:, 0:2]
    d = np.hypot(e[:, 0], e[:, 1])
    speed = approach_speed(d, vmax, law["gain"], law["decel_mps2"])
    unit = np.where(d[:, None] > 1e-9, e / np.maximum(d, 1e-9)[:, None], 0.0)
    v = est[:, 2:4] + speed[:, None] * unit
    if law["sonar_keep_out_m"] > 0:
        v = sonar_keep_off(v, ranges, law["sonar_keep_out_m"], law["sonar_gain"])
    norm = np.hypot(v[:, 0], v[:, 1])
    v = v * np.minimum(1.0, vmax / np.maximum(norm, 1e-12))[:, None]
    omega = est[:, 6] + law["heading_gain"] * np.arctan2(est[:, 4], est[:, 5])
    return np.clip(np.column_stack([v / vmax, omega / wmax]), -1.0, 1.0).astype(np.float32)


def check_estimator_meta(meta: Any) -> str | None:
    """The problem with a file's ``estimator`` record, or None: ``{outputs: OUTPUTS, scale: 7
    positive numbers, law: {LAW_KEYS: numbers >= 0}}``."""
    if not isinstance(meta, dict) or meta.get("outputs") != list(OUTPUTS):
        return f"must be an object whose 'outputs' are {list(OUTPUTS)}"
    scale, law = meta.get("scale"), meta.get("law")
    number = (int, float)
    if not (isinstance(scale, list) and len(scale) == len(OUTPUTS)
            and all(isinstance(x, number) and not isinstance(x, bool) and math.isfinite(x) and x > 0 for x in scale)):
        return f"'scale' must be {len(OUTPUTS)} positive numbers (one per output)"
    if not (isinstance(law, dict) and set(law) == set(LAW_KEYS)
            and all(isinstance(x, number) and not isinstance(x, bool) and math.isfinite(x) and x >= 0 for x in law.values())):
        return f"'law' must give exactly {list(LAW_KEYS)}, each a number >= 0"
    return None


class EstimatorPolicy(RecurrentPolicy):
    """A recurrent network whose output is an estimate (module docstring), acted on by
    :func:`estimate_law`; lost robots drive by the scripted reference. The memory is the recurrent
    policy's: one hidden state per agent, zero when it (re)joins slave-role driving."""

    def __init__(self, spec: PolicySpec, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                 index: np.ndarray, recurrent: Recurrent, meta: dict[str, Any]):
        problem = check_estimator_meta(meta.get("estimator"))
        if problem:
            raise PolicyLoadError(f"policy field 'estimator' {problem}")
        if meta.get("residual_of") is not None:
            raise PolicyLoadError("policy fields 'estimator' and 'residual_of' exclude each other: an estimating policy's "
                                  "action comes from its law, not from a correction of another policy")
        super().__init__(spec, layers, activation, index, recurrent, meta)
        est = meta["estimator"]
        self.scale = np.asarray(est["scale"], dtype=np.float64)
        self.law = {k: float(v) for k, v in est["law"].items()}
        self.fallback = LeaderFollowerPolicy(spec)  # lost: the reference's rejoin and search
        self._fixes = fix_indices(spec.layout)
        self._sonar = spec.layout.slices["self.ultrasonic"]
        self.last_estimate: dict[str, np.ndarray] = {}  # each agent's estimate on its last step (for measurement)

    def _act(self, agents: list[str], observations: list[np.ndarray]) -> dict[str, np.ndarray]:
        n = self.cell.hidden_size
        zero = np.zeros(n)
        h = np.stack([self._hidden[a] if self._last.get(a) == self._step - 1 else zero for a in agents])
        x = np.stack(observations)
        out, h = self.step_batch(x, h)
        est = out * self.scale
        for i, a in enumerate(agents):
            self._hidden[a], self._last[a] = h[i], self._step
            self._asked.add(a)
            self.last_estimate[a] = est[i]
        act = estimate_law(est, np.asarray(x[:, self._sonar], dtype=np.float64) * self.spec.us_max_range_m,
                           self.spec.max_speed_mps, self.spec.max_omega_rps, self.law)
        lost = lost_mask(x, self._fixes)
        if lost.any():
            ref = self.fallback.act_all({agents[i]: observations[i] for i in np.flatnonzero(lost)})
            for i in np.flatnonzero(lost):
                act[i] = ref[agents[i]]
        return {a: act[i] for i, a in enumerate(agents)}
