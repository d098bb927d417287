"""The sequence manager: organize, maintain, disperse (seed 000 §3.1, Fig. 4).

Robot states: a *waiting* robot that receives the swarm-organizing request goes to
*organizing* and then *slave*-role driving; the user-connected robot goes from its driving state
(*following*/*leading*/*remote*) to *organizing* and then *master*-role driving. On the disperse
request, slaves return to *waiting* and the master to its previous driving state.
"""

from __future__ import annotations

from collections.abc import Callable

import cython

from petswarm_env.comms.radio import PAN_WAITING, Frame
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.station import Station

if cython.compiled:  # a station's typed attributes (station.pxd) and what it knows (knowledge.pxd): the per-step
    # checks of a slave's master and of a master's ring read them by C reads
    from cython.cimports.petswarm_env.middleware.knowledge import Knowledge, MasterStatus
    from cython.cimports.petswarm_env.middleware.station import Station as _Typed
else:
    from petswarm_env.middleware.knowledge import Knowledge, MasterStatus
    _Typed = Station

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)


@cython.cclass
class SequenceManager:
    """One robot's sequence manager (module docstring). A typed class (``sequence.pxd``): its
    attributes are declared there."""

    def __init__(self, node: Station):
        self.node = node
        self._cfg = None  # the protocol's timeouts are read at the first check (:meth:`_timeouts`)
        node.on(msg.DISPERSE, self._on_disperse)
        node.on(msg.DISPERSE_ACK, self._on_disperse_ack)
        self._acks: set[int] = set()
        self.last_master: int | None = None  # to re-acknowledge a repeated disperse request
        # (time noticed, the master's node id, the timeout instant: last status heard + protocol.status_timeout_s)
        self.master_lost_at: list[tuple[float, int | None, float]] = []
        self.successor = None  # the succession manager (middleware/succession.py), wired by the node
        # the master: when it last heard a ring frame of a member (or started its ring); wired by the node
        self.ring_heard: Callable[[], float | None] = lambda: None

    def leave_swarm(self) -> None:
        """Back to waiting on the common PAN, forgetting the swarm."""
        node = self.node
        node.state = "waiting"
        node.pans = frozenset({PAN_WAITING})
        node.swarm_pan = None
        node.formation = None
        node.know = Knowledge()

    @cython.ccall
    def master_lost(self, now_s: cython.double) -> cython.bint:
        """Whether this slave has no master now (the caller's emergency stop). A slave that heard
        no status broadcast of its master for ``protocol.status_timeout_s`` has lost it (docs/faults.md):
        it records the loss and starts choosing a new master among the slaves
        (:mod:`.succession`); it stays stopped while that runs. The timeout counts from the last
        status broadcast heard since it joined; before the first one, from its joining plus
        ``protocol.organize_timeout_s`` (the master broadcasts only once the join protocol ended,
        which takes that long at most: a robot that joined early in a long organize must not
        time out before the master's first broadcast)."""
        node: _Typed = self.node
        if node.state != "slave":
            return False
        if self.successor is not None and self.successor.electing:
            if not self.successor.master_heard_again():
                return True
        if node.cfg is not self._cfg:
            self._timeouts()
        know: Knowledge = node.know
        status: MasterStatus = know.status
        last: cython.double = node.joined_s
        if status is not None and status.time_s >= last:
            last = status.time_s
        else:
            last += self._organize_timeout_s
        if now_s - last <= self._status_timeout_s:
            return False
        self.master_lost_at.append((now_s, node.member_node(0), last + self._status_timeout_s))
        if self.successor is None:
            self.leave_swarm()
            return True
        self.successor.start(now_s)
        return True

    @cython.cfunc
    def _timeouts(self) -> cython.void:
        """The protocol's organize and status timeouts, read from the station's config (read anew
        when the station is given another config: a takeover adopts its master's)."""
        node: _Typed = self.node
        cfg = node.cfg
        self._organize_timeout_s = cfg.protocol.organize_timeout_s
        self._status_timeout_s = cfg.protocol.status_timeout_s
        self._cfg = cfg

    def cut_off(self, now_s: float) -> bool:
        """A master that heard no ring frame of any of its members for ``protocol.status_timeout_s``
        (its radio failed, or every member did) is cut off from its swarm: the same rule as its
        slaves' status timeout, from the other end. Its user session then releases the user
        (an alert to the belt; the slaves choose a new master, :mod:`.succession`)."""
        node: _Typed = self.node
        ring = self.ring_heard()
        know: Knowledge = node.know
        if node.state != "master" or know.total_members <= 1 or ring is None:
            return False
        if node.cfg is not self._cfg:
            self._timeouts()
        return now_s - ring > self._status_timeout_s

    def power_off(self) -> None:
        """The robot is off (a ``dead`` or ``battery`` fault, sim/faults.py): its middleware stops,
        forgetting everything; it hears no PAN."""
        self.leave_swarm()
        node = self.node
        node.state = "off"
        node.pans = frozenset()
        node.connected_user = None

    def power_on(self) -> None:
        """The robot was switched on again (a transient fault cleared, or an arrival): it boots
        into waiting on the common PAN, knowing nothing."""
        self.leave_swarm()

    def _on_disperse(self, frame: Frame) -> None:
        node = self.node
        if node.state == "slave":
            self.last_master = node.member_node(0)
            node.send(msg.DISPERSE_ACK, dst=frame.src)
            # leave once the acknowledgement is on its way (the MAC keeps the PAN of queued frames)
            self.leave_swarm()
        elif node.state == "waiting" and frame.src == self.last_master:
            # our acknowledgement was lost and the master asks again on the common PAN
            node.send(msg.DISPERSE_ACK, dst=frame.src, pan=frame.pan)

    def _on_disperse_ack(self, frame: Frame) -> None:
        if frame.dst == self.node.node_id:
            self._acks.add(frame.src)

    def disperse(self, result: dict):
        """Master process: broadcast disperse until every slave acknowledged (or retries run out)."""
        node = self.node
        clock = node.clock
        cfg = node.cfg.protocol
        slaves = {n for m, n in node.know.members.items() if m != 0}
        self._acks = set()
        retries = 0
        node.pans = node.pans | {PAN_WAITING}  # acknowledgements of robots that already left
        while True:
            node.send(msg.DISPERSE)
            if retries:  # a slave whose acknowledgement was lost is already back on the common PAN
                node.send(msg.DISPERSE, pan=PAN_WAITING)
            yield clock.timeout(cfg.response_timeout_s)
            if slaves <= self._acks or retries >= cfg.max_retries:
                break
            retries += 1
        result["acknowledged"] = sorted(self._acks & slaves)
        result["retries"] = retries
        self.leave_swarm()
        node.state = node.previous_driving_state
