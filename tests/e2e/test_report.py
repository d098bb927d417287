"""The HTML comparison report (evaluation/report.py) on small synthetic result files."""

from __future__ import annotations

import base64
import json
import math
import re
import sys

import pytest

from petswarm.evaluation.report import load_result, write_report
from petswarm.evaluation.stats import mean_ci95, t_critical_95


def _episode(seed: int, scenario: str, policy: str, rmse: float, steps: int = 12, gif: str | None = None) -> dict:
    user = [[0.1 * i, 0.05 * (i % 4)] for i in range(steps)]
    robots = {f"robot_{k}": [[x - 0.5 * k, y + 0.3 * (k % 2)] for x, y in user] for k in range(3)}
    ep = {
        "seed": seed,
        "scenario": scenario,
        "policy": policy,
        "formation_rmse_m": rmse,
        "steps": steps,
        "slaves": 2,
        "collisions": {"robot_robot": 1, "robot_user": 0, "robot_wall": 2},
        "organize_time_s": 1.2,
        "join_retries": 1,
        "token_recoveries": 0,
        "frames": {"sent": 100, "lost": 5, "collided": 10},
        "error_trace": [rmse * (1 + 0.5 / (i + 1)) for i in range(steps)],
        "trajectory": {"dt_s": 0.1, "user": user, "master": "robot_0", "robots": robots},
        "arbiter_wins": {"safety": 2, "user": 0, "policy": steps * 2 - 2},
    }
    if gif:
        ep["gif"] = gif
    return ep


# RMSE per (label, scenario): scripted zigzag mean 0.12, learned zigzag mean 0.18 -> ratio 1.50
VALUES = {
    ("scripted", "zigzag"): [0.10, 0.12, 0.14],
    ("scripted", "straight"): [0.20, 0.20, 0.20],
    ("learned", "zigzag"): [0.17, 0.18, 0.19],
    ("learned", "straight"): [0.10, 0.11, 0.12],
}


def _result(label: str, num_slaves: int = 2, gif_first: str | None = None) -> dict:
    episodes = []
    for scenario in ("zigzag", "straight"):
        for seed, rmse in enumerate(VALUES[(label, scenario)]):
            gif = gif_first if (scenario == "zigzag" and seed == 0) else None
            episodes.append(_episode(seed, scenario, label, rmse, gif=gif))
    return {"label": label, "config": {"control_period_s": 0.1, "swarm": {"num_slaves": num_slaves, "formation": "wedge"}}, "episodes": episodes}


def _write(path, data) -> str:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    return str(path)


def test_report_compares_labels_with_ci_ratio_plots_and_gif_links(tmp_path):
    runs = tmp_path / "runs" / "eval"
    gif = runs / "gifs" / "zigzag_seed0.gif"
    gif.parent.mkdir(parents=True)
    gif.write_bytes(b"GIF89a")
    a = _write(runs / "scripted.json", _result("scripted", 2))
    b = _write(runs / "learned.json", _result("learned", 3, gif_first="gifs/zigzag_seed0.gif"))
    out = tmp_path / "reports" / "report.html"
    write_report([a, b], str(out))

    text = out.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    for needle in ("scripted", "learned", "zigzag", "straight", "petswarm_v0"):
        assert needle in text
    # CI: scripted zigzag sd 0.02, n 3, t(2) = 4.303 -> ±0.050; learned zigzag sd 0.01 -> ±0.025
    assert "0.120 ± 0.050" in text
    assert "0.180 ± 0.025" in text
    assert "ratio to scripted" in text
    assert re.search(r"<td>0\.180 ± 0\.025</td><td>3</td><td>1\.50</td>", text)
    assert re.search(r"<td>0\.110 ± 0\.025</td><td>3</td><td>0\.55</td>", text)  # learned straight: 0.11 / 0.20
    # best per scenario highlighted: scripted on zigzag, learned on straight
    assert re.search(r'<tr class="(?:grp )?best"><td class="l">zigzag</td><td class="l">scripted', text)
    assert re.search(r'<tr class="(?:grp )?best"><td class="l">straight</td><td class="l">learned', text)
    # config difference found
    assert "swarm.num_slaves" in text
    # embedded PNGs that decode: bars + 2 error-over-time + 2 trajectory plots
    images = re.findall(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)"', text)
    assert len(images) >= 5
    assert all(base64.b64decode(img)[:8] == b"\x89PNG\r\n\x1a\n" for img in images)
    assert "25–75 percentile" in text
    # self-contained: no external resources
    assert "http://" not in text and "https://" not in text and "<script" not in text
    # GIF link relative to the report, pointing at the file beside the JSON
    assert 'href="../runs/eval/gifs/zigzag_seed0.gif"' in text
    assert (out.parent / "../runs/eval/gifs/zigzag_seed0.gif").resolve() == gif.resolve()
    assert "file not found" not in text
    # collisions totals (3 episodes x 1 robot-robot, x 2 robot-wall) and arbiter shares (2 / 24 ticks per episode)
    assert "<td>3</td><td>3</td><td>0</td><td>6</td><td>9</td>" in text
    assert "12 (8.3 %)" in text  # 6 episodes x 2 safety wins of 144 ticks
    # no temporary files left
    assert sorted(p.name for p in out.parent.iterdir()) == ["report.html"]


def test_degenerate_inputs_one_label_zero_episodes_nan_missing_fields(tmp_path):
    old = {"episodes": [{"seed": 0, "formation_rmse_m": float("nan"), "steps": 5}, {"seed": 1, "formation_rmse_m": 0.3}]}
    empty = {"label": "empty", "episodes": []}
    p_old = tmp_path / "old_result.json"
    p_old.write_text(json.dumps(old))  # NaN written as the bare token NaN, as json.dump(allow_nan=True) does
    p_empty = _write(tmp_path / "empty.json", empty)

    out = tmp_path / "one.html"
    write_report([str(p_old)], str(out))
    text = out.read_text(encoding="utf-8")
    assert "old_result" in text  # label falls back to the file name
    assert "0.300 ± n/a" in text  # one finite value: no interval
    assert "2 (1 without a value)" in text
    assert "n/a" in text and "—" in text  # missing fields; no scripted reference
    assert "no trajectories recorded" in text

    out2 = tmp_path / "empty.html"
    write_report([p_empty], str(out2))
    assert "No episodes" in out2.read_text(encoding="utf-8")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.html", "empty.json", "old_result.json", "one.html"]


def test_labels_are_escaped_and_duplicates_distinguished(tmp_path):
    a = _result("scripted")
    a["label"] = "<b>mix:robot_2=learned</b>"
    for ep in a["episodes"]:  # no traces or trajectories: fewer plots, faster test
        del ep["error_trace"], ep["trajectory"]
    p1 = _write(tmp_path / "a.json", a)
    p2 = _write(tmp_path / "b.json", a)
    out = tmp_path / "r.html"
    write_report([p1, p2], str(out))
    text = out.read_text(encoding="utf-8")
    assert "<b>mix:" not in text
    assert "&lt;b&gt;mix:robot_2=learned&lt;/b&gt; [a.json]" in text
    assert "&lt;b&gt;mix:robot_2=learned&lt;/b&gt; [b.json]" in text


@pytest.mark.parametrize(
    "content, problem",
    [
        ("{not json", "not valid JSON"),
        ("", "empty"),
        ("[1, 2]", "expected a JSON object"),
        ('{"episodes": 3}', "'episodes' must be a list"),
        ('{"episodes": [1]}', "episode 0 must be a JSON object"),
    ],
)
def test_bad_result_file_raises_value_error_naming_it(tmp_path, content, problem):
    good = _write(tmp_path / "good.json", _result("scripted"))
    bad = tmp_path / "broken_result.json"
    bad.write_text(content)
    out = tmp_path / "report.html"
    with pytest.raises(ValueError) as info:
        write_report([good, str(bad)], str(out))
    message = str(info.value)
    assert "broken_result.json" in message and problem in message and "\n" not in message
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken_result.json", "good.json"]


def test_missing_file_and_no_files(tmp_path):
    with pytest.raises(ValueError, match="nope.json: result file not found"):
        load_result(tmp_path / "nope.json")
    with pytest.raises(ValueError, match="no result files"):
        write_report([], str(tmp_path / "r.html"))


def test_confidence_interval_and_t_table(monkeypatch):
    m, h, n = mean_ci95([0.10, 0.12, 0.14, float("nan"), None])
    assert n == 3 and m == pytest.approx(0.12) and h == pytest.approx(4.303 * 0.02 / math.sqrt(3), rel=1e-3)
    assert math.isnan(mean_ci95([0.5])[1]) and math.isnan(mean_ci95([])[0])
    monkeypatch.setitem(sys.modules, "scipy.special", None)  # force the fallback table
    assert t_critical_95(2) == 4.303 and t_critical_95(30) == 2.042 and t_critical_95(31) == 1.96


def test_gif_path_relative_to_the_working_directory_is_found_too(tmp_path, monkeypatch):
    # a GIF path written as given on the command line (relative to the cwd, not to the JSON)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs" / "eval").mkdir(parents=True)
    (tmp_path / "runs" / "eval" / "zigzag_seed0.gif").write_bytes(b"GIF89a")
    data = {"label": "learned", "episodes": [{"seed": 0, "scenario": "zigzag", "formation_rmse_m": 0.1, "gif": "runs/eval/zigzag_seed0.gif"}]}
    res = _write(tmp_path / "runs" / "eval" / "learned.json", data)
    write_report([res], "report.html")
    text = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert 'href="runs/eval/zigzag_seed0.gif"' in text and "file not found" not in text
