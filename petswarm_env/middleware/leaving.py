"""A robot leaving its swarm's formation for its own fault (seed 003 Algorithm 2 step 5: "the faulty
robot leaves"): where it drives, for how long, and whether it is in anyone's way. A mixin of
:class:`~.recovery.RecoveryManager`, whose state (``clear_out``, ``pace_until_m``, ``back_after_m``,
``_cleared``, ``_was_master``) and robot (``node``) it reads; its command is the robot's middleware's, on its own
MCU clock, from its wheel odometry alone."""

from __future__ import annotations

import math

from petswarm_env.middleware.formation import Formation
from petswarm_env.sim.geometry import wrap_angle


class Leaving:
    """The move out of the formation, on a :class:`~.recovery.RecoveryManager`."""

    def _plan_clear_out(self, members: dict[int, int] | None = None, formation: Formation | None = None,
                        cut_off: bool = False) -> None:
        """The robot leaves its slot for its own fault (seed 003 Algorithm 2 step 5: "the faulty robot
        leaves"): it drives out of the formation, sideways in its own frame, away from the formation's
        axis (its slot's side; the left for a slot on the axis), until it stands beyond the formation's
        outermost slot by its diameter and :data:`CLEAR_MARGIN_M`. It keeps the swarm's pace from the
        master's last status broadcast and :data:`CLEAR_AHEAD_MPS` more only until a gap of :data:`CLEAR_LANE_GAP_M` lies between it and the outermost
        slot's lane (:attr:`pace_until_m`, sideways metres); the rest of the way it moves sideways only,
        standing along the walk, so the swarm walks past it; then it stops (chosen: a robot that stops
        where it was stands in the path of the member that takes its place and of the members behind
        it, which the walking formation drives into; one that keeps the swarm's pace all the way holds
        a fixed direction while the swarm may turn — on a zigzag walk it cut across the formation or
        stopped beside it where the next turn brought the swarm onto it). The command is its
        middleware's (:meth:`leaving_command`); it needs no sensor that may have failed: the wheels alone.

        ``cut_off``: the robot is the master itself, cut off from its swarm (:meth:`plan_clear_out_cut_off`),
        and leaves as a master that handed its user over.

        A robot in nobody's way stops where it stands instead (:meth:`in_the_way`, on ``members`` and
        ``formation``, the tables of the member update that removed it): the swarm walks on away from it
        (chosen: the rear robot of a wedge's arm, moving out at the swarm's pace while the swarm turned
        toward its side, was carried ahead into the lane of the front robot of its arm, which then ran
        into it as it stood — slave faults on the zigzag walk; docs/faults.md). An old master's move:
        :meth:`_plan_old_master`."""
        node = self.node
        if node.formation is None:
            return
        pos = node.formation.slot_positions()
        member = node.know.member
        was_master = self._was_master or cut_off
        if not (0 < member or cut_off) or member >= len(pos):
            return
        self.back_after_m = math.inf  # (an old master of a following swarm's move sets it below)
        self._clear_dir = (0.0, 1.0)  # the move's progress is counted along this, body frame: sideways (across the walk: below)
        status = node.know.status  # the master's pace (none heard yet: its own)
        vx = float(status.velocity[0]) if status is not None else float(node.odometry.read()[0])
        lateral = float(pos[member][1])
        side = 1.0 if lateral >= 0 else -1.0
        if members is not None and formation is not None and not was_master \
                and not self.in_the_way(members, formation, 1.0 if vx >= 0 else -1.0):
            self.clear_out = (node.clock.now, 0.0, side * CLEAR_SPEED_MPS, 0.0)  # (0, 0, 0) at the next step
            self._cleared = (node.clock.now, 0.0)
            return
        outermost = max((float(p[1]) * side for p in pos), default=0.0)
        clear_m = outermost - lateral * side + 2.0 * node.cfg.robot.radius_m  # beside the outermost slot's robot
        out_m = clear_m + CLEAR_MARGIN_M
        if was_master:
            self._plan_old_master(pos, member, side, clear_m, out_m, cut_off)
            return
        self.pace_until_m = clear_m + CLEAR_LANE_GAP_M
        ahead = math.copysign(CLEAR_AHEAD_MPS, vx)  # ahead the way the swarm walks
        self.clear_out = (node.clock.now, vx + ahead, side * CLEAR_SPEED_MPS, out_m)
        self._cleared = (node.clock.now, 0.0)

    def _plan_old_master(self, pos, member: int, side: float, clear_m: float, out_m: float, cut_off: bool) -> None:
        """The move out of a master that handed its user over (or was cut off): ``pos`` its formation's slots,
        ``member`` its own, ``side`` its slot's side, ``clear_m`` to beside the outermost slot's robot, ``out_m`` the whole move.

        Following: sideways at the wheels' top speed (:data:`HANDOVER_SIDE_MPS`), keeping no pace, until it is clear
        of the outermost slot's lane by :data:`CLEAR_LANE_GAP_M` (:attr:`back_after_m`), and from there sideways and
        back against the walk (:data:`HANDOVER_BACK_MPS`), so that it is left behind the swarm's tail (chosen: backing
        off from the start, it crossed the arm of a wedge behind it, whose robots stand 30° off the back axis, and ran
        into them; sideways alone, the zigzag walk re-formed less; docs/faults.md). With no slot behind its own (a
        row: its members stand beside it) it backs straight off at :data:`BEHIND_ROW_MPS` for :data:`BEHIND_ROW_M` and
        stops behind the row (:func:`_slot_behind`; chosen: sideways it drove through the members beside it and carried
        the outer one off, 4 m and more: row, IR on the master, seeds 4400-4419, re-formed 12 of 20; standing where it
        stood, the new master drove onto it on its way to its user's line and pushed it into the members' lane).

        Leading: out at that speed without the swarm's pace (chosen: at a slave's pace and speed it stood beside the
        new master's lane when a zigzag turn brought the swarm onto it, the new master's obstacle exception stopped it
        and its user walked on alone; leading zigzag, seeds 300-339: the user driven to the end 16 -> 34 of 40;
        straight, seeds 200-239: re-formed 35 -> 38 of 40), across the walk it told the new master (its ψ, carried
        over its own turn since by its AHRS), else sideways (chosen: just after a zigzag's turn its back is up to 80°
        off the walk, and sideways it drove along the new master's way ahead of their user, where that one's obstacle
        exception stopped it: seeds 300-339, driven to the end 31 -> 40 of 40 with the new master's heading
        estimates carried over the old master's broadcast turn, succession.master_turned)."""
        node = self.node
        now = node.clock.now
        self.pace_until_m = 0.0
        self._cleared = (now, 0.0)
        if node.know.mode == "following" and not _slot_behind(pos, member, lane_near_m(node.cfg.robot.radius_m)):
            self._clear_dir, self.back_after_m = (1.0, 0.0), 0.0  # straight back, counted along the walk
            self.clear_out = (now, -BEHIND_ROW_MPS, 0.0, BEHIND_ROW_M)
        elif node.know.mode == "following":  # its +x: it faced its user
            self.back_after_m = clear_m + CLEAR_LANE_GAP_M
            self.clear_out = (now, -HANDOVER_BACK_MPS, side * HANDOVER_SIDE_MPS, out_m)
        else:  # leading: its front; the swarm walks the way its back faces
            told = None if cut_off else node.modes.walk_told
            vx, vy = 0.0, side * HANDOVER_SIDE_MPS
            if told is not None:
                across = told[0] - wrap_angle(node.ahrs_yaw() - told[1]) - side * 0.5 * math.pi
                self._clear_dir, self.back_after_m = (math.cos(across), math.sin(across)), 0.0
                vx, vy = HANDOVER_SIDE_MPS * self._clear_dir[0], HANDOVER_SIDE_MPS * self._clear_dir[1]
            self.clear_out = (now, vx, vy, out_m)

    def plan_clear_out_cut_off(self) -> None:
        """A master cut off from its swarm (its radio silent: no ring frame of any member,
        :meth:`~.sequence.SequenceManager.cut_off`) releases its user and returns to waiting; first it plans
        the move out of its formation that a master handing its user over makes (:meth:`_plan_clear_out`: the
        slaves choose a new master among themselves, which drives to where it stands). Chosen: standing, it was
        in the leading successor's travel direction and that robot's obstacle exception stopped it while its
        user walked on alone (leading, the master radio-silent at 20 s, seeds 1300-1319: the user driven to the
        end in 12 of 20 with the successor's walk direction and place rule, 20 with the move out; seeds 0-39:
        24 -> 40 of 40). From its own tables and wheels; no radio is needed."""
        self._plan_clear_out(cut_off=True)

    def in_the_way(self, members: dict[int, int], formation: Formation, walk: float) -> bool:
        """Whether this robot, standing at the slot it held, is in a remaining member's way: within its
        diameter and :data:`CLEAR_LANE_GAP_M` of the straight move of a member from the slot it held to the
        slot ``formation`` gives it (``members``: member number -> node id, of the member update), or of
        the lane of a new slot behind it the way the swarm walks (``walk``, +1 or -1 along the formation's
        x: such a member walks into a robot that stands). In the formation's frame, from the tables the
        master sent (seed 000 Fig. 8: the member and neighbour tables); no sensor is read."""
        node = self.node
        old = node.formation.slot_positions()
        new = formation.slot_positions()
        me = old[node.know.member]
        near = lane_near_m(node.cfg.robot.radius_m)
        held = {n: m for m, n in node.know.members.items()}
        for m, n in members.items():
            if m == 0 or m >= len(new):
                continue
            if (float(new[m][0]) - me[0]) * walk < 0 and abs(float(new[m][1]) - me[1]) < near:
                return True  # its lane passes here
            a = held.get(n)
            if a is not None and a < len(old) and segment_distance(me, old[a], new[m]) < near:
                return True  # it moves through here
        return False

    def leaving_command(self, now_s: float | None = None) -> tuple[float, float, float] | None:
        """The body-frame command of the move out of the formation (:meth:`_plan_clear_out`) until its
        wheel odometry counts the sideways distance (or :data:`CLEAR_TIMEOUT` times the time it takes at
        the commanded speed passed), (0, 0, 0) once, then None (nothing to drive). It runs on the robot's
        own MCU clock (seed 000 §3.3: each robot its own clock), as the plan did; ``now_s``, the caller's
        time, is not read (before, the episode's true time against the plan's local time: the move never
        timed out, and its first odometry step counted the clocks' offset, so a leaving robot drove
        sideways for the rest of the episode)."""
        c = self.clear_out
        if c is None:
            return None
        now_s = self.node.clock.now
        t0, vx, vy, out_m = c
        last_s, done_m = self._cleared
        ox, oy, _ = self.node.odometry.read()
        ux, uy = self._clear_dir
        done_m += abs(ox * ux + oy * uy) * (now_s - last_s)  # the wheels' travel since, sideways (or across the walk)
        self._cleared = (now_s, done_m)
        if done_m < out_m and now_s - t0 < CLEAR_TIMEOUT * out_m / abs(vx * ux + vy * uy) and self.node.state == "waiting":
            # the swarm's pace until out of the lanes, then standing along the walk (the swarm walks past); an old
            # master of a following swarm backs off beyond the lanes
            along = done_m < self.pace_until_m or done_m >= self.back_after_m
            return (vx if along else 0.0, vy, 0.0)
        self.clear_out = None
        return (0.0, 0.0, 0.0)


CLEAR_SPEED_MPS = 0.5  # chosen: the sideways speed of a faulty robot leaving the formation (a third of the top speed)
CLEAR_TIMEOUT = 3.0  # chosen: the move out gives up after three times its time at the commanded speed (a robot held by a contact)
# chosen: a slave also drives ahead of the swarm's pace, out of the way of the member behind it that moves up
# (a master that handed its user over does not: the user and the new master are ahead of it)
CLEAR_AHEAD_MPS = 0.25
# chosen: the old master of a following swarm (swarm.hand_over_for_fault) moves out sideways at the wheels' top speed (a
# Pet-Bot's) with no pace, and once clear of the lanes sideways and back against the walk: its own pace carried it into
# a zigzag's turn, and backing off from the start ran it into a wedge's arm (docs/faults.md); the old master of a
# leading swarm sideways at HANDOVER_SIDE_MPS alone (RecoveryManager._plan_clear_out)
HANDOVER_SIDE_MPS, HANDOVER_BACK_MPS = 1.0, 0.5
# chosen: the old master of a following row (no slot behind its own) backs straight off at a Pet-Bot's top speed
# (robot.max_speed_mps; a slower body's wheels clip it) for a robot diameter and a lane gap and more, out of the row
# before the new master, driving onto its user's line, reaches its place. The master's IR fault, row, re-formed
# against stopping where it stood: seeds 0-99 74 -> 83, 4500-4549 39 -> 44 of 50, 1300-1399 82 -> 83 (at 0.5 m/s:
# 77 and 44; 1.0 m/s: 77 and 43; 0.6 m: 81 and 43; 2.0 m: 83 and 44; docs/faults.md)
BEHIND_ROW_MPS, BEHIND_ROW_M = 1.5, 1.0
# chosen: its clearance beyond the formation's outermost slot (a formation drifts sideways by half a spacing as it
# re-forms; a master that handed its user over: its formation then re-centres on the new master, which drives onto
# the user's line, half a spacing or more sideways — IR on the master, seeds 20-39: re-formed 14/20 with 1.0 m,
# 17/20 with 1.5 m). A slave's was 1.0 m while it kept the swarm's pace all the way; standing along the walk for the
# last part, it stands clear of the passing swarm at 1.5 m as the master did (slave faults on a zigzag walk, seeds
# 100-119: re-formed 18/18/20 of 20 against 18/17/17 at 1.0 m; docs/faults.md)
CLEAR_MARGIN_M = 1.5
# chosen: the leaving robot keeps the swarm's pace until this gap (one robot diameter at the shipped 0.2 m radius)
# lies between it and the robot of the outermost slot's lane; the member behind it in its lane can no longer run
# into it there (slave faults, seeds 200-219: zigzag re-formed 19/18/18 of 20, before 17/16/16; straight 20/20/19,
# before 19/20/20 — calibrated on those seeds, and noisy: 0.6 m read 19/16/13 on the zigzag)
CLEAR_LANE_GAP_M = 0.4


def lane_near_m(radius_m: float) -> float:
    """How near a robot of radius ``radius_m`` may pass another's place or lane before it is in its way: its diameter
    and :data:`CLEAR_LANE_GAP_M`."""
    return 2.0 * radius_m + CLEAR_LANE_GAP_M


def _slot_behind(pos, member: int, near_m: float) -> bool:
    """Whether a slot of the formation (``pos``: slot positions) lies behind slot ``member`` within ``near_m`` of its
    lane (the formation's frame: +x the way the master faces). An old master's slot of the table re-rooted at the new
    master (modes.plan_master_handover) is where it stood about that one."""
    x0, y0 = float(pos[member][0]), float(pos[member][1])
    return any(k != member and float(p[0]) < x0 and abs(float(p[1]) - y0) < near_m for k, p in enumerate(pos))


def segment_distance(p, a, b) -> float:
    """The distance from point ``p`` to the segment from ``a`` to ``b`` (2-D)."""
    ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
    dx, dy = bx - ax, by - ay
    n2 = dx * dx + dy * dy
    t = 0.0 if n2 == 0.0 else min(1.0, max(0.0, ((float(p[0]) - ax) * dx + (float(p[1]) - ay) * dy) / n2))
    return math.hypot(float(p[0]) - ax - t * dx, float(p[1]) - ay - t * dy)
