"""The experiments' own programs (``python -m petswarm.experiments.NAME``, the commands docs/faults.md and
docs/results.md give): a bad flag, seed list, override or output path is one line on stderr naming the problem,
exit status 2, no traceback, before any episode runs; and ``measure_scale --json`` writes what it printed."""

import json
import runpy
import sys

import pytest

# runpy runs a module another program has imported already (measure_succession.parse_seeds): harmless here
pytestmark = pytest.mark.filterwarnings("ignore:'petswarm.experiments.:RuntimeWarning")

PROGRAMS = ["assignment_compare", "calibrate_ir", "calibrate_lf", "calibrate_organize", "measure_building",
            "measure_count", "measure_mixed", "measure_scale", "measure_succession", "measure_walks",
            "measure_wearables", "organize_under_loss", "reassignment", "refit", "sensor_faults"]
TAKE_SEEDS = ["measure_building", "measure_count", "measure_mixed", "measure_scale", "measure_succession",
              "measure_walks", "sensor_faults"]  # --seeds as a range or a comma list (measure_succession.parse_seeds)
TAKE_SET = ["measure_building", "measure_scale", "measure_succession", "measure_walks", "sensor_faults"]


def _run(monkeypatch, capsys, name: str, *argv: str) -> tuple[int, str, str]:
    """Run the program as ``python -m`` does (its ``__main__`` block), in this process."""
    monkeypatch.setattr(sys, "argv", [f"{name}.py", *argv])
    with pytest.raises(SystemExit) as exc:
        runpy.run_module(f"petswarm.experiments.{name}", run_name="__main__", alter_sys=False)
    out, err = capsys.readouterr()
    return exc.value.code, out, err


def _one_line(err: str, name: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"python -m petswarm.experiments.{name}: error: "), err
    assert "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize("name", PROGRAMS)
def test_an_unknown_flag_is_one_line(monkeypatch, capsys, name):
    code, _, err = _run(monkeypatch, capsys, name, "--no-such-flag")
    assert code == 2
    assert "unrecognized arguments: --no-such-flag" in _one_line(err, name)


@pytest.mark.parametrize("name", TAKE_SEEDS)
@pytest.mark.parametrize("seeds", ["x", "5-2", "1,,2", "-3"])
def test_a_bad_seed_list_is_one_line_naming_the_form(monkeypatch, capsys, name, seeds):
    code, out, err = _run(monkeypatch, capsys, name, f"--seeds={seeds}")
    assert code == 2
    line = _one_line(err, name)
    assert f"--seeds '{seeds}'" in line and "e.g. --seeds 0-19" in line
    assert "seed" not in out  # no episode ran


@pytest.mark.parametrize("name", TAKE_SET)
@pytest.mark.parametrize("item, words", [("foo", "must look like KEY=VALUE"),
                                         ("swarm.num_slavez=3", "unknown config key 'swarm.num_slavez'"),
                                         ("swarm.num_slaves=0", "greater than or equal to 1")])
def test_a_bad_override_is_one_line_naming_the_key(monkeypatch, capsys, name, item, words):
    code, _, err = _run(monkeypatch, capsys, name, "--seeds", "0", "--set", item)
    assert code == 2
    assert words in _one_line(err, name)


def test_measure_scale_refuses_an_unwritable_json_before_running(monkeypatch, capsys, tmp_path):
    code, out, err = _run(monkeypatch, capsys, "measure_scale", "--seeds", "0", "--json", str(tmp_path))
    assert code == 2
    assert "is a folder; name a file" in _one_line(err, "measure_scale")
    assert out == "" and list(tmp_path.iterdir()) == []


def test_measure_scale_writes_its_cases_and_episodes_as_json(monkeypatch, capsys, tmp_path):
    path = tmp_path / "scale.json"
    code, out, _ = _run(monkeypatch, capsys, "measure_scale", "--slaves", "2", "--seeds", "0,1", "--json", str(path))
    assert code == 0
    data = json.loads(path.read_text())
    assert data["seeds"] == [0, 1]
    (case,) = data["cases"]
    assert (case["slaves"], case["loss"]) == (2, 0.0)
    assert [r["seed"] for r in case["episodes"]] == [0, 1]
    s = case["summary"]
    assert s["episodes"] == 2 and s["built"] == sum(r["building_time_s"] == r["building_time_s"] for r in case["episodes"])
    printed = out.strip().splitlines()[-1].split()  # the case's printed line: slaves loss episodes joined built ...
    assert [int(printed[0]), int(printed[2]), int(printed[3]), int(printed[4])] == [2, s["episodes"], s["joined"], s["built"]]
