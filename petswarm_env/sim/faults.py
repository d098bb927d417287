"""Every robot's fault state, in one place (seed 003: robots fail and are replaced).

A fault is hardware truth: the robot's software does not read it. Each kind switches off a part of
the robot, and each part's model asks :class:`Health` whether it works:

* ``dead`` — the robot is off: the motors stop (the body stays where it is, an obstacle), the radio
  sends and hears nothing, the IR module neither transmits nor receives, the middleware is off;
* ``battery`` — the battery is drained to 0: the same as ``dead``, through the same entry point
  (:meth:`FaultState.set` with ``battery``); a battery that its robot's motion and sensing drain to 0
  (sim/battery.py) is this fault too (``Runtime.check_batteries``);
* ``radio_silent`` — the 802.15.4 radio sends and receives no frame (the robot drives on);
* ``ir`` — the IR module is off: no transmission in its token slot, no reception of the others';
* ``ultrasonic`` — the ring gives no readings: every sensor reads ``robot.ultrasonic.max_range_m``
  (an echo-less ping: "nothing in range"; chosen, the value the ring gives in the open, so the
  safety stage sees no obstacle), and its transducers do not ring down after their bursts (chosen:
  the ring's driver sends no burst; the driver's self-test reports it with every reading, as the
  transducer diagnosis of ultrasonic front-ends does). :meth:`Faults.ultrasonic_ok` is the
  per-robot flag the ring model follows (``Sensors.read_rings``); the observation's presence flags
  and the robot's status change only when its own diagnosis has found the ring dead
  (middleware/diagnosis.py);
* ``ahrs`` — the AHRS gives no new yaw: it repeats its last reading from the fault on (a frozen
  output; chosen — the robot's software cannot tell, like a stuck sensor bus).

A transient fault (``duration_s``) clears after its duration: the part works again; a robot that
was ``dead`` (or whose battery was swapped) reboots — its middleware starts again in the waiting
state with nothing known (it may be recruited again). ``duration_s`` null = permanent.

:class:`Faults` holds every robot's :class:`FaultState` and the episode's fault log (what was
injected when: the experimenter's record, :mod:`petswarm_env.metrics`). The env schedules the
config's faults on the clock and resolves ``master`` / ``random_slave`` at the fault's time
(:mod:`petswarm_env.runtime`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from petswarm_env.sim.health import KINDS, POWER_KINDS, FaultState  # (one robot's health: sim/health.py, compiled)


@dataclass(frozen=True)
class FaultRecord:
    time_s: float  # clock time the fault started
    robot: int
    kind: str
    role: str  # what the robot was when it failed: master | slave | waiting | off
    duration_s: float | None


class Faults:
    """Every robot's fault state and the episode's log. ``on_change(robot, kind, on)`` callbacks
    (set by the env) apply a change to the parts that are not asked each time (the motors, the
    middleware's power, the AHRS)."""

    def __init__(self, states: list[FaultState]):
        self.states = states  # each robot's own (Robot.health), in robot order
        self.log: list[FaultRecord] = []
        self._permanent: set[tuple[int, str]] = set()  # (robot, kind) of the faults that never clear
        self.on_change: list[Callable[[int, str, bool], None]] = []

    def of(self, robot: int) -> FaultState:
        return self.states[robot]

    def inject(self, robot: int, kind: str, now_s: float, role: str = "", duration_s: float | None = None) -> None:
        """Fault ``kind`` starts on ``robot`` now (logged)."""
        self.log.append(FaultRecord(now_s, robot, kind, role, duration_s))
        if duration_s is None:
            self._permanent.add((robot, kind))
        self._set(robot, kind, True)

    def clear(self, robot: int, kind: str) -> None:
        """A transient fault ends."""
        self._set(robot, kind, False)

    def _set(self, robot: int, kind: str, on: bool) -> None:
        state = self.states[robot]
        was = set(state.active)
        state.set(kind, on)
        if state.active != was:
            for callback in self.on_change:
                callback(robot, kind, on)

    def powered(self, robot: int) -> bool:
        return self.states[robot].powered

    def off_for_good(self, robot: int) -> bool:
        """Whether robot ``robot`` is off and stays off for the rest of the episode (a permanent
        ``dead`` or ``battery`` fault): the env's agent lifecycle (petswarm_env/episode.py), never a robot's
        knowledge."""
        return not self.states[robot].powered and any((robot, k) in self._permanent for k in POWER_KINDS)

    def ultrasonic_ok(self, robot: int) -> bool:
        """Whether robot ``robot``'s ultrasonic ring delivers readings (the observation's presence flag)."""
        return self.states[robot].ultrasonic_ok

    def sensing_health(self, robot: int) -> dict[str, bool]:
        """The sensing parts that work: the experimenter's view (a robot's own status reads what its
        diagnosis found, middleware/diagnosis.py, never this)."""
        s = self.states[robot]
        return {"ultrasonic": s.ultrasonic_ok, "ir": s.ir_ok, "ahrs": s.ahrs_ok}
