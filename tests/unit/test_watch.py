"""Smart watch (petswarm_env/wearables/watch.py): seed 002 Table 1 gestures and the remote driver."""

import math

import numpy as np
import pytest

from petswarm_env.config import load_config
from petswarm_env.wearables.watch import GESTURES, RemoteDriver, Watch, gesture_trace, recognise_gesture

CFG = load_config().watch
DT = 0.1  # the env's control period


def recognised(gesture, t=0.0, seed=0):
    watch = Watch(CFG, np.random.default_rng(seed))
    watch.perform(gesture, t)
    cmds = watch.poll(t + CFG.recognition_delay_s)
    assert len(cmds) == 1
    return cmds[0]


def drive(driver, yaw=0.0, t=0.0, max_steps=200):
    """A small kinematic loop: integrate the driver's body-frame command; return yaw, the commands, t."""
    seen = []
    for _ in range(max_steps):
        out = driver.command(t, yaw)
        if out is None:
            return yaw, seen, t
        seen.append(out)
        yaw += out[2] * DT
        t += DT
    raise AssertionError("the driver never finished")


# gesture -> (kind, sign of vx, sign of vy, sign of ω) of seed 002 Table 1
TABLE_1 = {
    "forward": ("move", 1, 0, 0),
    "backward": ("move", -1, 0, 0),
    "left": ("move", 0, 1, 0),
    "right": ("move", 0, -1, 0),
    "up": ("rotate", 0, 0, 1),  # counter-clockwise
    "down": ("rotate", 0, 0, -1),  # clockwise
}


@pytest.mark.parametrize("gesture", [g for g in GESTURES if g != "circle"])
def test_each_gesture_gives_its_command_and_motion(gesture):
    kind, sx, sy, sw = TABLE_1[gesture]
    cmd = recognised(gesture)
    assert cmd.kind == kind and cmd.gestures == (gesture,) and not cmd.diagonal
    driver = RemoteDriver(CFG)
    assert driver.push(cmd) is None
    vx, vy, w = driver.command(0.0, 0.0)
    assert (np.sign(vx), np.sign(vy), np.sign(w)) == (sx, sy, sw)
    if kind == "move":
        assert math.hypot(vx, vy) == pytest.approx(CFG.remote_speed_mps)


def test_circle_cancels():
    cmd = recognised("circle")
    assert cmd.kind == "cancel"
    driver = RemoteDriver(CFG)
    driver.push(recognised("forward"))
    assert driver.command(0.0, 0.0) is not None
    assert driver.push(cmd) == "cancel"
    assert driver.active is None and driver.command(0.1, 0.0) is None


def test_recognition_delay_is_respected():
    watch = Watch(CFG, np.random.default_rng(1))
    watch.perform("left", 2.0)
    assert watch.poll(2.0 + CFG.recognition_delay_s - 0.01) == []
    (cmd,) = watch.poll(2.0 + CFG.recognition_delay_s)
    assert cmd.recognised_s == pytest.approx(2.0 + CFG.recognition_delay_s) and cmd.performed_s == 2.0
    assert watch.poll(10.0) == []  # delivered once


@pytest.mark.parametrize("gesture, sign", [("up", 1.0), ("down", -1.0)])
@pytest.mark.parametrize("yaw0_deg", [0.0, 170.0, -100.0])
def test_up_down_rotate_90_degrees_on_the_ahrs_yaw(gesture, sign, yaw0_deg):
    driver = RemoteDriver(CFG)
    driver.push(recognised(gesture))
    yaw0 = math.radians(yaw0_deg)
    yaw, seen, _ = drive(driver, yaw0)
    assert len(seen) > 5  # it took a while: capped at the remote turn rate
    assert max(abs(w) for _, _, w in seen) <= math.radians(CFG.remote_turn_rate_dps) + 1e-12
    assert math.degrees(yaw - yaw0) == pytest.approx(sign * 90.0, abs=3.0)


def test_move_lasts_the_move_duration():
    driver = RemoteDriver(CFG)
    driver.push(recognised("backward"))
    _, seen, _ = drive(driver, t=5.0)
    assert len(seen) * DT == pytest.approx(CFG.move_duration_s, abs=DT / 2)
    assert driver.active is None


def test_forward_then_left_within_the_window_is_a_diagonal():
    watch = Watch(CFG, np.random.default_rng(2))
    watch.perform("forward", 0.0)
    watch.perform("left", CFG.gesture_duration_s)  # the next stroke right after the first
    cmds = watch.poll(10.0)
    assert [c.gestures for c in cmds] == [("forward",), ("forward", "left")]
    diag = cmds[1]
    assert diag.diagonal and diag.direction == pytest.approx((math.sqrt(0.5), math.sqrt(0.5)))
    driver = RemoteDriver(CFG)
    driver.push(cmds[0])
    driver.command(0.0, 0.0)
    driver.push(diag)  # the diagonal replaces the first move
    vx, vy, w = driver.command(0.1, 0.0)
    assert vx > 0 and vy > 0 and w == 0.0 and vx == pytest.approx(vy)
    assert math.hypot(vx, vy) == pytest.approx(CFG.remote_speed_mps)


def test_moves_outside_the_window_stay_two_moves():
    watch = Watch(CFG, np.random.default_rng(2))
    watch.perform("forward", 0.0)
    watch.perform("left", CFG.combination_window_s + 0.2)
    cmds = watch.poll(10.0)
    assert [c.gestures for c in cmds] == [("forward",), ("left",)]
    assert not any(c.diagonal for c in cmds)


def test_same_axis_moves_do_not_combine():
    watch = Watch(CFG, np.random.default_rng(3))
    watch.perform("forward", 0.0)
    watch.perform("backward", CFG.gesture_duration_s)
    watch.perform("right", 2 * CFG.gesture_duration_s)  # combines with the backward before it
    cmds = watch.poll(10.0)
    assert [c.gestures for c in cmds] == [("forward",), ("backward",), ("backward", "right")]
    assert cmds[2].direction == pytest.approx((-math.sqrt(0.5), -math.sqrt(0.5)))


def test_one_stroke_at_a_time():
    watch = Watch(CFG, np.random.default_rng(4))
    watch.perform("up", 1.0)
    with pytest.raises(ValueError):
        watch.perform("down", 1.0 + CFG.gesture_duration_s / 2)
    with pytest.raises(ValueError):
        watch.perform("wave", 5.0)


def test_misrecognition_comes_from_sloppy_strokes():
    def error_rate(cfg):
        rng = np.random.default_rng(5)
        trials = [(g, recognise_gesture(cfg, gesture_trace(cfg, g, rng))) for g in GESTURES for _ in range(40)]
        return sum(g != r for g, r in trials) / len(trials)

    assert error_rate(CFG) == 0.0
    assert error_rate(CFG.model_copy(update={"cross_axis_leak": 1.0})) > 0.1
