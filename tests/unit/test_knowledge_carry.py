"""An IR fix carried over the robot's own motion in the swarm (middleware/knowledge.py): its own wheel
odometry less the master's broadcast driving speed (seed 000 §3.5's compensation of the ring's update
delay), turned by its own AHRS yaw; no truth."""

import math

import pytest

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.middleware.knowledge import RECKON_GAP_S, IRMeasurement, Knowledge, MasterStatus
from tests.oracles import carried_fix


def _status(vx: float, vy: float) -> MasterStatus:
    return MasterStatus((vx, vy, 0.0), "stop", "following", 0.0, (0.0, -1.0), 0.0)


def _drive(know: Knowledge, steps: int, vx: float, vy: float, yaw: float, t0: float = 0.0) -> float:
    for k in range(steps + 1):
        know.dead_reckon(t0 + 0.1 * k, vx, vy, yaw)
    return t0 + 0.1 * steps


def test_a_fix_recedes_as_the_robot_drives_toward_it_and_turns_with_it():
    know = Knowledge()
    know.dead_reckon(0.0, 0.0, 0.0, 0.3)
    fix = IRMeasurement(2.0, 0.0, 0.0, 0.3, *know.odometry_xy)  # 2 m straight ahead
    assert carried_fix(fix, 0.3, *know.odometry_xy) == pytest.approx(fix.position_now(0.3))
    _drive(know, 10, 0.5, 0.0, 0.3)  # 0.5 m forward
    assert carried_fix(fix, 0.3, *know.odometry_xy) == pytest.approx((1.5, 0.0))
    # turned 90° left on the spot: the robot now stands 1.5 m to the right
    assert carried_fix(fix, 0.3 + math.pi / 2, *know.odometry_xy) == pytest.approx((0.0, -1.5), abs=1e-9)
    _drive(know, 10, 0.0, 1.0, 0.3, t0=2.0)  # 1 m sideways, left: the fix moves right
    assert carried_fix(fix, 0.3, *know.odometry_xy) == pytest.approx((1.5, -1.0))


def test_motion_with_the_swarm_does_not_move_a_fix():
    """A robot that drives as the master broadcasts (it keeps its place in the swarm) sees its
    neighbour's fix stay; it counts only its motion relative to the swarm."""
    know = Knowledge(status=_status(0.8, 0.1))
    know.dead_reckon(0.0, 0.0, 0.0, 0.0)
    fix = IRMeasurement(1.0, math.pi / 2, 0.0, 0.0, *know.odometry_xy)
    _drive(know, 20, 0.8, 0.1, 0.0)
    assert carried_fix(fix, 0.0, *know.odometry_xy) == pytest.approx((0.0, 1.0))
    _drive(know, 10, 0.8 + 0.5, 0.1, 0.0, t0=3.0)  # then 0.5 m/s faster than the swarm for 1 s
    assert carried_fix(fix, 0.0, *know.odometry_xy) == pytest.approx((-0.5, 1.0))


def test_a_gap_in_the_count_starts_it_again():
    know = Knowledge()
    know.dead_reckon(0.0, 1.0, 0.0, 0.0)
    know.dead_reckon(RECKON_GAP_S + 0.1, 1.0, 0.0, 0.0)  # not counted for longer than a gap: no jump
    assert know.odometry_xy == (0.0, 0.0)
    know.dead_reckon(RECKON_GAP_S + 0.2, 1.0, 0.0, 0.0)
    assert know.odometry_xy == pytest.approx((0.1, 0.0))


def test_the_count_follows_each_slaves_true_motion_while_its_user_stands():
    """In an episode (1 + 4, scattered start: the slaves drive to their slots while the user and
    the master stand), each slave's dead-reckoned displacement, turned from its AHRS frame into
    the world by the experimenter, is its true displacement within the odometry's noise (relative: it
    grows with the path driven, which the building's renumbering can make longer than the way)."""
    env = petswarm_env.parallel_env(max_cycles=60)
    policy = make_policy("scripted", PolicySpec.from_env(env), 0)
    obs, _ = env.reset(seed=0)
    policy.reset(0)
    obs, *_ = env.step(policy.act_all(obs))
    ep = env.episode
    nodes, robots = ep.fleet.nodes, ep.world.robots
    start = {}
    for a in env.agents:
        idx = ep.agent_index[a]
        offset = robots[idx].heading - nodes[idx].ahrs_yaw()  # the AHRS frame in the world (the experimenter's)
        start[idx] = (tuple(robots[idx].position), nodes[idx].know.odometry_xy, offset)
    path = {idx: 0.0 for idx in start}
    last = {idx: p for idx, (p, _, _) in start.items()}
    while env.agents and not any(se.user.walking for se in ep.sessions):
        obs, *_ = env.step(policy.act_all(obs))
        for idx in path:
            x, y = robots[idx].position
            path[idx] += math.hypot(x - last[idx][0], y - last[idx][1])
            last[idx] = (x, y)
    moved = 0.0
    for idx, ((x0, y0), (u0, v0), offset) in start.items():
        x1, y1 = robots[idx].position
        u1, v1 = nodes[idx].know.odometry_xy
        du, dv = u1 - u0, v1 - v0
        c, s = math.cos(offset), math.sin(offset)
        true = math.hypot(x1 - x0, y1 - y0)
        err = math.hypot(c * du - s * dv - (x1 - x0), s * du + c * dv - (y1 - y0))
        assert err < 0.05 + 0.1 * path[idx], (idx, err, true, path[idx])
        moved = max(moved, true)
    assert moved > 0.5  # the slaves drove to their slots
