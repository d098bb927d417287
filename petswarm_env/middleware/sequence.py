"""The sequence manager: organize, maintain, disperse (seed 000 §3.1, Fig. 4).

Robot states: a *waiting* robot that receives the swarm-organizing request goes to
*organizing* and then *slave*-role driving; the user-connected robot goes from its driving state
(*following*/*leading*/*remote*) to *organizing* and then *master*-role driving. On the disperse
request, slaves return to *waiting* and the master to its previous driving state.
"""

from __future__ import annotations

from petswarm_env.comms.radio import PAN_WAITING, Frame
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.knowledge import Knowledge
from petswarm_env.middleware.station import Station


class SequenceManager:
    def __init__(self, node: Station):
        self.node = node
        node.on(msg.DISPERSE, self._on_disperse)
        node.on(msg.DISPERSE_ACK, self._on_disperse_ack)
        self._acks: set[int] = set()
        self.last_master: int | None = None  # to re-acknowledge a repeated disperse request
        # (time noticed, the master's node id, the timeout instant: last status heard + protocol.status_timeout_s)
        self.master_lost_at: list[tuple[float, int | None, float]] = []

    def leave_swarm(self) -> None:
        """Back to waiting on the common PAN, forgetting the swarm."""
        node = self.node
        node.state = "waiting"
        node.pans = frozenset({PAN_WAITING})
        node.swarm_pan = None
        node.formation = None
        node.know = Knowledge()

    def master_lost(self, now_s: float) -> bool:
        """A slave that heard no status broadcast of its master for ``protocol.status_timeout_s``
        (since it joined, if none yet) has lost its master (chosen): it stops — the caller's
        emergency stop — and returns to waiting. True when that happened now."""
        node = self.node
        if node.state != "slave":
            return False
        status, last = node.know.status, node.joined_s
        if status is not None and status.time_s > last:
            last = status.time_s
        if now_s - last <= node.cfg.protocol.status_timeout_s:
            return False
        self.master_lost_at.append((now_s, node.member_node(0), last + node.cfg.protocol.status_timeout_s))
        self.leave_swarm()
        return True

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
