"""The physical world: scenarios, the user, obstacles and the ultrasonic ring."""

import math

import numpy as np
import pytest

from petswarm_env.config import load_config
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.sim.body import COLLISION_ROBOT
from petswarm_env.sim.robot import Robot
from petswarm_env.sim.sensors import UltrasonicRing
from petswarm_env.sim.world import World


def _walk(name, seconds, seed=0, **overrides):
    cfg = load_config(overrides={"user.scenario": name, **overrides})
    world = World(cfg, SCENARIOS[name].script(cfg.user, np.random.default_rng(seed)))
    world.user.walking = True
    world.advance(int(seconds / world.dt_sub))
    return world


@pytest.mark.parametrize("name, turn_deg", [("turn_left_60", 60.0), ("turn_right_60", -60.0), ("u_turn", 180.0)])
def test_turn_scenarios_turn_by_their_angle(name, turn_deg):
    world = _walk(name, 30.0)
    assert math.degrees(world.user.heading) == pytest.approx(turn_deg, abs=1.0)


def test_user_stands_during_the_start_delay_then_walks():
    cfg = load_config()
    world = _walk("straight", cfg.user.start_delay_s - 0.2)
    assert world.user.position == pytest.approx((0.0, 0.0), abs=1e-9)
    world.advance(int((10.2) / world.dt_sub))
    assert world.user.position[0] == pytest.approx(cfg.user.walk_speed_mps * 10.0, rel=0.02)


def test_stop_and_go_stops():
    world = _walk("stop_and_go", load_config().user.start_delay_s + 6.5)
    assert world.user.activity == "stop"


def test_random_walk_is_seeded():
    a = _walk("random_walk", 20.0, seed=1).user.position
    b = _walk("random_walk", 20.0, seed=1).user.position
    c = _walk("random_walk", 20.0, seed=2).user.position
    assert a == b and a != c


def test_unknown_scenario_is_refused_with_the_choices():
    from petswarm_env import scenarios

    with pytest.raises(ValueError, match="unknown scenario 'moonwalk'; choose one of: straight, .*zigzag"):
        scenarios.get("moonwalk")
    assert len(SCENARIOS) == 12  # the 8 walks, heterogeneous and the 3 runtime-change scenarios


def test_ultrasonic_sees_a_box_ahead_and_a_robot_collides_with_it():
    cfg = load_config(overrides={"world.obstacles": [{"center_m": [3.0, 0.0], "size_m": [1.0, 2.0]}]})
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    world.user.body.position = (-10.0, 0.0)
    robot: Robot = world.add_robot((1.0, 0.0), 0.0)
    rng = np.random.default_rng(0)
    ring = UltrasonicRing(cfg.robot, world.wall_a, world.wall_b)
    front = ring.ranges(world, [0], rng)[0, 0]
    assert front == pytest.approx(3.0 - 0.5 - 1.0 - cfg.robot.radius_m, abs=0.05)
    back = ring.ranges(world, [0], rng)[0, 4]
    assert back == pytest.approx(cfg.robot.ultrasonic.max_range_m)  # nothing behind within range
    robot.set_command(1.0, 0.0, 0.0)
    world.advance(400)  # 4 s at 1 m/s: it reaches the box
    assert world.collisions.robot_wall >= 1
    assert robot.position[0] < 2.5 - cfg.robot.radius_m + 0.05  # the box stops it


def test_robots_bump_into_the_user_and_the_user_does_not_yield():
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    robot = world.add_robot((-2.0, 0.0), 0.0)
    robot.set_command(1.0, 0.0, 0.0)
    world.advance(300)
    assert world.collisions.robot_user >= 1
    assert world.user.position == pytest.approx((0.0, 0.0), abs=1e-6)


def test_truth_arrays_follow_the_physics_and_are_read_only():
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    robot = world.add_robot((1.0, 2.0), 0.5)
    centers, radii, headings = world.truth_arrays()
    assert centers[0].tolist() == [1.0, 2.0] and headings[0] == 0.5
    assert radii.tolist() == [cfg.robot.radius_m, cfg.user.radius_m]
    with pytest.raises(ValueError):
        centers[0, 0] = 0.0
    robot.set_command(1.0, 0.0, 1.0)
    world.advance(5)
    c2, _, h2 = world.truth_arrays()
    assert c2[0].tolist() == list(robot.position) and h2[0] == robot.heading and c2[0, 0] > 1.0
    world.add_robot((-1.0, 0.0), 0.0)  # a new body: new arrays
    assert world.truth_arrays()[0].shape == (3, 2)
    robot.body.position = (9.0, 9.0)  # moved by hand: stale until told
    world.invalidate_truth()
    assert world.robot_positions()[0].tolist() == [9.0, 9.0]


def test_truth_lists_are_the_truth_arrays_values_read_either_way():
    """``World.truth_lists`` (what an IR slot reads) gives the truth arrays' values as Python floats,
    read straight from the bodies when the arrays are stale and from the arrays when they are
    current; a new body and a body moved by hand (told) are seen."""
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    robot = world.add_robot((1.0, 2.0), 0.5)
    world.add_robot((-0.3, 0.7), -2.0).set_command(0.4, -0.2, 0.8)
    robot.set_command(1.0, 0.0, 1.0)

    def as_arrays(lists):
        return [[list(c) for c in lists[0]], list(lists[1]), list(lists[2])]

    for steps in (3, 1, 2):
        world.advance(steps)
        direct = world.truth_lists()  # the arrays are stale: read from the bodies
        centers, radii, headings = world.truth_arrays()
        want = [centers.tolist(), radii.tolist(), headings.tolist()]
        assert as_arrays(direct) == want and all(type(v) is float for v in direct[1] + direct[2])
        world.advance(1)
        world.truth_arrays()
        assert as_arrays(world.truth_lists()) == [a.tolist() for a in world.truth_arrays()]  # from the current arrays
    world.add_robot((3.0, -1.0), 1.0)
    assert len(world.truth_lists()[0]) == 4 and world.truth_lists()[0][2] == (3.0, -1.0)
    robot.body.position = (9.0, 9.0)
    world.invalidate_truth()
    assert tuple(world.truth_lists()[0][0]) == (9.0, 9.0)


def _pushing_world():
    """A robot driving into another one at 1 m/s: contacts every substep."""
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    world.user.body.position = (-10.0, 0.0)
    a, b = world.add_robot((0.0, 0.0), 0.0), world.add_robot((0.5, 0.0), 0.0)
    a.command = (1.0, 0.0, 0.0)
    world.invalidate_truth()
    return world, a, b


def test_the_substep_loop_steps_the_space_as_pymunk_does():
    """World.advance (body.Substeps, Chipmunk's step called directly in the compiled form) against
    the same substeps written out with pymunk's own Space.step: the same bodies, bit for bit."""
    fast, _, _ = _pushing_world()
    slow, _, _ = _pushing_world()
    fast.advance(100)
    dt = slow.dt_sub
    for k in range(1, 101):
        slow.clock.run_until(k * dt)
        for body in (*slow.robots, *slow.users):
            body.apply(dt)
        slow.space.step(dt)
    assert [(r.position, r.heading, r.velocity_body) for r in fast.robots] == \
        [(r.position, r.heading, r.velocity_body) for r in slow.robots]
    assert fast.collisions.robot_robot == slow.collisions.robot_robot > 0
    assert fast.substeps.steps == fast.substeps.done == 100


def test_what_a_collision_callback_defers_runs_after_the_substep():
    """A post-step callback and a body removal asked for inside Chipmunk's step (pymunk defers them
    while the space is locked) run after that substep, as pymunk's Space.step runs them."""
    world, a, b = _pushing_world()
    seen = []

    def begin(arbiter, space, data):
        seen.append(space._locked)
        space.add_post_step_callback(lambda sp, key, tag: seen.append(tag), "post", "post")
        space.remove(b.body, b.shape)

    world.space.on_collision(COLLISION_ROBOT, COLLISION_ROBOT, begin=begin)
    world.advance(40)
    assert seen[:2] == [True, "post"]
    assert b.body not in world.space.bodies and not world.space._locked
