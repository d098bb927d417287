"""The swarm outlives its master: the slaves choose a new master among themselves (chosen; seed 000
Table 3's rules, seed 002 §3.2's wake-up pairing).

Seed 000 names no rule for a master that dies; its Table 3 says which robot should be the master of
a driving mode, and that is the rule the slaves apply among themselves when theirs is lost:
*following* → the robot closest to the user, *leading* → the robot with the highest hierarchical
level (level 1, the robot farthest from the user: :mod:`.modes`). Only a robot whose body carries
the two LF antennas a master locates its user with may be chosen (``robot_types``; a member's
capability travels in the joining answer and in the member tables, :mod:`.messages`).

1. **Loss.** A slave that heard no status broadcast of its master for ``protocol.status_timeout_s``
   (:meth:`~.sequence.SequenceManager.master_lost`) stops (emergency stop) and starts
   :meth:`SuccessionManager.start`. A status broadcast of the master heard after that calls the
   choice off (:meth:`SuccessionManager.master_heard_again`: its broadcasts were lost, not the master).
2. **Candidacy.** A slave that may be master works out its claim from what it knows
   (:func:`own_user_estimate`): the user where its master's last status broadcast put them (master
   frame), placed through its own IR fix of the master and its heading-exchange estimate of the
   master's heading (without a fresh fix: its own slot of the neighbour table; without a heading
   estimate: headings taken as aligned — every robot faces the user). It broadcasts a *candidacy*
   (its claim: the distance in centimetres, negated in leading mode, then its member number — a total
   order every slave computes alike) twice within ``succession.election_window_s``, staggered by its
   member number.
3. **Choice.** At the end of its window, a slave whose own claim is the best it heard takes over:
   it computes the new tables (:func:`succession_plan`: itself member 0, the lost master out, the
   others on the slots of the standard table one smaller by the least total move) and broadcasts
   the *takeover* frame (its claim, the tables) until every member acknowledged it, for at most
   ``succession.takeover_timeout_s`` without the acknowledgements of at least half the other
   members — then it was alone or with a few (its own radio failed, or a few far members lost a
   master that the others still hear: chosen, a quorum, so that a minority never takes the
   swarm from a live master) and returns to waiting. With that quorum it is the master
   (``took_over``): the ring, the status broadcast and the periodic scan start on it.
4. **Acceptance.** A slave accepts a takeover of its lost master (its own status timeout passed:
   a slave that still hears its master does not follow a robot that alone lost it; the takeover is
   repeated, so a slave whose timeout comes a little later accepts it then) from a claim at least as
   good as any it accepted, applies the tables and acknowledges; a new master that hears a better
   claim's takeover yields (becomes its slave). A slave that accepted nothing within the window and
   the takeover timeout returns to waiting, as before.
5. **The user.** The new master knows its user only from frames and its own sensors
   (:func:`own_user_estimate`, kept in :attr:`SuccessionManager.user_estimate`); the user session
   (:mod:`.user_session`) drives it there and bursts its wake-up pattern (seed 002 §3.2) until the
   belt, which dropped its old link at its own BLE supervision timeout, pairs with it.

A successor knows its user's request only from frames: the number of slaves is the number it took
over, the shape and spacing are those of the neighbour table it holds (:func:`adopted_swarm_config`).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import numpy as np

from petswarm_env.comms.radio import Frame
from petswarm_env.config import CustomLink
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation, formation_for_mode, leading_user
from petswarm_env.middleware.knowledge import FRESH_IR_S
from petswarm_env.middleware.matching import least_total, move_cost
from petswarm_env.middleware.station import Station
from petswarm_env.sim.geometry import wrap_angle

LF_ANTENNAS = 2  # a master locates its user with two LF antennas (seed 002 §3.3)


# chosen: where a new master looks for its user after an unanswered wake-up burst (seed 002 has no
# search). The places it bursts from lie on a triangular lattice SEARCH_SPACING_M apart: every point
# of the plane is within SEARCH_SPACING_M / sqrt(3) = 0.81 m of one, inside the 1 m wake-up range
# (seed 002 §3.2) with 0.19 m for where it stops (SEARCH_STAND_M short of a place). Of the lattice
# laid around its first estimate, it takes the SEARCH_PLACES nearest the stretch the user may have
# walked on before the belt's alert stopped them (up to SEARCH_WALK_M the way they walked,
# succession.user_travel: the master's last status broadcast is a status timeout old when the slaves
# notice the loss), and visits them likeliest first (the nearer of two about as likely: SEARCH_DETOUR,
# since each place costs a wake-up period of lf.wake_period_s whatever the drive), bursting at each.
SEARCH_SPACING_M = 1.4
SEARCH_WALK_M = 1.4
SEARCH_PLACES = 13
SEARCH_STAND_M = 0.2
SEARCH_DETOUR = 0.5
# the new master's approach to its user (user_session._successor_command):
APPROACH_SLACK_M = 0.15  # chosen: a new master bursts its wake-up pattern once this near its approach distance ...
STALLED_MPS = 0.05  # chosen: ... or once its own odometry says it stands (it can get no closer)
BLOCKED_S = 2.0  # chosen: ... or once it has come no closer (PROGRESS_M) for this long (something stands in its way)
PROGRESS_M = 0.1  # chosen: a new master comes closer to where it drives by at least this per BLOCKED_S, or it is blocked
# chosen: after a handover for a broken part the user walks on once the new master's LF fix puts them this near its
# distance (the first fix came at the 2 m edge of the LF range, seed 002 §3.3: the user walked off out of range)
RESUME_SLACK_M = 0.5
# chosen: ... and, leading, once the new master has come to rest at its place ahead of them (its own odometry): its
# LF track of a standing user is steady only then (swinging in, the tracker read the robot's arc as the user's walk)
SETTLED_MPS = 0.15
SETTLED_RPS = 0.2
# chosen: a new master takes the way its user walks as the old master told it (its controller's ψ) over the old master's
# axis (its back, leading; its front, following) when the two part by more than this: on a zigzag the old master's
# heading lags the walk after a turn (leading: up to 80°, its arc capped at LEADING_ARC_MAX_RPS); within it, its heading
# (steady) did better than its ψ (the LF track's, noisy): IR on the master, leading straight, seeds 100-119, 200-219 and
# 300-379, re-formed 106/120 with it, 95 with ψ always; leading zigzag in emergency at the end 64 -> 10 of 120 (docs/faults.md)
TOLD_WALK_OFF_DEG = 25.0
MASTER_TURN_HISTORY = 600  # chosen: status broadcasts whose turn rates a slave keeps (SuccessionManager.heard_status)


def search_places(origin: tuple[float, float], way: tuple[float, float], spacing_m: float = SEARCH_SPACING_M,
                  walk_m: float = SEARCH_WALK_M, count: int = SEARCH_PLACES) -> list[tuple[float, tuple[float, float]]]:
    """The places a new master bursts its wake-up pattern from while it looks for its user (the
    comment above): the ``count`` points of a triangular lattice around ``origin`` (its first
    estimate of the user) nearest the stretch from ``origin`` ``walk_m`` along the unit vector
    ``way`` (the way the user walked), each with its distance to that stretch, nearest first. One
    frame for the arguments and the result."""
    ux, uy = way
    vx, vy = -uy, ux
    row = spacing_m * math.sqrt(3.0) / 2.0
    reach = int(math.ceil((walk_m + spacing_m * math.sqrt(count)) / spacing_m)) + 1
    lattice = []
    for k in range(-reach, reach + 1):
        b = k * row
        for j in range(-reach, reach + 1):
            a = (j + 0.5 * (k % 2)) * spacing_m
            cost = math.hypot(a - min(max(a, 0.0), walk_m), b)  # distance to the stretch walked
            lattice.append((round(cost, 9), abs(k), a, b))
    lattice.sort()
    return [(cost, (origin[0] + a * ux + b * vx, origin[1] + a * uy + b * vy)) for cost, _, a, b in lattice[:count]]


def next_place(todo: list[tuple[float, tuple[float, float]]], here: tuple[float, float], skip: int | None = None) -> int:
    """Which of the places ``todo`` (:func:`search_places`) a robot at ``here`` visits next: the one
    nearest the stretch walked, a place ``SEARCH_DETOUR`` m of the way from the robot counting as one
    metre farther from the stretch; not ``skip`` (a place it could not reach) while others are left."""
    pick = [i for i in range(len(todo)) if i != skip] or list(range(len(todo)))
    return min(pick, key=lambda i: (round(todo[i][0] + SEARCH_DETOUR * math.dist(here, todo[i][1]), 9), i))



def search_step(search: tuple | None, guess: tuple[float, float] | None, pose, way: tuple[float, float] | None,
                yaw0: float, reached: bool) -> tuple[tuple, tuple[float, float]]:
    """One step of a new master's search for its user, in its odometry frame: returns the search
    state and the next place to burst from. The first step lays the places out (:func:`search_places`)
    around ``guess`` (where it puts the user; None: around itself, it stands in its user's swarm)
    along ``way`` (the way the user walked, its body frame at its takeover, yaw ``yaw0``:
    :func:`user_travel`; None: the line from itself to the guess). A place not ``reached`` (it came
    no closer: something in its way) stays to do, tried again from elsewhere; once every place is
    done the search starts over. ``pose``: its odometry (x, y, yaw)."""
    here = (pose[0], pose[1])
    if search is None:
        origin = guess if guess is not None else here
        if way is not None:
            c0, s0 = math.cos(yaw0), math.sin(yaw0)
            way = (c0 * way[0] - s0 * way[1], s0 * way[0] + c0 * way[1])
        else:
            dx, dy = origin[0] - here[0], origin[1] - here[1]
            d = math.hypot(dx, dy)
            way = (dx / d, dy / d) if d > 1e-6 else (math.cos(pose[2]), math.sin(pose[2]))
        search = (origin, way, search_places(origin, way), None)
    origin, way, todo, current = search
    skip = None
    if current is not None and not reached:
        todo.append(current)
        skip = len(todo) - 1
    if not todo:
        todo = search_places(origin, way)
    current = todo.pop(next_place(todo, here, skip))
    return (origin, way, todo, current), current[1]

def body_can_be_master(station: Station) -> bool:
    """Whether this robot's own body carries the LF antennas a master needs (its own body report;
    a bare station is a petbot, which does)."""
    body = station.own_body_status()
    if body is None:
        return True
    return sum(1 for s in body.get("sensors", ()) if s["type"] == "LF") >= LF_ANTENNAS


def own_user_estimate(node: Station, now_s: float, master: int | None = None) -> tuple[float, float] | None:
    """Where this slave puts its user now, in its own body frame, from what it knows (module
    docstring, step 2): the master's last status broadcast (the user in the master's frame), its own
    IR fix of the master (fresh within ``FRESH_IR_S``; else its own slot of the neighbour table),
    its heading-exchange estimate of the master's heading (else aligned). None without a status.
    ``master``: the robot whose broadcast it was (by default member 0 of its tables)."""
    placed = own_user_and_master(node, now_s, master)
    return placed[0] if placed is not None else None


def user_travel(user: tuple[float, float], master: tuple[float, float], mode: str) -> tuple[float, float] | None:
    """The direction its user walks, in this robot's body frame, from where it puts the user and
    their master (:func:`own_user_and_master`): seed 002 §3.3 — in following the master walks behind
    its user, who walks away from it (master → user); in leading it walks ahead and the user walks
    toward it (user → master). None in remote (the user drives the robot) or with the two together."""
    if mode not in ("following", "leading"):
        return None
    dx, dy = user[0] - master[0], user[1] - master[1]
    d = math.hypot(dx, dy)
    if d < 1e-6:
        return None
    return (dx / d, dy / d) if mode == "following" else (-dx / d, -dy / d)


def master_heading_offset(node: Station, master: int) -> float:
    """θ_master − θ_self as this robot knows it: its heading-exchange estimate of the master's heading, carried
    over its own turn since (its AHRS) and the master's (the turn rates of the master's status broadcasts since,
    :meth:`SuccessionManager.master_turned`); else aligned with it (0: the scripted slaves hold the master's heading
    in formation)."""
    head = node.know.heading.get(master)
    if head is None:
        return 0.0
    turned = node.succession.master_turned(master, head.time_s) if hasattr(node, "succession") else 0.0
    return head.relative_rad + turned - wrap_angle(node.ahrs_yaw() - head.own_yaw_rad)


def in_place_to_resume(tracker, psi: float | None, now: float, alert_pause_s: float, target_m: float, leading: bool,
                       cfg, odometry: tuple[float, float, float]) -> bool:
    """After a belt's alert (a handover for a broken part, an emergency), whether the user may walk on: the
    (new) master's own LF fix (``tracker``, newer than the pause at ``alert_pause_s``; ``now`` on its own clock) puts its user
    near enough (``RESUME_SLACK_M`` beyond its distance ``target_m``) and, ``leading``, its place ahead
    of them — the user inside the reliable ±``lf.reliable_half_angle_deg`` of straight behind it, by its
    own walking direction ``psi`` (seed 002 §3.4: the leading robot keeps its user behind it), the
    robot at rest by its ``odometry``. A leading robot beside its user must out-pace them to regain
    that place, with the wheels it also needs to keep pace; standing, the user lets it swing in first
    (chosen)."""
    if tracker.last_fix_s <= alert_pause_s:
        return False
    user_body = tracker.user_body(now)[0]
    r = math.hypot(*user_body)
    if r > target_m + RESUME_SLACK_M:
        return False
    if not leading or psi is None:
        return True
    off = wrap_angle(math.atan2(user_body[1], user_body[0]) + math.pi - psi)  # its place about the user from straight ahead
    lim = math.radians(cfg.lf.reliable_half_angle_deg - cfg.master.rotate_deadband_deg)
    settled = math.hypot(odometry[0], odometry[1]) < SETTLED_MPS and abs(odometry[2]) < SETTLED_RPS
    return abs(off) <= lim and r >= target_m - RESUME_SLACK_M and settled


def walk_direction(node: Station, master: int, mode: str, told: float | None = None) -> float:
    """The way the user of a ``mode`` master walks, in this robot's body frame, from the master's heading
    as this robot knows it (:func:`master_heading_offset`). Leading: the master drives backwards along
    its user's walking direction, facing them (seed 002 §3.4), so the user walks where the master's back
    points (its heading plus π); measured over seeds 200-219 at an IR-fault handover: 7.5° mean error,
    against 13° for the direction from where it puts the user to where it puts the master
    (:func:`user_travel`: two IR-placed points 1.6 m apart). Following: the master drives behind its
    user, facing them (seed 002 §3.3), so the user walks where its front points (its heading). ``told``: the
    way the user walks in the master's own frame, as it told it in the handover (its controller's ψ): taken
    instead when over ``TOLD_WALK_OFF_DEG`` off that axis — the master had not swung round after a turn."""
    axis = math.pi if mode == "leading" else 0.0
    off = master_heading_offset(node, master)
    if told is not None and abs(wrap_angle(told - axis)) > math.radians(TOLD_WALK_OFF_DEG):
        return wrap_angle(off + told)
    return wrap_angle(off + axis)


def own_user_and_master(node: Station, now_s: float, master: int | None = None
                        ) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """:func:`own_user_estimate` and where this slave puts the master itself (its IR fix, else its
    slot of the neighbour table), both in its own body frame."""
    know = node.know
    status = know.status
    own_slot = know.member
    if master is None:
        master = node.member_node(0)
    if status is None or master is None:
        return None
    yaw = node.ahrs_yaw()
    phi = master_heading_offset(node, master)
    c, s = math.cos(phi), math.sin(phi)
    seen = know.ir.get(master)
    if seen is not None and now_s - seen.time_s <= FRESH_IR_S:
        mx, my = seen.position_now(yaw)
    elif node.formation is not None and 0 <= own_slot < node.formation.size and master in know.members.values() \
            and master != node.node_id:
        # the master from the two slots of the neighbour table (the master's frame), turned into own frame: as a
        # slave its own slot; as the new master of a handover (modes.py) the old master's slot of the re-rooted table
        pos = node.formation.slot_positions()
        m = next(k for k, n in know.members.items() if n == master)
        sx, sy = (float(v) for v in pos[own_slot] - pos[m])
        mx, my = -(c * sx - s * sy), -(s * sx + c * sy)
    else:
        return None
    ux, uy = status.user_position_m
    return (mx + c * ux - s * uy, my + s * ux + c * uy), (mx, my)


def claim_key(distance_m: float, mode: str, member: int) -> tuple[int, int]:
    """Table 3's order (smaller is better): following (or remote) → the closest to the user;
    leading → the highest hierarchical level, the farthest. Then the lower member number."""
    cm = int(round(100.0 * distance_m))
    return (-cm if mode == "leading" else cm), member


def least_move(current: dict[int, np.ndarray], slots: dict[int, np.ndarray]) -> dict[int, int]:
    """Slot -> member: each member of ``current`` (member -> position) to one slot of ``slots``
    (slot -> position, as many) by the least total move (the Hungarian method on
    :func:`~.matching.move_cost`, as a removal's re-plan; among equal totals each member keeps the slot
    of its own rank)."""
    members, targets = sorted(current), sorted(slots)
    order = least_total([[move_cost(float(np.hypot(*(current[m] - slots[k])))) for k in targets] for m in members])
    return {targets[order[i]]: m for i, m in enumerate(members)}


def succession_plan(formation: Formation, members: dict[int, int], new_root: int, mode: str,
                    swarm_cfg, user: tuple[float, float] | None = None) -> tuple[dict[int, int], Formation]:
    """The new tables when member ``new_root`` takes the lost master's (member 0's) place: the
    standard table of the known shape (``swarm_cfg``: :func:`adopted_swarm_config`) for one member
    less, laid out for ``mode`` (``user``: :func:`~.formation.leading_user`, in leading), anchored where the lost master stood; the new master is member 0,
    the other members take its slots by the least total move from their slots of the old table.
    Returns (member number -> node id, formation)."""
    n = len(members) - 1
    try:
        new = formation_for_mode(swarm_cfg, n, mode, user)
    except ValueError:
        # a custom table that cannot be cut to one member less (a member it keeps refers only to members beyond
        # the new size): the table keeps its size, as the recovery keeps a custom table at a loss, turned about the
        # new master (Formation.rerooted: the slots stand where they stood); the lost master's slot stays open
        new, renumber = formation.rerooted(new_root)
        return dict(sorted((renumber[m], node) for m, node in members.items() if m != 0)), new
    old_slots = formation.slot_positions()
    new_slots = new.slot_positions()
    rest = {m: old_slots[m] for m in members if m not in (0, new_root)}
    chosen = least_move(rest, {k: new_slots[k] for k in range(1, n)})
    table = {0: members[new_root]}
    table.update({k: members[m] for k, m in chosen.items()})
    return dict(sorted(table.items())), new


def adopted_swarm_config(node: Station):
    """The swarm section a robot that became master holds (a successor, or the new master of a Table 3
    change): its user's request as the frames told it — the shape of its neighbour table, the spacing
    of member 1's first link, the slaves the swarm had (its tables' members but one); a custom table
    is its own rows (turned back from the leading layout)."""
    cfg = node.cfg
    formation = node.formation
    update: dict = {"num_slaves": max(1, node.know.total_members - 1), "spares": 0}  # a spare is a member like the others
    if formation is not None and formation.links:
        first = formation.links[min(formation.links)][0]
        update["formation"] = formation.shape
        update["spacing_m"] = float(math.hypot(*first.offset_m)) or cfg.swarm.spacing_m
        if formation.shape == "custom":
            table = formation.rotated(math.pi) if node.know.mode == "leading" else formation
            update["custom_links"] = [CustomLink(robot=m, neighbour=lk.neighbour, offset_m=list(lk.offset_m))
                                      for m, lks in table.links.items() for lk in lks]
    return cfg.model_copy(update={"swarm": cfg.swarm.model_copy(update=update)})


class SuccessionManager:
    """Both sides of the choice of a new master on one robot (module docstring)."""

    def __init__(self, node: Station, leave: Callable[[], None]):
        self.node = node
        self._leave = leave  # back to waiting (SequenceManager.leave_swarm)
        self.lost: int | None = None  # the node id of the master whose loss is being settled
        self.electing = False
        self.claims: dict[int, tuple[int, int]] = {}  # node id -> claim key heard (own included)
        self.accepted: tuple[int, int] | None = None  # the claim of the takeover accepted (or made)
        self.user_estimate: tuple[float, float] | None = None  # a new master: its user, own body frame, at its takeover
        self.user_travel: tuple[float, float] | None = None  # a new master: the way its user walked, own body frame, at its takeover
        self.elections: list[tuple[float, float, int | None, int]] = []  # a new master: (loss noticed, took over, lost, itself)
        self._noticed_s = 0.0
        self._seq = -1
        self._acks: set[int] = set()
        # the master's turn integrated from the turn rates of its status broadcasts: (time on own clock, radians since
        # the first, that broadcast's rate), of the robot ``_turn_src`` (chosen: MASTER_TURN_HISTORY of them, 60 s at the
        # shipped 0.1 s broadcast period)
        self._turns: deque[tuple[float, float, float]] = deque(maxlen=MASTER_TURN_HISTORY)
        self._turn_src: int | None = None
        node.on(msg.CANDIDACY, self._on_candidacy)
        node.on(msg.TAKEOVER, self._on_takeover)
        node.on(msg.TAKEOVER_ACK, self._on_ack)

    # -- the master's turn since a heading exchange ---------------------------------------------------
    def heard_status(self, src: int, now_s: float, turn_rate_rps: float) -> None:
        """A status broadcast of ``src`` arrived at ``now_s`` (own clock) with the master's turn rate (seed 000 §3.5:
        its (vx, vy, ω)): its turn since the last one, by the mean of the two rates, is added up."""
        turns = self._turns
        if src != self._turn_src or not turns:
            self._turn_src = src
            turns.clear()
            turns.append((now_s, 0.0, turn_rate_rps))
            return
        t0, acc, rate0 = turns[-1]
        turns.append((now_s, acc + 0.5 * (rate0 + turn_rate_rps) * (now_s - t0), turn_rate_rps))

    def master_turned(self, master: int, since_s: float) -> float:
        """How far ``master`` turned from ``since_s`` (own clock) to its latest status broadcast heard, by the turn
        rates its broadcasts carried (0 where none of it reaches back there: another master's, or none heard). A
        heading-exchange estimate of the master is carried over it (:func:`master_heading_offset`; chosen: with the
        master's IR module broken, its slaves' estimates stood from before the fault, and where the user turned
        about meanwhile the new master of the handover put its user 2-3 m off: u_turn, IR on the master)."""
        turns = self._turns
        if master != self._turn_src or not turns or turns[0][0] > since_s:
            return 0.0
        at = 0.0
        for t, acc, rate in reversed(turns):
            if t <= since_s:
                at = acc + rate * (since_s - t)
                break
        return turns[-1][1] - at

    # -- a slave that lost its master -------------------------------------------------------------
    def start(self, now_s: float) -> None:
        """Our status timeout passed: stop, and claim the master's place if we may (step 2)."""
        node = self.node
        self.lost = node.member_node(0)
        self.electing = True
        self.accepted = None
        self._noticed_s = now_s
        self.claims = {}
        if body_can_be_master(node):
            est = own_user_estimate(node, now_s)
            if est is not None:
                key = claim_key(math.hypot(*est), node.know.mode, node.know.member)
                self.claims[node.node_id] = key
                window = node.cfg.succession.election_window_s
                stagger = 0.01 * node.know.member  # chosen: one 10 ms step per member number
                for at in (stagger, stagger + window / 2):
                    node.later(at, self._send_candidacy, self.lost, key)
        node.clock.process(self._choose(self.lost))

    def master_heard_again(self) -> bool:
        """A status broadcast of the master came after we noticed its loss (its broadcasts were
        lost, not the master): the choice is called off, and we drive on as its slave."""
        status = self.node.know.status
        if self.electing and status is not None and status.time_s > self._noticed_s and self.node.member_node(0) == self.lost:
            self.electing = False
            self.claims = {}
            return True
        return False

    def _send_candidacy(self, lost: int | None, key: tuple[int, int]) -> None:
        node = self.node
        if self.electing and self.lost == lost and node.state == "slave":
            node.send(msg.CANDIDACY, lost=lost, claim=key[0], member=key[1], mode=node.know.mode, lf=True)

    def _on_candidacy(self, frame: Frame) -> None:
        p = frame.payload
        if self.electing and p["lost"] == self.lost and p["lf"]:
            self.claims[frame.src] = (p["claim"], p["member"])

    def _choose(self, lost: int | None):
        """At the end of the window: take over if our claim is the best heard (step 3); otherwise
        wait for the takeover, and return to waiting without one."""
        node = self.node
        cfg = node.cfg.succession
        yield node.clock.timeout(cfg.election_window_s)
        if not self.electing or self.lost != lost or node.state != "slave" or self.master_heard_again():
            return
        own = self.claims.get(node.node_id)
        if own is not None and own == min(self.claims.values()):
            yield from self._take_over(lost, own)
            return
        yield node.clock.timeout(cfg.takeover_timeout_s + cfg.election_window_s)
        if self.electing and self.lost == lost and node.state == "slave" and not self.master_heard_again():
            self.electing = False
            self._leave()  # nobody took the master's place: back to waiting, as before

    # -- the elected slave ------------------------------------------------------------------------
    def _take_over(self, lost: int | None, key: tuple[int, int]):
        node = self.node
        clock = node.clock
        know = node.know
        old_member = know.member
        placed = own_user_and_master(node, clock.now)
        self.user_estimate = placed[0] if placed is not None else None
        self.user_travel = user_travel(*placed, know.mode) if placed is not None else None
        adopted = adopted_swarm_config(node)
        table, formation = succession_plan(node.formation, know.members, old_member, know.mode, adopted.swarm,
                                           leading_user(adopted))
        self._seq += 1  # own count: only the acknowledgements carry it back
        seq = self._seq
        self.accepted = key
        lf = sorted(n for n in table.values() if n in know.lf_members or n == node.node_id)
        payload = dict(seq=seq, lost=lost, claim=key[0], member=key[1], members=dict(table), shape=formation.shape,
                       links=formation.links_payload(), mode=know.mode, lf=lf)
        others = {n for m, n in table.items() if m != 0}
        self._acks = set()
        committed = False
        deadline = clock.now + node.cfg.succession.takeover_timeout_s
        retries = 0
        while others:
            node.send(msg.TAKEOVER, **payload)
            yield clock.timeout(node.cfg.protocol.response_timeout_s)
            if self.accepted != key or node.state not in ("slave", "master"):
                return  # a better claim's takeover came: we yielded
            if not committed and self.master_heard_again():
                self.accepted = None
                return  # the master is alive: its broadcasts were lost
            if not committed and 2 * len(self._acks & others) >= len(others):
                committed = True
                self._commit(table, formation, adopted, lost)
            if others <= self._acks or retries >= node.cfg.protocol.max_retries or (not committed and clock.now >= deadline):
                break
            retries += 1
        if not committed:
            self.electing = False
            self._leave()  # nobody heard us: our own radio is the one that failed

    def _commit(self, table: dict[int, int], formation: Formation, adopted, lost: int | None) -> None:
        node = self.node
        self.electing = False
        node.cfg = adopted  # our user's request as the frames told it (module docstring)
        know = node.know
        know.members = dict(table)
        know.total_members = len(table)
        know.member = 0
        know.status = None
        node.formation = formation
        node.state = "master"
        node.join.replan_after_first_round()  # its table is its own plan: re-planned by its IR fixes (join.py)
        node.connected_user = None  # the user's belt pairs with us by the wake-up procedure (user session)
        node.pans = frozenset({node.swarm_pan})
        self.elections.append((self._noticed_s, node.clock.now, lost, node.node_id))
        node.took_over.emit()

    def _on_ack(self, frame: Frame) -> None:
        if frame.dst == self.node.node_id and frame.payload["seq"] == self._seq:
            self._acks.add(frame.src)

    # -- every member -----------------------------------------------------------------------------
    def _on_takeover(self, frame: Frame) -> None:
        """A slave took the lost master's place (step 4)."""
        node = self.node
        p = frame.payload
        members = {int(m): n for m, n in p["members"].items()}
        if node.node_id not in members.values() or node.state not in ("slave", "master"):
            return
        key = (p["claim"], p["member"])
        if not self.electing and self.accepted is None:
            status = node.know.status
            last = status.time_s if status is not None else node.joined_s
            if node.state != "slave" or node.member_node(0) != p["lost"] \
                    or node.clock.now - last <= node.cfg.protocol.status_timeout_s:
                return  # our master is alive to us: not its successor's member (no acknowledgement)
            self.lost = p["lost"]
        elif p["lost"] != self.lost or (self.accepted is not None and key > self.accepted):
            return  # another loss, or a worse claim than the one we accepted
        node.send(msg.TAKEOVER_ACK, dst=frame.src, seq=p["seq"])
        if self.accepted == key and node.member_node(0) == frame.src:
            return  # a repeat of the takeover we applied
        self.accepted = key
        self.electing = False
        know = node.know
        was_master = node.state == "master"
        know.members = members
        know.total_members = len(members)
        know.member = next(m for m, n in members.items() if n == node.node_id)
        know.mode = p["mode"]
        know.lf_members = frozenset(p["lf"])
        node.formation = Formation.from_links_payload(p["shape"], p["links"])
        node.joined_s = node.clock.now  # the new master's status broadcasts start now
        if was_master:  # a better claim than ours: we yield and drive as its slave (its first
            node.state = "slave"  # acknowledgement makes it the swarm's master: took_over)
