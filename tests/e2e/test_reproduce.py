"""`petswarm reproduce`: registry, CLI arguments, JSON schema, --check exit codes, the organize
experiment on a small run, the HTML report and atomic writes."""

from __future__ import annotations

import json
import math
import os

import pytest

from cli.main import main
from experiments import registry
from experiments.ir_accuracy import IR_QUICK_SAMPLES_PER_POINT
from experiments.organize_time import PAPER_MIN_ORGANIZE_S, organize_rows, organize_summary, organize_time
from experiments.reaction_time import reaction_trial
from experiments.report import render_html
from experiments.results import Experiment, ExperimentResult, NotAvailable, Row
from experiments.rotation_sync import rotation_trial
from petswarm_env.config import load_config

ROW_KEYS = {"metric", "paper", "sim", "tolerance", "ok"}


def _fake(rows=(), missing: str | None = None):
    def run(cfg, seed, quick, progress):
        if missing:
            raise NotAvailable(missing)
        progress(1, 1)
        return ExperimentResult(rows=list(rows), data={"seed": seed, "quick": quick})

    return run


@pytest.fixture
def fakes(monkeypatch):
    """Experiments with known rows: one within tolerance, one outside, one not available."""
    good = [Row.within("a (s)", 1.0, 1.05, 0.1)]
    bad = [Row.within("a (s)", 1.0, 1.05, 0.1), Row.within("b (%)", 30.0, 50.0, 15.0)]
    for name, fn in [("fake_ok", _fake(good)), ("fake_bad", _fake(bad)), ("fake_na", _fake(missing="needs the widget"))]:
        monkeypatch.setitem(registry.EXPERIMENTS, name, Experiment(name, name, fn))


# -- registry and arguments -----------------------------------------------------------------------------
def test_registry_has_the_issue_names_in_order():
    assert list(registry.EXPERIMENTS) == ["ir_accuracy", "reaction_time", "organize_time", "lf_accuracy", "rotation_sync",
                                          "sensor_mapping", "ruta_example"]


def test_parse_only():
    assert registry.parse_only(None) == list(registry.EXPERIMENTS)
    assert registry.parse_only(" organize_time, ir_accuracy,organize_time") == ["organize_time", "ir_accuracy"]
    with pytest.raises(ValueError, match="unknown experiment 'nope'; valid experiments: ir_accuracy, reaction_time"):
        registry.parse_only("ir_accuracy,nope")
    with pytest.raises(ValueError, match="no experiment named"):
        registry.parse_only(" , ")


def test_cli_unknown_experiment_lists_the_valid_ones(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["reproduce", "--only", "organise_time"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "organise_time" in err
    for name in ("ir_accuracy", "reaction_time", "organize_time", "lf_accuracy", "rotation_sync"):
        assert name in err


def test_row_tolerance():
    assert Row.within("m", 10.0, 11.9, 2.0).ok
    assert Row.within("m", 10.0, 8.0, 2.0).ok
    assert not Row.within("m", 10.0, 12.1, 2.0).ok
    assert not Row.within("m", 10.0, math.nan, 2.0).ok


# -- --check and the JSON ------------------------------------------------------------------------------
def test_check_exit_code(fakes, capsys):
    assert main(["reproduce", "--only", "fake_ok", "--check"]) == 0
    assert main(["reproduce", "--only", "fake_bad"]) == 0  # without --check a failing row is only printed
    assert main(["reproduce", "--only", "fake_ok,fake_bad", "--check"]) == 1
    assert main(["reproduce", "--only", "fake_bad", "--check"]) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and "b (%)" in out


def test_not_available_is_reported_and_fails_check(fakes, capsys):
    assert main(["reproduce", "--only", "fake_ok,fake_na", "--check"]) == 1
    out = capsys.readouterr().out
    assert "not available yet: needs the widget" in out


def test_json_schema(fakes, tmp_path):
    out = tmp_path / "sub" / "repro.json"
    assert main(["reproduce", "--only", "ir_accuracy,fake_bad,fake_na", "--quick", "--json", str(out)]) == 0
    text = out.read_text()
    data = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-standard JSON constant {c}"))
    assert set(data) == {"experiments"}
    exps = data["experiments"]
    assert list(exps) == ["ir_accuracy", "fake_bad", "fake_na"]
    for name, exp in exps.items():
        assert isinstance(exp["rows"], list)
        for row in exp["rows"]:
            assert set(row) == ROW_KEYS, name
            assert isinstance(row["metric"], str) and isinstance(row["ok"], bool)
            for k in ("paper", "sim", "tolerance"):
                assert isinstance(row[k], float), (name, k)
    ir = exps["ir_accuracy"]
    assert [r["metric"] for r in ir["rows"]] == ["distance RMSE (cm)", "direction RMSE (°)"]
    assert ir["rows"][0]["paper"] == 7.898 and ir["rows"][1]["paper"] == 5.8
    assert ir["data"]["samples_per_point"] == IR_QUICK_SAMPLES_PER_POINT
    assert [r["ok"] for r in exps["fake_bad"]["rows"]] == [True, False]
    assert exps["fake_na"]["rows"] == [] and exps["fake_na"]["available"] is False


# -- organize_time -----------------------------------------------------------------------------------------
def test_organize_time_small_run_gives_sane_rows():
    calls = []
    res = organize_time(load_config(), 0, True, lambda d, t: calls.append((d, t)), slave_counts=(1, 2), trials=4)
    assert calls[-1] == (8, 8)
    assert [r.metric for r in res.rows] == [
        "min organize time, 1 slave (s)", "min organize time, 2 slaves (s)",
        "retry probability, 1 slave (%)", "retry probability, 2 slaves (%)",
        "retry probability rises with the slave count (1 = yes)",
    ]
    s1, s2 = res.data["summary"]["1"], res.data["summary"]["2"]
    assert s1["organizations"] == s2["organizations"] == 4
    assert s1["failed"] == s2["failed"] == 0
    assert s1["retry_pct"] == 0.0  # one slave: nothing to collide with
    assert 0.3 < s1["min_s"] <= s1["mean_s"] <= s1["max_s"] < 3.0
    assert s2["min_s"] > s1["min_s"]  # one more notification round
    assert res.rows[0].ok and res.rows[2].ok  # 1 slave: 0.6 s ± 0.1, 0 % ± 15
    for t in res.data["trials"]["2"]:
        assert t["complete"] and t["slaves"] == 2


def test_organize_rows_flag_misses_and_a_falling_probability():
    def summ(pcts):
        return {n: {"min_s": PAPER_MIN_ORGANIZE_S[n], "retry_pct": p} for n, p in pcts.items()}

    rows = {r.metric: r for r in organize_rows(summ({1: 0.0, 2: 40.0, 3: 30.0}))}
    assert rows["retry probability, 2 slaves (%)"].ok is False  # 40 vs 6 > 15 points
    assert rows["retry probability, 3 slaves (%)"].ok is True
    assert rows["retry probability rises with the slave count (1 = yes)"].ok is False  # 40 → 30 falls
    rows = organize_rows(summ({1: 0.0, 2: 10.0, 3: 30.0}))
    assert all(r.ok for r in rows)


def test_organize_summary_counts_a_failed_organization_as_retried():
    trials = [
        {"elapsed_s": 0.6, "retries": 0, "complete": True},
        {"elapsed_s": 1.2, "retries": 1, "complete": True},
        {"elapsed_s": math.nan, "retries": 3, "complete": False},
        {"elapsed_s": 0.7, "retries": 0, "complete": True},
    ]
    s = organize_summary(trials)
    assert s["failed"] == 1
    assert s["retry_pct"] == 50.0
    assert (s["min_s"], s["max_s"]) == (0.6, 1.2)


# -- report and atomic writes ---------------------------------------------------------------------------------
def test_html_report_has_plots_and_placeholders():
    cfg = load_config()
    results = registry.run_experiments(["ir_accuracy"], cfg, 0, True)
    results["organize_time"] = organize_time(cfg, 0, True, lambda d, t: None, slave_counts=(1, 2), trials=2)
    results["rotation_sync"] = ExperimentResult(rows=[], available=False, note="not available yet: a test")
    page = render_html(results, "petswarm reproduce --test")
    assert page.count('src="data:image/png;base64,') == 2  # Fig. 19 and Fig. 22 / Table 5
    assert "not available yet" in page  # rotation_sync
    assert "--only reaction_time" in page  # not run: says how to select it
    assert "http://" not in page and "https://" not in page  # self-contained


def test_json_and_report_are_written_atomically(fakes, tmp_path, monkeypatch, capsys):
    js, page = tmp_path / "r.json", tmp_path / "r.html"
    js.write_text("old json")
    page.write_text("old page")

    def fail_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", fail_replace)
    assert main(["reproduce", "--only", "fake_ok", "--json", str(js)]) == 2
    assert main(["reproduce", "--only", "fake_ok", "--report", str(page)]) == 2
    assert "disk full" in capsys.readouterr().err
    assert js.read_text() == "old json" and page.read_text() == "old page"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.html", "r.json"]  # no temporary file left behind


# -- the join protocol keeps scanning while nobody answered (a fix found by organize_time) -----------------
def test_master_rescans_while_every_scan_response_was_lost(monkeypatch):
    """Two scans in a row whose responses all collided used to end the organize with no slave
    (reset raised); the master must keep scanning within protocol.max_retries."""
    import petswarm_env
    from petswarm_env.comms import radio

    init = radio.RadioMedium.__init__
    dropped = []

    def init_with_filter(self, *args, **kwargs):
        init(self, *args, **kwargs)

        def drop(frame):  # lose the responses to the first two scans (2 robots each)
            if frame.kind == "scan_response" and len(dropped) < 4:
                dropped.append(frame.src)
                return True
            return False

        self.drop_filter = drop

    monkeypatch.setattr(radio.RadioMedium, "__init__", init_with_filter)
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": 2, "swarm.formation": "grid"})
    env.reset(seed=0)
    res = env.swarm.organize_result
    assert len(dropped) == 4
    assert res.retries >= 2 and len(res.members) == 3 and res.complete


# -- the experiments with the user in the loop ------------------------------------------------------------------
def test_reaction_trial_measures_master_then_slaves():
    t = reaction_trial(load_config(), 0)
    assert 0.1 < t["master_s"] < 2.0 and 0.1 < t["slave_s"] < 2.5  # the chain takes time, but reacts
    assert t["slave_minus_master_s"] == pytest.approx(t["slave_s"] - t["master_s"])


@pytest.mark.parametrize("target", [-90.0, 45.0])
def test_rotation_trial_arcs_with_the_user(target):
    arc = rotation_trial(load_config(), 0, target)
    assert arc * target > 0 and abs(arc - target) < 0.3 * abs(target)


def test_reaction_and_rotation_sections_render():
    res = {
        "reaction_time": ExperimentResult(
            rows=[Row.within("master reaction, 90th percentile (s)", 1.1, 0.6, 0.2)],
            data={"trials": [{}] * 3, "cdf": {"master": [0.4, 0.5, 0.6], "slave": [0.5, 0.7, 0.8], "slave_minus_master": [0.1, 0.2, 0.2]}}),
        "rotation_sync": ExperimentResult(
            rows=[Row("+90°: accuracy (%) > 94", 95.78, 96.0, 1.78, True)],
            data={"targets": {"90.0": {"paper_mean_deg": 87.56, "sim_mean_deg": 88.0, "sim_sigma_deg": 2.0,
                                       "sim_accuracy_pct": 96.0, "arcs_deg": [88.0, 86.0, 90.0]}}}),
    }
    page = render_html(res, "petswarm reproduce --test")
    assert "Fig. 20" in page and page.count('src="data:image/png;base64,') == 1
    assert "87.56" in page and "96" in page
