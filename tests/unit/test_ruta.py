"""Seed 003's RUTA (petswarm_env/middleware/ruta.py): the §4.1.2 equations on the §5.2.1 numbers,
Algorithm 1 (centralized) and Algorithm 2 (decentralized) decisions on small hand-made cases."""

import math

import pytest

from petswarm_env.middleware import ruta
from petswarm_env.middleware.ruta import (
    Bid,
    RobotStatus,
    RutaParams,
    Subtask,
    assign_centralized,
    capable,
    close_auction,
    deploy_first,
    centralized_from_reports,
    fittest,
    must_request_bids,
    own_bid,
    phi_manip,
    phi_nav,
    phi_sens,
    priority,
    robot_utility,
    utility,
    utility_table,
)

# ---- the equations on the worked example (§5.2.1) ---------------------------------------------


def test_r1_nav_exact_arithmetic_is_3_95_where_the_paper_prints_3_90():
    exact = phi_nav(2200.0, 130.0, 3.0)  # 0.7 * (2200/130) * (1/3)
    assert exact == pytest.approx(3.94872, abs=1e-5)
    assert round(exact, 2) == 3.95
    paper_printed = 3.90  # "0.7 [5.58] = 3.90": 2200/130/3 is 5.641, not 5.58
    assert abs(exact - paper_printed) == pytest.approx(0.0487, abs=1e-4)
    assert utility(1.0, exact, 1.0, 1.0) == exact  # d = 1, pri = 1, u2 = 1 as printed


def test_r2_nav_is_4_81():
    assert phi_nav(2200.0, 320.0, 1.0) == pytest.approx(4.8125)  # paper: 0.7 [6.87] = 4.81


def test_grip_priority_at_110_s_announced_at_20_s_is_0_45():
    assert priority(110.0, 20.0, 0.01) == pytest.approx(0.45)


def test_priority_caps_at_one_half_and_is_negative_before_announcement():
    assert priority(500.0, 20.0, 0.01) == 0.5  # ½ · min(4.8, 1)
    assert priority(15.0, 20.0, 0.01) == pytest.approx(-0.025)
    assert utility(1.0, 5.0, priority(15.0, 20.0, 0.01)) == 0.0  # max(0, ·)


def test_r2_grip_phis_and_utility():
    manip = phi_manip(9.0, 200.0, 2000.0, 60.0)
    sens = phi_sens(11.0, 200.0, 2150.0, 65.0)
    assert manip == pytest.approx(1.05)
    assert sens == pytest.approx(1.63731, abs=1e-5)  # paper 1.64
    assert manip + sens == pytest.approx(2.68731, abs=1e-5)  # paper 2.69
    u = utility(3.0, manip + sens, 0.45, 1.0)
    assert u == pytest.approx(0.69818, abs=1e-5)  # paper prints 0.69 (truncated)
    assert utility(3.0, 2.69, 0.45, 1.0) == pytest.approx(0.69888, abs=1e-5)  # from the printed 2.69


def test_r4_grip_utility_1_09_beats_r2():
    r4 = utility(4.3, 5.04, 0.45, 1.0)  # R4's φ 5.04 is printed without inputs
    assert r4 == pytest.approx(1.09373, abs=1e-5)
    assert r4 > utility(3.0, 2.69, 0.45, 1.0)


def test_utility_exponent_is_minus_one_half():
    assert utility(4.0, 2.0, 0.5, 1.0) == pytest.approx(0.5)  # 4^-½ · 2 · 0.5
    assert utility(4.0, 2.0, 0.5, 3.0) == pytest.approx(1.5)  # u2 scales it
    with pytest.raises(ValueError, match="d_m must be a finite number > 0"):
        utility(0.0, 1.0, 0.5)


def test_equations_refuse_bad_input():
    with pytest.raises(ValueError, match="slip_pct must be a finite number > 0"):
        phi_nav(2200.0, 130.0, 0.0)
    with pytest.raises(ValueError, match="rate_sens_ma must be a finite number > 0"):
        phi_sens(1.0, 200.0, 2000.0, 0.0)
    with pytest.raises(ValueError, match="p_rem_mah must be a finite number >= 0"):
        phi_manip(1.0, 200.0, -1.0, 60.0)
    with pytest.raises(ValueError, match="t_s must be a finite number"):
        priority(math.nan, 0.0, 0.01)


def test_worked_example_figures():
    f = ruta.worked_example()
    assert f["nav_utility"]["R1"] == pytest.approx(3.94872, abs=1e-5)  # exact on the inputs
    assert f["R1_nav_utility_from_printed_bracket"] == pytest.approx(3.906)  # 0.7 × 5.58
    assert f["R1_nav_bracket_exact"] == pytest.approx(5.64103, abs=1e-5)
    assert f["nav_utility"]["R2"] == pytest.approx(4.8125)
    assert f["nav_utility"]["R4"] == pytest.approx(1.21)
    assert f["deployed_first"] == ["R2", "R1"]
    assert f["grip_pri"] == pytest.approx(0.45)
    assert f["R2_phi_given"] == pytest.approx(2.68731, abs=1e-5)
    assert f["grip_utility"]["R2"] == pytest.approx(0.69818, abs=1e-5)
    assert f["grip_utility"]["R4"] == pytest.approx(1.09373, abs=1e-5)
    assert f["grips_first_decentralized"] == f["grips_first_centralized"] == "R4"


# ---- robots, subtasks, the utility table -------------------------------------------------------

P = RutaParams(t_m_s=200.0, u1_per_s=0.01, u2=1.0, min_distance_m=0.1)
NAV = Subtask("slot1", announced_s=0.0, nav=True)
EDGE = Subtask("slot2", announced_s=0.0, nav=True, sens_s=50.0)  # navigation + sensing toward the outside


def _robot(rid, d1=1.0, d2=1.0, **kw):
    base = {"p_rem_mah": 2000.0, "slip_pct": 2.0, "rate_servo_ma": 200.0, "rate_sens_ma": 50.0}
    base.update(kw)
    return RobotStatus(rid, distance_m={"slot1": d1, "slot2": d2}, **base)


def test_robot_utility_sums_the_parts_of_the_subtask():
    r = _robot(1, d2=4.0)
    pri = priority(100.0, 0.0, 0.01)  # 0.5
    expect = 4.0 ** -0.5 * (phi_nav(2000.0, 200.0, 2.0) + phi_sens(50.0, 200.0, 2000.0, 50.0)) * pri
    assert robot_utility(r, EDGE, 100.0, P) == pytest.approx(expect)
    assert expect == pytest.approx(0.5 * (3.5 + 9.0) * 0.5)


def test_incapable_robots_have_zero_utility():
    no_sensor = _robot(2, rate_sens_ma=None)
    assert not capable(no_sensor, EDGE) and capable(no_sensor, NAV)
    assert robot_utility(no_sensor, EDGE, 100.0, P) == 0.0
    assert robot_utility(_robot(3, faulty=True), NAV, 100.0, P) == 0.0
    assert robot_utility(_robot(4, p_rem_mah=0.0), NAV, 100.0, P) == 0.0
    grip = Subtask("grip", manip_s=9.0, located=False)
    assert robot_utility(_robot(5), grip, 100.0, P) == 0.0  # no actuator


def test_distance_floor_and_unlocated_subtasks():
    at_slot = robot_utility(_robot(1, d1=0.0), NAV, 100.0, P)
    assert at_slot == pytest.approx(0.1 ** -0.5 * phi_nav(2000.0, 200.0, 2.0) * 0.5)
    anywhere = Subtask("watch", sens_s=20.0, located=False)
    assert robot_utility(RobotStatus(9, 1000.0, 1.0, rate_sens_ma=50.0), anywhere, 100.0, P) == pytest.approx(
        phi_sens(20.0, 200.0, 1000.0, 50.0) * 0.5)  # d = 1


def test_missing_distance_report_is_refused():
    with pytest.raises(ValueError, match="robot 7 reports no distance to subtask 'slot1'"):
        robot_utility(RobotStatus(7, 2000.0, 2.0, rate_servo_ma=200.0), NAV, 10.0, P)
    with pytest.raises(ValueError, match="subtask 'x' has no part"):
        Subtask("x")


# ---- Algorithm 1 (centralized) -----------------------------------------------------------------


def test_alg1_each_subtask_to_its_best_free_robot_in_schedule_order():
    u = {("A", "s1"): 1.0, ("B", "s1"): 3.0, ("C", "s1"): 2.0,
         ("A", "s2"): 2.0, ("B", "s2"): 5.0, ("C", "s2"): 1.0}
    res = assign_centralized(["s1", "s2"], u, team=["A", "B", "C"])
    assert res.assignment == {"s1": "B", "s2": "A"}  # B took s1 first: one subtask per robot
    assert res.unassigned == () and res.trials == 1 and res.team == ("A", "B", "C")
    res = assign_centralized(["s2", "s1"], u, team=["A", "B", "C"])  # s2 first in the schedule
    assert res.assignment == {"s2": "B", "s1": "C"}


def test_alg1_a_tie_keeps_the_earlier_robot_in_the_ordering():
    u = {("A", "s1"): 2.0, ("B", "s1"): 2.0}
    assert assign_centralized(["s1"], u, team=["A", "B"]).assignment == {"s1": "A"}
    assert assign_centralized(["s1"], u, team=["B", "A"]).assignment == {"s1": "B"}


def test_alg1_busy_robots_are_skipped():
    u = {("A", "s1"): 9.0, ("B", "s1"): 1.0}
    assert assign_centralized(["s1"], u, team=["A", "B"], busy={"A"}).assignment == {"s1": "B"}


def test_alg1_adds_the_best_remaining_robot_when_the_team_cannot_finish():
    u = {("A", "s1"): 1.0, ("A", "s2"): 1.0, ("C", "s2"): 3.0, ("D", "s2"): 4.0}
    res = assign_centralized(["s1", "s2"], u, team=["A"], pool=["C", "D"])
    assert res.assignment == {"s1": "A", "s2": "D"}
    assert res.team == ("A", "D") and res.trials == 2


def test_alg1_faulty_robot_is_replaced_by_the_remaining_robot_with_the_highest_utility():
    u = {("B", "s1"): 7.0, ("C", "s1"): 1.0, ("D", "s1"): 2.0}
    res = assign_centralized(["s1"], u, team=["A", "B"], pool=["C", "D"], busy={"B"}, faulty={"A"})
    assert res.assignment == {"s1": "D"} and res.team == ("B", "D")  # A left the ordering
    # a free team member with a higher utility than the recruit still wins the pass (steps 1-6)
    res = assign_centralized(["s1"], u, team=["A", "B"], pool=["C"], faulty={"A"})
    assert res.assignment == {"s1": "B"} and res.team == ("B", "C")
    # a faulty robot in the pool is not recruited
    res = assign_centralized(["s1"], u, team=["A"], pool=["D", "C"], faulty={"A", "D"})
    assert res.assignment == {"s1": "C"} and res.team == ("C",)


def test_alg1_stops_after_k_trials():
    u = {("C", "s1"): 3.0, ("D", "s2"): 2.0, ("E", "s3"): 1.0}
    res = assign_centralized(["s1", "s2", "s3"], u, team=[], pool=["C", "D", "E"], max_trials=2)
    assert res.assignment == {"s1": "C"} and res.unassigned == ("s2", "s3") and res.trials == 2
    assert res.team == ("C", "D")
    res = assign_centralized(["s1", "s2", "s3"], u, team=[], pool=["C", "D", "E"], max_trials=10)
    assert res.assignment == {"s1": "C", "s2": "D", "s3": "E"} and res.trials == 4
    with pytest.raises(ValueError, match="max_trials"):
        assign_centralized(["s1"], u, team=[], max_trials=0)


def test_alg1_stops_when_no_remaining_robot_can_help():
    u = {("A", "s1"): 1.0, ("C", "s2"): 0.0}
    res = assign_centralized(["s1", "s2"], u, team=["A"], pool=["C"])
    assert res.assignment == {"s1": "A"} and res.unassigned == ("s2",) and res.team == ("A",) and res.trials == 1


def test_alg1_on_reported_status_outer_slot_goes_to_a_robot_with_sensors():
    robots = [_robot(1, d1=1.0, d2=1.0, rate_sens_ma=None), _robot(2, d1=1.0, d2=4.0)]
    u = utility_table(robots, [EDGE, NAV], 100.0, P)
    res = assign_centralized(["slot2", "slot1"], u, team=[1, 2])
    assert res.assignment == {"slot2": 2, "slot1": 1}
    assert u[(1, "slot2")] == 0.0 and u[(2, "slot2")] == pytest.approx(3.125)


def test_alg1_from_reports_replaces_a_robot_reporting_a_fault():
    reports = [_robot(1, faulty=True), _robot(2, d1=9.0), _robot(3, d1=1.0), _robot(4, d1=4.0)]
    res = centralized_from_reports(reports, [NAV], 100.0, team=[1, 2], params=P, busy={2})
    assert res.assignment == {"slot1": 3} and res.team == (2, 3)  # 3 is the closest waiting robot


# ---- Algorithm 2 (decentralized) ---------------------------------------------------------------


def test_own_bid_is_the_robots_utility_or_no_reply():
    r = _robot(1, d1=4.0)
    assert own_bid(r, NAV, 100.0, P) == pytest.approx(robot_utility(r, NAV, 100.0, P))
    assert own_bid(r, NAV, 100.0, P, busy=True) is None  # holds a subtask already
    assert own_bid(_robot(2, rate_sens_ma=None), EDGE, 100.0, P) is None  # cannot sense
    assert own_bid(r, Subtask("later", announced_s=200.0, nav=True, located=False), 100.0, P) is None  # not announced yet


def test_a_robot_whose_sensor_fails_requests_bids_for_its_subtask():
    assert not must_request_bids(_robot(1), EDGE)
    assert must_request_bids(_robot(1, rate_sens_ma=None), EDGE)  # ultrasonic fault
    assert not must_request_bids(_robot(1, rate_sens_ma=None), NAV)  # a plain slot needs no sensing
    assert must_request_bids(_robot(1, p_rem_mah=0.0), NAV)  # battery empty


def test_fittest_highest_utility_ties_to_lower_id_whatever_the_order():
    bids = [Bid(5, "s", 1.0, 0.2), Bid(3, "s", 2.0, 0.3), Bid(2, "s", 2.0, 0.4), Bid(4, "s", 0.0, 0.1)]
    assert fittest(bids).robot == 2
    assert fittest(list(reversed(bids))).robot == 2
    assert fittest([Bid(4, "s", 0.0, 0.1)]) is None
    assert fittest([]) is None


def test_close_auction_counts_bids_within_t_out_only():
    bids = [Bid(1, "s", 0.5, 100.4), Bid(2, "s", 3.0, 106.0), Bid(3, "t", 9.0, 101.0)]  # 2 is late, 3 bids on t
    d = close_auction(bids, "s", announced_s=100.0, t_out_s=5.0)
    assert d.kind == "assign" and d.winner.robot == 1
    stale = [Bid(4, "s", 9.0, 99.0)]  # heard before this announcement
    assert close_auction(stale, "s", 100.0, 5.0).kind == "reannounce"


def test_close_auction_without_reply_reannounces_then_leaves_the_subtask_unfilled():
    d = close_auction([], "s", announced_s=100.0, t_out_s=5.0, attempt=1, max_attempts=3)
    assert d.kind == "reannounce" and d.next_announce_s == 105.0 and d.winner is None
    assert close_auction([], "s", 105.0, 5.0, attempt=2, max_attempts=3).next_announce_s == 110.0
    last = close_auction([], "s", 110.0, 5.0, attempt=3, max_attempts=3)
    assert last.kind == "unfilled" and last.next_announce_s is None
    with pytest.raises(ValueError, match="attempt must be in 1..max_attempts"):
        close_auction([], "s", 110.0, 5.0, attempt=4, max_attempts=3)
    with pytest.raises(ValueError, match="t_out_s must be a finite number > 0"):
        close_auction([], "s", 110.0, 0.0)


def test_fault_example_timing_assigns_at_105_s():
    t = ruta.FAULT_EXAMPLE_S  # announced 100 s, utilities 101 s, assigned 105 s
    bids = [Bid("R3", "pull", 1.2, t["utilities"]), Bid("R1", "pull", 1.5, t["utilities"])]
    d = close_auction(bids, "pull", t["announced"], t["assigned"] - t["announced"])
    assert d.kind == "assign" and d.winner.robot == "R1"


def test_deploy_first_two_highest():
    assert deploy_first({"R1": 3.95, "R2": 4.81, "R4": 1.21}) == ("R2", "R1")
    assert deploy_first({1: 2.0, 2: 2.0, 3: 5.0}) == (3, 1)
    assert deploy_first({1: 0.0, 2: 1.0}) == (2,)
    assert deploy_first({1: 1.0, 2: 2.0, 3: 3.0}, n=1) == (3,)


def test_tables_1_and_2_as_printed():
    assert ruta.TABLE_1[3] == (1200, 2.5, 201)
    # centralized faster than decentralized for every team of Table 2
    assert all(c_t < d_t for _cu, c_t, _du, d_t in ruta.TABLE_2.values())
