"""Swarm-network formation: the join protocol (seed 000 §3.4, Fig. 8, Tables 1–2).

1. The master broadcasts a *scan*; waiting robots answer; the master estimates the joining
   candidates among the responders (by the RSSI distance of their answers).
2. The master broadcasts the *joining query* to the candidates; each decides by Table 1 and
   answers joining-available / joining-unavailable. Missing answers → query again (retry).
   Fewer available robots than the user requires → scan again (retry: "whenever the master has
   not received every expected response, it retries that step", §3.4; a response may have been
   lost or collided, §4.5). A rescan lists the robots already heard, which stay silent (chosen),
   so the answers of the missing robots do not collide with theirs again.
3. The master selects by Table 2 and sends each candidate a *joining notification* (new PAN ID,
   member number, total number of members, the member table; chosen: the neighbour table with its
   reference offsets, the formation's shape and the driving mode — a member knows of its swarm only
   what this frame and the later mode-change frames told it) or a *non-participating
   notification*; each answers with an acknowledgement. Missing acknowledgements → notify again
   (retry).
4. Joined robots switch to the new PAN ID.

Who joins and which slot each member takes is ``swarm.assignment`` (:mod:`.assignment`): Table 2's
closest (the default), or seed 003's RUTA — ``ruta_centralized`` (the candidates' joining answers
carry their status; Algorithm 1 on the master) or ``ruta_decentralized`` (an auction of the open
slots between step 2 and step 3; Algorithm 2). The pipeline for any set of open member numbers:
:meth:`JoinManager._scan_and_query`, then :meth:`JoinManager._choose` (the auction, then
:meth:`JoinManager._select`), then :meth:`JoinManager._notify`; an organize opens members
1..required, a refill after a lost member (faults) the lost ones.

Budgets (chosen): every step retries at most ``protocol.max_retries`` times (the scans; each round
of queries; each robot's notification), and the whole protocol ends ``protocol.organize_timeout_s``
after it started, whatever its state: every wait is cut at that deadline, the scans stop early
enough to leave the notifications their time (:data:`NOTIFY_RESERVE_TRIES`), and a robot not yet
notified at the deadline is never notified (it stays waiting; it is in the member table the others
received, so the ring skips it). A swarm may thus organize short of the required number; the env
reports it (``slaves_missing``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from petswarm_env.comms.radio import PAN_WAITING, Frame
from petswarm_env.middleware import assignment
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation, leading_user, table_for_members
from petswarm_env.middleware.ruta import Bid
from petswarm_env.middleware.station import Station
from petswarm_env.middleware.succession import body_can_be_master


# Robots on the common PAN that answer a scan: waiting robots, and user-connected robots not in a
# swarm (command-waiting or driving alone), which then decline by Table 1 (connected to a user).
SCAN_ANSWERING_STATES = ("waiting", "command_waiting", "following", "leading", "remote")
# chosen: while fewer robots are available than required, the scan is retried until the organize
# deadline less the notification step's time: a response timeout per robot to notify and this many
# more for retries (a reserve of 4 tries per robot left 16 robots 0.4 s of a 10 s budget to scan in)
NOTIFY_RESERVE_TRIES = 4
# chosen: the master takes as joining candidates the scan responders its RSSI estimate puts within
# this many times the available region (the RSSI distance is off by ~10 % at 1 dB shadowing)
CANDIDATE_REACH = 1.3
# chosen: a refill (of a lost member's slot) scans at most this many times; the master's periodic scan
# (protocol.rescan_period_s) tries again later while a slot stays open
REFILL_SCANS = 3


class OrganizeError(RuntimeError):
    """A swarm could not organize within ``protocol.organize_timeout_s`` (the env's reset): the
    message names the seed and the likely cause (:func:`organize_obstacle`). A run records the
    episode as not organized and goes on (evaluation/runner.py)."""

    def __init__(self, message: str, seed: int | None, cause: str):
        super().__init__(message)
        self.seed, self.cause = seed, cause


# chosen: more robots than this organizing at once on one medium (several users) is named as the likely
# cause of a failed organize: their scan answers and acknowledgements collide (4 users x 5 robots organize)
CROWD_ROBOTS = 24


def organize_obstacle(cfg) -> str:
    """The config value that most likely kept a swarm from organizing, most certain first: a bit
    rate too low for a query and its answer within ``protocol.response_timeout_s``; a radio range
    shorter than the master's available region (the waiting robots stand inside it); a crowd of
    users' robots organizing at once on one medium; frame loss; else the answers' collisions."""
    radio, proto = cfg.radio, cfg.protocol
    n = cfg.swarm.num_slaves

    def airtime(nbytes: int) -> float:
        return 8.0 * (nbytes + radio.frame_overhead_bytes) / radio.bitrate_bps

    exchange = airtime(msg.SIZE_BYTES[msg.JOIN_QUERY] + msg.LIST_ENTRY_BYTES * n) + airtime(msg.SIZE_BYTES[msg.JOIN_ANSWER])
    if exchange + 2 * radio.processing_s > proto.response_timeout_s:
        return (f"radio.bitrate_bps={radio.bitrate_bps:g}: a joining query and its answer take {exchange:.3g} s on the air, "
                f"more than protocol.response_timeout_s={proto.response_timeout_s:g} s; raise the bit rate (802.15.4: 250000)")
    if radio.range_m < proto.join_radius_m:
        return (f"radio.range_m={radio.range_m:g} is shorter than the master's available region (protocol.join_radius_m="
                f"{proto.join_radius_m:g}, where the waiting robots stand): they cannot hear its scan; raise radio.range_m")
    robots = cfg.world.num_users * (1 + n + cfg.swarm.extra_robots)
    if cfg.world.num_users > 1 and robots > CROWD_ROBOTS:
        return (f"size: {cfg.world.num_users} users x {n} slaves ({robots} robots) organize at once on one medium and "
                "their answers collide; fewer users (world.num_users) or slaves (swarm.num_slaves), or a longer "
                "protocol.organize_timeout_s")
    if radio.loss_prob > 0:
        return (f"radio.loss_prob={radio.loss_prob:g}: too many frames lost; lower it, or raise protocol.organize_timeout_s="
                f"{proto.organize_timeout_s:g} or protocol.max_retries={proto.max_retries}")
    return (f"the answers collided every time; raise protocol.organize_timeout_s={proto.organize_timeout_s:g} "
            f"or protocol.max_retries={proto.max_retries}")


def can_join(connected_user: int | None, distance_m: float, available_radius_m: float) -> bool:
    """Table 1 (seed 000): connection is checked first — a robot connected to another user
    cannot join and never checks distance; otherwise it can join inside the available region."""
    if connected_user is not None:
        return False
    return distance_m <= available_radius_m


def select_joiners(available: dict[int, float], required: int) -> list[int]:
    """Table 2 (seed 000): ``available`` maps robot id -> estimated distance to the master.
    If fewer are required than can join, take the closest; otherwise take all. The selected
    robots come closest first (ties by id), the order of their member numbers: the closest is
    member 1, the next member 2, and so on (chosen: seed 000 says only that each robot identifies
    its neighbours from its number and the total; the master knows its candidates by their RSSI
    distance alone, and the low numbers hold the slots nearest the master)."""
    ranked = sorted(available, key=lambda rid: (available[rid], rid))
    return ranked[:required] if required < len(ranked) else ranked


@dataclass
class OrganizeResult:
    members: dict[int, int] = field(default_factory=dict)  # member number -> node id
    retries: int = 0
    elapsed_s: float = 0.0
    candidates: list[int] = field(default_factory=list)
    unavailable: list[int] = field(default_factory=list)
    not_selected: list[int] = field(default_factory=list)
    complete: bool = False


class JoinManager:
    """Both roles of the join protocol on one robot."""

    def __init__(self, node: Station):
        self.node = node
        self._expect: set[int] = set()
        self._got: dict[int, Frame] = {}
        self._kinds: frozenset[str] = frozenset()  # the answers the current step waits for (_on_response)
        self._all_in = None
        self._deadline = float("inf")  # the organize deadline (protocol.organize_timeout_s after it started)
        self.opened_s = 0.0  # when the open slots opened (RUTA's t_j): the organize's start; a refill sets it
        self._bid_seq = 0  # the current slot announcement (ruta_decentralized): bids of other ones are stale
        self._bid_at: dict[int, float] = {}  # bidder -> when its bid for the current announcement arrived
        self._auction_won: dict[int, int] = {}  # the last auction's outcome: member number -> robot id
        self._query_range_m: float | None = None  # candidate side: its RSSI range estimate of the joining query
        self.replans = 0  # master: member updates sent by replan_by_fixes (the slots re-planned after the ring's first round)
        self._replan_due = False  # master: it organized its swarm itself (Table 2's blind numbers): replan_by_fixes once
        node.on(msg.SCAN, self._on_scan)
        node.on(msg.JOIN_QUERY, self._on_query)
        node.on(msg.STATUS_QUERY, self._on_query)
        node.on(msg.JOIN_NOTIFY, self._on_notify)
        node.on(msg.NON_PARTICIPATE, self._on_non_participate)
        node.on(msg.SLOT_ANNOUNCE, self._on_announce)
        node.on(msg.BID, self._on_bid)
        for kind in (msg.SCAN_RESPONSE, msg.JOIN_ANSWER, msg.STATUS_ANSWER, msg.NOTIFY_ACK):
            node.on(kind, self._on_response)

    # -- master side ----------------------------------------------------------------------------
    def _on_response(self, frame: Frame) -> None:
        """An answer to this master: kept only when it is of the kind the current step waits for
        (``self._kinds``) — a scan response that arrives late, during the queries, is not a joining
        answer, nor an acknowledgement — from a robot it waits for (any robot, in the scan window)."""
        if frame.dst != self.node.node_id or frame.kind not in self._kinds:
            return
        if frame.kind == msg.SCAN_RESPONSE or frame.src in self._expect:
            self._got[frame.src] = frame
        if self._expect and self._expect <= set(self._got) and self._all_in is not None and not self._all_in.triggered:
            self._all_in.succeed()

    def _collect(self, expect: set[int], timeout_s: float, kinds: tuple[str, ...]):
        """Wait until every robot in ``expect`` answered with a frame of one of ``kinds``, the
        timeout passes or the organize deadline comes (SimPy)."""
        clock = self.node.clock
        self._kinds = frozenset(kinds)
        self._expect = set(expect)
        self._all_in = clock.event()
        yield clock.any_of([self._all_in, clock.timeout(self._left(timeout_s))])
        self._expect = set()

    def _left(self, wait_s: float) -> float:
        """``wait_s``, cut at the organize deadline."""
        return max(0.0, min(wait_s, self._deadline - self.node.clock.now))

    def _may_retry(self, retries: int, reserve_s: float = 0.0) -> bool:
        """A step may be tried again: within its ``protocol.max_retries`` and before the deadline,
        leaving ``reserve_s`` for the steps after it."""
        return retries < self.node.cfg.protocol.max_retries and self.node.clock.now + reserve_s < self._deadline

    def organize(self, required: int, pan: int, result: OrganizeResult, mode_of: Callable[[], str], spares: int = 0):
        """Master-side organize process (SimPy generator), the steps of seed 000 Fig. 8; fills
        ``result``. The formation is the master's: the shape its user chose (its own
        ``swarm`` configuration), laid out for the driving mode ``mode_of()`` once the members are
        selected; the joining notifications carry it to the members. ``spares`` (``swarm.spares``,
        chosen): up to this many available robots beyond the ``required`` join too, on the shape's
        next slots (the scans retry for the required ones only); they walk with the swarm, so a lost
        member's place is filled from inside it (middleware/recovery.py)."""
        node = self.node
        t0 = node.clock.now
        self.opened_s = t0
        self.replan_after_first_round()
        self._deadline = t0 + node.cfg.protocol.organize_timeout_s  # the whole protocol ends by then
        # the master forms the PAN from now on: it listens there for the acknowledgements of robots
        # that already moved to it (a retried joining notification), its own PAN's frames
        node.swarm_pan = pan
        node.pans = frozenset({PAN_WAITING, pan})
        candidates, answers = yield from self._scan_and_query(required, result)  # steps 1-2
        result.candidates = sorted(candidates)
        chosen, n_available = yield from self._choose(candidates, answers, list(range(1, required + spares + 1)), result)
        members = {0: node.node_id}  # step 3: the member table, the master is member 0; the filled slots
        members.update({i + 1: chosen[m] for i, m in enumerate(sorted(chosen))})  # numbered 1..n (no gap)
        mode = mode_of()
        formation = table_for_members(node.cfg.swarm, members, mode, leading_user(node.cfg))
        node.know.lf_members = self._lf_members(members, answers)
        yield from self._notify(members, pan, formation, mode, result)  # step 3
        # 4. the master drives its swarm on the new PAN ID
        node.enter_swarm("master", pan, 0, dict(members), formation, mode)
        result.members = members
        result.elapsed_s = node.clock.now - t0
        joiners = len(members) - 1
        result.complete = joiners >= min(required, n_available) and joiners > 0

    def _scan_and_query(self, required: int, result: OrganizeResult, max_scans: int | None = None,
                        region_m: float | None = None):
        """Steps 1-2: scan, then query the new candidates. While fewer robots are available than
        the user requires, the master has not received every response it expects (a scan response
        may have been lost, or collided: seed 000 §4.5, "simultaneous message reception or message
        corruption") and retries the scan (§3.4: "whenever the master has not received every
        expected response, it retries that step"), within ``protocol.max_retries`` scans and the
        organize deadline, less the time the notifications need (:data:`NOTIFY_RESERVE_TRIES`
        tries of each). Returns the candidates (robot id -> estimated distance) and their answers
        (robot id -> frame). ``region_m``: a refill's available region (:meth:`~.recovery.RecoveryManager.refill_region_m`), which
        the joining query announces; None: the organize's, ``protocol.join_radius_m``."""
        timeout = self.node.cfg.protocol.response_timeout_s
        candidates: dict[int, float] = {}
        answers: dict[int, Frame] = {}
        scans = 0
        while True:
            new = yield from self._scan(candidates, region_m)
            candidates.update(new)
            yield from self._query(set(new), answers, result, region_m)
            n_available = sum(1 for f in answers.values() if f.payload["available"])
            reserve = timeout * (max(required, len(answers)) + NOTIFY_RESERVE_TRIES)
            if n_available >= required or not self._may_retry(scans, reserve) or (max_scans is not None and scans + 1 >= max_scans):
                return candidates, answers
            scans += 1
            result.retries += 1

    def _scan(self, known: dict[int, float], region_m: float | None = None):
        """Step 1: broadcast the scan (listing the robots already heard, which stay silent) and
        estimate the joining candidates among the new responders (seed 000 §3.4): those whose
        response's RSSI puts them within :data:`CANDIDATE_REACH` times the available region (each
        candidate then checks the region itself, Table 1) — robot id -> estimated distance."""
        node = self.node
        self._got = {}
        self._kinds = frozenset({msg.SCAN_RESPONSE})
        node.send(msg.SCAN, pan=PAN_WAITING, known=sorted(known))
        yield node.clock.timeout(self._left(node.cfg.protocol.scan_window_s))
        reach = CANDIDATE_REACH * (region_m or node.cfg.protocol.join_radius_m)
        return {rid: f.rx_distance_est_m for rid, f in self._got.items() if rid not in known and f.rx_distance_est_m <= reach}

    def _query(self, pending: set[int], answers: dict[int, Frame], result: OrganizeResult, region_m: float | None = None):
        """Step 2: the joining query to the ``pending`` candidates until each answered (Table 1
        is theirs to apply); missing answers → query again (a retry, within ``max_retries`` of this
        step and the deadline)."""
        node = self.node
        cfg = node.cfg.protocol
        self._got = {}
        tries = 0
        # ruta_centralized: the query asks for the candidates' status (seed 003 Algorithm 1's input)
        kind = msg.STATUS_QUERY if node.cfg.swarm.assignment == "ruta_centralized" else msg.JOIN_QUERY
        region = {} if region_m is None else {"region_m": region_m}  # a refill's region travels in its query
        while pending:
            node.send(kind, pan=PAN_WAITING, candidates=sorted(pending), **region)
            yield from self._collect(pending, cfg.response_timeout_s, (msg.JOIN_ANSWER, msg.STATUS_ANSWER))
            answers.update({rid: self._got[rid] for rid in pending if rid in self._got})
            pending -= set(answers)
            if pending:
                if not self._may_retry(tries):
                    return
                tries += 1
                result.retries += 1

    def _choose(self, candidates: dict[int, float], answers: dict[int, Frame], open_members: list[int],
                result: OrganizeResult):
        """Step 3's selection for the ``open_members`` (SimPy generator): the auction
        (``ruta_decentralized``), then :meth:`_select`; returns what :meth:`_select` returns."""
        yield from self._auction(candidates, answers, open_members)
        return self._select(candidates, answers, open_members, result)

    def _select(self, candidates: dict[int, float], answers: dict[int, Frame], open_members: list[int],
                result: OrganizeResult) -> tuple[dict[int, int], int]:
        """Step 3, the selection by ``swarm.assignment`` (:mod:`.assignment`) for the open member
        numbers: ``(member number -> robot id for the open members filled, how many robots could
        join)``; fills ``result.unavailable`` and ``result.not_selected``. ``closest``: Table 2, the
        closest available robots fill the lowest open numbers; ``ruta_centralized``: Algorithm 1 on
        the status answers; ``ruta_decentralized``: the auction's winners (:meth:`_auction`)."""
        node = self.node
        available = {rid: candidates[rid] for rid, f in answers.items() if f.payload["available"]}
        result.unavailable = sorted(set(answers) - set(available))
        strategy = node.cfg.swarm.assignment
        if strategy == "closest":
            chosen = assignment.select_closest(select_joiners(available, len(open_members)), open_members)
        elif strategy == "ruta_centralized":
            reports = {rid: assignment.status_from_payload(rid, answers[rid].payload) for rid in available
                       if answers[rid].kind == msg.STATUS_ANSWER}
            ranges = {rid: assignment.mean_range(available[rid], answers[rid].payload["distance_m"]) for rid in reports}
            chosen = assignment.select_centralized(reports, ranges, self._slot_geometry(open_members), open_members,
                                                   node.clock.now - self.opened_s, node.cfg)
        else:
            chosen = {m: rid for m, rid in self._auction_won.items() if m in open_members and rid in available}
        result.not_selected = sorted(set(answers) - set(chosen.values()))
        return chosen, len(available)

    def _slot_geometry(self, open_members: list[int]) -> dict[int, tuple[float, int]]:
        """The open slots' geometry (:func:`assignment.slot_geometry`): the master's own formation
        once it drives one that has every open slot (a refill of a lost member's slot), else the
        configured shape with members up to the highest open number (a refill may open a slot the
        current, shrunk table no longer has)."""
        node = self.node
        formation = node.formation
        if node.state != "master" or formation is None or not set(open_members) <= set(formation.links):
            formation = assignment.slots_formation(node.cfg.swarm, open_members)
        geometry = assignment.slot_geometry(formation)
        return {m: geometry[m] for m in open_members}

    def _auction(self, candidates: dict[int, float], answers: dict[int, Frame], open_members: list[int]):
        """``ruta_decentralized``: seed 003 Algorithm 2 for the open slots (SimPy generator; nothing,
        and no event, with the other assignments). The master announces the open slots to the free
        available candidates; each bids its own utilities; the round closes after t_out
        (``ruta.bid_timeout_s``) or once every listed bidder answered; the fittest bid of each slot
        wins (:func:`assignment.close_round`). Slots left open are announced again to the robots
        still free while a listed bidder's bid was missing, up to ``ruta.max_announcements`` and the
        organize deadline. Fills ``self._auction_won``."""
        node = self.node
        self._auction_won = {}
        if node.cfg.swarm.assignment != "ruta_decentralized":
            return
        rc = node.cfg.ruta
        free = sorted(rid for rid, f in answers.items() if f.payload["available"])
        open_ = sorted(open_members)
        geometry = self._slot_geometry(open_)
        attempt = 0
        while open_ and free and attempt < rc.max_announcements and self._may_retry(0):
            attempt += 1
            self._bid_seq += 1
            self._bid_at = {}
            announced = node.clock.now
            node.send(msg.SLOT_ANNOUNCE, pan=PAN_WAITING, seq=self._bid_seq, attempt=attempt,
                      slots=assignment.announce_slots(geometry, open_, announced - self.opened_s), bidders=list(free))
            self._got = {}
            yield from self._collect(set(free), rc.bid_timeout_s, (msg.BID,))
            bids = [Bid(rid, str(m), u, self._bid_at[rid]) for rid, f in self._got.items()
                    for m, u in f.payload["utilities"]]
            won = assignment.close_round(bids, open_, announced, rc.bid_timeout_s, attempt, rc.max_announcements)
            self._auction_won.update(won)
            missing = set(free) - set(self._got)
            open_ = [m for m in open_ if m not in won]
            free = [rid for rid in free if rid not in won.values()]
            if not missing:
                return  # every free robot bid: a slot still open has no robot able to take it

    def replan_after_first_round(self) -> None:
        """Master: its table is its own plan (its organize, Table 2's blind numbers; a succession's table from
        its own knowledge): :meth:`replan_by_fixes` re-plans it once its ring has gone round."""
        self._replan_due = True

    def replan_by_fixes(self) -> None:
        """Master, once its IR token ring has gone round after organizing (chosen, not in the papers):
        which member takes which slot, re-planned by what it measured. Step 3 numbers the members
        closest first by the RSSI range of their answers (bearing unknown), so from a scattered start
        a large swarm's robots cross each other on the way to their slots; after one round the master
        has its own IR fix of every member in its IR reach (the RSSI range of the others' ring frames):
        the members take the slots by the least total distance it estimates
        (:meth:`~.recovery.RecoveryManager.nearest_slots`, the same rule as a refill), and it
        broadcasts the member update with the new member table when that differs. From
        ``protocol.replan_min_slaves`` slaves on (the default 1 + 4 keeps its numbering, frame for frame).
        Only after the master's own organize or a succession (:meth:`replan_after_first_round`): a robot
        handed the master's role over restarts the ring too, but its table is its predecessor's, renumbered
        already, re-rooted at it (Table 3) and re-planned from its place when the old master leaves
        (:meth:`~.recovery.RecoveryManager.removal_plan`); planned again from where it stood beside its old
        slot, before it drove to its place, the rear members of a large wedge crossed the formation (the
        master's IR fault, 1 + 8, seeds 1300-1319: re-formed 7 of 20; docs/faults.md)."""
        node = self.node
        know = node.know
        formation = node.formation
        due, self._replan_due = self._replan_due, False
        if not due:
            return  # a master that took its role over (a handover, a succession) keeps the table it took
        if node.state != "master" or formation is None or know.total_members - 1 < node.cfg.protocol.replan_min_slaves:
            return
        recovery = node.recovery
        members = dict(know.members)
        table = recovery.nearest_slots(members, formation, building=True)
        if table == members:
            return
        self.replans += 1
        # the neighbour table stays; only the numbers move: the recovery manager's commit and its
        # acknowledged member update (middleware/recovery.py), as after a removal
        recovery.reassign(table, formation)

    def refill(self, open_members: list[int], pan: int, members: dict[int, int], mode: str, result: OrganizeResult,
               region_m: float | None = None):
        """Recruit waiting robots into the ``open_members`` of an organized swarm (SimPy generator;
        docs/faults.md): the same pipeline as organizing — scan, query, :meth:`_select`, notify — on the
        common PAN, within ``protocol.organize_timeout_s``. ``members`` is the master's member
        table now. Returns the new member table (the joiners notified in it), or None when no robot
        was recruited. The formation for the new size is the standard one of the master's shape and
        ``mode`` (:func:`~.formation.formation_for_mode`), which the joining notification carries.
        ``region_m``: the refill's available region, announced in its joining query
        (:meth:`~.recovery.RecoveryManager.refill_region_m`); None: ``protocol.join_radius_m``."""
        node = self.node
        t0 = node.clock.now
        self._deadline = t0 + node.cfg.protocol.organize_timeout_s
        node.pans = frozenset({PAN_WAITING, pan})  # hear the waiting robots' answers beside the swarm's frames
        try:
            candidates, answers = yield from self._scan_and_query(len(open_members), result, REFILL_SCANS, region_m)
            result.candidates = sorted(candidates)
            self.opened_s = t0  # the open slots' subtasks were announced now (RUTA's priority counts from here)
            picked, _ = yield from self._choose(candidates, answers, open_members, result)
            if not picked:
                return None
            # a member that fell back to waiting (its status timeout: it missed its master's frames, as after a missed
            # master change under loss) answers the query as a waiting robot: it takes its own number back and the open
            # one stays open for the next scan (chosen: given the open number too, it stood twice in the table and
            # steered by the other number's references, 2 m off for 20 s; the master's IR fault at loss 0.3, seed 115)
            held = {n: m for m, n in members.items() if m != 0}
            picked = {held.get(n, m): n for m, n in picked.items()}
            new = dict(members)
            new.update(picked)
            new = dict(sorted(new.items()))
            node.know.lf_members = node.know.lf_members | self._lf_members(picked, answers)
            formation = table_for_members(node.cfg.swarm, new, mode, leading_user(node.cfg))
            yield from self._notify(new, pan, formation, mode, result, joiners=set(picked.values()))
            result.members = new
            result.elapsed_s = node.clock.now - t0
            return new
        finally:
            if node.state == "master":
                node.pans = frozenset({pan})

    def _lf_members(self, members: dict[int, int], answers: dict[int, Frame]) -> frozenset[int]:
        """The robots of ``members`` whose bodies carry LF antennas (may be master), as their joining
        answers said (the joining answer's flag; a status answer's sensor mask), the master itself
        by its own body."""
        out = {self.node.node_id} if body_can_be_master(self.node) else set()
        for rid in members.values():
            f = answers.get(rid)
            if f is None:
                continue
            if f.kind == msg.STATUS_ANSWER:
                if f.payload["sensors"] & assignment.SENSOR_BITS["LF"]:
                    out.add(rid)
            elif f.payload.get("lf"):
                out.add(rid)
        return frozenset(out)

    def _notify(self, members: dict[int, int], pan: int, formation: Formation, mode: str, result: OrganizeResult,
                joiners: set[int] | None = None):
        """Step 3, the result: a joining notification to each selected robot — the new PAN ID, its
        member number, the total number of members and the member table (seed 000 §3.4: "from
        which each robot identifies its neighbours"), and (chosen) the neighbour table with its
        reference offsets and the driving mode: all a member knows of the swarm comes in this
        frame — a non-participating notification to the others, one robot after another, each
        acknowledged; a missing acknowledgement → notify again (a retry). ``joiners``: only these
        members are notified (a refill; the others are members already)."""
        node = self.node
        cfg = node.cfg.protocol
        links = formation.links_payload()
        notify = {rid: msg.JOIN_NOTIFY for m, rid in members.items() if m != 0 and (joiners is None or rid in joiners)}
        notify.update({rid: msg.NON_PARTICIPATE for rid in result.not_selected})
        for rid in sorted(notify, key=lambda r: (notify[r] != msg.JOIN_NOTIFY, r)):
            if not self._may_retry(0):
                return  # the deadline came: the robots not notified stay waiting
            attempt = 0
            while True:
                self._got = {}
                pans = [PAN_WAITING] if attempt == 0 or notify[rid] != msg.JOIN_NOTIFY else [PAN_WAITING, pan]
                for p in pans:  # a robot whose ack was lost has already moved to the new PAN
                    if notify[rid] == msg.JOIN_NOTIFY:
                        member = next(m for m, n in members.items() if n == rid)
                        node.send(msg.JOIN_NOTIFY, dst=rid, pan=p, new_pan=pan, member=member, total=len(members),
                                  members=dict(members), shape=formation.shape, mode=mode, links=links,
                                  lf=sorted(n for n in members.values() if n in node.know.lf_members))
                    else:
                        node.send(msg.NON_PARTICIPATE, dst=rid, pan=p)
                yield from self._collect({rid}, cfg.response_timeout_s, (msg.NOTIFY_ACK,))
                if rid in self._got or not self._may_retry(attempt):
                    break
                result.retries += 1
                attempt += 1

    # -- candidate side -------------------------------------------------------------------------
    def _on_scan(self, frame: Frame) -> None:
        if self.node.state in SCAN_ANSWERING_STATES and self.node.node_id not in frame.payload.get("known", ()):
            self.node.send(msg.SCAN_RESPONSE, dst=frame.src, pan=PAN_WAITING)

    def _on_query(self, frame: Frame) -> None:
        node = self.node
        if node.node_id not in frame.payload["candidates"]:
            return
        if node.state not in SCAN_ANSWERING_STATES and node.connected_user is None:
            return  # joined another swarm meanwhile: it no longer hears the common PAN anyway
        region = frame.payload.get("region_m", node.cfg.protocol.join_radius_m)  # a refill announces its own
        ok = can_join(node.connected_user, frame.rx_distance_est_m, region)
        if frame.kind == msg.JOIN_QUERY and getattr(node, "failed_sensors", ()):
            ok = False  # chosen: Table 2 knows no sensors, so a robot that found one of its own broken declines
            # (ruta_centralized asks for the status instead, which then speaks for it)
        self._query_range_m = frame.rx_distance_est_m
        if frame.kind == msg.STATUS_QUERY:  # the master asks for the status (ruta_centralized)
            node.send(msg.STATUS_ANSWER, dst=frame.src, pan=PAN_WAITING,
                      **assignment.status_payload(assignment.own_status(node), ok, frame.rx_distance_est_m))
        else:
            node.send(msg.JOIN_ANSWER, dst=frame.src, pan=PAN_WAITING, available=ok, lf=body_can_be_master(node))

    def _on_announce(self, frame: Frame) -> None:
        """Algorithm 2 on a free candidate: its own utility for each announced slot, bid back to the
        announcer (an empty bid: it can take none), ``ruta.bid_slot_s`` times its place in the
        announcement's bidder list after it processed the announcement. The range is the mean of its RSSI estimates of the
        joining query and of this announcement (:func:`assignment.mean_range`)."""
        node = self.node
        p = frame.payload
        if node.state != "waiting" or node.node_id not in p["bidders"]:
            return
        r = assignment.mean_range(self._query_range_m, frame.rx_distance_est_m)
        utilities = assignment.own_utilities(assignment.own_status(node), r, p["slots"], node.cfg.ruta)
        delay = p["bidders"].index(node.node_id) * node.cfg.ruta.bid_slot_s  # its turn in the listed order
        node.later(delay, self._send_bid, frame.src, p["seq"], utilities)

    def _send_bid(self, master: int, seq: int, utilities: list) -> None:
        self.node.send(msg.BID, dst=master, pan=PAN_WAITING, seq=seq, utilities=utilities)

    def _on_bid(self, frame: Frame) -> None:
        if frame.dst != self.node.node_id or frame.payload["seq"] != self._bid_seq or frame.src not in self._expect:
            return  # another master's, a stale announcement's, or after the round closed
        self._bid_at.setdefault(frame.src, self.node.clock.now)
        self._on_response(frame)

    def _on_notify(self, frame: Frame) -> None:
        node = self.node
        p = frame.payload
        if node.state == "waiting":  # the member and neighbour tables and the mode: all from the frame
            members = {int(m): n for m, n in p["members"].items()}
            node.enter_swarm("slave", p["new_pan"], p["member"], members,
                             Formation.from_links_payload(p["shape"], p["links"]), p["mode"])
            node.know.lf_members = frozenset(p["lf"])
            node.became_slave.emit(p["new_pan"])
        if node.swarm_pan == p["new_pan"]:  # (re-)acknowledge, also when the first ack was lost
            node.send(msg.NOTIFY_ACK, dst=frame.src, pan=frame.pan)

    def _on_non_participate(self, frame: Frame) -> None:
        if self.node.state == "waiting":
            self.node.send(msg.NOTIFY_ACK, dst=frame.src, pan=PAN_WAITING)
