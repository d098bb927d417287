"""Mecanum kinematics, command saturation and acceleration limits (SPEC §1; seed 000 §3.6.1)."""

import math

import numpy as np
import pymunk
import pytest

from petswarm_env.config import load_config
from petswarm_env.sim.robot import Robot, body_velocity, saturate_command, wheel_speeds

CFG = load_config().robot
L = CFG.wheel_lever_m


def max_wheel(vx, vy, w):
    return float(np.max(np.abs(wheel_speeds(vx, vy, w, L))))


# -- inverse / forward kinematics ----------------------------------------------------------------


def test_inverse_forward_round_trip():
    rng = np.random.default_rng(1)
    for vx, vy, w in rng.uniform(-2.0, 2.0, (200, 3)):
        back = body_velocity(wheel_speeds(vx, vy, w, L), L)
        assert back == pytest.approx((vx, vy, w), abs=1e-12)


def test_round_trip_other_lever():
    back = body_velocity(wheel_speeds(0.3, -0.7, 1.1, 0.5), 0.5)
    assert back == pytest.approx((0.3, -0.7, 1.1), abs=1e-12)


def test_pure_forward_turns_all_wheels_equally():
    # wheel order: front-left, front-right, rear-left, rear-right
    assert wheel_speeds(0.8, 0.0, 0.0, L) == pytest.approx([0.8, 0.8, 0.8, 0.8])


def test_pure_sideways_is_the_mecanum_x_pattern():
    # strafing left: FL and RR run backwards, FR and RL forwards
    assert wheel_speeds(0.0, 0.5, 0.0, L) == pytest.approx([-0.5, 0.5, 0.5, -0.5])


def test_pure_rotation_runs_left_side_against_right_side():
    # CCW: left wheels backwards, right wheels forwards, all at lever*ω
    w = 1.2
    assert wheel_speeds(0.0, 0.0, w, L) == pytest.approx([-L * w, L * w, -L * w, L * w])


def test_forward_kinematics_of_wheel_patterns():
    assert body_velocity(np.array([1.0, 1.0, 1.0, 1.0]), L) == pytest.approx((1.0, 0.0, 0.0))
    assert body_velocity(np.array([-1.0, 1.0, 1.0, -1.0]), L) == pytest.approx((0.0, 1.0, 0.0))
    assert body_velocity(np.array([-1.0, 1.0, -1.0, 1.0]), L) == pytest.approx((0.0, 0.0, 1.0 / L))


# -- saturation ------------------------------------------------------------------------------------


def test_command_within_limits_is_unchanged():
    assert saturate_command(0.5, -0.3, 0.4, CFG) == pytest.approx((0.5, -0.3, 0.4))


@pytest.mark.parametrize(
    "cmd",
    [(3.0, 0.0, 0.0), (0.0, -4.0, 0.0), (2.0, 2.0, 0.0), (1.4, -0.9, 1.5), (-1.0, 1.3, -1.9), (5.0, 5.0, 1.0)],
)
def test_saturation_keeps_direction_and_caps_wheels(cmd):
    vx, vy, w = cmd
    assert abs(w) <= CFG.max_omega_rps  # so only the wheel scaling acts
    assert max_wheel(vx, vy, w) > CFG.max_speed_mps  # these commands do saturate
    svx, svy, sw = saturate_command(vx, vy, w, CFG)
    # the peak wheel is exactly at the limit
    assert max_wheel(svx, svy, sw) == pytest.approx(CFG.max_speed_mps)
    # one common factor k in (0, 1) on all three components: the direction is kept
    ks = [s / c for s, c in zip((svx, svy, sw), cmd) if c != 0]
    assert all(0 < k < 1 for k in ks)
    assert ks == pytest.approx([ks[0]] * len(ks))
    assert all(s == 0 for s, c in zip((svx, svy, sw), cmd) if c == 0)


def test_pure_translation_saturates_at_max_speed():
    vx, vy, w = saturate_command(10.0, 0.0, 0.0, CFG)
    assert (vx, vy, w) == pytest.approx((CFG.max_speed_mps, 0.0, 0.0))
    # diagonal: wheels see |vx| + |vy|, so the body speed is lower than the straight-line maximum
    vx, vy, _ = saturate_command(10.0, 10.0, 0.0, CFG)
    assert vx + vy == pytest.approx(CFG.max_speed_mps)
    assert vx == pytest.approx(vy)


def test_omega_is_clipped_to_its_limit():
    assert saturate_command(0.0, 0.0, 10.0, CFG)[2] == pytest.approx(CFG.max_omega_rps)
    assert saturate_command(0.0, 0.0, -10.0, CFG)[2] == pytest.approx(-CFG.max_omega_rps)
    # clipping ω comes first; the wheel scaling may then reduce it further, never raise it
    vx, vy, w = saturate_command(1.5, 0.0, 10.0, CFG)
    assert 0 < w < CFG.max_omega_rps
    assert vx / w == pytest.approx(1.5 / CFG.max_omega_rps)
    assert max_wheel(vx, vy, w) == pytest.approx(CFG.max_speed_mps)


def test_random_commands_never_exceed_limits():
    rng = np.random.default_rng(7)
    for vx, vy, w in rng.uniform(-5, 5, (300, 3)):
        svx, svy, sw = saturate_command(vx, vy, w, CFG)
        assert max_wheel(svx, svy, sw) <= CFG.max_speed_mps + 1e-9
        assert abs(sw) <= CFG.max_omega_rps + 1e-12


# -- acceleration limits on a physical robot ---------------------------------------------------------


def make_robot(heading=0.0):
    space = pymunk.Space()
    space.gravity = (0.0, 0.0)
    return Robot(0, CFG, space, (0.0, 0.0), heading), space


def speed(robot):
    v = robot.body.velocity
    return math.hypot(v.x, v.y)


def test_robot_command_is_saturated():
    robot, _ = make_robot()
    robot.set_command(5.0, 0.0, 9.0)
    assert max_wheel(*robot.command) == pytest.approx(CFG.max_speed_mps)
    assert robot.command[2] < CFG.max_omega_rps


@pytest.mark.parametrize("heading", [0.0, 1.0, -2.5])
def test_acceleration_limit_on_step_command(heading):
    robot, space = make_robot(heading)
    dt = 0.01
    robot.set_command(1.5, 0.0, 0.0)
    robot.apply(dt)
    assert speed(robot) <= CFG.max_accel_mps2 * dt + 1e-9
    assert speed(robot) == pytest.approx(CFG.max_accel_mps2 * dt)  # and it does accelerate
    space.step(dt)
    # the body-frame command is forward: the world velocity points along the heading
    v = robot.body.velocity
    assert math.atan2(v.y, v.x) == pytest.approx(heading, abs=1e-9)
    prev = speed(robot)
    for _ in range(20):
        robot.apply(dt)
        space.step(dt)
        assert speed(robot) - prev <= CFG.max_accel_mps2 * dt + 1e-9
        prev = speed(robot)


def test_reaches_the_command_after_enough_time():
    robot, space = make_robot(0.3)
    dt = 0.01
    robot.set_command(1.5, 0.0, 0.0)
    t_needed = 1.5 / CFG.max_accel_mps2  # 0.75 s
    steps = int(math.ceil(t_needed / dt))
    for _ in range(steps - 2):
        robot.apply(dt)
        space.step(dt)
    assert speed(robot) < 1.5 - 1e-6  # not earlier than the limit allows
    for _ in range(10):
        robot.apply(dt)
        space.step(dt)
    assert speed(robot) == pytest.approx(1.5, abs=1e-9)
    assert robot.velocity_body[0] == pytest.approx(1.5, abs=1e-9)
    assert robot.velocity_body[1] == pytest.approx(0.0, abs=1e-9)


def test_angular_acceleration_limit():
    robot, space = make_robot()
    dt = 0.01
    robot.set_command(0.0, 0.0, 2.0)
    robot.apply(dt)
    assert robot.body.angular_velocity == pytest.approx(CFG.max_alpha_rps2 * dt)
    for _ in range(100):
        robot.apply(dt)
        space.step(dt)
    assert robot.body.angular_velocity == pytest.approx(2.0)


def test_braking_is_also_limited():
    robot, space = make_robot()
    dt = 0.01
    robot.set_command(1.0, 0.0, 0.0)
    for _ in range(100):
        robot.apply(dt)
        space.step(dt)
    assert speed(robot) == pytest.approx(1.0)
    robot.set_command(0.0, 0.0, 0.0)
    robot.apply(dt)
    assert speed(robot) == pytest.approx(1.0 - CFG.max_accel_mps2 * dt)
