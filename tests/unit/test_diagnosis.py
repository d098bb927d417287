"""A robot's own sensor diagnosis (middleware/diagnosis.py) on hand-made readings: what it concludes
from its own sensors only."""

from __future__ import annotations

from types import SimpleNamespace

from petswarm_env.config import load_config
from petswarm_env.middleware import diagnosis as D
from petswarm_env.middleware.knowledge import IRMeasurement, Knowledge
from petswarm_env.sim.faults import FaultState

CFG = load_config()
MAX = CFG.robot.ultrasonic.max_range_m


def _diag():
    robot = SimpleNamespace(health=FaultState(), command=(0.0, 0.0, 0.0), ahrs=SimpleNamespace(_last_yaw=0.0),
                            spec=None, sensors_off=set())
    know = Knowledge(member=1, members={0: 0, 1: 1, 2: 2})
    ring = SimpleNamespace(slot_starts={}, slot_range_m={}, own_slot=None, report_s=-1.0)
    d = D.Diagnosis(1, CFG, robot, lambda: know, ring)
    found = []
    d.on_detect = found.append
    return d, robot, know, found


def test_a_frozen_ahrs_is_found_and_a_changing_one_clears_it():
    d, _, _, found = _diag()
    for k in range(20):  # a noisy reading never repeats
        d.on_ahrs(0.1 * k, 0.001 * ((k * 7) % 5))
    assert found == []
    for k in range(D.AHRS_FROZEN):
        d.on_ahrs(2.0 + 0.1 * k, 0.25)
    assert found == ["ahrs"] and "ahrs" in d.failed
    d.on_ahrs(3.0, 0.26)
    assert "ahrs" not in d.failed


def test_a_neighbour_on_a_ray_that_never_echoes_is_a_dead_ring_and_an_echo_revives_it():
    d, robot, know, found = _diag()
    present = [1.0] * CFG.robot.ultrasonic.count
    silent = [MAX] * CFG.robot.ultrasonic.count
    for k in range(D.US_MISSES):
        now = 10.0 + 0.1 * k
        know.ir[2] = IRMeasurement(1.0, 0.0, now - 0.1, 0.0)  # straight ahead, 1 m: sensor 0 must see it
        assert found == []
        d.on_ring(silent, present, now)
    assert found == ["ultrasonic"] and robot.sensors_off == set(range(1, CFG.robot.ultrasonic.count + 1))
    d.on_ring([0.55] + silent[1:], present, 11.0)  # an echo
    assert "ultrasonic" not in d.failed and robot.sensors_off == set()


def test_a_ring_whose_bursts_do_not_ring_down_is_dead_and_a_passing_self_test_revives_it():
    """The driver's self-test: readings whose bursts did not ring down, a few in a row, are a dead ring
    (whatever the neighbours); one passing reading in between starts the count over."""
    d, robot, _, found = _diag()
    present = [1.0] * CFG.robot.ultrasonic.count
    silent = [MAX] * CFG.robot.ultrasonic.count
    t = 10.0
    for _ in range(D.US_SILENT_BURSTS - 1):
        d.on_ring(silent, present, t, False)
        t += 0.1
    d.on_ring(silent, present, t, True)  # a glitch, not a dead ring
    for _ in range(D.US_SILENT_BURSTS - 1):
        t += 0.1
        d.on_ring(silent, present, t, False)
    assert found == []
    d.on_ring(silent, present, t + 0.1, False)
    assert found == ["ultrasonic"] and robot.sensors_off == set(range(1, CFG.robot.ultrasonic.count + 1))
    d.on_ring(silent, present, t + 0.2, False)
    assert "ultrasonic" in d.failed
    d.on_ring(silent, present, t + 0.3, True)  # the fault ended: the transducers ring again
    assert "ultrasonic" not in d.failed and robot.sensors_off == set()


def test_a_body_without_an_ultrasonic_sensor_is_not_judged():
    d, _, _, found = _diag()
    for k in range(10):
        d.on_ring([MAX] * 8, [0.0] * 8, 10.0 + 0.1 * k, False)
    assert found == []


def test_a_reading_at_the_maximum_range_within_its_noise_is_no_echo():
    """A sensor that hears nothing reads its maximum range; the simulated one adds its noise to it, so
    a reading a noise's width below the maximum is still "nothing" (not an echo that clears the count)."""
    d, _, know, found = _diag()
    present = [1.0] * CFG.robot.ultrasonic.count
    near_max = [MAX - CFG.robot.ultrasonic.noise_m] * CFG.robot.ultrasonic.count
    for k in range(D.US_MISSES):
        now = 10.0 + 0.1 * k
        know.ir[2] = IRMeasurement(1.0, 0.0, now - 0.1, 0.0)
        d.on_ring(near_max, present, now)
    assert found == ["ultrasonic"]


def test_a_neighbour_between_rays_proves_nothing():
    """The ring's rays pass on either side of a body 22° off a sensor at 0.9 m: a healthy ring reads
    nothing there too, however long it lasts."""
    d, _, know, found = _diag()
    present = [1.0] * CFG.robot.ultrasonic.count
    silent = [MAX] * CFG.robot.ultrasonic.count
    for k in range(100):
        t = 10.0 + 0.1 * k
        know.ir[2] = IRMeasurement(0.9, 0.39, t - 0.1, 0.0)
        d.on_ring(silent, present, t)
    assert found == []


def test_switched_off_the_robot_forgets_what_it_found():
    d, robot, _, found = _diag()
    for k in range(D.AHRS_FROZEN + 1):
        d.on_ahrs(0.1 * k, 0.5)
    assert d.failed == {"ahrs"}
    robot.health.set("dead", True)
    d.on_ring([MAX] * 8, [1.0] * 8, 5.0)
    assert d.failed == set()


def test_a_noiseless_ahrs_that_stays_still_while_the_wheels_turn_is_found_and_a_change_clears_it():
    """An AHRS without noise or drift is judged by the rotation commanded over the window against its own:
    a robot that turns on command while its AHRS reads the same yaw has a broken AHRS; a straight drive
    with the same still AHRS does not."""
    quiet = load_config(overrides={"robot.ahrs_noise_deg": 0.0, "robot.ahrs_drift_dps": 0.0})
    present, silent = [1.0] * 8, [MAX] * 8

    def run(omega):
        robot = SimpleNamespace(health=FaultState(), command=(0.0, 0.0, omega), ahrs=SimpleNamespace(_last_yaw=0.0),
                                spec=None, sensors_off=set())
        ring = SimpleNamespace(slot_starts={}, slot_range_m={}, own_slot=None, report_s=-1.0)
        know = Knowledge(member=1, members={0: 0, 1: 1})
        d = D.Diagnosis(1, quiet, robot, lambda: know, ring)
        found = []
        d.on_detect = found.append
        for k in range(int(D.AHRS_WINDOW_S / 0.1) + 2):
            d.on_ring(silent, present, 10.0 + 0.1 * k, True)
            d.on_ahrs(10.0 + 0.1 * k, 0.3)
        return d, found

    _, found = run(0.0)
    assert found == []
    d, found = run(1.0)  # 1 rad/s commanded for over half the window, the AHRS still
    assert found == ["ahrs"] and "ahrs" in d.failed
    d.on_ahrs(20.0, 0.9)
    assert "ahrs" not in d.failed
