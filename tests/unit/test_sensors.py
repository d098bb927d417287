"""The robot's own sensors (sim/sensors.py): ultrasonic ring, wheel odometry, AHRS."""

import math

import numpy as np
import pytest

from petswarm_env.config import load_config
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.sim.sensors import AHRS, NormalStream, Sensors, UltrasonicRing
from petswarm_env.sim.world import World


def _world(cfg, robots):
    world = World(cfg, SCENARIOS["straight"].script(cfg.user, np.random.default_rng(0)))
    world.user.body.position = (-20.0, 0.0)
    for p, th in robots:
        world.add_robot(p, th)
    return world


def test_ring_ranges_from_the_rim_clipped_and_noisy_in_one_draw():
    cfg = load_config()
    us = cfg.robot.ultrasonic
    world = _world(cfg, [((0.0, 0.0), 0.0), ((1.0, 0.0), math.pi), ((0.0, 0.45), 0.0)])
    ring = UltrasonicRing(cfg.robot, world.wall_a, world.wall_b)
    quiet = load_config(overrides={"robot.ultrasonic.noise_m": 0.0}).robot
    exact = UltrasonicRing(quiet, world.wall_a, world.wall_b).ranges(world, [0, 1], np.random.default_rng(0))
    gap = 1.0 - 2 * cfg.robot.radius_m  # robots 0 and 1 face each other, rim to rim
    assert exact[0, 0] == pytest.approx(gap) and exact[1, 0] == pytest.approx(gap)
    assert exact[0, 2] == pytest.approx(max(0.45 - 2 * cfg.robot.radius_m, us.min_range_m))  # robot 2 on the left, clipped
    assert exact[0, 4] == us.max_range_m  # nothing behind
    got = ring.ranges(world, [0, 1], np.random.default_rng(5))
    noise = np.random.default_rng(5).normal(0.0, us.noise_m, exact.shape)  # one draw of the ring's shape
    want = np.where(exact >= us.max_range_m, us.max_range_m, np.clip(exact + noise, us.min_range_m, us.max_range_m))
    np.testing.assert_allclose(got, want, atol=1e-12)  # a ray that meets nothing reads max_range, noise or not
    assert ring.ranges(world, [], np.random.default_rng(0)).shape == (0, us.count)


def test_sensors_read_every_ring_and_draw_odometry_in_order():
    cfg = load_config()
    world = _world(cfg, [((0.0, 0.0), 0.0), ((1.0, 0.0), math.pi)])
    sensors = Sensors(world, cfg.robot, np.random.default_rng(7))
    ring = UltrasonicRing(cfg.robot, world.wall_a, world.wall_b)
    rng = np.random.default_rng(7)
    assert np.array_equal(sensors.ranges, ring.ranges(world, [0, 1], rng))  # read at construction
    v = (0.5, -0.2, 0.3)
    k = cfg.robot.odometry_noise_rel
    assert k > 0
    e = rng.normal(0.0, k, 3)
    world.robots[1]._wheels = v  # what its motors drive (Robot.wheel_velocity)
    assert sensors.odometry(1) == (v[0] * (1 + e[0]), v[1] * (1 + e[1]), v[2] * (1 + e[2]))
    many = sensors.odometry_noise(4)  # four readings in one draw: the numbers of four draws of 3
    assert many == [rng.normal(0.0, k, 3).tolist() for _ in range(4)]
    assert sensors.odometry(1, many[2]) == tuple(x * (1 + n) for x, n in zip(v, many[2]))
    assert np.array_equal(sensors.read_rings(), ring.ranges(world, [0, 1], rng)) and sensors.ranges.shape == (2, 8)
    exact = Sensors(world, load_config(overrides={"robot.odometry_noise_rel": 0.0}).robot, np.random.default_rng(0))
    assert exact.odometry(1) == v and exact.odometry_noise(3) is None


def test_ahrs_is_truth_plus_a_drifting_bias_and_white_noise():
    cfg = load_config()
    world = _world(cfg, [((0.0, 0.0), 0.7)])
    robot = world.robots[0]
    assert robot.ahrs_yaw == robot.ahrs.yaw
    ahrs = AHRS(robot, cfg.robot, np.random.default_rng(3))
    z = np.random.default_rng(3).standard_normal(256)[::-1]  # the block the AHRS draws from, handed out last first
    noise, drift = math.radians(cfg.robot.ahrs_noise_deg), math.radians(cfg.robot.ahrs_drift_dps)
    assert ahrs.yaw(0.0) == 0.7 + noise * z[0]  # no time passed: no bias step
    bias = drift * math.sqrt(0.5) * z[1]
    assert ahrs.yaw(0.5) == 0.7 + bias + noise * z[2]
    assert ahrs.yaw(0.5) == 0.7 + bias + noise * z[3]  # the same instant: the same bias
    quiet = load_config(overrides={"robot.ahrs_noise_deg": 0.0, "robot.ahrs_drift_dps": 0.0}).robot
    assert AHRS(robot, quiet).yaw(10.0) == 0.7


def test_ahrs_counts_from_its_own_power_on_heading():
    """No shared frame (seed 000 §3.5: no compass): at power-on each AHRS takes a
    random power-on heading (its first draw), so robots facing the same way read unrelated yaws,
    while a robot's own readings still differ by its own rotation; a robot turned before power-on
    with the same stream reads exactly what the unturned one reads."""
    cfg = load_config(overrides={"robot.ahrs_noise_deg": 0.0, "robot.ahrs_drift_dps": 0.0})
    world = _world(cfg, [((0.0, 0.0), 0.7), ((2.0, 0.0), 0.7), ((4.0, 0.0), 0.7 + 1.3)])
    a, b, turned = (AHRS(r, cfg.robot) for r in world.robots)
    a.power_on(np.random.default_rng(1))
    b.power_on(np.random.default_rng(2))
    turned.power_on(np.random.default_rng(1))
    offset = np.random.default_rng(1).uniform(-math.pi, math.pi)
    assert a.yaw(0.0) == pytest.approx(-offset)  # 0.7 − (0.7 + offset)
    assert abs(math.remainder(a.yaw(0.0) - b.yaw(0.0), 2 * math.pi)) > 0.1  # same heading, other frames
    assert turned.yaw(0.0) == pytest.approx(a.yaw(0.0), abs=1e-12)  # the scene's rotation is invisible
    before = a.yaw(1.0)
    world.robots[0].body.angle += 0.4
    assert a.yaw(2.0) - before == pytest.approx(0.4)
    offsets = [AHRS(world.robots[0], cfg.robot) for _ in range(400)]
    for k, s in enumerate(offsets):
        s.power_on(np.random.default_rng(100 + k))
    readings = np.array([s.yaw(0.0) for s in offsets])
    hist, _ = np.histogram(np.mod(readings, 2 * math.pi), bins=4, range=(0, 2 * math.pi))
    assert hist.min() > 60  # spread over the whole circle: no preferred direction


def test_odometry_counts_what_the_wheels_turn_not_a_shove():
    """Wheel encoders: a robot commanded to stop and shoved reads ~0 (its wheels slip); one driving reads
    its wheels' speed, which follows the command under the acceleration limit."""
    import pymunk

    from petswarm_env.config import load_config
    from petswarm_env.sim.robot import Robot
    from petswarm_env.sim.sensors import Odometry

    cfg = load_config(overrides={"robot.odometry_noise_rel": 0.0}).robot
    space = pymunk.Space()
    robot = Robot(0, cfg, space, (0.0, 0.0), 0.0)
    odo = Odometry(robot, cfg, np.random.default_rng(0))
    robot.set_command(0.0, 0.0, 0.0)
    robot.body.velocity = (0.6, 0.0)  # shoved
    for _ in range(3):
        robot.apply(0.02)
        space.step(0.02)
    assert robot.velocity_body[0] > 0.3  # the body still slides
    assert odo.read() == (0.0, 0.0, 0.0)  # the wheels did not turn
    robot.set_command(1.0, 0.0, 0.0)
    for _ in range(5):
        robot.apply(0.02)
        space.step(0.02)
    vx, vy, w = odo.read()
    assert math.isclose(vx, 5 * 0.02 * cfg.max_accel_mps2) and vy == 0.0 and w == 0.0  # the motors' ramp


def test_the_sensor_stream_hands_out_the_generators_normals_in_order():
    """NormalStream draws blocks ahead; the numbers it hands out are those of numpy's normal(0, σ,
    size) calls on the same generator, in order, across block boundaries."""
    stream = NormalStream(np.random.default_rng(5), block=7)
    rng = np.random.default_rng(5)
    for size, scale in [(3, 0.1), (10, 0.02), (1, 1.0), (15, 0.5), (0, 0.3), (7, 2.0)]:
        assert stream.normal(scale, size) == rng.normal(0.0, scale, size).tolist()
        assert stream.standard_normal(size + 2) == rng.standard_normal(size + 2).tolist()


def test_an_ahrs_stream_hands_each_block_out_last_first_as_draws_does():
    """The AHRS's normals come from a NormalStream that hands each block out from its last z to its
    first: the numbers, in the order, of :class:`~petswarm_env.sim.draws.Draws`' normals (its former
    stream), across block boundaries."""
    from petswarm_env.sim.draws import Draws

    stream = NormalStream(np.random.default_rng(9), 256, True)
    draws = Draws(np.random.default_rng(9))
    assert stream.standard_normal(600) == [draws.normal() for _ in range(600)]


def test_the_odometry_of_a_slipping_robot_is_its_wheels_view_with_the_noise():
    """Sensors.odometry (the observation's C reading of the wheels) equals noisy_odometry of
    Robot.wheel_velocity, slip (wheel_gain ≠ 1) or none, bit for bit."""
    from petswarm_env.sim.sensors import noisy_odometry

    cfg = load_config()
    world = _world(cfg, [((0.0, 0.0), 0.0), ((1.0, 0.0), math.pi)])
    sensors = Sensors(world, cfg.robot, np.random.default_rng(7))
    slipping, plain = world.robots
    slipping.wheel_gain = 1.0 / 0.85  # a body that keeps 85 % of what its wheels turn
    for r, v in ((slipping, (0.3, -0.1, 0.7)), (plain, (-0.2, 0.05, -0.4))):
        r._wheels = v
        e = [0.013, -0.021, 0.008]
        assert sensors.odometry(r.index, e) == noisy_odometry(r.wheel_velocity, e)
    assert slipping.wheel_velocity != slipping._wheels
