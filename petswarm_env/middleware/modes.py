"""Driving-mode change with and without master change (seed 000 §3.5, Fig. 10, Table 3).

Table 3 — criteria for changing the master when the driving mode is changed:

=====================  ==========================================  ==========================================
driving-mode change    master-change request: Change               master-change request: No change
=====================  ==========================================  ==========================================
leading → following    select the closest robot as the master, but  do not change the master, but change the
                       do not change the neighbour robots'          neighbour robots' relative-location
                       relative-location reference                  reference
following → leading    select the robot with the highest            do not change the master, but change the
                       hierarchical level as master, and the        neighbour robots' relative-location
                       neighbour robots' relative-location          reference
                       reference
=====================  ==========================================  ==========================================

Hierarchy levels are numbered from the robot farthest from the user (level 1, seed 000 §3.5);
"the highest hierarchical level" is read as the top of that hierarchy, level 1 — the robot
farthest from the user, where the leading-mode master belongs (Fig. 10). "The closest robot" is
the one closest to the user.

Closest and farthest are what the master knows, not where the neighbour table says the robots
should be (:func:`measured_geometry`): each member where the master's IR module last measured it
(distance and bearing, the bearing carried over the master's own rotation since, AHRS), the user
where its LF tracking puts them. Fallbacks (chosen): a member the master has not measured within
:data:`~.knowledge.FRESH_IR_S` (occluded by another member, or beyond the IR's range) stands at its
nominal slot of the neighbour table — the best the master knows of it; without an LF track the
user stands at the standard distance ahead (:func:`~.formation.user_position_in_formation`). Ties
go to the lower member number.

The following → leading cell with a master change reads, in the text extraction, "select the robot
with the highest hierarchical level as master, and the neighbor robots' relative-location
reference"; the paper's running text states the rule for both rows: "if Master-change request is
the 'Change' condition and driving-mode change occurs, the master is changed, but the neighbor
robot's relative-location reference is not" — and that is the point of changing the master (no
re-forming, less delay). The running text wins here: with a master change the references are kept
in both directions (the table re-rooted at the new master).

:func:`plan_mode_change` is the pure rule; :class:`ModeManager` runs it on the radio: the master
broadcasts the *mode-change* frame (new mode, member table, neighbour table) until every member
acknowledged, then hands the user connection over to the new master (*handover* frame,
acknowledged), which takes the user's wearables over BLE.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from petswarm_env.comms.radio import Frame
from petswarm_env.config import SwarmConfig
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation, formation_for_mode, user_position_in_formation
from petswarm_env.middleware.knowledge import FRESH_IR_S, Knowledge
from petswarm_env.middleware.station import Station
from petswarm_env.middleware.succession import adopted_swarm_config

TABLE3_MODES = ("following", "leading")


@dataclass(frozen=True)
class ModeChangePlan:
    mode: str
    members: dict[int, int]  # new member number -> node id (member 0 = the master)
    formation: Formation
    master_changed: bool
    references_changed: bool


@dataclass(frozen=True)
class SwarmGeometry:
    """Where the master places its members and its user, in its own body frame now (m)."""

    positions: dict[int, tuple[float, float]]  # member number -> position (the master, 0, at the origin)
    user_xy: tuple[float, float]
    measured: frozenset[int]  # the members placed by a fresh IR measurement (the others: their nominal slot)

    def user_distance(self, member: int) -> float:
        x, y = self.positions[member]
        return math.hypot(x - self.user_xy[0], y - self.user_xy[1])

    def ahead_of_user(self, member: int) -> float:
        """How far ``member`` stands ahead of the user along a leading master's walk: the master faces its
        user and drives backwards along the walk (seed 002 §3.4), so the walk is its own −x."""
        return self.user_xy[0] - self.positions[member][0]


def measured_geometry(formation: Formation, know: Knowledge, yaw_rad: float, now_s: float,
                      user_xy: tuple[float, float] | None, user_distance_m: float) -> SwarmGeometry:
    """The master's own view of its swarm for Table 3 (see the module docstring): its IR
    measurements of the members (``know``, its AHRS reading ``yaw_rad`` now), its LF track of the
    user (``user_xy``, body frame; None without a track: ``user_distance_m`` ahead), the nominal
    slots for the members it has not measured within ``FRESH_IR_S``. The formation frame is the
    master's body frame (every robot faces its user: :func:`~.formation.formation_for_mode`)."""
    slots = formation.slot_positions().tolist()
    positions, measured = {0: (0.0, 0.0)}, set()
    for m in range(1, formation.size):
        seen = know.ir.get(know.members.get(m))
        if seen is not None and now_s - seen.time_s <= FRESH_IR_S:
            positions[m] = seen.position_now(yaw_rad)
            measured.add(m)
        else:
            positions[m] = (float(slots[m][0]), float(slots[m][1]))
    if user_xy is None:
        user_xy = user_position_in_formation(formation, user_distance_m)
    return SwarmGeometry(positions, (float(user_xy[0]), float(user_xy[1])), frozenset(measured))


def nominal_geometry(formation: Formation, user_distance_m: float) -> SwarmGeometry:
    """Every member at its slot, the user at the standard distance ahead: the neighbour table's view."""
    return measured_geometry(formation, Knowledge(), 0.0, 0.0, None, user_distance_m)


def plan_mode_change(
    cfg: SwarmConfig,
    formation: Formation,
    members: dict[int, int],
    old_mode: str,
    new_mode: str,
    master_change: bool,
    geometry: SwarmGeometry,
    lf_members: frozenset[int] | None = None,
    user: tuple[float, float] | None = None,
) -> ModeChangePlan:
    """Apply Table 3 to the current swarm, the closest / farthest robot from ``geometry`` (what the
    master knows: :func:`measured_geometry`), among the robots that may be master (``lf_members``:
    the node ids whose bodies carry LF antennas, from the joining answers; None = every robot);
    ``user`` (:func:`~.formation.leading_user`): where a leading layout's user stands.

    Changes between a Table 3 mode and remote control keep master and references (the table has no
    row for them).
    """
    if old_mode == new_mode or old_mode not in TABLE3_MODES or new_mode not in TABLE3_MODES:
        return ModeChangePlan(new_mode, dict(members), formation, False, False)
    n = formation.size
    if not master_change:  # keep the master, change the references: the standard layout of the new mode
        return ModeChangePlan(new_mode, dict(members), formation_for_mode(cfg, n, new_mode, user), False, True)
    distance = geometry.user_distance
    able = [m for m in range(n) if m == 0 or lf_members is None or members.get(m) in lf_members]
    if new_mode == "following":  # leading → following: the closest robot
        new_root = min(able, key=lambda m: (round(distance(m), 9), m))
    else:  # following → leading: the top of the hierarchy, the robot farthest from the user
        new_root = min(able, key=lambda m: (-round(distance(m), 9), m))
    new_formation, renumber = formation.rerooted(new_root)  # references unchanged
    new_members = {renumber[m]: node for m, node in members.items()}
    return ModeChangePlan(new_mode, dict(sorted(new_members.items())), new_formation, new_root != 0, False)


def plan_master_handover(formation: Formation, members: dict[int, int], mode: str, geometry: SwarmGeometry,
                         lf_members: frozenset[int] | None = None) -> ModeChangePlan | None:
    """A master that can no longer do its job (its IR module broke: its slaves lose their fix of it,
    middleware/diagnosis.py) hands its user over by Table 3's rule for the mode it drives — following:
    the robot closest to the user, leading: the highest hierarchical level, the farthest ahead of the user
    along the walk (:meth:`SwarmGeometry.ahead_of_user`: the levels of Fig. 10) — among the
    others that may be master (``lf_members``), from what it knows (``geometry``: with its IR broken its
    members stand at their slots, :func:`measured_geometry`). As Table 3's master change, the references
    are kept (the table re-rooted at the new master); the old master is a slave at the new master's old
    slot, which it then asks to leave (seed 003 Algorithm 2 step 5). None: no other robot may be master
    (chosen), or a mode Table 3 has no row for."""
    if mode not in TABLE3_MODES or formation.size < 2:
        return None
    able = [m for m in range(1, formation.size) if m in members and (lf_members is None or members[m] in lf_members)]
    if not able:
        return None
    # following: the closest; leading: the farthest ahead along the walk (Fig. 10's levels run along the leading
    # layout; by distance alone a robot beside its user could be "farthest" and must first swing round them)
    if mode == "following":
        new_root = min(able, key=lambda m: (round(geometry.user_distance(m), 9), m))
    else:
        new_root = min(able, key=lambda m: (-round(geometry.ahead_of_user(m), 9), m))
    new_formation, renumber = formation.rerooted(new_root)
    new_members = {renumber[m]: node for m, node in members.items()}
    return ModeChangePlan(mode, dict(sorted(new_members.items())), new_formation, True, False)


class ModeManager:
    """Both ends of a mode change on one robot."""

    def __init__(self, node: Station):
        self.node = node
        self.last_seq = -1
        self._last_src: int | None = None  # the master whose plan ``last_seq`` numbers (each master counts its own)
        self._sent_seq = 0  # own count of the plans this robot announced as master
        self._acks: set[int] = set()
        self.handover_acked = False
        self.told_walk_rad: float | None = None  # the way the user walks, as the master that handed them over told it
        self.walk_told: tuple[float, float] | None = None  # what this master told, and its AHRS yaw then (leaving.py)
        self.handed_from: int | None = None  # the robot that handed its user over to this one (RecoveryManager._remove)
        node.on(msg.MODE_CHANGE, self._on_mode_change)
        node.on(msg.MODE_CHANGE_ACK, self._on_ack)
        node.on(msg.HANDOVER, self._on_handover)
        node.on(msg.HANDOVER_ACK, self._on_handover_ack)

    # -- master side ------------------------------------------------------------------------------
    def change(self, plan: ModeChangePlan, result: dict, walk_rad: float | None = None):
        """Master process: announce the plan until acknowledged, then hand the user over. The plan's
        number is this master's own count: a slave compares it only with the same master's. ``walk_rad``:
        a master handing over for a broken part tells the new master the way its user walks (its body
        frame, 2 bytes more: ``messages.WALK_BYTES``; chosen, succession.walk_direction)."""
        self._sent_seq += 1
        seq = self._sent_seq
        node = self.node
        clock = node.clock
        cfg = node.cfg.protocol
        old_members = dict(node.know.members)
        others = {n for n in old_members.values() if n != node.node_id}
        self._acks = set()
        retries = 0
        payload = dict(seq=seq, mode=plan.mode, members=dict(plan.members), shape=plan.formation.shape,
                       links=plan.formation.links_payload(),
                       lf=sorted(n for n in plan.members.values() if n in node.know.lf_members))
        while True:
            node.send(msg.MODE_CHANGE, **payload)
            yield clock.timeout(cfg.response_timeout_s)
            if others <= self._acks or retries >= cfg.max_retries:
                break
            retries += 1
        result["retries"] = retries
        new_master = plan.members[0]
        self._commit(plan)
        if new_master != node.node_id:
            retries = 0
            self.handover_acked = False
            self.walk_told = None if walk_rad is None else (walk_rad, node.ahrs_yaw())
            while True:
                told = {} if walk_rad is None else {"walk_rad": round(walk_rad, 3)}  # int16 mrad
                node.send(msg.HANDOVER, dst=new_master, seq=seq, user=node.connected_user,
                          previous=node.previous_driving_state, **told)
                yield clock.timeout(cfg.response_timeout_s)
                if self.handover_acked or retries >= cfg.max_retries:
                    break
                retries += 1
            result["handover_retries"] = retries
            node.state = "slave"  # the user goes over to the new master (Table 3: master change)
            node.joined_s = clock.now  # a slave now: its status timeout counts from here
            node.connected_user = None
            node.handed_over.emit(new_master)
        result["done_s"] = clock.now

    def _commit(self, plan: ModeChangePlan) -> None:
        """The (old) master commits the plan once every member acknowledged it (seed 000 §3.5: the
        new tables, re-rooted at the new master under Table 3's master change)."""
        node = self.node
        previous = node.know.members
        node.know.members = dict(plan.members)
        node.know.total_members = len(plan.members)
        node.know.member = next(m for m, n in plan.members.items() if n == node.node_id)
        node.know.mode = plan.mode
        node.formation = plan.formation
        node.plan_applied.emit(plan, previous)

    def _on_ack(self, frame: Frame) -> None:
        if frame.dst == self.node.node_id:
            self._acks.add(frame.src)

    def _on_handover_ack(self, frame: Frame) -> None:
        if frame.dst == self.node.node_id:
            self.handover_acked = True

    # -- members ----------------------------------------------------------------------------------
    def _on_mode_change(self, frame: Frame) -> None:
        node = self.node
        p = frame.payload
        node.send(msg.MODE_CHANGE_ACK, dst=frame.src)
        if (frame.src == self._last_src and p["seq"] <= self.last_seq) or node.state != "slave":
            return  # a repeat of a plan of the same master, or not a slave
        members = {int(m): n for m, n in p["members"].items()}
        if node.node_id not in members.values():
            # the new tables leave us out (the master removed us as lost, and its removal notice
            # never reached us): we are no member of that plan, so we keep what we know and our own
            # status timeout tells us the swarm is gone (chosen)
            return
        self.last_seq, self._last_src = p["seq"], frame.src
        node.know.members = members
        node.know.total_members = len(members)
        node.know.member = next(m for m, n in members.items() if n == node.node_id)
        node.formation = Formation.from_links_payload(p["shape"], p["links"])
        node.know.mode = p["mode"]  # the driving mode as the frame says: the slave's own knowledge
        node.know.lf_members = frozenset(p["lf"])

    def _on_handover(self, frame: Frame) -> None:
        node = self.node
        node.send(msg.HANDOVER_ACK, dst=frame.src)
        if node.state == "slave" and node.know.member == 0:  # take the user connection over
            node.cfg = adopted_swarm_config(node)  # its user's request as its tables tell it (succession.py)
            node.state = "master"
            node.connected_user = frame.payload["user"]  # its wearables reconnect over BLE
            node.previous_driving_state = frame.payload["previous"]
            self.told_walk_rad = frame.payload.get("walk_rad")  # the old master's ψ, its body frame (None: not told)
            self.handed_from = frame.src  # the robot that handed its user over (a member of its table still)
            node.pans = frozenset({node.swarm_pan})
            node.took_over.emit()
