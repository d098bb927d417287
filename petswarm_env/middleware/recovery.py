"""Losing and recruiting members while organized (seed 003: a failing robot's task is
taken over, robots are added at runtime).

Both sides run on one robot's station, like the other managers:

* **removal** (master): the token ring declares a member lost (:mod:`.token_ring`: silent for
  ``protocol.lost_after_rounds`` rounds), or a member whose sensor failed asks to be replaced (its
  bid request, seed 003 Algorithm 2 step 5: :meth:`RecoveryManager.sensor_failed`). The master
  removes it from its tables; the formation is the standard one of the master's shape for one
  member less (:func:`~.formation.formation_for_mode`; chosen: every member number stays in 1..n,
  so every rule that numbers the members — the ring order, the neighbour tables, Table 3 — works
  as before), and the remaining members take its slots by the least total move the master
  estimates from its IR fixes and RSSI ranges (:meth:`RecoveryManager.nearest_slots`: the robots
  near a slot fill it, so the loss moves the fewest metres; a long move counts its square too,
  :func:`~.matching.move_cost`, so no robot is sent across the formation). It broadcasts the
  *member update* frame — new total, member table, neighbour table,
  mode (:mod:`.messages`) — until every remaining member acknowledged it (a lost update or a lost
  acknowledgement → broadcast again, within ``protocol.max_retries``; a member that never heard
  it keeps its old tables until the next update, and if it was the one renumbered, the ring does
  not reach it and it is declared lost in turn). The refill starts at once, beside the update's
  retries (under loss they may take a second or more; the refill's own update supersedes it).
* **refill** (master): right after a removal, and every ``protocol.rescan_period_s`` while a slot
  is open (the tables hold fewer than ``swarm.num_slaves`` slaves: a member lost, or organized
  short), the master recruits waiting robots through the join pipeline of seed 000 Fig. 8 —
  scan, query, :meth:`~.join.JoinManager._select` (the assignment's one seam: Table 2's closest
  fills the lowest open numbers), notify (:meth:`~.join.JoinManager.refill`) — into the open
  member numbers, then broadcasts the member update with the new tables. Robots switched on
  mid-episode (``arrivals``) are found by the same periodic scan.
  While the master stands, the refill's joining query announces a region that reaches the open
  slots (:meth:`RecoveryManager.refill_region_m`): a robot left waiting at the rim of the organize's
  region is within reach of a slot a loss opens.
* **astray** (master): a member that lost its swarm — the RSSI range of its ring frames puts it
  farther from the master than both its slot's distance plus :data:`ASTRAY_M` and
  :data:`ASTRAY_REACHES` times the IR's reach (``ir.max_range_m``: nobody can give it a fix), and the master has no fresh IR fix of it — for
  :data:`ASTRAY_S` in a row (:meth:`RecoveryManager.check_astray`, at each periodic scan) is removed like a lost member
  and its slot refilled: it still answers the ring by radio (30 m), so the ring alone would keep it
  a member, driving with no fix, until it left radio range (a mixed pool's slow r1 lost its
  swarm at the start of the walk and drifted 14-30 m away). It hears the member update and goes back to
  waiting, where the periodic scan recruits it again once it is inside the available region.
* **no robot to recruit**: the formation stays at the smaller size the removal planned (the
  remaining members re-planned, its tables sent), and the periodic scan keeps looking.
* **members** apply an update they hear (acknowledging every copy); a robot that finds itself
  out of the member table leaves the swarm (back to waiting).

The master reports what changed upward (``members_changed``: ``lost`` or ``joined`` and the
robots), for the user's swarm and the experimenter.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from petswarm_env.comms.radio import Frame
from petswarm_env.middleware import assignment, ruta
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation, formation_for_mode, leading_user, table_for_members
from petswarm_env.middleware.knowledge import FRESH_IR_S
from petswarm_env.middleware.join import JoinManager, OrganizeResult
from petswarm_env.middleware.leaving import Leaving, lane_near_m, segment_distance
from petswarm_env.middleware.matching import PAST_MASTER_M, least_total, move_cost
from petswarm_env.middleware.replan import STANDING_MPS, Replanning
from petswarm_env.middleware.station import Station


# chosen: a member whose RSSI range differs from its slot's distance from the master by more than this is not at
# its slot (the RSSI range is off by ~10 % at 1 dB shadowing: 0.2 m at 2 m)
OFF_SLOT_M = 0.75
# chosen: a member whose RSSI range exceeds its slot's distance from the master by this much, and the IR's reach,
# with no fresh IR fix of it, for ASTRAY_S in a row, has lost its swarm and is removed (the rejoin timeout: its last
# fix stays fresh knowledge.FRESH_IR_S, then ASTRAY_S, seen at a periodic scan: at most 2 + 3 + 1 = 6 s). 1.5 m is > 6 σ of the RSSI range's error at 3 m (~10 % at
# 1 dB shadowing), and the scattered start stands within 2.25 m of the master, inside the 3 m IR reach
ASTRAY_M = 1.5
ASTRAY_S = 3.0
# chosen: ... and beyond 1.5 times the IR's reach (4.5 m at 3 m). At 1 reach a swarm re-forming after a master change
# lost members that were only lagging (mode_change, seeds 0-4: members removed in 4 of 5 episodes, the whole swarm
# in one); at 2 reaches a mixed pool's slave stayed >= 5 m off its slot in 2 of 20 runs
# (python -m petswarm.experiments.measure_mixed --seeds 0-19 --variants plain --assignments closest: 20/20 at 1.5)
ASTRAY_REACHES = 1.5


class RecoveryManager(Leaving, Replanning):
    """Both sides of member removal and refill on one robot."""

    def __init__(self, node: Station, join: JoinManager, forget: Callable[[int], None], leave: Callable[[], None]):
        self.node = node
        self.join = join
        self._forget = forget  # the ring's count of a robot starts over (TokenRing.forget)
        self._leave = leave  # back to waiting (SequenceManager.leave_swarm)
        self.last_seq = -1
        self._last_src: int | None = None  # the master whose update ``last_seq`` numbers (each master counts its own)
        self._sent_seq = -1
        self._seq = -1
        self._acks: set[int] = set()
        self._needed: set[int] = set()
        self._event = None
        self._lost: list[int] = []
        self._leaving_master: int | None = None  # master: the robot that handed its user over to it, asking to leave (_remove)
        self.busy = False
        self.mirrored = False  # master: the last removal chose the mirror image of the standard table
        self.update_retries = 0  # master: member-update broadcasts repeated for a missing acknowledgement
        self.refills: list[OrganizeResult] = []
        self._organized_slaves = 0  # master: the slaves it drove with when its periodic scan started (places)
        self.pool_heard = 0  # master: the joining candidates its organize's scans heard (places; set by the swarm)
        self.astray: list[tuple[float, int]] = []  # master: (time, node id) of each member removed as astray
        self.replans: list[tuple[float, bool]] = []  # master: (time, mirrored) of each renumbering while building (replan_building)
        self._astray_since: dict[int, float] = {}  # master: member -> since when its range has said astray
        self.bid_requests: list[tuple[float, str]] = []  # member: (time, the part that failed) of each bid request started
        self._request_seq = -1
        self._request_acked = None
        self._asked_out = False  # member: a bid request of ours is pending (its own fault, not a loss)
        self.self_removals = 0  # member: times it left for its own fault without the member update (_request_bids)
        self._was_master = False  # member: it handed its user over for a part it found broken (after_handover)
        self.cannot_lead: Callable[[str], None] | None = None  # master: the node's seam to hand its user over
        # (start, vx, vy, distance): the move out of the formation (_plan_clear_out)
        self.clear_out: tuple[float, float, float, float] | None = None
        self._cleared = (0.0, 0.0)  # (time, sideways metres the wheels counted) of that move
        self._clear_dir = (0.0, 1.0)  # the body-frame direction that move's progress is counted along (leaving.py)
        self.pace_until_m = math.inf  # the sideways metres of that move it keeps the swarm's pace for
        self.back_after_m = math.inf  # ... and beyond which it drives its along-walk speed again (an old master: back)
        node.on(msg.MEMBER_UPDATE, self._on_update)
        node.on(msg.MEMBER_UPDATE_ACK, self._on_ack)
        node.on(msg.BID_REQUEST, self._on_bid_request)
        node.on(msg.BID_REQUEST_ACK, self._on_bid_request_ack)

    # -- master side ----------------------------------------------------------------------------
    def member_lost(self, node_id: int) -> None:
        """The ring declared ``node_id`` lost: remove it (then refill), one loss after another. Only the master its own
        table names: a master that committed a handover's table (Table 3, modes.py) is still "master" until the new one
        acknowledges the handover, and under loss that takes retries; its ring, no longer followed, declared a member
        lost and its update took that member out of the new master's swarm (chosen; loss 0.3, the master's IR fault,
        seed 115)."""
        node = self.node
        if node.state != "master" or node.member_node(0) != node.node_id or node_id in self._lost:
            return
        self._lost.append(node_id)
        if not self.busy:  # busy from now on, not from when the process first runs: one recovery at a time
            self.busy = True
            node.clock.process(self._recover())

    def open_members(self) -> list[int]:
        """The member numbers the swarm's places leave open: after the last member, up to :attr:`places`
        (``swarm.num_slaves``, its user's request, plus the spare places its organize filled)."""
        return list(range(self.node.know.total_members, self.places + 1))

    @property
    def places(self) -> int:
        """The slave places the master keeps filled: ``swarm.num_slaves`` (the master's own configuration:
        its user's request) and, of the ``swarm.spares`` beyond it, as many as robots its organize heard
        beyond that count (:attr:`pool_heard`: the joining candidates its scans found, seed 000 Fig. 8 step 1,
        whether they joined or declined by Table 1) or recruited (chosen: a spare place exists where the
        pool had a robot to spare when the swarm organized — a spare at the rim of the available region
        declines by its own RSSI estimate at one query and joins at a later scan; a pool of exactly the
        user's count keeps no spare place open, so its full swarm runs no periodic scan, as with
        ``swarm.spares`` 0)."""
        swarm = self.node.cfg.swarm
        return min(swarm.num_slaves + swarm.spares, max(swarm.num_slaves, self._organized_slaves, self.pool_heard))

    def maintain(self, pan: int):
        """Master process: the periodic scan while organized on ``pan`` and a slot is open."""
        node = self.node
        clock = node.clock
        period = node.cfg.protocol.rescan_period_s
        self._organized_slaves = node.know.total_members - 1  # the slaves its organize (or takeover) left it with
        while True:
            yield clock.timeout(period)
            if node.state != "master" or node.swarm_pan != pan:
                return
            self.check_astray()
            self.replan_building()
            if not self.busy and self.open_members():
                self.busy = True
                yield from self._refill()
                self.busy = False
                if self._lost:
                    self.busy = True
                    clock.process(self._recover())

    def check_astray(self) -> None:
        """Master: remove every member astray for :data:`ASTRAY_S` (module docstring). What it reads
        is its own: the RSSI range of each member's latest ring frame to it (within ``FRESH_IR_S``),
        its IR fixes, its formation."""
        node = self.node
        know = node.know
        ring = getattr(node, "ring", None)
        if node.formation is None or ring is None:
            return
        now = node.clock.now
        slots = node.formation.slot_positions()
        reach = node.cfg.ir.max_range_m
        seen_ir = {n for n, fix in know.ir.items() if now - fix.time_s <= FRESH_IR_S}
        astray = set()
        for m, n in know.members.items():
            if m == 0 or m >= len(slots) or n in seen_ir or now - ring.heard.get(n, -math.inf) > FRESH_IR_S:
                continue
            r = ring.slot_range_m.get(n, math.nan)
            if r > max(math.hypot(*slots[m]) + ASTRAY_M, ASTRAY_REACHES * reach):
                astray.add(n)
        self._astray_since = {n: self._astray_since.get(n, now) for n in astray}
        for n, since in sorted(self._astray_since.items()):
            if now - since >= ASTRAY_S - 1e-9 and n not in self._lost:
                self.astray.append((now, n))
                del self._astray_since[n]
                self.member_lost(n)

    def _recover(self):
        """Remove the lost members one after another, then refill (SimPy process; ``busy`` was set
        when it was started, so no refill of the periodic scan or second recovery runs beside it:
        they would share the join manager's answers)."""
        self.busy = True
        while self._lost and self.node.state == "master" and self.node.member_node(0) == self.node.node_id:
            yield from self._remove(self._lost.pop(0))
            if not self._lost and self.open_members():
                yield from self._refill()
        self.busy = False

    def _remove(self, node_id: int):
        node = self.node
        know = node.know
        members = dict(know.members)
        lost = know.number_of(node_id)
        if lost is None or lost == 0:
            return
        # the robot that handed its user over to this master leaves for its fault (its bid request): the master
        # will stand where that robot stood, on its user's line (the handover's table re-rooted it here, beside it)
        held = node.formation.slot_positions() if node.formation is not None else None
        shift = None
        if node_id == self._leaving_master and held is not None and lost < len(held):
            shift = (float(held[lost][0]), float(held[lost][1]))
        self._leaving_master = None
        del members[lost]
        try:
            formation = formation_for_mode(node.cfg.swarm, len(members), know.mode, leading_user(node.cfg))
        except ValueError:  # a custom table fixes its size: the loss is detected, the tables stay
            return
        members, formation, self.mirrored = self.removal_plan(members, formation, shift)
        self._commit(members, formation)
        self._forget(node_id)
        node.members_changed.emit("lost", [node_id])
        # announced beside the refill that follows (chosen: the refill's scan does not wait for every
        # acknowledgement; its own update, once a robot joined, supersedes this one)
        node.clock.process(self._announce(members, formation))
        yield node.clock.timeout(0.0)

    def removal_plan(self, members: dict[int, int], formation: Formation, shift: tuple[float, float] | None = None,
                     building: bool = False) -> tuple[dict[int, int], Formation, bool]:
        """The remaining members (``members``, the lost one out) on ``formation`` (the standard table one
        smaller) or on its mirror image, whichever the least total move (:meth:`nearest_slots`) makes
        shorter (chosen: a wedge that lost a front slave on one arm is refilled from the other arm's rear
        otherwise, that robot crossing the formation through its neighbours; equal totals keep the
        standard table). ``shift``: where the master will stand, in its frame (the slots are laid out about
        that place; None: where it stands); ``building``: while the formation builds (:func:`~.matching.move_cost`).
        Returns (member number -> node id, the formation, whether it is the mirror)."""
        mirror = formation.mirrored()
        total, table = self._least_move(members, formation, shift, building)
        total_m, table_m = self._least_move(members, mirror, shift, building)
        if total_m < total - 1e-9:
            return table_m, mirror, True
        return table, formation, False

    def nearest_slots(self, members: dict[int, int], formation: Formation, building: bool = False) -> dict[int, int]:
        """The remaining slaves (``members``: member number -> node id, the lost one out) on the slots
        1..n of ``formation`` by the least total move the master estimates (:func:`~.matching.move_cost`, ``building``
        while the formation builds; chosen: the slots fill with the robots already near them, so a loss moves the
        fewest metres, and no robot crosses the formation). Where the master
        places a member, in its own frame (the formation frame: x along its heading): where its IR
        fix puts it when the fix is fresh (:data:`~.knowledge.FRESH_IR_S`); else at the slot it
        holds (it drives there) unless the RSSI range of its latest ring frame disagrees with that
        slot's distance by more than :data:`OFF_SLOT_M` — then on that slot's bearing at the RSSI range r;
        a member holding no slot of the table, at r with the bearing unknown
        (:func:`~.assignment.slot_distance`). Equal totals keep the robots in member order."""
        return self._least_move(members, formation, None, building)[1]

    def _least_move(self, members: dict[int, int], formation: Formation, shift: tuple[float, float] | None = None,
                    building: bool = False) -> tuple[float, dict[int, int]]:
        """:meth:`nearest_slots` and the total distance of its assignment (m, as the master estimates it)."""
        held, cost = self._move_costs(members, formation, shift)
        slaves = [n for m, n in sorted(members.items()) if m != 0]
        # each move of d metres counts d + d²·1/m (matching.move_cost; building: the square only breaks ties): of two
        # plans of about the same metres, the one without a long move; on a line — a column, or any robots all beyond
        # their slots — every assignment moves the same metres, and the order with no robot passing another is taken
        order = least_total([[move_cost(d, building) for d in row] for row in cost])
        out = {0: members[0]}
        for i, n in enumerate(slaves):
            out[order[i] + 1] = n
        return sum(cost[i][order[i]] for i in range(len(slaves))), dict(sorted(out.items()))

    def _move_costs(self, members: dict[int, int], formation: Formation,
                    shift: tuple[float, float] | None = None) -> tuple[list[int], list[list[float]]]:
        """The slaves of ``members`` in member order: the member number each holds, and the distance (m, as the
        master estimates it, :meth:`nearest_slots`) from where each is to each of the slots 1..n of ``formation``
        laid out about the master's place ``shift`` (None: where it stands)."""
        node = self.node
        know = node.know
        slaves = [n for m, n in sorted(members.items()) if m != 0]
        holds = {n: m for m, n in members.items()}
        held = node.formation.slot_positions().tolist() if node.formation is not None else []
        slots = formation.slot_positions().tolist()[1: len(slaves) + 1]
        if shift is not None:
            slots = [(sx + shift[0], sy + shift[1]) for sx, sy in slots]
        yaw = node.ahrs_yaw()
        now = node.clock.now
        ranges = node.ring.slot_range_m if hasattr(node, "ring") else {}
        # a handover's plan (``shift``): the table's frame fitted onto this master's own by the members it has fresh
        # fixes of (the rigid motion that carries their slots onto their fixes, least squares; chosen) carries a member
        # out of IR sight from its slot of the table, and the new slots about the old master's place (it stood on the
        # table's axis, facing the user, where this master goes). A new master's own frame need not be the table's: on
        # 1 + 8, seed 7094, the table lay 31° round from it (5° of that its own turn since it took the user over); the
        # slots unfitted put an unseen rear member 1 m from where it stood, and the plan sent another member to the slot
        # beside it (docs/faults.md)
        fit = self._slots_onto_fixes(slaves, holds, held, yaw, now) if shift is not None else None
        master_at = [shift] if shift is not None else []  # where the new master goes (matching.PAST_MASTER_M)
        if fit is not None:
            (c, s_), (tx, ty) = fit
            held, slots, master_at = ([(c * x - s_ * y + tx, s_ * x + c * y + ty) for x, y in points]
                                      for points in (held, slots, master_at))
        near = lane_near_m(node.cfg.robot.radius_m)
        cost = []
        for n in slaves:
            fix = know.ir.get(n)
            r = ranges.get(n, math.nan)
            at = held[holds[n]] if holds[n] < len(held) else None
            if fix is not None and now - fix.time_s <= FRESH_IR_S:
                at = fix.position_now(yaw)
            elif at is not None and math.isfinite(r) and abs(r - math.hypot(*at)) > OFF_SLOT_M:
                # not at its slot by the RSSI: on its slot's bearing (where it steers) at the RSSI range (chosen:
                # with the bearing unknown, sqrt(r² + a²) grows with the slot's distance a whatever r says, so a
                # member the RSSI put beyond its rear slot was sent to a front slot, swapping places with the
                # member there — 2 m of moves where none was needed; leading AHRS faults, seeds 200-219)
                a = math.hypot(*at)
                at = (at[0] * r / a, at[1] * r / a) if a > 0 else None
            if at is not None:
                cost.append([math.hypot(at[0] - sx, at[1] - sy) + PAST_MASTER_M * any(
                    segment_distance(p, at, (sx, sy)) < near for p in master_at) for sx, sy in slots])
            elif math.isfinite(r):
                cost.append([assignment.slot_distance(r, math.hypot(sx, sy)) for sx, sy in slots])
            else:
                cost.append([0.0] * len(slots))  # nothing known: any slot
        return [holds[n] for n in slaves], cost

    def _slots_onto_fixes(self, slaves: list[int], holds: dict[int, int], held: list, yaw: float,
                          now: float) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """The rigid motion (cos, sin of its turn; its shift) that carries the held slots of the members this master has
        fresh IR fixes of onto those fixes, least squares (a shift alone from one fix; None from none): where the
        table's frame lies in this master's own."""
        pairs = []
        for n in slaves:
            fix = self.node.know.ir.get(n)
            if fix is not None and now - fix.time_s <= FRESH_IR_S and holds[n] < len(held):
                pairs.append((held[holds[n]], fix.position_now(yaw)))
        if not pairs:
            return None
        k = len(pairs)
        hx, hy = sum(h[0] for h, _ in pairs) / k, sum(h[1] for h, _ in pairs) / k
        fx, fy = sum(f[0] for _, f in pairs) / k, sum(f[1] for _, f in pairs) / k
        dot = sum((h[0] - hx) * (f[0] - fx) + (h[1] - hy) * (f[1] - fy) for h, f in pairs)
        cross = sum((h[0] - hx) * (f[1] - fy) - (h[1] - hy) * (f[0] - fx) for h, f in pairs)
        turn = math.atan2(cross, dot) if k > 1 and (dot or cross) else 0.0
        c, s = math.cos(turn), math.sin(turn)
        return (c, s), (fx - (c * hx - s * hy), fy - (s * hx + c * hy))

    def _refill(self):
        node = self.node
        know = node.know
        result = OrganizeResult()
        self.refills.append(result)
        open_members = self.open_members()
        new = yield from self.join.refill(open_members, node.swarm_pan, dict(know.members), know.mode, result,
                                          self.refill_region_m(open_members))
        if new is None or node.state != "master":
            return
        added = [n for m, n in new.items() if know.members.get(m) != n]
        formation = table_for_members(node.cfg.swarm, new, know.mode, leading_user(node.cfg))
        if self.mirrored:  # the table the removal mirrored stays so: the members hold their sides
            formation = formation.mirrored()
        self._commit(new, formation)
        for n in added:
            self._forget(n)
        node.members_changed.emit("joined", added)
        yield from self._announce(new, formation)

    def refill_region_m(self, open_members: list[int]) -> float | None:
        """A refill's available region (chosen; seed 000 Table 1 defines the organize's, ``protocol.join_radius_m``
        around the master, where its swarm gathers): while the master stands (its own odometry below
        :data:`STANDING_MPS`), ``protocol.join_radius_m`` around the open slots — a robot that far from a slot is
        at most the slot's distance from the master more from the master, the one distance it measures (the
        query's RSSI) — but never beyond where :meth:`check_astray` would remove it from that slot; while the
        swarm walks, the organize's (None: a recruit from farther falls behind a walking swarm). A robot left
        waiting at the rim of the organize's region (Table 2 took the closest) stays within reach of a slot a
        loss opens, though the master moved to its user's distance since."""
        node = self.node
        vx, vy, _ = node.odometry.read()
        if math.hypot(vx, vy) >= STANDING_MPS or node.formation is None:
            return None
        slots = assignment.slots_formation(node.cfg.swarm, open_members).slot_positions()
        reach = max((math.hypot(*slots[m]) for m in open_members if m < len(slots)), default=0.0)
        astray = max(reach + ASTRAY_M, ASTRAY_REACHES * node.cfg.ir.max_range_m)
        radius = node.cfg.protocol.join_radius_m
        return max(radius, min(radius + reach, astray))

    def reassign(self, members: dict[int, int], formation: Formation) -> None:
        """The master's new numbering of its members on ``formation``: held at once, then sent as
        an acknowledged member update (as after a removal)."""
        self._commit(members, formation)
        self.node.clock.process(self._announce(members, formation))

    def _commit(self, members: dict[int, int], formation: Formation) -> None:
        know = self.node.know
        know.members = dict(members)
        know.total_members = len(members)
        self.node.formation = formation

    def _announce(self, members: dict[int, int], formation: Formation):
        """Broadcast the member update until every other member acknowledged it."""
        node = self.node
        clock = node.clock
        cfg = node.cfg.protocol
        # this master's own count (2 bytes on air, messages.py); a slave compares it only with the same
        # master's earlier updates: no number of one robot is compared with another's
        seq = self._sent_seq + 1
        self._sent_seq = self._seq = seq
        others = {n for m, n in members.items() if m != 0}
        payload = dict(seq=seq, members=dict(members), shape=formation.shape, links=formation.links_payload(),
                       mode=node.know.mode)
        self._acks = set()
        retries = 0
        while others and self._seq == seq:  # a newer update supersedes this one
            node.send(msg.MEMBER_UPDATE, **payload)
            self._needed, self._event = others, clock.event()
            yield clock.any_of([self._event, clock.timeout(cfg.response_timeout_s)])
            if self._seq != seq or others <= self._acks or retries >= cfg.max_retries or node.state != "master":
                break
            retries += 1
        self.update_retries += retries

    def _on_ack(self, frame: Frame) -> None:
        if frame.dst != self.node.node_id or frame.payload["seq"] != self._seq:
            return
        self._acks.add(frame.src)
        ev = self._event
        if ev is not None and not ev.triggered and self._needed <= self._acks:
            ev.succeed()

    def _on_bid_request(self, frame: Frame) -> None:
        """Master: a member cannot hold its slot any more (its sensor failed): acknowledge, then take
        it out of the tables like a lost member — its slot is open, the members are re-planned and the
        refill recruits the fittest robot for it by ``swarm.assignment`` (seed 003 Algorithm 2 steps
        5-7: the slot announcement is the request to the free robots, the fittest bid takes it over;
        Algorithm 1 on their status reports with ``ruta_centralized``)."""
        node = self.node
        if frame.dst != node.node_id or node.state != "master":
            return
        node.send(msg.BID_REQUEST_ACK, dst=frame.src, seq=frame.payload["seq"])
        diagnosis = getattr(node, "diagnosis", None)
        if diagnosis is not None and not frame.payload["sensors"] & assignment.SENSOR_BITS["IR"]:
            diagnosis.neighbour_ir_broken()  # the misses of our own IR checks so far are its module's doing
        if frame.src in node.know.members.values():
            # the robot that handed its user over to this one asks to leave (after_handover): its removal
            # plans the slots from its place, where this master drives (_remove)
            self._leaving_master = frame.src if frame.src == node.modes.handed_from else None
            node.modes.handed_from = None  # once: a later request of the same robot is a slave's
            self.member_lost(frame.src)

    def _on_bid_request_ack(self, frame: Frame) -> None:
        ev = self._request_acked
        if frame.dst == self.node.node_id and frame.payload["seq"] == self._request_seq and ev is not None \
                and not ev.triggered:
            ev.succeed()

    # -- members --------------------------------------------------------------------------------
    def sensor_failed(self, part: str) -> None:
        """The robot's own diagnosis found ``part`` broken (middleware/diagnosis.py). A slave that its
        lowered status leaves unable to hold its slot (``ruta.must_request_bids`` on the slot's
        subtask, :func:`~.assignment.slot_subtask`) sends the bid request to its master (seed 003
        Algorithm 2 step 5), repeated until acknowledged (``protocol.max_retries``)."""
        node = self.node
        if node.state == "master" and part in MASTER_NEEDS and self.cannot_lead is not None:
            self.cannot_lead(part)  # it hands its user over (Table 3), then asks to leave as a slave
            return
        if node.state != "slave" or node.formation is None:
            return
        member = node.know.member
        geometry = assignment.slot_geometry(node.formation)
        if member not in geometry:
            return
        held = assignment.slot_subtask(member, geometry[member][1], node.cfg.ruta)
        status = assignment.own_status(node)
        if ruta.must_request_bids(status, held):
            self.bid_requests.append((node.clock.now, part))
            self._asked_out = True
            sensors = sum(bit for kind, bit in assignment.SENSOR_BITS.items() if kind in status.sensors)
            node.clock.process(self._request_bids(member, sensors))

    def after_handover(self, failed: frozenset[str]) -> None:
        """This master handed its user over (Table 3, modes.py) and is a slave now: a part it found
        broken may leave it unable to hold its slot (:meth:`sensor_failed`: the bid request)."""
        self._was_master = bool(failed)
        for part in sorted(failed):
            self.sensor_failed(part)

    def _request_bids(self, member: int, sensors: int):
        node = self.node
        clock = node.clock
        cfg = node.cfg.protocol
        pan = node.swarm_pan
        seq = self._request_seq = self._request_seq + 1  # own count: only its acknowledgement carries it back
        for _ in range(cfg.max_retries + 1):
            if node.state != "slave" or node.swarm_pan != pan or node.member_node(0) is None:
                return  # removed meanwhile (the member update came): the request was heard
            self._request_acked = clock.event()
            node.send(msg.BID_REQUEST, dst=node.member_node(0), seq=seq, member=member, sensors=sensors)
            yield clock.any_of([self._request_acked, clock.timeout(cfg.response_timeout_s)])
            if self._request_acked.triggered:
                break
        else:
            return
        # acknowledged: the master takes us out of its tables, and only the remaining members acknowledge its member
        # update, so a lost one is never repeated for us; without it for protocol.status_timeout_s we leave by
        # ourselves (chosen: the old master of a handover at loss 0.3 missed it and stayed a slave of a swarm
        # whose tables had no place for it, holding ring slots, to the end; the master's IR fault, seed 210)
        yield clock.timeout(cfg.status_timeout_s)
        if self._asked_out and node.state == "slave" and node.swarm_pan == pan:
            self.self_removals += 1
            self._plan_clear_out()
            self._asked_out = self._was_master = False
            self._leave()

    def _on_update(self, frame: Frame) -> None:
        node = self.node
        if node.state != "slave":
            return
        p = frame.payload
        node.send(msg.MEMBER_UPDATE_ACK, dst=frame.src, seq=p["seq"])
        if frame.src == self._last_src and p["seq"] <= self.last_seq:
            return  # an older update of the same master
        self.last_seq, self._last_src = p["seq"], frame.src
        members = {int(m): n for m, n in p["members"].items()}
        if members.get(0) != frame.src:
            return  # a member update comes from the master its table names (chosen: see :meth:`member_lost`)
        if node.node_id not in members.values():  # removed: not a member any more
            if self._asked_out:
                self._plan_clear_out(members, Formation.from_links_payload(p["shape"], p["links"]))
            self._asked_out = self._was_master = False
            self._leave()
            return
        know = node.know
        know.members = members
        know.total_members = len(members)
        know.member = next(m for m, n in members.items() if n == node.node_id)
        know.mode = p["mode"]
        node.formation = Formation.from_links_payload(p["shape"], p["links"])

# the parts a master's job needs (chosen): its IR module — every slave locates it by its IR (seed 000 §3.3,
# the master's slot of the ring) and it measures the heading exchange's bearings; a master whose IR broke
# hands its user over (swarm.hand_over_for_fault). Its ultrasonic ring and AHRS: recorded, no handover (the LF
# antennas locate its user, seed 002 §3.2-3.4, and the slaves see its IR; handing over measured worse: re-formed
# 18/20 and the user lost in 3 of 40 runs, against 19/20 and none kept — docs/faults.md)
MASTER_NEEDS = frozenset({"ir"})
