"""swarm.assignment's pure parts (petswarm_env/middleware/assignment.py): the slot -> subtask mapping
(seed 003 §4.1.2 on the formation's slots), d without ground truth, own_status, Algorithm 1 on the
slots and Algorithm 2's round decision."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from petswarm_env.config import load_config
from petswarm_env.middleware import assignment as A
from petswarm_env.middleware import ruta

CFG = load_config()


def geometry(formation, n=4):
    return A.slot_geometry(A.slots_formation(CFG.swarm.model_copy(update={"formation": formation}), list(range(1, n + 1))))


# -- slots as subtasks ----------------------------------------------------------------------------------


@pytest.mark.parametrize("formation, expected", [
    ("wedge", {1: (1.0, 1), 2: (1.0, 1), 3: (2.0, 2), 4: (2.0, 2)}),  # the arms' ends are the outer edge
    ("column", {1: (1.0, 2), 2: (2.0, 2), 3: (3.0, 2), 4: (4.0, 3)}),  # sides exposed, the last one behind too
    ("row", {1: (1.0, 2), 2: (1.0, 2), 3: (2.0, 3), 4: (2.0, 3)}),
])
def test_slot_geometry_distance_from_master_and_exposed_sides(formation, expected):
    got = geometry(formation)
    assert {m: (round(a, 9), e) for m, (a, e) in got.items()} == expected


def test_a_slot_inside_the_formation_has_no_sensing_part():
    cfg = load_config(overrides={"swarm.formation": "custom", "swarm.custom_links": [
        {"robot": 1, "neighbour": 0, "offset_m": [-1.0, 0.0]}, {"robot": 2, "neighbour": 1, "offset_m": [-1.0, 0.0]},
        {"robot": 3, "neighbour": 1, "offset_m": [0.0, 1.0]}, {"robot": 4, "neighbour": 1, "offset_m": [0.0, -1.0]}]})
    g = A.slot_geometry(A.slots_formation(cfg.swarm, [1, 2, 3, 4]))
    assert g[1] == (1.0, 0)  # a plus sign: the centre is covered on all four sides
    sub = A.slot_subtask(1, g[1][1], CFG.ruta)
    assert sub.nav and sub.sens_s is None and sub.manip_s is None
    edge = A.slot_subtask(3, g[3][1], CFG.ruta)
    assert edge.sens_s == pytest.approx(CFG.ruta.t_m_s * g[3][1] / 4)


def test_slot_distance_is_the_rms_over_an_unknown_bearing():
    r, a = 1.7, 2.0
    bearings = np.linspace(0, 2 * math.pi, 20001)[:-1]
    rms = math.sqrt(np.mean((r * np.cos(bearings) - a) ** 2 + (r * np.sin(bearings)) ** 2))
    assert A.slot_distance(r, a) == pytest.approx(rms, rel=1e-9)
    assert A.slot_distance(1.0, 2.0) < A.slot_distance(1.5, 2.0)  # closer robots are better for every slot


def test_mean_range_skips_missing_estimates():
    assert A.mean_range(1.0, 2.0) == 1.5
    assert A.mean_range(None, 2.0) == 2.0
    assert A.mean_range(None) == math.inf


# -- own status -------------------------------------------------------------------------------------------


def test_own_status_is_the_provisional_petbot_and_the_sensor_fault_hook_removes_sensing():
    station = SimpleNamespace(node_id=7, cfg=CFG)
    s = A.own_status(station)
    assert (s.id, s.robot_type, s.p_rem_mah, s.slip_pct, s.rate_servo_ma, s.rate_act_ma, s.rate_sens_ma) == \
        (7, "petbot", 2500.0, 1.0, 320.0, None, 65.0)
    assert s.sensors == {"DISTANCE", "IR", "LF", "AHRS"}
    station.failed_sensors = {"ultrasonic"}
    broken = A.own_status(station)
    assert broken.rate_sens_ma is None and broken.sensors == {"IR", "LF", "AHRS"}
    edge, inner = A.slot_subtask(3, 2, CFG.ruta), A.slot_subtask(1, 0, CFG.ruta)
    assert not ruta.capable(broken, edge) and ruta.capable(broken, inner)
    for part in ("ir", "ahrs"):  # a slot needs the IR ring and the AHRS (assignment.SLOT_NEEDS)
        station.failed_sensors = {part}
        assert not ruta.capable(A.own_status(station), inner) and ruta.must_request_bids(A.own_status(station), inner)


def test_status_payload_round_trip():
    s = A.own_status(SimpleNamespace(node_id=3, cfg=CFG))
    p = A.status_payload(s, True, 1.25)
    assert p["rate_act_ma"] == A.NO_MODULE and p["distance_m"] == 1.25 and p["available"] is True and p["sensors"] == 15
    back = A.status_from_payload(3, p)
    assert back == s
    assert A.status_from_payload(3, {**p, "sensors": 6}).rate_sens_ma is None  # no DISTANCE bit: no sensing


# -- the strategies ---------------------------------------------------------------------------------------


def test_closest_fills_the_lowest_open_numbers():
    assert A.select_closest([5, 2, 9], [1, 2, 3, 4]) == {1: 5, 2: 2, 3: 9}
    assert A.select_closest([5], [3]) == {3: 5}  # a refill of slot 3


SENSORS = frozenset({"DISTANCE", "IR", "LF", "AHRS"})  # a petbot's, every one working


def petbot(rid, **kw):
    return ruta.RobotStatus(rid, 2500.0, 1.0, 320.0, None, 65.0, robot_type="petbot", sensors=SENSORS, **kw)


def test_centralized_with_identical_robots_is_closest_first():
    g = geometry("wedge")
    reports = {rid: petbot(rid) for rid in (4, 5, 6, 7)}
    ranges = {4: 2.0, 5: 0.8, 6: 1.5, 7: 1.1}
    got = A.select_centralized(reports, ranges, g, [1, 2, 3, 4], 1.0, CFG)
    assert got == {1: 5, 2: 7, 3: 6, 4: 4}


def test_centralized_gives_the_outer_slot_to_the_robot_that_can_sense():
    g = {1: (1.0, 2), 2: (1.0, 0)}  # slot 1 on the outer edge, slot 2 inside
    blind = ruta.RobotStatus(4, 2500.0, 1.0, 320.0, None, None, robot_type="petbot", sensors=SENSORS - {"DISTANCE"})  # no ultrasonic ring
    got = A.select_centralized({4: blind, 5: petbot(5)}, {4: 0.5, 5: 2.0}, g, [1, 2], 1.0, CFG)
    assert got == {1: 5, 2: 4}


def test_centralized_prefers_the_better_battery_and_slip_at_equal_range():
    g = {1: (1.0, 1)}
    tired = ruta.RobotStatus(4, 500.0, 1.0, 320.0, None, 65.0, sensors=SENSORS)
    slippy = ruta.RobotStatus(5, 2500.0, 4.0, 320.0, None, 65.0, sensors=SENSORS)
    got = A.select_centralized({4: tired, 5: slippy, 6: petbot(6)}, {4: 1.0, 5: 1.0, 6: 1.0}, g, [1], 1.0, CFG)
    assert got == {1: 6}


def test_own_utilities_leave_out_what_the_robot_cannot_take_and_are_float32():
    slots = [(1, 1.0, 0, 0.5), (3, 2.0, 2, 0.5)]
    blind = ruta.RobotStatus(4, 2500.0, 1.0, 320.0, None, None, sensors=SENSORS - {"DISTANCE"})
    assert [m for m, _ in A.own_utilities(blind, 1.0, slots, CFG.ruta)] == [1]
    full = A.own_utilities(petbot(5), 1.0, slots, CFG.ruta)
    assert [m for m, _ in full] == [1, 3]
    for _, u in full:
        assert u == float(np.float32(u)) and u > 0
    # the same robot, computed by hand: eq. 3 (+ eq. 4 on the edge), eq. 6, eq. 7
    pri = ruta.priority(0.5, 0.0, CFG.ruta.u1_per_s)
    nav = ruta.phi_nav(2500.0, 320.0, 1.0)
    assert full[0][1] == pytest.approx(ruta.utility(math.sqrt(2.0), nav, pri), rel=1e-6)
    sens = ruta.phi_sens(CFG.ruta.t_m_s / 2, CFG.ruta.t_m_s, 2500.0, 65.0)
    assert full[1][1] == pytest.approx(ruta.utility(math.sqrt(5.0), nav + sens, pri), rel=1e-6)


def bid(robot, slot, u, t=1.05):
    return ruta.Bid(robot, str(slot), u, t)


def test_round_two_bids_for_one_slot_the_higher_wins_a_tie_the_lower_id():
    assert A.close_round([bid(8, 1, 0.3), bid(5, 1, 0.2)], [1], 1.0, 0.2, 1, 3) == {1: 8}
    assert A.close_round([bid(8, 1, 0.3), bid(5, 1, 0.3)], [1], 1.0, 0.2, 1, 3) == {1: 5}


def test_round_a_robot_fittest_for_two_slots_takes_the_lower_the_other_goes_to_the_next():
    bids = [bid(5, 1, 0.5), bid(5, 2, 0.5), bid(6, 1, 0.4), bid(6, 2, 0.4), bid(7, 2, 0.1)]
    assert A.close_round(bids, [1, 2], 1.0, 0.2, 1, 3) == {1: 5, 2: 6}


def test_round_a_bid_outside_the_window_does_not_count_and_an_unbid_slot_stays_open():
    bids = [bid(5, 1, 0.5, t=1.3), bid(6, 1, 0.1, t=1.1)]  # robot 5's arrived after t_out
    assert A.close_round(bids, [1, 2], 1.0, 0.2, 1, 3) == {1: 6}
    assert A.close_round([], [1, 2], 1.0, 0.2, 3, 3) == {}


def test_a_body_report_becomes_ruta_status_slip_floor_no_module_no_sensor_empty_battery():
    body = {"id": 4, "type": "r1", "battery_mah": 1800.0, "battery_empty": False, "wheel_slip_pct": 0.0,
            "servo_ma": 130.0, "actuator_ma": 0.0, "sensing_ma": 65.0,
            "sensors": [{"id": 1, "type": "DISTANCE", "radius_m": 0.1, "angle_deg": 0}]}
    s = A.status_from_body(body)
    assert (s.id, s.robot_type, s.p_rem_mah, s.slip_pct, s.rate_servo_ma, s.rate_act_ma, s.rate_sens_ma, s.faulty) == \
        (4, "r1", 1800.0, A.MIN_SLIP_PCT, 130.0, None, 65.0, False)
    assert s.sensors == {"DISTANCE", "AHRS"}
    assert A.status_from_body(body, failed={"ultrasonic"}).rate_sens_ma is None
    assert A.status_from_body({**body, "sensors": [{"id": 9, "type": "IR"}]}).rate_sens_ma is None
    empty = A.status_from_body({**body, "battery_mah": 0.0, "battery_empty": True})
    assert empty.faulty and not ruta.capable(empty, A.slot_subtask(1, 0, CFG.ruta))


def test_own_status_reads_the_body_report_when_the_station_has_one():
    body = {"id": 2, "type": "mybot", "battery_mah": 2000.0, "wheel_slip_pct": 2.0, "servo_ma": 300.0,
            "actuator_ma": 0.0, "sensing_ma": 65.0, "sensors": [{"type": "DISTANCE"}]}
    station = SimpleNamespace(node_id=2, cfg=CFG, own_body_status=lambda: body)
    assert A.own_status(station) == A.status_from_body(body)
    station.own_body_status = lambda: None  # today's body: no report -> the provisional petbot
    assert A.own_status(station).robot_type == "petbot"


def test_schedule_puts_the_slots_fewer_robots_can_take_first_else_member_order():
    assert A.schedule([1, 2, 3, 4], {1: 4, 2: 4, 3: 4, 4: 4}) == [1, 2, 3, 4]
    assert A.schedule([1, 2, 3, 4], {1: 4, 2: 3, 3: 3, 4: 3}) == [2, 3, 4, 1]


def test_centralized_leaves_the_blind_robot_the_inner_slot_even_when_it_is_closest():
    g = {1: (1.0, 0), 2: (2.0, 1), 3: (1.4, 1)}  # slot 1 needs no sensing
    blind = ruta.RobotStatus(4, 2500.0, 1.0, 320.0, None, None, sensors=SENSORS - {"DISTANCE"})
    reports = {4: blind, 5: petbot(5), 6: petbot(6)}
    got = A.select_centralized(reports, {4: 0.5, 5: 1.0, 6: 1.5}, g, [1, 2, 3], 1.0, CFG)
    assert got[1] == 4 and set(got) == {1, 2, 3}


def test_round_leaves_the_blind_robot_the_slot_only_it_and_others_bid_for():
    bids = [bid(4, 1, 0.9), bid(5, 1, 0.5), bid(5, 2, 0.6), bid(6, 1, 0.4), bid(6, 2, 0.3)]
    assert A.close_round(bids, [1, 2], 1.0, 0.2, 1, 3) == {2: 5, 1: 4}
    bids = [bid(5, 1, 0.9), bid(4, 1, 0.5), bid(5, 2, 0.6)]  # robot 4 bids only for slot 1
    assert A.close_round(bids, [1, 2], 1.0, 0.2, 1, 3) == {2: 5, 1: 4}


def test_a_body_report_whose_sensors_do_not_work_reports_no_sensing_and_no_such_sensor():
    """The robot's own record of its broken sensors (``working``: Robot.sensors_off, set by its diagnosis)
    lowers the status: a blind robot is ranked as blind."""
    ring = [{"id": k, "type": "DISTANCE", "working": False} for k in range(1, 9)]
    body = {"id": 4, "type": "petbot", "battery_mah": 2500.0, "battery_empty": False, "wheel_slip_pct": 1.0,
            "servo_ma": 320.0, "actuator_ma": 0.0, "sensing_ma": 65.0,
            "sensors": ring + [{"id": 9, "type": "IR", "working": True}]}
    s = A.status_from_body(body)
    assert s.rate_sens_ma is None and s.sensors == {"IR", "AHRS"}
    assert not ruta.capable(s, A.slot_subtask(3, 2, CFG.ruta)) and ruta.capable(s, A.slot_subtask(1, 0, CFG.ruta))
    ir_off = A.status_from_body({**body, "sensors": [{"id": 9, "type": "IR", "working": False}]})
    assert "IR" not in ir_off.sensors and not ruta.capable(ir_off, A.slot_subtask(1, 0, CFG.ruta))
