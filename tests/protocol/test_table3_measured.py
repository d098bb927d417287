"""Table 3 from measurements (seed 000 §3.5, Table 3).

On a driving-mode change with master change, "the closest robot" (leading → following) and "the
robot with the highest hierarchical level" (following → leading: the farthest from the user) are
the ones the master measured so — its IR measurements of the members, its LF track of the user —
not the ones the neighbour table says should be so. A member the master has not measured lately
stands at its nominal slot.
"""

import math

import numpy as np
import pytest

import petswarm_env
from petswarm_env.config import load_config
from petswarm_env.middleware.formation import formation_for_mode, leading_user
from petswarm_env.middleware.knowledge import FRESH_IR_S, IRMeasurement, Knowledge
from petswarm_env.middleware.modes import measured_geometry, nominal_geometry, plan_mode_change

CFG = load_config()


def _know(positions, now=10.0, yaw=0.3):
    """A master's knowledge: members 1.. at node ids 11.., measured at ``positions`` (member ->
    body-frame point, None = never measured), all at ``now`` with its AHRS at ``yaw``."""
    know = Knowledge(member=0, members={m: 10 + m for m in range(5)})
    for m, p in positions.items():
        if p is not None:
            know.ir[10 + m] = IRMeasurement(math.hypot(*p), math.atan2(p[1], p[0]), now, yaw)
    return know


@pytest.mark.parametrize("old, new", [("following", "leading"), ("leading", "following")])
def test_the_measured_geometry_picks_where_the_nominal_one_would_not(old, new):
    f = formation_for_mode(CFG.swarm, 5, old, leading_user(CFG))
    members = {m: 10 + m for m in range(5)}
    slots = f.slot_positions()
    nominal = plan_mode_change(CFG.swarm, f, members, old, new, True, nominal_geometry(f, 1.0), user=leading_user(CFG))
    picked = next(m for m, n in members.items() if n == nominal.members[0])
    # the nominal pick stands, in truth, beside the master: neither closest to nor farthest from the user
    moved = {m: (tuple(slots[m]) if m != picked else (0.0, 1.2 if slots[m][1] >= 0 else -1.2)) for m in range(1, 5)}
    geometry = measured_geometry(f, _know(moved), 0.3, 10.0, None, 1.0)
    assert geometry.measured == frozenset(range(1, 5))
    plan = plan_mode_change(CFG.swarm, f, members, old, new, True, geometry, user=leading_user(CFG))
    distance = {m: geometry.user_distance(m) for m in range(5)}
    want = (max if new == "leading" else min)(distance, key=lambda m: (distance[m], -m if new == "leading" else m))
    assert plan.members[0] == members[want] != nominal.members[0]


def test_an_unseen_member_stands_at_its_slot_and_the_bearing_turns_with_the_master():
    f = formation_for_mode(CFG.swarm, 5, "following")
    slots = f.slot_positions()
    know = _know({1: (-1.0, 0.4), 2: None, 3: (-1.5, 1.0), 4: (-1.7, -1.1)}, now=10.0, yaw=0.3)
    know.ir[13].time_s = 10.0 - FRESH_IR_S - 0.01  # too old
    geometry = measured_geometry(f, know, 0.3 + 0.5, 10.0, (0.9, 0.1), 1.0)  # the master turned 0.5 rad since
    assert geometry.measured == frozenset({1, 4})
    np.testing.assert_allclose(geometry.positions[2], slots[2])
    np.testing.assert_allclose(geometry.positions[3], slots[3])
    b = math.atan2(0.4, -1.0) - 0.5
    np.testing.assert_allclose(geometry.positions[1], (math.hypot(1.0, 0.4) * math.cos(b), math.hypot(1.0, 0.4) * math.sin(b)))
    assert geometry.user_xy == (0.9, 0.1)
    assert measured_geometry(f, know, 0.3, 10.0, None, 1.0).user_xy == (1.0, 0.0)  # no LF track: the standard distance


def test_a_master_change_in_the_env_takes_the_robot_the_master_measured_farthest():
    """Following → leading in a running swarm whose robots do not stand where the table says: the
    nominal pick (the wedge's rear member 3) is put beside the master; the new master is the robot
    the master's IR module saw farthest from its user."""
    env = petswarm_env.parallel_env(max_cycles=200, **{"user.scenario": "straight", "user.start_delay_s": 60.0})
    env.reset(seed=2)
    sw, world = env.episode.swarm, env.episode.world
    members = dict(sw.master.know.members)
    nominal = plan_mode_change(env.cfg.swarm, sw.formation, members, "following", "leading", True,
                               nominal_geometry(sw.formation, 1.0))
    nominal_node = nominal.members[0]
    assert nominal_node == members[3]
    # put member 3 on the master's left, 1.2 m out
    master = world.robots[sw.master.node_id]
    (mx, my), th = master.position, master.heading
    robot = world.robots[nominal_node]
    robot.body.position = (mx - 1.2 * math.sin(th), my + 1.2 * math.cos(th))
    robot.body.velocity = (0.0, 0.0)
    world.invalidate_truth()
    for _ in range(15):  # the ring measures everyone again; nobody drives
        env.step({})
    env.episode.world.user.pending_commands.append("mode:leading")
    for _ in range(60):
        env.step({})
        if sw.events["master_changes"]:
            break
    geometry = sw.last_geometry
    assert geometry is not None and 3 in geometry.measured
    distance = {m: geometry.user_distance(m) for m in geometry.positions}
    farthest = max(distance, key=lambda m: (distance[m], -m))
    assert farthest != 3 and sw.events["master_changes"] == 1
    assert sw.master.node_id == members[farthest] != nominal_node
