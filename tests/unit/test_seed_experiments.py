"""The reproduce experiments of seeds 001 and 003 (experiments/sensor_mapping.py,
experiments/ruta_example.py): their rows pass on the code as it is and fail when the code's answer
departs from the paper's printed data."""

import dataclasses
import math

import pytest

from petswarm.experiments import ruta_example, sensor_mapping
from petswarm.experiments.registry import results_json, run_experiments
from petswarm.experiments.results import Row
from petswarm_env.config import load_config
from petswarm_env.mapping import MYBOT, RITY, TABLE_V, LocationRule, SensorLocation, build_sensor_table
from petswarm_env.middleware import ruta


def _noop(done, total):
    pass


# ---- sensor_mapping ----------------------------------------------------------------------------


def test_sensor_mapping_gives_table_v_and_writes_it_in_the_json():
    res = run_experiments(["sensor_mapping"], load_config(), 0, True)
    out = results_json(res)["experiments"]["sensor_mapping"]
    assert out["ok"] and len(out["rows"]) == 9
    # Table V as printed (test_mapping.py spells it out): 1-5 -> 1-5, 6 -> 7, all valid
    assert out["data"]["table"] == out["data"]["paper_table"] == [r.as_dict() for r in TABLE_V]
    assert [(r["physical"], r["virtual"]) for r in out["data"]["table"]] == [(1, 1), (2, 2), (3, 3), (4, 4), (5, 5), (6, 7)]
    assert out["data"]["virtual_without_source"] == [6, 8]  # 315° and 225°: presence 0
    assert all(r["basis"] == "validated" for r in out["rows"])


def _mybot_moved(angle_of_6: float, offset: float = 0.0):
    return tuple(dataclasses.replace(s, location=SensorLocation(s.location.radius_m,
                                                                 (angle_of_6 if s.id == 6 else s.location.angle_deg) + offset))
                 for s in MYBOT.sensors)


def test_sensor_mapping_rows_fail_on_a_wrong_table():
    wrong = build_sensor_table(RITY.sensors, _mybot_moved(225.0))  # sensor 6 at 225°: -> virtual 8
    rows = {r.metric: r for r in sensor_mapping.mapping_rows(wrong)}
    assert not rows["physical 6 → virtual (Table V)"].ok and rows["physical 6 → virtual (Table V)"].sim == 8.0
    assert rows["physical 1 → virtual (Table V)"].ok
    off = build_sensor_table(RITY.sensors, _mybot_moved(270.0, offset=10.0))  # every sensor 10° off: type only
    rows = {r.metric: r for r in sensor_mapping.mapping_rows(off)}
    assert not rows["rows with a valid location"].ok and rows["rows with a valid location"].sim == 0.0
    assert rows["rows with a valid type"].ok
    short = build_sensor_table(RITY.sensors, MYBOT.sensors[:5])  # physical 6 missing
    rows = {r.metric: r for r in sensor_mapping.mapping_rows(short)}
    assert not rows["physical 6 → virtual (Table V)"].ok and math.isnan(rows["physical 6 → virtual (Table V)"].sim)
    assert not rows["physical sensors in the table"].ok


def test_sensor_mapping_rows_pass_on_table_v_itself_and_with_radius_compared():
    assert all(r.ok for r in sensor_mapping.mapping_rows(TABLE_V))
    same_radius = build_sensor_table(RITY.sensors, MYBOT.sensors, LocationRule(compare_radius=True))
    assert all(r.ok for r in sensor_mapping.mapping_rows(same_radius))  # both at 0.15 m


# ---- ruta_example ------------------------------------------------------------------------------


def test_ruta_example_rows_all_pass_and_are_validated():
    res = ruta_example.ruta_example(load_config(), 0, True, _noop)
    assert res.ok and len(res.rows) == 12
    assert {r.basis for r in res.rows} == {"validated"}
    rows = {r.metric: r for r in res.rows}
    exact = rows["R1 nav utility, exact on the inputs 0.7 × 2200/130 × 1/3 (paper prints 3.90 from 5.58; exact 3.95)"]
    assert exact.paper == 3.95 and exact.sim == pytest.approx(3.94872, abs=1e-5) and exact.tolerance == 0.01
    printed = rows["R1 nav utility, on the printed bracket 0.7 × 5.58"]
    assert printed.sim == pytest.approx(3.906) and printed.tolerance == 0.01
    assert rows["R2 grip utility at 3 m"].sim == pytest.approx(0.69818, abs=1e-5)
    assert res.data["grips_first_decentralized"] == "R4"


def test_ruta_example_rows_fail_when_an_equation_is_off(monkeypatch):
    real = ruta.phi_nav
    monkeypatch.setattr(ruta, "phi_nav", lambda **kw: real(**kw) * 0.9 / 0.7)  # φ_sens's 0.9 in φ_nav
    rows = {r.metric: r for r in ruta_example.example_rows(ruta.worked_example())}
    assert not rows["R2 nav utility"].ok
    assert not rows["R1 nav utility, exact on the inputs 0.7 × 2200/130 × 1/3 (paper prints 3.90 from 5.58; exact 3.95)"].ok
    assert rows["grip pri at t = 110 s, t_j = 20 s"].ok
    monkeypatch.setattr(ruta, "phi_nav", real)
    monkeypatch.setattr(ruta, "priority", lambda t, tj, u1: min(u1 * (t - tj), 1.0))  # without the ½
    rows = {r.metric: r for r in ruta_example.example_rows(ruta.worked_example())}
    assert not rows["grip pri at t = 110 s, t_j = 20 s"].ok and not rows["R4 grip utility at 4.3 m (φ 5.04 as printed)"].ok
    assert rows["R4 grips first, Algorithm 2 (fittest bid) (1 = yes)"].ok  # the order survives a common factor


def test_ruta_example_decision_rows_fail_on_the_wrong_robot():
    fig = ruta.worked_example()
    fig.update(grips_first_decentralized="R2", grips_first_centralized=None, deployed_first=["R2", "R4"])
    rows = {r.metric: r for r in ruta_example.example_rows(fig)}
    assert not rows["R4 grips first, Algorithm 2 (fittest bid) (1 = yes)"].ok
    assert not rows["R4 grips first, Algorithm 1 (master assigns) (1 = yes)"].ok
    assert not rows["R1 and R2 deployed first (R4 nav 1.21 as printed) (1 = yes)"].ok


def test_rows_refuse_an_unknown_basis():
    with pytest.raises(ValueError, match="basis 'fitted' is not one of calibrated, validated"):
        Row.within("m", 1.0, 1.0, 0.0, basis="fitted")
    assert Row.within("m", 1.0, 1.0, 0.0, basis="validated").to_json()["basis"] == "validated"
