"""The IR token ring and the heading exchange (seed 000 §3.3 Fig. 7, §3.5 Fig. 9).

Robots have independent clocks, so IR transmission is sequenced by a token:

1. the holder broadcasts the *transmission-start* sign and waits for the responses;
2. it transmits IR until its deadline while all others receive and measure it;
   the holder's neighbours then send it *heading information* (the bearing at which they saw it);
3. at the deadline it broadcasts the *token* with the number of the next robot and waits for the
   responses (retrying when the next robot does not answer, skipping it after ``token_retries``);
4. the next robot sends the *sync* message, switches its IR module to transmit and starts over.

A lost token must not stall the ring (SPEC §3.3, chosen): the master watches the ring and, after
``token_timeout_s`` of silence, regenerates the token and transmits itself.

A member that stops answering (chosen): the holder before it retries the token ``token_retries`` times, then skips it, every
round. The master counts, at the start of each of its own slots (one round of the ring), the members it heard no ring frame
from since the start of its previous slot — their acknowledgements of its start sign and token (and those it overhears,
addressed to other holders), their own start signs, tokens and sync messages; the ring's first slot counts nothing (no round
has passed) (a live member sends several each round, so loss alone rarely silences one: at ``radio.loss_prob`` 0.3, five
frames all lost is 0.2 %) — and declares a member *lost* after ``protocol.lost_after_rounds`` such rounds in a row:
``lost_handler(node_id)``, the recovery manager (:mod:`.recovery`), removes it from the tables.

A crowded ring (chosen; seed 000 gives the sequence of Fig. 7, not its timing for many robots): the answers to one ring frame
all leave after one MCU processing delay, spread only by its jitter (``radio.processing_jitter_s``), and CSMA cannot tell apart
two senders whose assessments fall within one turnaround, so once the answers need more air than the jitter spreads them over —
``(members − 1) × (an answer's airtime + turnaround) > processing_jitter_s``, from 7 slaves on with the defaults — most of them
collide (1 + 16: 60 % of the token answers, 3.7 tokens per hand-over). :func:`ring_plan` then runs it as (:class:`RingPlan`):

- the members answer a start sign in member order after the holder, ``protocol.ring_answer_slot_s`` apart (802.15.4's own
  remedy, a backoff, made deterministic by the member number every robot holds);
- only the robot a token names answers it (the one answer the holder waits for; the others' sign of life is their answer to
  every start sign);
- the holder passes the token at its IR deadline instead of waiting for its neighbours' heading reports, which it pairs when
  they arrive (during the next slot): a round of N slots must revisit every member within the IR fix's freshness
  (:data:`~.knowledge.FRESH_IR_S`, 2 s), and 17 slots of 0.16 s (with the wait) take 2.7 s, 17 of 0.11 s 1.9 s;
- the holder transmits IR ``protocol.ring_ir_tx_crowded_s`` (15 ms) instead of ``protocol.ir_tx_s`` (40 ms): the rest of a slot
  — the answers to its start sign (~50 ms) and the token's hand-over (~25 ms), MCU processing delays — stays, so this is what
  shortens the round (1 + 16: 1.75 → 1.42 s, one missed slot then leaves a fix about 3 s old instead of 3.5 s).

After its ring's first round the master has measured every member in its IR reach: it hands the round to the join manager, which
may re-plan which member takes which slot (:meth:`~.join.JoinManager.replan_by_fixes`, from ``protocol.replan_min_slaves``
slaves on). A ring that is not crowded (the default 1 + 4) runs as before, frame for frame.

Heading exchange: robot j saw robot i at bearing φ_ji (in j's frame); i saw j at φ_ij. Then θ_j − θ_i = φ_ij − φ_ji + π (SPEC
§3.4), with no compass. The two bearings must come from the same round of the ring: i pairs j's report with its own measurement
of j's latest slot, and drops the report when it missed that slot (j occluded or out of range) or when its measurement is older
than i's own previous slot (chosen: i missed j's start signs since, lost frames; at loss 0.3, two robots re-forming after a
handover, such a pair put j's heading 56-62° off) — a bearing from an older round, with both robots moved since, would give a
wrong heading.

Relayed (chosen, not in seed 000): a differential body j with a fresh exchange with the master reports φ_ji less
ψ_j = θ_master − θ_j from it, so i's θ_j − θ_i comes out as θ_master − θ_i, the formation's heading
(:meth:`TokenRing.send_heading`). Seed 000's holonomic robots hold the formation's heading and report their own, as there; a
differential body points where it drives, and its neighbours placed their slots turned by as much (docs/results.md, the
heterogeneous swarm). Relayed by every robot, 1 + 16 petbots built their formation in 54 of 60 episodes against 56 (the
relays' errors add up along a deep formation); relayed again from relays, two differential bodies relaying each other
had nothing holding them to the master's heading.
"""

from __future__ import annotations

import math

import cython

from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.ring_plan import RingPlan, ring_plan

if cython.compiled:  # C reads and calls: station.pxd, clock.pxd (the MCU's), knowledge.pxd, radio.pxd (frames), geometry.pxd
    from cython.cimports.petswarm_env.comms.radio import Frame
    from cython.cimports.petswarm_env.middleware.knowledge import HeadingEstimate, IRMeasurement, Knowledge
    from cython.cimports.petswarm_env.middleware.station import Station
    from cython.cimports.petswarm_env.sim.clock import LocalClock
    from cython.cimports.petswarm_env.sim.geometry import wrap_float
else:
    from petswarm_env.comms.radio import Frame
    from petswarm_env.middleware.knowledge import HeadingEstimate, IRMeasurement, Knowledge
    from petswarm_env.middleware.station import Station
    from petswarm_env.sim.clock import LocalClock
    from petswarm_env.sim.geometry import wrap_float

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)
_NEG_INF = cython.declare(cython.double, -math.inf)  # (a C constant: read for every heading report and cut-off check)

# chosen: a holder announced this long ago (its start sign, sync or the token to it) still transmits: the slot's
# acknowledgement wait and its IR transmission (protocol.ring_response_timeout_s 0.05 + ir_tx_s 0.04) with room
ANNOUNCE_S = 0.12
RELAY_AGE_S = 2.0  # chosen: a heading exchange this recent is relayed (send_heading): the observation's age range

# the ring's frame kinds, read for every ring frame (a C global, not an attribute of the messages module)
_TX_START = cython.declare(str, msg.TX_START)
_TX_START_ACK = cython.declare(str, msg.TX_START_ACK)
_TOKEN = cython.declare(str, msg.TOKEN)
_TOKEN_ACK = cython.declare(str, msg.TOKEN_ACK)
_SYNC = cython.declare(str, msg.SYNC)
_HEADING = cython.declare(str, msg.HEADING)


def relative_heading(bearing_self_sees_other: float, bearing_other_sees_self: float) -> float:
    """θ_other − θ_self from the two mutual IR bearings (seed 000 §3.5; SPEC §3.4)."""
    return wrap_float(bearing_self_sees_other - bearing_other_sees_self + math.pi)


@cython.final
@cython.cclass
class _Wait:
    """What the holder waits for — every acknowledgement it needs, or its neighbours' heading reports — with the response
    timeout: the first of the two resumes its slot (seed 000 Fig. 7: "waits for the responses"). ``triggered``: what it waited
    for came; ``armed``: the slot waits on it (the heading reports are waited for only in a ring that is not crowded);
    ``done``: the slot resumed. Its steps are keyed on the clock where SimPy put the same wait written as ``AnyOf(event,
    timeout)`` in a process: the event, then the condition, each one step later."""

    slot = cython.declare(object)  # the _Slot it resumes
    triggered = cython.declare(cython.bint)
    armed = cython.declare(cython.bint)
    done = cython.declare(cython.bint)

    def __init__(self, slot):
        self.slot = slot
        self.triggered = self.armed = self.done = False


@cython.cclass
class TokenRing:
    """One robot's token ring and heading exchange (module docstring). A typed class of the
    compiled core; its methods are looked up as Python attributes, so a test may replace them."""

    __dict__ = cython.declare(dict)
    node = cython.declare(Station, visibility="public")
    token_seq = cython.declare(cython.longlong, visibility="public")
    holding = cython.declare(cython.bint, visibility="public")
    last_activity_s = cython.declare(cython.double, visibility="public")
    recoveries = cython.declare(cython.long, visibility="public")
    drop_next_token = cython.declare(cython.bint, visibility="public")
    _acks = cython.declare(set)
    _acks_needed = cython.declare(set)
    _acks_event = cython.declare(_Wait)
    _headings_expected = cython.declare(set)
    _headings_event = cython.declare(_Wait)
    _slot_start = cython.declare(dict)
    _own_starts = cython.declare(tuple)  # (previous, latest) start of our own slots
    holder_heard = cython.declare(tuple, visibility="public")
    token_to = cython.declare(tuple, visibility="public")
    own_slot = cython.declare(object, visibility="public")
    report_s = cython.declare(cython.double, visibility="public")
    slot_range_m = cython.declare(dict, visibility="public")
    heard = cython.declare(dict, visibility="public")
    silent_rounds = cython.declare(dict, visibility="public")
    round_start_s = cython.declare(cython.double, visibility="public")
    started_s = cython.declare(cython.double, visibility="public")
    rounds = cython.declare(cython.long, visibility="public")
    lost_handler = cython.declare(object, visibility="public")
    _declared = cython.declare(set)
    _plan = cython.declare(object)
    _neighbours = cython.declare(tuple)  # (formation, member, its neighbours' member numbers): _Slot._ir_done's
    _clock = cython.declare(LocalClock)  # the robot's own MCU clock (Station.clock)
    _times = cython.declare(tuple)  # (the station's config, three of its protocol times): _protocol
    relays_heading = cython.declare(cython.bint, visibility="public")  # send_heading: the formation's heading, not its own

    def __init__(self, node: Station):
        self.node = node
        self._clock = node.clock
        body = node.own_body_status()  # its own body: a differential drive cannot hold a heading of its own choosing
        self.relays_heading = body is not None and body["drive"] == "differential"
        self.token_seq = -1  # highest token sequence number seen
        self.holding = False
        self.last_activity_s = 0.0
        self.recoveries = 0  # master only: tokens regenerated
        self.drop_next_token = False  # fault injection: silently lose the next token handed to us
        self._acks = set()
        self._acks_needed = set()
        self._acks_event = None
        self._headings_expected = set()
        self._headings_event = None
        self._slot_start = {}  # robot -> start of its latest IR slot (its TX_START)
        self._own_starts = (-math.inf, -math.inf)
        self.holder_heard = (None, -math.inf)  # (sender of the latest start sign or sync, when)
        self.token_to = (None, -math.inf)  # (the robot the latest token heard went to, when)
        self.own_slot = None  # (start, neighbours that acked) of our latest slot
        self.report_s = -math.inf  # when a neighbour last reported the bearing it saw us at (heading exchange)
        self.slot_range_m = {}  # robot -> the RSSI range of its latest start sign or ack to us (middleware/diagnosis.py)
        self.heard = {}  # robot -> when we last received one of its ring frames
        self.silent_rounds = {}  # master: member -> rounds in a row it was not heard in
        self.round_start_s = 0.0  # master: start of its previous slot
        self.started_s = -math.inf  # master: when it started its ring
        self.rounds = 0  # master: rounds of its ring since it started it
        self.lost_handler = None  # master: called with the node id of a member declared lost (Node wires it)
        self._declared = set()
        self._plan = None  # (total members, its plan)
        self._neighbours, self._times = (None, -1, ()), None
        node.on(msg.TX_START, self._on_tx_start)
        node.on(msg.TOKEN, self._on_token)
        node.on(msg.SYNC, self._on_sync)
        node.on(msg.HEADING, self._on_heading)
        node.on(msg.TX_START_ACK, self._on_ack)
        node.on(msg.TOKEN_ACK, self._on_ack)

    @property
    def slot_starts(self) -> dict[int, float]:  # robot -> when its latest IR slot began (its start sign heard): diagnosis.py
        return self._slot_start

    def plan(self) -> RingPlan:
        """The ring's plan for the swarm as this robot's tables count it (:func:`ring_plan`)."""
        return self._current_plan()

    @cython.cfunc
    def _current_plan(self):  # plan() as a C call from the ring's own handlers
        total = cython.cast(Knowledge, self.node.know, typecheck=True).total_members
        if self._plan is None or self._plan[0] != total:
            self._plan = (total, ring_plan(self.node.cfg, total))
        return self._plan[1]

    @cython.cfunc
    def _protocol(self) -> tuple:
        """(config, ring_response_timeout_s, token_timeout_s, token_retries): the station's, read anew for another config."""
        cfg = self.node.cfg
        if self._times is None or self._times[0] is not cfg:
            p = cfg.protocol
            self._times = (cfg, p.ring_response_timeout_s, p.token_timeout_s, p.token_retries)
        return self._times

    # -- ring order -----------------------------------------------------------------------------
    @cython.cfunc
    def _next_member(self, member):
        total = cython.cast(Knowledge, self.node.know, typecheck=True).total_members
        return (member + 1) % total if total else 0

    @cython.cfunc
    def _neighbour_members(self, formation, member) -> tuple:
        """``formation.neighbours(member)`` in its order, kept while the table (never changed in place) and number stay."""
        kept: tuple = self._neighbours
        if kept[0] is not formation or kept[1] != member:
            kept = (formation, member, tuple(formation.neighbours(member)))
            self._neighbours = kept
        return kept[2]

    @cython.cfunc
    def _ring_peers(self) -> set:
        return {n for n in cython.cast(Knowledge, self.node.know, typecheck=True).members.values() if n != self.node.node_id}

    # -- holder -----------------------------------------------------------------------------------
    @cython.cfunc
    def _wait_acks(self, needed: set, slot: _Slot):
        """The holder waits for acknowledgements from ``needed``, or the response timeout: ``slot``
        resumes at the first of the two (:class:`_Wait`)."""
        self._acks = set()
        self._acks_needed = needed
        wait: _Wait = _Wait(slot)
        self._acks_event = wait
        wait.armed = True
        self._clock.call_later(self._protocol()[1], self._wait_over, (wait,))

    def _wait_over(self, wait: _Wait) -> None:
        """The first of a wait's two ends (its event, or its timeout) resumes its slot; the later one is nothing."""
        if wait.done or not wait.armed:
            return
        wait.done = True
        self._clock.call_soon(wait.slot.resume, ())

    def _on_ack(self, frame: Frame) -> None:
        src = frame.src
        self.heard[src] = self._clock.local_now()  # an acknowledgement to another holder, overheard, is a sign of life too
        if frame.dst != self.node.node_id:
            return
        self._acks.add(src)
        self.slot_range_m[src] = frame.rx_distance_est_m  # its RSSI range, as of its latest ring frame to us
        wait: _Wait = self._acks_event
        if wait is not None and not wait.triggered and self._acks_needed <= self._acks:
            wait.triggered = True
            if wait.armed:
                self._clock.call_soon(self._wait_over, (wait,))

    def hold(self, seq: int) -> None:
        """Become the holder of token ``seq`` and run its slot (:class:`_Slot`): start sign, IR transmission, token hand-over."""
        _Slot(self, seq).start()

    @cython.cfunc
    def _count_silent(self, peers: set, slot_start: cython.double):
        """Master, at the start of its slot: a round has passed since its previous slot; count the members not heard in it,
        and declare lost those silent ``protocol.lost_after_rounds`` rounds in a row (module docstring)."""
        since, heard, silent = self.round_start_s, self.heard, self.silent_rounds
        need = self.node.cfg.protocol.lost_after_rounds
        if (since == self.started_s and slot_start == since) or slot_start < self.started_s:
            return  # the ring's first slot (no round has passed yet: only the start sign's acknowledgements), or one it began as a slave holding the token as it took the master's role over
        for peer in peers:
            if heard.get(peer, -math.inf) >= since:
                silent[peer] = 0
                continue
            silent[peer] = silent.get(peer, 0) + 1
            if silent[peer] >= need and peer not in self._declared and self.lost_handler is not None:
                self._declared.add(peer)
                self.lost_handler(peer)
        self.round_start_s = slot_start
        self.rounds += 1
        if self.rounds == 1:  # every member has had its slot: the master has measured each one in its IR reach
            self.node.join.replan_by_fixes()

    def last_heard_s(self) -> float | None:
        """Master: when it last heard a ring frame of a member of its tables, or started its ring
        (None without a member): the sequence manager's cut-off (:meth:`~.sequence.SequenceManager.cut_off`)."""
        peers = self._ring_peers()
        if not peers:
            return None
        latest: cython.double = _NEG_INF
        for k, p in enumerate(peers):  # max(...) as the builtin takes it: a later time replaces only a greater one
            t = self.heard.get(p)  # a peer never heard counts -inf, which replaces nothing
            if t is not None and (k == 0 or float(t) > latest):
                latest = t
        return latest if latest > self.started_s else self.started_s  # max(self.started_s, latest)

    def forget(self, node_id: int) -> None:
        """Master: ``node_id`` left the tables (or joined them anew): its count starts over."""
        self.silent_rounds.pop(node_id, None)
        self._declared.discard(node_id)
        self.heard.pop(node_id, None)

    def start_as_master(self) -> None:
        """The master starts the ring (with a fresh token) and its watchdog."""
        node = self.node
        self.round_start_s = self.started_s = self._clock.local_now()  # every member's first round counts from now
        self.silent_rounds = {}
        self.rounds = 0
        if node.know.total_members > 1:
            self.token_seq += 1000  # supersede any token still in flight
            self._clock.call_start(self.hold, (self.token_seq,))
            self._clock.call_start(self._watch, ())

    def _begin(self, seq: int) -> None:
        """Become the holder: send the sync message, switch IR to transmit, run the slot."""
        self.node.send(_SYNC, seq=seq)
        self.hold(seq)

    # -- everyone ---------------------------------------------------------------------------------
    def _on_tx_start(self, frame: Frame) -> None:
        node: Station = self.node
        src, now = frame.src, self._clock.local_now()
        self.last_activity_s = self._slot_start[src] = self.heard[src] = now
        self.holder_heard = (src, now)
        self.slot_range_m[src] = frame.rx_distance_est_m  # the announcer's RSSI range (the IR self-check)
        seq = frame.payload["seq"]
        self.token_seq = max(seq, self.token_seq)
        slot = self._current_plan().answer_slot_s
        holder = cython.cast(Knowledge, node.know, typecheck=True).number_of(src) if slot > 0 else None
        if holder is None:
            node.send(_TX_START_ACK, src)
        else:  # crowded ring: in member order after the holder
            rank = (node.know.member - holder - 1) % node.know.total_members
            node.later(rank * slot, node.send, _TX_START_ACK, src)

    def _on_token(self, frame: Frame) -> None:
        node: Station = self.node
        src, now, payload = frame.src, self._clock.local_now(), frame.payload
        self.last_activity_s = self.heard[src] = now
        nxt = cython.cast(Knowledge, node.know, typecheck=True).members.get(payload["next"])
        if nxt is not None:
            self.token_to = (nxt, now)
        named = nxt == node.node_id
        if named or self._current_plan().all_answer_token:
            node.send(_TOKEN_ACK, src)
        seq = payload["seq"]
        if seq <= self.token_seq or not named:
            return
        self.token_seq = seq
        if self.drop_next_token:
            self.drop_next_token = False
            return
        self._clock.call_start(self._begin, (seq,))

    def _on_sync(self, frame: Frame) -> None:
        src, now = frame.src, self._clock.local_now()
        self.last_activity_s = self.heard[src] = now
        self.holder_heard = (src, now)
        self.token_seq = max(self.token_seq, frame.payload["seq"])

    def announced_holder(self) -> int | None:
        """Who transmits the IR we measure now, as this robot knows it: the sender of the latest start sign or sync it heard
        (the holder's own frames), else the robot the latest token it heard was passed to, if that frame is recent enough to
        be this slot's (:data:`ANNOUNCE_S`); None: it heard no announcement and cannot say whose IR it measured (the
        measurement is dropped). Chosen order: a token's "next" names a member by the receiver's own table and a token may be
        passed on again (its acknowledgement lost) while the first robot holds."""
        now = self._clock.local_now()
        for holder, t in (self.holder_heard, self.token_to):
            if now - t <= ANNOUNCE_S:
                return holder
        return None

    def report_heading(self, holder: int) -> bool:
        """The IR medium asks a neighbour of the transmitter ``holder`` at the end of its slot: if
        we measured it in this slot, we report the bearing we saw it at (Fig. 9)."""
        seen: IRMeasurement = cython.cast(Knowledge, self.node.know, typecheck=True).ir.get(holder)
        if seen is None or seen.time_s != self._clock.local_now():
            return False
        self.send_heading(holder, seen.bearing_rad)
        return True

    def send_heading(self, holder: int, bearing_rad: float) -> None:
        """Neighbour of the transmitter: report the bearing at which we saw it (Fig. 9), after the
        MCU has processed the measurement; a differential body (:attr:`relays_heading`) reports it from
        the formation's heading as it knows it (:meth:`Knowledge.formation_offset`; module docstring)."""
        node: Station = self.node
        if self.relays_heading and node.state != "master":
            know: Knowledge = cython.cast(Knowledge, node.know, typecheck=True)
            if know.heading:
                psi: cython.double = know.formation_offset(self._clock.local_now(), node._own_yaw(), RELAY_AGE_S)
                if psi == psi:  # a fresh exchange with the master: relay its heading, else report our own
                    bearing_rad = wrap_float(bearing_rad - psi)
        node.later(node.processing_delay(), lambda: node.send(_HEADING, dst=holder, bearing=bearing_rad))

    def _on_heading(self, frame: Frame) -> None:
        node: Station = self.node
        if frame.dst != node.node_id:
            return
        self.report_s = self._clock.local_now()
        seen: IRMeasurement = node.know.ir.get(frame.src)
        if seen is not None and seen.time_s >= max(self._slot_start.get(frame.src, _NEG_INF), self._own_starts[0]):
            # our bearing of the sender dates from its slot of this round (module docstring): carry it over our rotation since
            yaw = node._own_yaw()  # (ahrs_yaw, a C call)
            bearing_now = seen.bearing_rad - (yaw - seen.own_yaw_rad)
            rel = relative_heading(bearing_now, frame.payload["bearing"])
            node.know.heading[frame.src] = HeadingEstimate(rel, self._clock.local_now(), yaw)
        # else we missed the sender's latest slot, or its start signs since our previous slot: no pair from this round
        self._headings_expected.discard(frame.src)
        wait: _Wait = self._headings_event
        if wait is not None and not wait.triggered and not self._headings_expected:
            wait.triggered = True
            if wait.armed:
                self._clock.call_soon(self._wait_over, (wait,))

    # -- master: watchdog -------------------------------------------------------------------------
    def _watch(self) -> None:
        """Master: regenerate a lost token after ``token_timeout_s`` of ring silence, looking every
        ``token_timeout_s / 2`` of its own clock while it is the master."""
        node = self.node
        if node.state == "master":
            self._clock.call_later(self._protocol()[2] / 2, self._watchdog, ())

    def _watchdog(self) -> None:
        node = self.node
        if node.state != "master":
            return
        if not self.holding and self._clock.local_now() - self.last_activity_s > self._protocol()[2]:
            self.recoveries += 1
            self.token_seq += 1000  # supersede any stale holder
            self._clock.call_start(self.hold, (self.token_seq,))
        self._watch()


# the step of a holder's slot that the next resume runs
_ACKED = cython.declare(cython.int, 0)  # the start sign's responses (or the timeout)
_IR_DONE = cython.declare(cython.int, 1)  # the IR transmission's end
_HEADINGS = cython.declare(cython.int, 2)  # the neighbours' heading reports (or the timeout)
_TOKEN_ACKED = cython.declare(cython.int, 3)  # the token's acknowledgement (or the timeout)


@cython.final
@cython.cclass
class _Slot:
    """One holder's slot of the ring (seed 000 §3.3 Fig. 7), as a state machine on its MCU's clock:
    start sign and the responses, IR transmission, the neighbours' heading reports, token hand-over
    (with retries, skipping a robot that does not answer). A robot that leaves the swarm meanwhile
    (``node.know`` replaced) ends it; so does a newer token (``token_seq``) at the IR deadline."""

    ring = cython.declare(TokenRing)
    seq = cython.declare(cython.longlong)
    know = cython.declare(object)
    peers = cython.declare(set)
    slot_start = cython.declare(cython.double)
    step = cython.declare(cython.int)
    member = cython.declare(object)
    nxt = cython.declare(object)
    target = cython.declare(object)
    skips_left = cython.declare(cython.long)
    attempts_left = cython.declare(cython.long)

    def __init__(self, ring: TokenRing, seq: cython.longlong):
        self.ring = ring
        self.seq = seq
        self.know = ring.node.know  # leave_swarm() replaces it: then this slot is over
        self.step = _ACKED

    def start(self) -> None:
        ring: TokenRing = self.ring
        node = ring.node
        ring.holding = True
        ring.token_seq = self.seq
        ring.last_activity_s = ring._clock.local_now()
        self.peers = ring._ring_peers()
        self.slot_start = ring._clock.local_now()
        ring._own_starts = (ring._own_starts[1], self.slot_start)
        node.send(_TX_START, seq=self.seq)
        self.step = _ACKED
        ring._wait_acks(self.peers, self)

    def resume(self) -> None:
        step = self.step
        if step == _ACKED:
            self._acked()
        elif step == _IR_DONE:
            self._ir_done()
        elif step == _HEADINGS:
            self._pass_token()
        else:
            self._token_acked()

    @cython.cfunc
    def _end(self):
        self.ring.holding = False

    @cython.cfunc
    def _acked(self):
        ring: TokenRing = self.ring
        node = ring.node
        if node.state == "master" and node.know is self.know:
            ring._count_silent(self.peers, self.slot_start)
        self.step = _IR_DONE
        ring._clock.call_later(ring._current_plan().ir_tx_s, self.resume, ())

    @cython.cfunc
    def _ir_done(self):
        ring: TokenRing = self.ring
        node, know = ring.node, self.know
        if ring.token_seq != self.seq or node.know is not know:  # superseded, or left the swarm
            self._end()
            return
        # every other member measures our IR now; our neighbours (by our neighbour table, in its
        # order) that saw us report the bearing they saw us at (Fig. 9): wait for them before passing on
        formation = node.formation
        neighbours = [know.members.get(m) for m in ring._neighbour_members(formation, know.member)] if formation is not None else []
        # our own slot as our IR self-check sees it: the neighbours that acknowledged our start sign (middleware/diagnosis.py)
        ring.own_slot = (self.slot_start, frozenset(n for n in neighbours if n in ring._acks))
        reporters = node.transmit_ir(neighbours)
        ring._headings_expected = set(reporters)
        wait: _Wait = _Wait(self)
        ring._headings_event = wait
        if reporters and ring._current_plan().wait_headings:  # else the reports are paired as they come (crowded ring)
            wait.armed = True
            self.step = _HEADINGS
            ring._clock.call_later(ring._protocol()[1], ring._wait_over, (wait,))
            return
        self._pass_token()

    @cython.cfunc
    def _pass_token(self):
        ring: TokenRing = self.ring
        node = ring.node
        ring._headings_expected = set()
        if node.know is not self.know:
            self._end()
            return
        self.member = node.know.member
        self.nxt = ring._next_member(self.member)
        self.skips_left = node.know.total_members
        self._next_target()

    @cython.cfunc
    def _next_target(self):
        """The token goes to the next member in the table; one the table lost meanwhile is passed over."""
        ring: TokenRing = self.ring
        know = ring.node.know
        while self.skips_left > 0:
            self.skips_left -= 1
            target = know.members.get(self.nxt)
            if target is None:  # the tables shrank meanwhile (a member removed)
                self.nxt = ring._next_member(self.nxt)
                continue
            self.target = target
            self.attempts_left = ring._protocol()[3] + 1
            self._send_token()
            return
        self._finish()

    @cython.cfunc
    def _send_token(self):
        self.attempts_left -= 1
        self.ring.node.send(_TOKEN, seq=self.seq + 1, next=self.nxt)
        self.step = _TOKEN_ACKED
        self.ring._wait_acks({self.target}, self)

    @cython.cfunc
    def _token_acked(self):
        ring: TokenRing = self.ring
        if ring.node.know is not self.know:
            self._end()
            return
        if self.target not in ring._acks and self.attempts_left > 0:
            self._send_token()  # retry
            return
        if self.target in ring._acks or self.nxt == self.member:
            self._finish()
            return
        self.nxt = ring._next_member(self.nxt)  # skip a robot that does not answer
        self._next_target()

    @cython.cfunc
    def _finish(self):
        ring: TokenRing = self.ring
        ring.holding = False
        ring.last_activity_s = ring._clock.local_now()
        if self.nxt == self.member:  # nobody else answered: keep the token
            ring._clock.call_start(ring._begin, (self.seq + 1,))
