"""One robot's station: all that its middleware managers see of the robot (seed 000 Fig. 5).

The lower layer of the middleware: the RF communication manager (a station on the shared 802.15.4
medium: :meth:`Station.send`, and the MCU's processing of every received frame before the frame is
dispatched to the handler registered with :meth:`Station.on`), the IR module's port, the robot's own
state (sequence-manager state, PANs, connected user, neighbour table) and what it knows
(:class:`~.knowledge.Knowledge`).

The managers of the upper layer — join (:mod:`.join`), token ring and heading exchange
(:mod:`.token_ring`), sequence (:mod:`.sequence`), modes (:mod:`.modes`) — are built by
:class:`~.node.Node` and see only this station: never the per-user swarm, never another robot.
What they cannot do on their own robot goes through two kinds of narrow seams that the fleet
(:mod:`.fleet`) plugs in:

* **ports** (down and out): :attr:`Station.transmit_ir`, the IR module's transmission, wired to the
  IR optical channel and to the robots that measure it;
* **signals** (up): what happened to this robot that the user's swarm must learn —
  :attr:`~Station.became_slave`, :attr:`~Station.plan_applied`, :attr:`~Station.handed_over`,
  :attr:`~Station.took_over`. A manager emits a signal after it changed
  the station's own state.

A module of the compiled core (``petswarm_env/_core.py``): the station is a typed class
(Cython's pure-Python mode) whose attributes read for every frame are typed; the rest live in the
instance's dictionary (every station is a :class:`~.node.Node`, a Python subclass). Its methods
are looked up as Python attributes, so a subclass (or a test) may replace them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import cython
import numpy as np
from cython.cimports.libc.math import isfinite as _isfinite

from petswarm_env.comms.radio import BROADCAST, PAN_WAITING, RadioMedium
from petswarm_env.config import Config
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation
from petswarm_env.sim.clock import Clock

if cython.compiled:  # the MCU clock's C methods (sim/clock.pxd): a received frame is scheduled by a C call; what the
    # robot knows as typed records (middleware/knowledge.pxd)
    from cython.cimports.petswarm_env.comms.radio import Frame  # a received frame's fields as C reads (comms/radio.pxd)
    from cython.cimports.petswarm_env.comms.radio import RadioMedium as _Medium  # a frame sent by a C call
    from cython.cimports.petswarm_env.middleware.diagnosis import Diagnosis  # its listeners as C calls (diagnosis.pxd)
    from cython.cimports.petswarm_env.middleware.knowledge import IRMeasurement, Knowledge
    from cython.cimports.petswarm_env.sim.clock import Due, LocalClock
else:
    from petswarm_env.comms.radio import Frame
    from petswarm_env.middleware.diagnosis import Diagnosis
    _Medium = RadioMedium
    from petswarm_env.middleware.knowledge import IRMeasurement, Knowledge
    from petswarm_env.sim.clock import Due, LocalClock
from petswarm_env.sim.draws import Draws
from petswarm_env.sim.sensors import Odometry
if cython.compiled:  # what the robot's sensors hand its software, and its AHRS's reading, by C calls (sim/sensors.pxd)
    from cython.cimports.petswarm_env.sim.sensors import AHRS, Readings
else:
    from petswarm_env.sim.sensors import AHRS, Readings

if TYPE_CHECKING:
    from petswarm_env.sim.robot import Robot

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_FIXED_BYTES: dict = msg.FIXED_BYTES


def mcu_clock(clock: Clock, cfg: Config, rng: np.random.Generator) -> LocalClock:
    """One MCU's own clock over ``clock``: a drift drawn uniformly within ±``robot.clock_drift_ppm``
    and an offset (the time since it powered on) within ``[0, robot.clock_offset_max_s)``, both from
    ``rng`` (its own stream of the episode's seed: same seed, same clocks)."""
    ppm, offset_max = cfg.robot.clock_drift_ppm, cfg.robot.clock_offset_max_s
    drift = float(rng.uniform(-ppm, ppm)) * 1e-6 if ppm > 0 else 0.0
    offset = float(rng.uniform(0.0, offset_max)) if offset_max > 0 else 0.0
    return LocalClock(clock, offset, drift)


@cython.final
@cython.cclass
class OwnClock(Readings):
    """The robot's sensors hand their readings to its software (its self-diagnosis), which stamps
    them with its MCU's own clock (seed 000 §3.3: independent clocks): :meth:`ring` and :meth:`ahrs`
    are the ultrasonic ring's and the AHRS's listeners, called for every reading with the true time,
    and call the diagnosis's ``on_ring`` / ``on_ahrs`` with the MCU's reading of it (``clock.local``)."""

    # its typed attributes (``_clock``, ``_diagnosis``) are declared in ``station.pxd``

    def __init__(self, clock: LocalClock, diagnosis: Diagnosis):
        self._clock = clock
        self._diagnosis = diagnosis

    @cython.ccall
    def ring(self, ranges, present, now_s: cython.double, rang: cython.bint):
        """``robot.readings.ring(ranges, present, now_s, rang)``: the ring's reading and self-test."""
        self._diagnosis.on_ring(ranges, present, self._clock.local(now_s), rang)

    @cython.ccall
    def ahrs(self, now_s: cython.double, yaw: cython.double):
        """``ahrs.readings.ahrs(now_s, yaw)``: one AHRS reading."""
        self._diagnosis.on_ahrs(self._clock.local(now_s), yaw)


@cython.final
@cython.freelist(64)  # one for every frame event: reused, not allocated
@cython.cclass
class _Handling(Due):
    """A received frame's handling after the MCU's processing delay (:meth:`Station.receive`): on
    the clock it calls the station's ``_handle`` (looked up then, so a subclass or a test may replace
    it) with the frame and the handler registered for its kind."""

    station = cython.declare(object)
    handler = cython.declare(object)
    frame = cython.declare(object)

    @cython.cfunc
    def run(self) -> cython.void:
        station: Station = self.station
        if type(station)._handle is _STATION_HANDLE:  # not replaced: the same method, by a C call
            station._handle_frame(self.handler, self.frame)
        else:
            station._handle(self.handler, self.frame)


class Signal:
    """An upward notification of one robot's middleware: a manager emits it, the fleet subscribes."""

    __slots__ = ("_subscribers",)

    def __init__(self) -> None:
        self._subscribers: list[Callable[..., None]] = []

    def connect(self, subscriber: Callable[..., None]) -> None:
        self._subscribers.append(subscriber)

    def emit(self, *args: Any) -> None:
        for subscriber in self._subscribers:
            subscriber(*args)


@cython.cclass
class Station:
    """One robot's lower layer, its state and its knowledge, attached to the radio."""

    # its typed attributes, read for every frame sent, received or handled, are declared in ``station.pxd``

    def __init__(self, node_id: int, cfg: Config, clock: Clock, radio: RadioMedium, robot: Robot,
                 rng: np.random.Generator):
        self.node_id = node_id
        self.cfg = cfg
        self.radio = radio
        self.rng = rng
        self.draws = Draws(rng)  # scalar draws (MCU processing jitter) taken from rng in blocks
        self._uniform = self.draws.uniform
        self._processing_s, self._jitter_s = cfg.radio.processing_s, cfg.radio.processing_jitter_s
        self._robot = robot  # own body: its AHRS, and the antenna's position
        self.odometry = Odometry(robot, cfg.robot, rng.spawn(1)[0])  # own wheel odometry, own noise stream
        # the MCU's own clock (seed 000 §3.3: the robots' clocks are independent): every timer and
        # timestamp of this robot's middleware is on it; the true clock only reads the body's sensors
        self.clock = mcu_clock(clock, cfg, rng.spawn(1)[0])
        self._mcu = self.clock
        self._true_clock = clock
        self._ahrs = robot.ahrs  # its AHRS: read for every IR fix and heading report (yaw, a C call)
        self.later = self.clock.later  # later(delay, fn, *args): a call after ``delay`` seconds of the MCU's clock
        # the antenna's position, for the radio's propagation model (not the middleware): the body's
        # reader bound once (a radio station reads it for every frame it sends or receives)
        self.position: Callable[[], tuple[float, float]] = robot.read_position
        self.pans: frozenset[int] = frozenset({PAN_WAITING})
        self.state = "waiting"  # sequence manager state, see sequence.py
        self.previous_driving_state = "following"  # a master's driving state before organizing (Fig. 4)
        self.connected_user: int | None = None  # the user this robot is connected to, if any
        self.know = Knowledge()
        self.formation: Formation | None = None
        self.swarm_pan: int | None = None
        self._frames_handled = 0  # frames handed to a handler (``counters``)
        self._foreign_pan_frames_processed = 0  # of them, on a PAN it is not on (must never happen)
        self.handlers: dict[str, Callable[[Frame], None]] = {}
        # port: transmit_ir(neighbours) -> reporters; the fleet wires it (see fleet.Fleet.ir_slot)
        self.transmit_ir: Callable[[list[int | None]], list[int]] = self._ir_not_wired
        self.became_slave = Signal()  # (pan): joined the swarm on PAN ``pan`` (joining notification)
        self.plan_applied = Signal()  # (plan, previous_members): the master committed a mode change
        self.handed_over = Signal()  # (new_master_id): the master handed its user over, is a slave now
        self.took_over = Signal()  # (): this robot took its swarm's user over, is the master now
        self.members_changed = Signal()  # (event, node_ids): the master removed ("lost") or recruited ("joined") members
        # the robot's hardware health (petswarm_env/sim/faults.py): a radio that is off sends and hears nothing
        self.health = robot.health
        self.joined_s = -math.inf  # when this robot last entered a swarm (the status timeout counts from here)
        radio.attach(self)

    # -- RF communication and message processing -------------------------------------------------
    def send(self, kind: str, dst: int = BROADCAST, pan: int | None = None, **payload: Any) -> None:
        if not self.health.radio_ok:  # radio off (a fault): nothing leaves
            return
        pan = self.swarm_pan if pan is None else pan
        fixed: dict = _FIXED_BYTES
        size = fixed.get(kind)  # a frame without a list or table: its kind's size (a C lookup of the typed dict)
        if size is None:
            size = msg.payload_bytes(kind, payload)
        radio: _Medium = self.radio
        radio.transmit(kind, self.node_id, dst, pan, payload, size)  # radio.send(self, Frame(...))

    def receive(self, frame: Frame) -> None:
        """Called by the medium for every frame its MAC accepted; handled after MCU processing."""
        handler = self.handlers.get(frame.kind)
        if handler is None or not self.health.radio_ok:
            return
        u: cython.double = self._uniform.next()  # processing_delay(), inlined: called for every reception
        handling: _Handling = _Handling.__new__(_Handling)
        handling.station, handling.handler, handling.frame = self, handler, frame
        self._mcu.call_due(self._processing_s + self._jitter_s * u, handling)

    def processing_delay(self) -> float:
        """MCU time to handle a received frame before it can answer (``processing_s`` plus a
        uniform jitter of up to ``processing_jitter_s``)."""
        u: cython.double = self._uniform.next()
        return self._processing_s + self._jitter_s * u

    def _handle(self, handler: Callable[[Frame], None], frame: Frame) -> None:
        self._handle_frame(handler, frame)

    @cython.cfunc
    def _handle_frame(self, handler, frame) -> cython.void:
        """:meth:`_handle` (a C call from the frame's handling, :class:`_Handling`, while no subclass
        or test replaced ``_handle``)."""
        f: Frame = frame
        pan = f.pan
        if pan not in self.pans:  # the PAN changed while the frame was being processed
            return
        if pan != PAN_WAITING and pan != self.swarm_pan:
            self._foreign_pan_frames_processed += 1  # must never happen
        self._frames_handled += 1
        handler(frame)

    @property
    def counters(self) -> dict[str, int]:
        """How many frames this station handled, and how many of them on a PAN it is not on."""
        return {"foreign_pan_frames_processed": self._foreign_pan_frames_processed,
                "frames_handled": self._frames_handled}

    def on(self, kind: str, handler: Callable[[Frame], None]) -> None:
        self.handlers[kind] = handler

    # -- swarm membership -----------------------------------------------------------------------
    def enter_swarm(self, state: str, pan: int, member: int, members: dict[int, int], formation: Formation,
                    mode: str) -> None:
        """Drive in ``state`` (``slave`` or ``master``) as ``member`` of the swarm on PAN ``pan`` with
        the member and neighbour tables and the driving ``mode`` it was told (a slave) or chose (the
        master) (seed 000 Fig. 8, step 4: joined robots switch to the new PAN ID)."""
        self.state = state
        self.joined_s = self.clock.now
        self.swarm_pan = pan
        self.pans = frozenset({pan})
        self.know.member = member
        self.know.members = members
        self.know.total_members = len(members)
        self.know.mode = mode
        self.formation = formation

    def member_node(self, member: int) -> int | None:
        return self.know.members.get(member)

    def reference_links(self):
        if self.formation is None or self.know.member <= 0:
            return ()
        return self.formation.links.get(self.know.member, ())

    # -- own sensors and the IR module ------------------------------------------------------------
    def driving_speed(self) -> tuple[float, float, float]:
        """The driving speed a master broadcasts (seed 000 §3.5, Fig. 9: "the user-connected robot sends its speed
        ... to sensitively react to the user's speed or direction changes"): the (vx, vy) its MOVE module drives the
        wheels toward (its controller's own last command, which the wheels reach under their acceleration limits),
        and the turn rate its wheel odometry measures. Chosen: the wheels' measured (vx, vy) lag each start and stop
        of the user by the motors' ramp, and the slaves' feed-forward lagged with them (stop-and-go, grid, hold RMSE
        0.136 -> 0.103 m; docs/results.md); the commanded ω as well made the leading zigzag worse (0.254 -> 0.278 m)."""
        vx, vy, _ = self._robot.motor_command
        return (vx, vy, self.odometry.read()[2])

    def ahrs_yaw(self) -> float:
        """Own AHRS reading (an own sensor: noisy, drifting)."""
        return self._own_yaw()

    @cython.cfunc
    def _own_yaw(self) -> cython.double:
        """:meth:`ahrs_yaw` (a C call from the compiled managers: the token ring's heading exchange, the IR fixes)."""
        return self._ahrs.yaw(self._true_clock.now)  # the sensor's physics runs on true time

    def own_body_status(self) -> dict | None:
        """Own body's status report for RUTA (type, battery, slip, draws, sensors), when the body
        gives one (``Robot.own_status``, robot types); None for a body without it."""
        report = getattr(self._robot, "own_status", None)
        return report() if report is not None else None

    def store_ir(self, other: int, distance_m: cython.double, bearing_rad: cython.double) -> None:
        """The IR module measured robot ``other``'s transmission (the IR medium calls it)."""
        if _isfinite(distance_m):
            know: Knowledge = self.know
            x, y = know.odometry_xy  # own dead-reckoned position (advanced each control step)
            know.ir[other] = IRMeasurement(distance_m, bearing_rad, self._mcu.local_now(), self._own_yaw(), x, y)

    def _ir_not_wired(self, neighbours: list[int | None]) -> list[int]:
        raise RuntimeError(f"robot {self.node_id}'s IR module is not wired to an IR medium (Fleet.add_node wires it)")


_STATION_HANDLE = Station._handle  # the handling every station runs unless a subclass or a test replaced it
