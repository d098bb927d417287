"""A robot's battery: capacity in mAh, drained by the drive and the sensors (seed 003 §4.1.2).

Seed 003 models a robot's remaining power P_rem (mAh) and the consumption rates of its subtasks
(rate_servo for navigation, rate_act for manipulation, rate_sens for sensing, in mA); it gives no
discharge model over time. Ours (chosen): every physics substep of length dt,

    drained_mAh += (sensing_mA + servo_mA · load + actuator_mA · actuating) · dt / 3600,
    load = min(1, |v| / v_max + |ω| / ω_max)

with (v, ω) the body's achieved velocity and its own limits: the servos draw their full-load
current at full speed (or full turn) and proportionally less below (chosen); the sensors and the
electronics draw all the time; the actuator (a manipulator) only while ``actuating`` (no swarm task
uses one yet). At 0 mAh the battery is :attr:`Battery.empty` — the one place that state lives —
and the robot stops (:meth:`~.robot.Robot.set_command` ignores its commands): a fault for the
fault machinery to pick up.

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): the battery is
a typed class, drained for every robot at every physics substep.
"""

from __future__ import annotations

import math

import cython

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_hypot = math.hypot  # Python's own (CPython's hypot is not the C library's: same value as before, bit for bit)
_MS_PER_H = 3600.0


@cython.cclass
class Battery:
    """One robot's battery (``spec``: a :class:`~petswarm_env.robot_types.Battery`)."""

    def __init__(self, spec, max_speed_mps: float, max_omega_rps: float):
        self.capacity_mah = float(spec.capacity_mah)
        self.remaining_mah = self.capacity_mah
        self.empty = False  # the battery-empty fault flag (the robot stops; faults wire it)
        self.actuating = False  # a manipulator in use (drains actuator_mA)
        self._servo, self._act, self._sens = float(spec.servo_ma), float(spec.actuator_ma), float(spec.sensing_ma)
        self._inv_v, self._inv_w = 1.0 / max_speed_mps, 1.0 / max_omega_rps

    @property
    def fraction(self) -> float:
        """Remaining charge, 0 … 1 (1 for a battery of infinite capacity)."""
        return self.remaining_mah / self.capacity_mah if math.isfinite(self.capacity_mah) else 1.0

    def current_ma(self, velocity_body: tuple[float, float, float]) -> float:
        """The current drawn at this body velocity (mA)."""
        vx, vy, w = velocity_body
        load = _hypot(vx, vy) * self._inv_v + abs(w) * self._inv_w
        return self._sens + self._servo * (load if load < 1.0 else 1.0) + (self._act if self.actuating else 0.0)

    @cython.ccall
    def drain(self, dt: cython.double, velocity_body: tuple) -> cython.bint:
        """One substep of ``dt`` s at ``velocity_body``; True when the battery has just emptied."""
        vx: cython.double
        vy: cython.double
        w: cython.double
        vx, vy, w = velocity_body
        return self.drain_at(dt, _hypot(vx, vy), w)

    @cython.cfunc
    def drain_at(self, dt: cython.double, speed: cython.double, omega: cython.double) -> cython.bint:
        """:meth:`drain` at the body speed ``speed`` = hypot(vx, vy) (m/s) and the turn rate
        ``omega`` (rad/s): :meth:`current_ma`'s formula written out, for the drive's call at every
        substep of every robot (:meth:`~.body.DrivenBody.apply`)."""
        if self.empty:
            return False
        load: cython.double = speed * self._inv_v + (omega if omega >= 0.0 else -omega) * self._inv_w
        ma: cython.double = self._sens + self._servo * (load if load < 1.0 else 1.0)
        if self.actuating:
            ma += self._act
        ms_per_h: cython.double = _MS_PER_H  # a C double (the module constant is a Python float)
        self.remaining_mah -= ma * dt / ms_per_h
        if self.remaining_mah <= 0.0:
            self.remaining_mah = 0.0
            self.empty = True
            return True
        return False

    def set_remaining(self, mah: float) -> None:
        """Set the charge (a scenario's or a fault's start state); 0 empties it."""
        self.remaining_mah = max(0.0, min(float(mah), self.capacity_mah))
        self.empty = self.remaining_mah <= 0.0
