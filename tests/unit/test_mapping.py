"""Seed 001's middle layer (petswarm_env/mapping.py): sensor mapping table, deliveries, behaviour
mapper, the differential MOVE module and the paper's own experiment (Tables III-V, VII)."""

import math

import pytest

from petswarm_env import mapping
from petswarm_env.mapping import (
    DISTANCE,
    MOVE_DIFFERENTIAL,
    MOVE_HOLONOMIC,
    MYBOT,
    RITY,
    TABLE_V,
    VISION,
    Behaviour,
    BehaviourMapper,
    BehaviourRefused,
    DifferentialLimits,
    LocationRule,
    Sensor,
    SensorLocation,
    SensorMapper,
    SensorRow,
    build_sensor_table,
    differential_move,
    distance_sensors,
)


def _s(sid, angle, kind=DISTANCE, radius=0.15):
    return Sensor(sid, kind, SensorLocation(radius, angle))


# ---- seed 001's experiment -------------------------------------------------------------------


def test_rity_onto_mybot_gives_table_v_exactly():
    assert mapping.seed001_sensor_table() == [
        {"physical": 1, "virtual": 1, "valid_type": True, "valid_location": True},
        {"physical": 2, "virtual": 2, "valid_type": True, "valid_location": True},
        {"physical": 3, "virtual": 3, "valid_type": True, "valid_location": True},
        {"physical": 4, "virtual": 4, "valid_type": True, "valid_location": True},
        {"physical": 5, "virtual": 5, "valid_type": True, "valid_location": True},
        {"physical": 6, "virtual": 7, "valid_type": True, "valid_location": True},
    ]
    assert mapping.seed001_sensor_table() == [r.as_dict() for r in TABLE_V]


def test_registrations_follow_tables_iii_and_iv():
    assert [(s.id, s.type, s.location.radius_m, s.location.angle_deg) for s in MYBOT.sensors] == [
        (1, DISTANCE, 0.15, 180.0), (2, DISTANCE, 0.15, 135.0), (3, DISTANCE, 0.15, 90.0),
        (4, DISTANCE, 0.15, 45.0), (5, DISTANCE, 0.15, 0.0), (6, DISTANCE, 0.15, 270.0)]
    assert [s.location.angle_deg for s in RITY.sensors] == [180.0, 135.0, 90.0, 45.0, 0.0, 315.0, 270.0, 225.0]
    assert [s.id for s in RITY.sensors] == list(range(1, 9))


def test_rity_on_mybot_deliveries_unmatched_virtual_sensors_get_presence_zero():
    m = SensorMapper(RITY.sensors, MYBOT.sensors)
    got = m.deliver({1: 0.5, 2: 0.6, 3: 0.7, 4: 0.8, 5: 0.9, 6: 1.1})
    assert list(got) == [1, 2, 3, 4, 5, 6, 7, 8]
    assert got[7].present and got[7].value == 1.1 and got[7].location == SensorLocation(0.15, 270.0)
    assert got[3].value == 0.7 and got[3].location_known
    for vid in (6, 8):  # 315° and 225°: Mybot has nothing there
        assert not got[vid].present and got[vid].value is None and got[vid].location is None


def test_behaviour_table_vii():
    assert mapping.seed001_behaviour_table() == [{"virtual": "EMOTION", "physical": "EMOTION", "missing_fields": []}]


# ---- the sensor mapping rule ---------------------------------------------------------------


def test_type_match_with_location_mismatch_delivers_value_with_null_location():
    m = SensorMapper([_s(1, 30.0)], [_s(9, 60.0, radius=0.2)])
    assert m.table == (SensorRow(9, 1, True, False),)
    d = m.deliver({9: 1.25})[1]
    assert d.present and d.value == 1.25 and d.location is None and not d.location_known


def test_no_type_match_gives_none_row_and_presence_zero():
    m = SensorMapper([_s(1, 0.0, DISTANCE)], [_s(1, 0.0, VISION)])
    assert m.table == (SensorRow(1, None, False, False),)
    assert m.deliver({1: 3.0})[1] == mapping.Delivery(1, False)
    assert m.source_of(1) is None


def test_type_and_location_matches_are_made_before_type_only_pairings():
    # physical 1 (90°) comes first but only matches in type; it must not take virtual 1 (0°),
    # which physical 2 matches in type and location.
    table = build_sensor_table([_s(1, 0.0), _s(2, 180.0)], [_s(1, 90.0), _s(2, 0.0)])
    assert table == (SensorRow(1, 2, True, False), SensorRow(2, 1, True, True))


def test_one_to_one_a_virtual_sensor_has_one_source():
    table = build_sensor_table([_s(1, 0.0)], [_s(1, 0.0), _s(2, 0.0)])
    assert table == (SensorRow(1, 1, True, True), SensorRow(2, None, False, False))


def test_location_rule_angles_only_by_default_and_wraps():
    assert build_sensor_table([_s(1, 270.0, radius=0.3)], [_s(1, -90.0, radius=0.15)]) == (SensorRow(1, 1, True, True),)
    with_radius = LocationRule(compare_radius=True, radius_tol_m=0.01)
    assert build_sensor_table([_s(1, 270.0, radius=0.3)], [_s(1, -90.0, radius=0.15)], with_radius) == (
        SensorRow(1, 1, True, False),)


def test_angle_tolerance_picks_the_closest_virtual_sensor():
    rule = LocationRule(angle_tol_deg=25.0)
    table = build_sensor_table([_s(1, 0.0), _s(2, 45.0)], [_s(7, 40.0)], rule)
    assert table == (SensorRow(7, 2, True, True),)
    assert build_sensor_table([_s(1, 0.0)], [_s(7, 40.0)], rule) == (SensorRow(7, 1, True, False),)


def test_a_mapped_sensor_without_reading_delivers_nothing():
    m = SensorMapper(RITY.sensors, MYBOT.sensors)
    got = m.deliver({1: 0.5})  # the other ultrasonic sensors are off (a fault)
    assert got[1].present and not got[2].present and not got[7].present


def test_table_is_built_once_then_only_looked_up(monkeypatch):
    m = SensorMapper(RITY.sensors, MYBOT.sensors)

    def refuse(*_a, **_k):
        raise AssertionError("the mapping table was rebuilt")

    monkeypatch.setattr(mapping, "build_sensor_table", refuse)
    for _ in range(3):
        assert m.deliver({6: 2.0})[7].value == 2.0
    assert m.table == TABLE_V


def test_bad_registrations_are_refused():
    with pytest.raises(ValueError, match="physical sensor id 1 is registered twice"):
        build_sensor_table([], [_s(1, 0.0), _s(1, 90.0)])
    with pytest.raises(ValueError, match="angle_deg must be a finite number"):
        SensorLocation(0.1, math.nan)
    with pytest.raises(ValueError, match="radius_m must be >= 0"):
        SensorLocation(-0.1, 0.0)
    with pytest.raises(ValueError, match="type must be a non-empty string"):
        Sensor(1, "", SensorLocation(0.1, 0.0))


def test_distance_sensors_helper_counts_ids():
    assert distance_sensors([0.0, 90.0], 0.2, first_id=3) == (_s(3, 0.0, radius=0.2), _s(4, 90.0, radius=0.2))


# ---- the behaviour mapper ------------------------------------------------------------------


def test_move_on_a_differential_body_maps_with_vy_missing():
    m = BehaviourMapper([MOVE_HOLONOMIC], [MOVE_DIFFERENTIAL], body="mybot")
    assert m.lookup("MOVE").physical == "MOVE" and m.lookup("MOVE").missing_fields == ("vy",)
    assert m.table_dicts() == [{"virtual": "MOVE", "physical": "MOVE", "missing_fields": ["vy"]}]
    full = BehaviourMapper([MOVE_HOLONOMIC], [MOVE_HOLONOMIC], body="petbot")
    assert full.lookup("MOVE").missing_fields == ()


def test_required_behaviour_without_module_is_refused_naming_it():
    with pytest.raises(BehaviourRefused, match="behaviour 'MOVE' has no module on Mybot-without-drive"):
        BehaviourMapper([MOVE_HOLONOMIC, Behaviour("EMOTION")], [Behaviour("EMOTION")], body="Mybot-without-drive")


def test_optional_behaviour_without_module_maps_to_none():
    m = BehaviourMapper([MOVE_HOLONOMIC, Behaviour("DANCE", ("style",))], [MOVE_HOLONOMIC], required=["MOVE"])
    assert m.lookup("DANCE").physical is None and m.lookup("DANCE").missing_fields == ("style",)
    with pytest.raises(KeyError, match="behaviour 'WALK' is not registered"):
        m.lookup("WALK")
    with pytest.raises(ValueError, match="required behaviour 'WALK' is not among"):
        BehaviourMapper([MOVE_HOLONOMIC], [MOVE_HOLONOMIC], required=["WALK"])


# ---- the differential MOVE module ----------------------------------------------------------

LIM = DifferentialLimits(max_speed_mps=1.0, max_omega_rad_s=2.0, lookahead_m=0.25)


def test_differential_without_vy_passes_the_move_unchanged():
    assert differential_move(0.6, 0.0, -0.4, LIM) == (0.6, -0.4)
    assert differential_move(-0.3, 0.0, 0.0, LIM) == (-0.3, 0.0)


def test_differential_turns_toward_the_commanded_side():
    assert differential_move(0.0, 0.2, 0.0, LIM) == (0.0, pytest.approx(0.8))  # left: CCW
    assert differential_move(0.0, -0.2, 0.0, LIM) == (0.0, pytest.approx(-0.8))  # right: CW
    assert differential_move(-0.4, 0.2, 0.0, LIM) == (-0.4, pytest.approx(0.8))  # reversing: front still turns left
    assert differential_move(0.5, 0.1, 0.3, LIM) == (0.5, pytest.approx(0.7))  # the policy's ω is added


def test_differential_limits_scale_both_and_keep_the_curvature():
    v, w = differential_move(0.8, 1.0, 0.0, LIM)  # ω would be 4.0 rad/s: scaled by 0.5
    assert (v, w) == (pytest.approx(0.4), pytest.approx(2.0))
    v, w = differential_move(3.0, 0.25, 0.0, LIM)  # v 3.0 -> 1.0, ω 1.0 -> 1/3
    assert (v, w) == (pytest.approx(1.0), pytest.approx(1.0 / 3.0))


def test_differential_body_reaches_a_point_to_its_side():
    """Closed loop: a body-frame velocity toward a target on the left each 50 ms; the look-ahead
    point must arrive at the target (the body turned toward it and drove there)."""
    x = y = th = 0.0
    target = (0.0, 2.0)
    dt = 0.05
    for _ in range(400):
        px, py = x + LIM.lookahead_m * math.cos(th), y + LIM.lookahead_m * math.sin(th)
        ex, ey = target[0] - px, target[1] - py
        bx, by = math.cos(th) * ex + math.sin(th) * ey, -math.sin(th) * ex + math.cos(th) * ey
        n = math.hypot(bx, by)
        k = min(1.0, 0.5 / n) if n > 0 else 0.0
        v, w = differential_move(bx * k * 2.0, by * k * 2.0, 0.0, LIM)
        x, y, th = x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th + w * dt
    px, py = x + LIM.lookahead_m * math.cos(th), y + LIM.lookahead_m * math.sin(th)
    assert math.hypot(px - target[0], py - target[1]) < 0.02
    assert abs(th - math.pi / 2) < 0.3  # now facing the target's side (+y)


def test_differential_bad_input_refused():
    with pytest.raises(ValueError, match="lookahead_m must be > 0"):
        DifferentialLimits(1.0, 1.0, 0.0)
    with pytest.raises(ValueError, match="vy must be a finite number"):
        differential_move(0.0, math.inf, 0.0, LIM)
