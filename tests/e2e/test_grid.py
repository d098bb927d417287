"""The comparison grid (docs/results.md): ``petswarm eval --grid FILE`` end to end through the
CLI (JSON, resume, the report's heatmap), the grid file's one-line errors, a cell's determinism,
and the committed grid's coverage."""

import json
import re
from pathlib import Path

import pytest

from petswarm.cli.main import main
from petswarm.evaluation.grid import run_cell
from petswarm.evaluation.grid_spec import load_grid

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = ROOT / "configs" / "eval" / "grid.yaml"

TINY = """\
seed: 900000000
episodes: 2
set: {max_cycles: 25, swarm.num_slaves: 2}
cells:
  - name: shapes
    product: {swarm.formation: [wedge, column]}
  - name: one learned among scripted
    team: {policy: reference, mix: {robot_2: candidate}}
"""


def _grid(tmp_path, text=TINY, name="grid.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_tiny_grid_end_to_end_json_resume_and_report_heatmap(tmp_path, capsys):
    grid, out, html = _grid(tmp_path), tmp_path / "grid.json", tmp_path / "report.html"
    assert main(["eval", "--grid", grid, "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "[  3/3]" in printed and "worst cells:" in printed
    data = json.loads(out.read_text())
    assert data["kind"] == "grid" and data["complete"] and data["episodes"] == []
    assert data["candidate"] == "learned" and data["reference"] == "scripted" and "learned" in data["policy_sha256"]
    assert [c["name"] for c in data["cells"]] == ["shapes formation=wedge", "shapes formation=column", "one learned among scripted"]
    for c in data["cells"]:
        assert c["seeds"] == [900000000, 900000001]
        assert c["ratio"] == pytest.approx(c["candidate"]["formation_rmse_m"] / c["reference"]["formation_rmse_m"])
        assert {"collisions", "robot_robot", "robot_user", "robot_wall", "per_episode"} <= set(c["candidate"])
        assert 0 <= c["episodes_better"] <= 2 and c["median_ratio"] > 0
        # judged on the hold RMSE (the committed default), with every guard
        assert c["score_metric"] == ("mix_robots_hold_rmse_m" if c["team"]["mix"] else "formation_hold_rmse_m")  # the mix: learned
        guards = (c["candidate"]["collisions"] <= c["reference"]["collisions"]
                  and c["candidate"]["formations_built"] >= c["reference"]["formations_built"]
                  and c["others_no_worse"] is not False and c["no_new_lost"] == (c["lost_only_candidate"] == []))
        assert c["meets_target"] == bool(c["score_ratio"] <= 0.8 and guards and c["no_new_lost"])
        assert len(c["ratio_ci95"]) == 2 and len(c["score_ratio_ci95"]) == 2
        for e in c["candidate"]["per_episode"]:
            assert {"formation_hold_rmse_m", "building_time_s", "refill_settle_rmse_m", "lost_robot_s"} <= set(e)
    mixed = data["cells"][2]
    assert mixed["team"] == {"policy": "scripted", "mix": {"robot_2": "learned"}}
    assert mixed["reference"]["label"] == "scripted" and mixed["mix_robots_ratio"] > 0
    assert {"mix_robots_hold_rmse_m", "others_rmse_m", "others_hold_rmse_m"} <= set(mixed["reference"]["per_episode"][0])
    assert mixed["others_ratio"] > 0 and isinstance(mixed["others_no_worse"], bool)
    assert data["cells"][0]["others_no_worse"] is None  # not a mixed cell: no guard
    assert data["summary"]["cells"] == 3 and len(data["summary"]["worst"]) == 3
    # --resume keeps every finished cell (nothing is run again) and writes the same figures
    assert main(["eval", "--grid", grid, "--json", str(out), "--resume"]) == 0
    assert capsys.readouterr().out.count("kept from --resume") == 3
    again = json.loads(out.read_text())
    assert [c["ratio"] for c in again["cells"]] == [c["ratio"] for c in data["cells"]]
    assert [c["score_ratio_ci95"] for c in again["cells"]] == [c["score_ratio_ci95"] for c in data["cells"]]
    # the report: the grid's section with its heatmap (one embedded PNG) and its table
    assert main(["report", str(out), "--out", str(html)]) == 0
    page = html.read_text()
    assert "Comparison grid" in page and "comparison grid heatmap" in page and "lost-robot episodes" in page
    assert len(re.findall(r"data:image/png;base64,", page)) == 1
    assert "shapes formation=column" in page
    assert not list(tmp_path.glob(".*"))  # no temp files left behind


def test_a_cell_is_deterministic(tmp_path):
    grid = load_grid(_grid(tmp_path), episodes=1)
    first, second = (run_cell(grid, grid.cells[0], "k") for _ in range(2))
    for side in ("candidate", "reference"):
        assert first[side]["per_episode"] == second[side]["per_episode"]
    assert first["ratio"] == second["ratio"]


@pytest.mark.parametrize(
    "text, words",
    [
        ("seed: 1\nepisodes: 1\ncels: []\n", ["unknown key 'cels'", "allowed keys: candidate, cells"]),
        ("seed: 1\nepisodes: 1\ncells:\n  - name: a\n    sett: {}\n", ["cell entry 0 ('a')", "unknown key 'sett'", "product"]),
        ("seed: 1\nepisodes: 1\ncells:\n  - team: {policy: reference, mx: {}}\n", ["cell entry 0", "unknown key 'mx'", "mix"]),
        ("seed: 1\nepisodes: 0\ncells: [{}]\n", ["'episodes'", "greater than or equal to 1"]),
        ("episodes: 1\ncells: [{}]\n", ["'seed' is missing"]),
        ("seed: 1\nepisodes: 1\ncells:\n  - name: b\n    set: {swarm.formaton: wedge}\n", ["cell 'b'", "swarm.formaton"]),
        ("seed: 1\nepisodes: 1\ncells:\n  - name: c\n    product: {user.scenario: [zigzag, moonwalk]}\n",
         ["cell 'c scenario=moonwalk'", "user.scenario", "zigzag"]),
        ("seed: 1\nepisodes: 1\ncells:\n  - name: d\n    team: {mix: {robot_9: reference}}\n", ["cell 'd'", "robot_9", "robot_1"]),
        ("seed: 1\nepisodes: 1\ncells:\n  - name: e\n    team: {policy: clever}\n", ["cell entry 0 ('e')", "unknown policy 'clever'"]),
        ("seed: 1\nepisodes: 1\ncells:\n  - name: f\n    product: {swarm.num_slaves: []}\n", ["'swarm.num_slaves' lists no values"]),
        ("seed: 1\nepisodes: 1\nset: {radio.loss_prob: 2}\ncells: [{}]\n", ["set:", "radio.loss_prob"]),
    ],
)
def test_grid_file_errors_are_one_line_naming_the_cell_and_the_fix(tmp_path, capsys, text, words):
    out = tmp_path / "out.json"
    assert main(["eval", "--grid", _grid(tmp_path, text), "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("petswarm: error:")
    for w in words:
        assert w in err, (w, err)
    assert not out.exists()


def test_grid_refuses_options_it_does_not_use(tmp_path, capsys):
    assert main(["eval", "--grid", _grid(tmp_path), "--mix", "robot_1=learned"]) == 2
    assert "drop --mix" in capsys.readouterr().err
    assert main(["eval", "--grid", _grid(tmp_path), "--resume"]) == 2
    assert "give --json OUT" in capsys.readouterr().err
    assert main(["eval", "--resume"]) == 2
    assert "--resume belongs to --grid" in capsys.readouterr().err


def test_the_committed_grid_has_40_cells_over_every_value_it_names():
    grid = load_grid(str(COMMITTED))
    assert len(grid.cells) >= 40
    assert grid.seed >= 900_000_000  # far from every seed training uses (docs/training.md, held-out seeds)
    seen: dict[str, set] = {}
    for c in grid.cells:
        cfg = c.config
        for key, value in (("scenario", cfg.user.scenario), ("formation", cfg.swarm.formation), ("mode", cfg.swarm.mode),
                           ("loss", cfg.radio.loss_prob), ("slaves", cfg.swarm.num_slaves), ("users", cfg.world.num_users)):
            seen.setdefault(key, set()).add(value)
    assert seen["scenario"] >= {"zigzag", "u_turn", "random_walk", "turn_left_60", "stop_and_go"}
    assert seen["formation"] >= {"wedge", "column", "row", "grid"}
    assert seen["mode"] >= {"following", "leading"}
    assert seen["loss"] >= {0.0, 0.15, 0.3} and seen["slaves"] >= {2, 4, 6} and 2 in seen["users"]
    mixes = [(c.policy, tuple(c.mix.values())) for c in grid.cells if c.mix]
    assert ("scripted", ("learned",)) in mixes and ("learned", ("scripted",)) in mixes


def test_a_killed_grid_keeps_its_finished_cells_and_resume_runs_only_the_rest(tmp_path):
    from petswarm.evaluation.grid import run_grid
    from petswarm_env.config import load_config

    grid, out = load_grid(_grid(tmp_path), episodes=1), tmp_path / "grid.json"
    lines = []

    def stop_after_first(line):
        lines.append(line)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_grid(grid, load_config(), str(out), progress=stop_after_first)
    partial = json.loads(out.read_text())
    assert not partial["complete"] and len(partial["cells"]) == 1
    resumed = run_grid(grid, load_config(), str(out), resume=True, progress=lines.append)
    assert resumed["complete"] and len(resumed["cells"]) == 3
    assert "kept from --resume" in lines[1] and all("kept" not in line for line in lines[2:])
    assert json.dumps(resumed["cells"][0], sort_keys=True) == json.dumps(partial["cells"][0], sort_keys=True)  # NaN != NaN
    # another seed is another cell: nothing is kept
    other = load_grid(_grid(tmp_path), episodes=1, seed=900000005)
    lines.clear()
    run_grid(other, load_config(), str(out), resume=True, progress=lines.append)
    assert not any("kept" in line for line in lines)


def test_the_report_shows_eval_results_and_the_grid_side_by_side(tmp_path):
    grid, out, ev, html = _grid(tmp_path), tmp_path / "grid.json", tmp_path / "scripted.json", tmp_path / "r.html"
    assert main(["eval", "--grid", grid, "--episodes", "1", "--json", str(out)]) == 0
    assert main(["eval", "--policy", "scripted", "--episodes", "1", "--set", "max_cycles=25", "--json", str(ev)]) == 0
    assert main(["report", str(ev), str(out), "--out", str(html), "--replays", "none"]) == 0
    page = html.read_text()
    assert "2. Formation RMSE per scenario" in page and "8. Comparison grid" in page and "3 cells × 1" in page


def test_grid_without_a_file_is_the_committed_grid_shipped_in_the_package():
    from petswarm.cli.main import SHIPPED_GRID, build_parser
    from petswarm.evaluation.grid_spec import load_grid

    args = build_parser().parse_args(["eval", "--grid"])
    assert args.grid == str(SHIPPED_GRID) and SHIPPED_GRID.is_file()
    assert len(load_grid(args.grid).cells) >= 40  # the packaged copy of configs/eval/grid.yaml (tests/e2e/test_docs.py)


def test_the_privileged_teacher_runs_as_a_grid_candidate_and_mixes_in(tmp_path, capsys):
    """``--policy privileged-teacher``: the ceiling of docs/training.md (ground truth, not a policy)."""
    grid, out = _grid(tmp_path), tmp_path / "ceiling.json"
    assert main(["eval", "--grid", grid, "--policy", "privileged-teacher", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["candidate"] == "privileged-teacher" and data["policy_sha256"] == {}
    assert data["cells"][2]["team"] == {"policy": "scripted", "mix": {"robot_2": "privileged-teacher"}}
    assert all(c["ratio"] > 0 for c in data["cells"])
    capsys.readouterr()
    # it is an evaluation instrument: `petswarm run` (which runs policies) does not take it
    with pytest.raises(SystemExit):
        main(["run", "--policy", "privileged-teacher"])
    assert "privileged-teacher" not in capsys.readouterr().err.split("got")[0]
    # the teacher of a training config that does not exist: one line naming it and the fix
    with pytest.raises(SystemExit):
        main(["eval", "--grid", grid, "--policy", "privileged-teacher:no_such_config"])
    err = capsys.readouterr().err.strip()
    assert "no training config 'no_such_config'" in err and len(err.splitlines()) == 1
