"""The body module (petswarm_env/sim/body.py): the position/heading base of robots and users, the
only code that reads and writes Chipmunk's body state."""

import math

import numpy as np
import pymunk
import pytest

from petswarm_env.config import load_config
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.sim.body import COLLISION_USER, Body, DrivenBody, read_poses
from petswarm_env.sim.world import World


def test_a_body_reads_what_pymunk_holds_and_writes_only_changes():
    space = pymunk.Space()
    b = Body(space, (1.0, -2.0), 0.4, 0.3, COLLISION_USER)
    space.add(b.body, b.shape)
    assert b.body.body_type == pymunk.Body.KINEMATIC and b.shape.collision_type == COLLISION_USER
    assert b.position == b.read_position() == (1.0, -2.0) and b.heading == 0.4
    b.set_velocity((0.5, 0.0), 1.0)
    assert tuple(b.body.velocity) == (0.5, 0.0) and b.turn_rate_rps == b.body.angular_velocity == 1.0
    space.step(0.1)
    assert b.position == pytest.approx((1.05, -2.0)) and b.heading == pytest.approx(0.5)
    assert b.position == tuple(b.body.position) and b.heading == b.body.angle


def test_a_driven_body_reaches_its_command_within_its_limits():
    space = pymunk.Space()
    b = DrivenBody(space, (0.0, 0.0), math.pi / 2, 0.2, 1, 8.0, 2.0, 4.0, friction=0.3, elasticity=0.0)
    space.add(b.body, b.shape)
    assert b.shape.friction == 0.3 and b.body.mass == 8.0
    b.command = (1.0, 0.0, 1.0)  # forward in its own frame: +y in the world
    b.apply(0.1)
    assert b.velocity_body == pytest.approx((0.2, 0.0, 0.4))  # 2 m/s² and 4 rad/s² over 0.1 s
    assert tuple(b.body.velocity) == pytest.approx((0.0, 0.2))
    for _ in range(20):
        space.step(0.1)
        b.apply(0.1)
    assert b.velocity_body[0] == pytest.approx(1.0) and b.velocity_body[2] == pytest.approx(1.0)


def test_read_poses_is_the_truth_arrays():
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    for i in range(3):
        world.add_robot((i, 2.0 * i), 0.1 * i)
    centers, headings = np.zeros((4, 2)), np.zeros(4)
    read_poses(world.robots, centers, 1, headings)
    truth, _, truth_headings = world.truth_arrays()
    assert centers[1:].tolist() == [list(r.position) for r in world.robots] == truth[:3].tolist()
    assert headings[1:].tolist() == [r.heading for r in world.robots] == truth_headings.tolist()
    assert centers[0].tolist() == [0.0, 0.0] and headings[0] == 0.0
    assert truth[3].tolist() == list(world.user.position)


def test_the_drives_hypot_is_pythons_bit_for_bit():
    """The compiled drive's hypot (CPython's vector_norm written in C) gives ``math.hypot``'s value
    to the bit: speeds of every scale, zeros, signs, subnormals, infinities and NaN."""
    from petswarm_env.sim.body import hypot

    rng = np.random.default_rng(0)
    pairs = [rng.normal(0.0, 1.0, (20000, 2)), np.exp(rng.uniform(-740.0, 709.0, (20000, 2))) * rng.choice([-1.0, 1.0], (20000, 2)),
             np.c_[rng.normal(0.0, 1.0, 2000), np.zeros(2000)], rng.normal(0.0, 1e-310, (2000, 2))]
    values = [(x, y) for arr in pairs for x, y in arr.tolist()]
    values += [(0.0, 0.0), (-0.0, 0.0), (3.0, 4.0), (1e308, 1e308), (5e-324, 5e-324), (math.inf, math.nan), (math.nan, 1.0), (-math.inf, 2.0)]
    assert [repr(hypot(x, y)) for x, y in values] == [repr(math.hypot(x, y)) for x, y in values]


def test_a_walking_body_not_on_its_script_steps_toward_a_point_without_turning():
    cfg = load_config()
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    user = world.user
    user.walking, user.returning = False, True
    x0, y0 = user.position
    heading = user.heading
    user.toward_x, user.toward_y, user.toward_mps = x0 + 3.0, y0 + 4.0, 0.5
    user.apply(0.02)
    assert tuple(user.body.velocity) == pytest.approx((0.3, 0.4)) and user.body.angular_velocity == 0.0
    world.space.step(1.0)
    assert user.position == pytest.approx((x0 + 0.3, y0 + 0.4)) and user.heading == heading
    user.returning = False
    user.apply(0.02)
    assert tuple(user.body.velocity) == (0.0, 0.0)
