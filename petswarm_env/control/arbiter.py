"""The control arbiter of seed 001 (§3, "control arbiter"): one command reaches the motors per tick.

Several sources want to drive one robot body. Seed 001 ranks them: robot self-protection
(collision avoidance, safety) above the user above the software agent. Here the sources are

* ``safety`` — the ultrasonic safety stage (seed 002 §3.4: "the final step is to avoid walls or
  obstacles") and the emergency stop (seed 002 Fig. 4);
* ``user`` — the user's own commands: remote control by watch gestures (seed 002 Table 1);
* ``policy`` — the software agent: the scripted or learned slave policy, or the master-role
  controller of the user-connected robot.

The highest-priority source that has something to say suppresses the lower ones; which source won
is counted per robot and per episode. ``control.safety_layer: false`` removes the ultrasonic stage
(a pure-RL study that wants the policy to learn avoidance by itself); the emergency stop stays.

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): the stage and
the arbiter are typed classes, the stage's check runs on C doubles (every robot, every step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cython
import numpy as np

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)
_sqrt = math.sqrt  # (the C library's sqrt in the compiled form: correctly rounded, the same value)
_INF = cython.declare(cython.double, math.inf)  # (a C constant: read for every filtered command)

SOURCES = ("safety", "user", "policy")  # seed 001: self-protection > user > software agent


@dataclass
class ArbiterCounts:
    wins: dict[str, int] = field(default_factory=lambda: {s: 0 for s in SOURCES})

    def add(self, source: str) -> None:
        self.wins[source] += 1


@cython.cclass
class SafetyStage:
    """Ultrasonic collision avoidance on a commanded body velocity.

    Each sensor limits the commanded speed toward what it sees to the speed from which the robot
    can still brake (at ``max_accel``) before ``stop_distance_m``: v ≤ √(2·a·(range − stop)); anything
    closer than half of ``stop_distance_m`` is backed away from. The stage *wins* the tick when it
    changed the command; otherwise it stays silent and the lower sources pass. It reads only the
    robot's own ultrasonic ring (its sensor), never ground truth.
    """

    # its typed attributes (each sensor's direction as an array and as Python floats, the stop distance, the backoff
    # speed, twice the braking limit) are declared in ``arbiter.pxd``

    def __init__(self, num_sensors: int, stop_distance_m: float, backoff_speed_mps: float, max_accel_mps2: float):
        ang = np.arange(num_sensors) * (2 * math.pi / max(num_sensors, 1))
        self.dirs = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        self._dx = self.dirs[:, 0].tolist()
        self._dy = self.dirs[:, 1].tolist()
        self.stop = stop_distance_m
        self.backoff = backoff_speed_mps
        self.two_a = 2.0 * max_accel_mps2

    @cython.ccall
    def filter(self, command, ranges):
        """The safe version of ``command`` (body frame), or None when nothing needed changing.

        A loop over the few sensors of the ring (a numpy call costs more than the arithmetic on
        eight values); ``min`` and ``max`` as Python's builtins give them."""
        vx: cython.double = float(command[0])
        vy: cython.double = float(command[1])
        stop: cython.double = self.stop
        two_a: cython.double = self.two_a
        half: cython.double = 0.5 * stop
        rs: list = ranges if type(ranges) is list else (  # a list of floats (a ring's row): read as it is
            ranges.tolist() if isinstance(ranges, np.ndarray) else [float(r) for r in ranges])
        n: cython.Py_ssize_t = len(rs)
        k: cython.Py_ssize_t
        r: cython.double
        nearest: cython.double = _INF
        for k in range(n):  # min(rs, default=inf)
            r = rs[k]
            if k == 0 or r < nearest:
                nearest = r
        gap: cython.double = nearest - stop
        if nearest >= half and vx * vx + vy * vy <= two_a * (0.0 if 0.0 > gap else gap):
            # the whole speed is below the nearest sensor's braking limit, so no sensor's component
            # of it can exceed its own (1e-9 m/s of slack below absorbs the rounding): nothing to do
            return None
        allowed: list = []
        over: list = []
        dx: cython.double
        dy: cython.double
        lim: cython.double
        for k in range(n):
            r = rs[k]
            gap = r - stop
            lim = _sqrt(two_a * (0.0 if 0.0 > gap else gap))
            allowed.append(lim)
            if k < len(self._dx):  # (a ring of more readings than sensors: the sensors' own)
                dx, dy = self._dx[k], self._dy[k]
                if dx * vx + dy * vy > lim + 1e-9 or r < half:
                    over.append(k)
        if not over:
            return None
        excess: cython.double
        back: cython.double
        for k in over:
            dx, dy = self._dx[k], self._dy[k]
            excess = (vx * dx + vy * dy) - cython.cast(cython.double, allowed[k])
            if excess > 0.0:  # too fast toward the obstacle: take the excess off
                vx, vy = vx - excess * dx, vy - excess * dy
            r = rs[k]
            if r < half:  # too close already: back away
                back = self.backoff * (1.0 - r / half)
                vx, vy = vx - back * dx, vy - back * dy
        return vx, vy, float(command[2])


@cython.cclass
class ControlArbiter:
    """Per-robot priority arbitration: safety > user > policy (seed 001)."""

    # its typed attributes (``safety``, None without an ultrasonic stage; ``counts``, the wins of this episode) are
    # declared in ``arbiter.pxd``: the command loops (step_kernel.py) call :meth:`decide` by a C call

    def __init__(self, safety: SafetyStage | None):
        self.safety = safety
        self.counts = ArbiterCounts()

    @cython.ccall
    def decide(self, policy_cmd, user_cmd=None, ranges=None, emergency_stop=False):
        """The one command for the motors this tick and the source that won: ``((vx, vy, ω), source)``, from the
        policy's and the user's body-frame commands (``(vx, vy, ω)``; ``user_cmd`` None: none) and the ring's
        ``ranges`` (None: no reading).

        The emergency stop (user lost, seed 002 Fig. 4) is self-protection: it always wins, also
        with the ultrasonic stage switched off."""
        if emergency_stop:
            cmd, source = (0.0, 0.0, 0.0), "safety"
        else:
            cmd, source = (user_cmd, "user") if user_cmd is not None else (policy_cmd, "policy")
            if self.safety is not None and ranges is not None:
                safe = self.safety.filter(cmd, ranges)
                if safe is not None:
                    cmd, source = safe, "safety"
        self.counts.wins[source] += 1  # (ArbiterCounts.add)
        return cmd, source
