"""One robot's middleware (seed 000 Fig. 5): its station and the managers it builds.

Lower layer: the RF communication manager and the IR module (:class:`~.station.Station`, which is
all a manager sees of its robot). Upper layer, built here for this robot alone: the sequence manager
(:mod:`.sequence`), the message-processing manager (dispatch of frames to the join protocol
:mod:`.join`, the mode change :mod:`.modes`, the token ring :mod:`.token_ring`, the master's
status broadcast and the choice of a new master :mod:`.succession`) and the relative-location
identification manager (:mod:`.token_ring`).
Everything a policy may see is in :class:`~.knowledge.Knowledge`.

The managers never see the per-user swarm nor another robot: what they report upward leaves through
the station's signals, the IR transmission through its IR port; :mod:`.fleet` wires both.

A module of the compiled core (``petswarm_env/_core.py``): the master's status broadcast is handled
here for every frame; the same file runs under the interpreter.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import cython
import numpy as np

from petswarm_env.comms.radio import RadioMedium
from petswarm_env.config import Config
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.diagnosis import Diagnosis
from petswarm_env.middleware.join import JoinManager
from petswarm_env.middleware.modes import ModeManager
from petswarm_env.middleware.recovery import RecoveryManager
from petswarm_env.middleware.sequence import SequenceManager
from petswarm_env.middleware.station import OwnClock, Signal, Station
from petswarm_env.middleware.succession import SuccessionManager
from petswarm_env.middleware.token_ring import TokenRing
from petswarm_env.sim.clock import Clock

if cython.compiled:  # a station's typed attributes (station.pxd): its MCU clock by a C read; the master's status as a
    # typed record (knowledge.pxd)
    from cython.cimports.petswarm_env.comms.radio import Frame  # a frame's fields as C reads (comms/radio.pxd)
    from cython.cimports.petswarm_env.middleware.knowledge import Knowledge, new_status
    from cython.cimports.petswarm_env.middleware.station import Station as _Typed
else:
    from petswarm_env.comms.radio import Frame
    from petswarm_env.middleware.knowledge import Knowledge, new_status
    _Typed = Station

if TYPE_CHECKING:
    from petswarm_env.sim.robot import Robot

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)


class Node(Station):
    """Middleware of one robot, attached to the radio as a station, with its own managers."""

    def __init__(self, node_id: int, cfg: Config, clock: Clock, radio: RadioMedium, robot: Robot,
                 rng: np.random.Generator):
        super().__init__(node_id, cfg, clock, radio, robot, rng)
        self.join = JoinManager(self)
        self.ring = TokenRing(self)
        self.seq = SequenceManager(self)
        self.modes = ModeManager(self)
        self.recovery = RecoveryManager(self, self.join, self.ring.forget, self.seq.leave_swarm)
        self.ring.lost_handler = self.recovery.member_lost
        # the robot's own sensor diagnosis (middleware/diagnosis.py), fed by its ring and AHRS readings
        self.diagnosis = Diagnosis(node_id, cfg, robot, lambda: self.know, self.ring)
        self.diagnosis.on_detect = self.recovery.sensor_failed
        self.cannot_lead = Signal()  # (part): as master, it found broken a part its job needs (RecoveryManager.sensor_failed)
        self.recovery.cannot_lead = self.cannot_lead.emit
        # a master that handed its user over is a slave: a part it found broken may leave it unable to hold its slot
        self.handed_over.connect(lambda _new_master: self.recovery.after_handover(frozenset(self.diagnosis.failed)))
        # the sensors hand their readings to the MCU, which stamps them with its own clock
        stamp = OwnClock(self.clock, self.diagnosis)
        robot.readings = stamp  # its ring's readings (Sensors.read_rings)
        robot.ahrs.readings = stamp
        self.succession = SuccessionManager(self, self.seq.leave_swarm)
        self.seq.successor = self.succession
        self.seq.ring_heard = self.ring.last_heard_s
        self.on(msg.STATUS, self._on_status)

    @property
    def failed_sensors(self) -> frozenset[str]:
        """The parts this robot has found broken itself (its status report leaves them out)."""
        return frozenset(self.diagnosis.failed)

    def _on_status(self, frame: Frame) -> None:
        """The master's periodic broadcast (seed 000 §3.5, Fig. 9): keep the latest."""
        p = frame.payload
        station: _Typed = self
        know: Knowledge = station.know
        know.status = new_status(p["velocity"], p["activity"], p["mode"], p["turn_rate"], p["user"],
                                 station._mcu.local_now(), p["rotating"])  # on its own clock (``clock.now``)
        self.succession.heard_status(frame.src, know.status.time_s, p["velocity"][2])
