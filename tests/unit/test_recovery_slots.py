"""Recovery moves the fewest metres: after a loss the master puts the remaining members on the slots
by the least total distance it can estimate (middleware/recovery.py, ``RecoveryManager.nearest_slots``)."""

from __future__ import annotations

import itertools
import math
import random
from types import SimpleNamespace

from petswarm_env.config import load_config
from petswarm_env.middleware.formation import formation_for_mode
from petswarm_env.middleware.knowledge import IRMeasurement, Knowledge
from petswarm_env.middleware.leaving import CLEAR_LANE_GAP_M, segment_distance
from petswarm_env.middleware.recovery import RecoveryManager, least_total

CFG = load_config()  # wedge, spacing 1 m: slots 1 (-0.87, 0.5), 2 (-0.87, -0.5), 3 (-1.73, 1), 4 (-1.73, -1)


def _manager(members, fixes, ranges=None, now=10.0):
    know = Knowledge(member=0, total_members=len(members), members=dict(members))
    for n, (x, y) in fixes.items():
        know.ir[n] = IRMeasurement(math.hypot(x, y), math.atan2(y, x), now - 0.2, 0.0)
    node = SimpleNamespace(cfg=CFG, know=know, state="master", formation=formation_for_mode(CFG.swarm, len(members), "following"),
                           clock=SimpleNamespace(now=now), ahrs_yaw=lambda: 0.0, on=lambda kind, handler: None,
                           ring=SimpleNamespace(slot_range_m=ranges or {}))
    return RecoveryManager(node, join=None, forget=lambda n: None, leave=lambda: None)


def test_least_total_is_the_optimum_of_every_permutation():
    rng = random.Random(3)
    for n in range(1, 7):
        for _ in range(50):
            cost = [[rng.random() for _ in range(n)] for _ in range(n)]
            best = min(sum(cost[i][p[i]] for i in range(n)) for p in itertools.permutations(range(n)))
            got = least_total(cost)
            assert sorted(got) == list(range(n)) and math.isclose(sum(cost[i][got[i]] for i in range(n)), best)


def test_the_member_nearest_the_open_slot_takes_it_not_the_highest_number():
    # member 1 (robot 11) lost; robot 13 (member 3) is still on its way, near slot 1; robot 14 holds slot 4
    members = {0: 0, 1: 11, 2: 12, 3: 13, 4: 14}
    rm = _manager(members, {12: (-0.87, -0.5), 13: (-0.95, 0.6), 14: (-1.73, -1.0)})
    remaining = {m: n for m, n in members.items() if n != 11}
    table = formation_for_mode(CFG.swarm, 4, "following")
    # building (metres; the old rule gave robot 14 number 1, 1.7 m, and 13 number 3, 1.0 m): 13 takes slot 1, 12 keeps
    # slot 2, 14 drives 2.0 m across the rear to slot 3
    assert rm.nearest_slots(remaining, table, building=True) == {0: 0, 1: 13, 2: 12, 3: 14}
    # a formation that stands (matching.move_cost: d + d²): no move of 2 m, three of at most one spacing (12 to the
    # front-left slot, 14 up its arm to 12's, 13 back to the rear-left one)
    assert rm.nearest_slots(remaining, table) == {0: 0, 1: 12, 2: 14, 3: 13}


def test_members_at_their_slots_keep_them_and_without_a_fix_the_held_slot_counts():
    members = {0: 0, 1: 11, 2: 12, 3: 13, 4: 14}
    rm = _manager(members, {11: (-0.87, 0.5), 12: (-0.87, -0.5)})  # 13 and 14 unseen (occluded): at their slots
    remaining = {m: n for m, n in members.items() if n != 14}
    assert rm.nearest_slots(remaining, formation_for_mode(CFG.swarm, 4, "following")) == {0: 0, 1: 11, 2: 12, 3: 13}


def test_a_wedge_that_lost_a_front_slave_takes_its_mirror_image_when_that_moves_less():
    """Slot 1 (front, left arm) lost: on the standard table one smaller the right arm's rear robot must
    cross to the left (1.7 m at best, through its neighbours); the mirror image moves one robot 1 m."""
    members = {0: 0, 1: 11, 2: 12, 3: 13, 4: 14}
    rm = _manager(members, {12: (-0.87, -0.5), 13: (-1.73, 1.0), 14: (-1.73, -1.0)})
    remaining = {m: n for m, n in members.items() if n != 11}
    standard = formation_for_mode(CFG.swarm, 4, "following")
    table, formation, mirrored = rm.removal_plan(remaining, standard)
    assert mirrored and table == {0: 0, 1: 12, 2: 13, 3: 14}
    slots = formation.slot_positions()
    assert [tuple(round(float(v), 2) for v in slots[m]) for m in (1, 2, 3)] == [(-0.87, -0.5), (-0.87, 0.5), (-1.73, -1.0)]


def test_a_loss_the_standard_table_serves_as_well_keeps_it():
    members = {0: 0, 1: 11, 2: 12, 3: 13, 4: 14}
    rm = _manager(members, {11: (-0.87, 0.5), 12: (-0.87, -0.5), 13: (-1.73, 1.0)})  # the last slot lost
    remaining = {m: n for m, n in members.items() if n != 14}
    standard = formation_for_mode(CFG.swarm, 4, "following")
    table, formation, mirrored = rm.removal_plan(remaining, standard)
    assert not mirrored and formation is standard and table == {0: 0, 1: 11, 2: 12, 3: 13}


def test_a_member_the_rssi_puts_beyond_its_slot_stays_on_its_slots_bearing():
    """Robot 13 (rear slot, left) has no fresh fix and its RSSI range reads 2.9 m (its slot is 2.0 m away):
    placed on its slot's bearing at that range it is nearest its own slot. With the bearing unknown
    (sqrt(r² + a²), growing with the slot's distance a whatever r says) it was sent to the front slot and
    robot 11, standing between the two, to the rear: both moved 1 m where neither needed to (leading AHRS
    fault, seed 210)."""
    members = {0: 0, 1: 11, 2: 12, 3: 13, 4: 14}
    rm = _manager(members, {11: (-1.25, 0.72), 12: (-0.87, -0.5)}, ranges={13: 2.9})
    remaining = {m: n for m, n in members.items() if n != 14}
    assert rm.nearest_slots(remaining, formation_for_mode(CFG.swarm, 4, "following")) == {0: 0, 1: 11, 2: 12, 3: 13}


def test_a_column_that_lost_a_member_keeps_the_robots_behind_in_their_order():
    """Column 1 + 4 that lost member 2 (2 m behind the master): the master sees only member 1 (the others are
    behind it on the same line) and places members 3 and 4 at their slots, 3 and 4 m back. Every assignment of
    them to the slots 2 and 3 m back moves 2 m in total; the tail robot sent to 2 m stopped against the robot
    at 3 m, and both lost the IR's reach of the robots ahead (column, seed 1). Each moves up one place."""
    cfg = load_config(overrides={"swarm.formation": "column"})
    members = {0: 0, 1: 11, 2: 12, 3: 13, 4: 14}
    rm = _manager(members, {11: (-1.0, 0.0)}, ranges={13: 3.1, 14: 3.8})
    rm.node.cfg, rm.node.formation = cfg, formation_for_mode(cfg.swarm, 5, "following")
    remaining = {m: n for m, n in members.items() if n != 12}
    table, _, _ = rm.removal_plan(remaining, formation_for_mode(cfg.swarm, 4, "following"))
    assert table == {0: 0, 1: 11, 2: 13, 3: 14}


def test_a_handovers_plan_is_laid_in_the_tables_frame_fitted_onto_the_fixes():
    """1 + 8: the new master's own frame lies 30° round from its table's and 0.3 m off (it took the user over off the
    table's heading and moved toward its user): every slot of the table, turned by 30° and shifted, is where its member
    stands. It sees members 1, 2 and 5; it does not see the others. The fit is the 30° turn and the shift, exactly; a
    handover's plan then costs every member, seen or not, as it stands in the table's frame against the new slots laid
    in that frame. A plan without a handover's place is as before: a seen member where its fix puts it, in the
    master's own frame."""
    members = {0: 0, **{m: 10 + m for m in range(1, 9)}}
    table = formation_for_mode(CFG.swarm, 9, "following")
    slots = table.slot_positions()
    turn, shift = math.radians(30.0), (0.3, -0.1)
    c, s = math.cos(turn), math.sin(turn)
    where = {10 + m: (c * slots[m][0] - s * slots[m][1] + shift[0], s * slots[m][0] + c * slots[m][1] + shift[1])
             for m in range(1, 9)}
    rm = _manager(members, {n: where[n] for n in (11, 12, 15)})
    rm.node.formation = table
    (fc, fs), (fx, fy) = rm._slots_onto_fixes([10 + m for m in range(1, 9)], {n: m for m, n in members.items()},
                                              slots.tolist(), 0.0, rm.node.clock.now)
    assert math.isclose(math.atan2(fs, fc), turn, abs_tol=1e-9) and math.isclose(fx, shift[0], abs_tol=1e-9)
    assert math.isclose(fy, shift[1], abs_tol=1e-9)
    remaining = {m: n for m, n in members.items() if n != 16}  # the robot that handed over held slot 6, say
    new = formation_for_mode(CFG.swarm, 8, "following").slot_positions()[1:]
    held, cost = rm._move_costs(remaining, formation_for_mode(CFG.swarm, 8, "following"), shift=(0.0, 0.0))
    for m, row in zip(held, cost):
        assert all(math.isclose(d, math.dist(slots[m], p), abs_tol=1e-9) for d, p in zip(row, new)), m
    held, cost = rm._move_costs(remaining, formation_for_mode(CFG.swarm, 8, "following"))
    assert all(math.isclose(d, math.dist(where[11], p), abs_tol=1e-9) for d, p in zip(cost[held.index(1)], new))
    assert all(math.isclose(d, math.dist(slots[7], p), abs_tol=1e-9) for d, p in zip(cost[held.index(7)], new))


def test_a_handovers_plan_sends_no_member_past_the_place_the_new_master_goes_to():
    """Grid 1 + 4, the master's IR broken: the new master is member 1, beside it (spacing 1 m); it will stand where the
    old master stood, 1 m to its left, and the old master's number is the one lost. Its old slot is open: the member
    straight behind it (robot 13) and the one diagonally behind the old master's place (robot 12) are 1 m and 1.41 m
    from it, and with the robot of the rear slot (14) moving up after either, the two plans cost the same
    (matching.move_cost). The diagonal move passes 0.71 m from the place the new master drives to, inside two radii and
    a lane gap, and the two held each other 6-8 s (seed 4515); with ``PAST_MASTER_M`` it costs more, and robot 13 moves
    straight up while robot 14 takes its slot."""
    cfg = load_config(overrides={"swarm.formation": "grid"})
    old = formation_for_mode(cfg.swarm, 5, "following")
    table, renumber = old.rerooted(1)
    nodes = {0: 10, 1: 11, 2: 12, 3: 13, 4: 14}  # old member -> robot; robot 11 the new master
    members = {renumber[m]: n for m, n in nodes.items()}
    slots = old.slot_positions()
    fixes = {n: (float(slots[m][0] - slots[1][0]), float(slots[m][1] - slots[1][1])) for m, n in nodes.items() if m > 1}
    rm = _manager(members, fixes)
    rm.node.cfg, rm.node.formation = cfg, table
    lost = renumber[0]
    shift = tuple(float(v) for v in table.slot_positions()[lost])
    assert shift == (0.0, 1.0)
    remaining = {m: n for m, n in members.items() if m != lost}
    plan, formation, _ = rm.removal_plan(remaining, formation_for_mode(cfg.swarm, 4, "following"), shift)
    new = {plan[m]: formation.slot_positions()[m] + shift for m in plan if m}
    assert plan[1] == 13 and new[12].tolist() == [-1.0, 1.0], plan
    for n, goal in new.items():
        assert segment_distance(shift, fixes[n], goal) >= 2.0 * cfg.robot.radius_m + CLEAR_LANE_GAP_M, n
