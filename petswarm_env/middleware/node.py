"""One robot's middleware (seed 000 Fig. 5): its managers and what it knows.

Lower layer: the RF communication manager (a station on the shared medium) and the IR module.
Upper layer: the sequence manager (:mod:`.sequence`), the message-processing manager (dispatch of
frames to the join protocol, the token ring and the status handlers) and the relative-location
identification manager (:mod:`.token_ring`). Everything a policy may see is in :class:`Knowledge`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import simpy

from petswarm_env.comms.radio import BROADCAST, PAN_WAITING, Frame, RadioMedium
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation
from petswarm_env.sim.draws import Draws
from petswarm_env.sim.events import scheduler
from petswarm_env.sim.robot import _get_position

if TYPE_CHECKING:
    from petswarm_env.middleware.swarm import Swarm


@dataclass
class IRMeasurement:
    distance_m: float
    bearing_rad: float  # bearing of the other robot in this robot's body frame
    time_s: float
    own_yaw_rad: float  # own AHRS yaw when measured (to carry the bearing over own rotation)


@dataclass
class HeadingEstimate:
    relative_rad: float  # θ_other − θ_self, from the heading exchange
    time_s: float
    own_yaw_rad: float  # own AHRS yaw when estimated


@dataclass
class MasterStatus:
    """The master's periodic broadcast (seed 000 §3.5, Fig. 9)."""

    velocity: tuple[float, float, float]  # master's (vx, vy, ω) in its body frame
    activity: str  # user activity: stop | rest | walk | run (the belt's recognition)
    mode: str  # following | leading | remote | emergency
    user_turn_rate_rps: float
    user_position_m: tuple[float, float]  # user relative to the master, master's frame
    time_s: float  # when this robot received it
    user_rotating: bool = False  # the belt's rotation flag (seed 002 §3.4)


@dataclass
class Knowledge:
    """What one robot knows. Filled only by frames and its own sensors."""

    member: int = -1  # member number in the swarm (0 = master), -1 = none
    total_members: int = 0
    members: dict[int, int] = field(default_factory=dict)  # member number -> node id
    ir: dict[int, IRMeasurement] = field(default_factory=dict)  # node id -> latest measurement
    heading: dict[int, HeadingEstimate] = field(default_factory=dict)  # node id -> relative heading
    status: MasterStatus | None = None


class Node:
    """Middleware of one robot, attached to the radio as a station."""

    def __init__(self, swarm: Swarm, node_id: int, rng: np.random.Generator):
        self.swarm = swarm
        self.node_id = node_id
        self.clock: simpy.Environment = swarm.clock
        self.later = scheduler(self.clock)  # later(delay, fn, *args): a call on the clock
        self.radio: RadioMedium = swarm.radio
        self.cfg = swarm.cfg
        self.rng = rng
        self.draws = Draws(rng)  # scalar draws (MCU processing jitter) taken from rng in blocks
        self._processing = (self.cfg.radio.processing_s, self.cfg.radio.processing_jitter_s)
        self._robots = swarm.world.robots  # the world's robot list (node id = robot index)
        self._cbody = self._robots[node_id]._cbody  # own body in Chipmunk (the antenna's position)
        self.pans: frozenset[int] = frozenset({PAN_WAITING})
        self.state = "waiting"  # sequence manager state, see sequence.py
        self.connected_user: int | None = None  # the user this robot is connected to, if any
        self.know = Knowledge()
        self.formation: Formation | None = None
        self.swarm_pan: int | None = None
        self.counters = {"foreign_pan_frames_processed": 0, "frames_handled": 0}
        self.handlers: dict[str, Callable[[Frame], None]] = {}
        self.radio.attach(self)

    # -- lower layer ------------------------------------------------------------------------------
    def position(self) -> tuple[float, float]:
        """Antenna position: the radio's propagation model needs it (not the middleware)."""
        p = _get_position(self._cbody)
        return (p.x, p.y)

    def send(self, kind: str, dst: int = BROADCAST, pan: int | None = None, **payload: Any) -> None:
        pan = self.swarm_pan if pan is None else pan
        frame = Frame(kind, self.node_id, dst, pan, payload, msg.SIZE_BYTES[kind])
        self.radio.send(self, frame)

    def receive(self, frame: Frame) -> None:
        """Called by the medium for every frame its MAC accepted; handled after MCU processing."""
        handler = self.handlers.get(frame.kind)
        if handler is None:
            return
        base, jitter = self._processing  # processing_delay(), inlined: called for every reception
        self.later(base + jitter * self.draws.uniform(), self._handle, handler, frame)

    def processing_delay(self) -> float:
        """MCU time to handle a received frame before it can answer (``processing_s`` plus a
        uniform jitter of up to ``processing_jitter_s``)."""
        base, jitter = self._processing
        return base + jitter * self.draws.uniform()

    def _handle(self, handler: Callable[[Frame], None], frame: Frame) -> None:
        pan = frame.pan
        if pan not in self.pans:  # the PAN changed while the frame was being processed
            return
        if pan != PAN_WAITING and pan != self.swarm_pan:
            self.counters["foreign_pan_frames_processed"] += 1  # must never happen
        self.counters["frames_handled"] += 1
        handler(frame)

    def on(self, kind: str, handler: Callable[[Frame], None]) -> None:
        self.handlers[kind] = handler

    # -- swarm membership -----------------------------------------------------------------------
    def member_node(self, member: int) -> int | None:
        return self.know.members.get(member)

    def reference_links(self):
        if self.formation is None or self.know.member <= 0:
            return ()
        return self.formation.links.get(self.know.member, ())

    def ahrs_yaw(self) -> float:
        """Own AHRS reading (an own sensor: noisy, drifting)."""
        return self._robots[self.node_id].ahrs_yaw(self.clock._now)  # (clock.now without the property)

    def store_ir(self, other: int, distance_m: float, bearing_rad: float) -> None:
        if math.isfinite(distance_m):
            self.know.ir[other] = IRMeasurement(distance_m, bearing_rad, self.clock._now, self.ahrs_yaw())
