"""`petswarm bench` with tiny settings: the JSON shape, positive numbers and the markdown report.
No timing is asserted (speeds depend on the machine and its load)."""

import json
import math
from collections import Counter

import pytest

from training.bench import CATEGORIES, _category, breakdown_from_samples, format_report, main_bench, tiny_settings


def _positive(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    json_path = out / "bench.json"
    md_path = out / "docs" / "benchmarks.md"
    plot_path = out / "docs" / "benchmarks_steps.png"
    result = main_bench(True, str(json_path), md_out=str(md_path), plot_out=str(plot_path),
                        settings=tiny_settings(), verbose=False)
    return result, json_path, md_path, plot_path


def test_json_has_the_required_shape(bench):
    result, json_path, _, _ = bench
    data = json.loads(json_path.read_text())
    assert data == json.loads(json.dumps(result))  # what was written is what was returned
    for key in ("results", "ratios", "memory_mb", "breakdown", "training", "machine"):
        assert key in data
    for r in data["results"]:
        assert isinstance(r["name"], str) and r["name"]
        assert isinstance(r["agents"], int) and r["agents"] > 0
        assert _positive(r["steps_per_s"]) and _positive(r["agent_steps_per_s"])
    names = {r["name"] for r in data["results"]}
    for n in (2, 5, 9):
        assert {f"petswarm_scripted_{n}", f"petswarm_random_{n}", f"floor_{n + 1}"} <= names
    petswarm = [r for r in data["results"] if r["kind"] == "petswarm"]
    assert sorted({r["agents"] for r in petswarm}) == [3, 6, 10]  # master + slaves
    for r in petswarm:
        assert r["agents"] == r["slaves"] + 1
        assert _positive(r["reset_ms"]) and r["policy_ms_per_step"] >= 0
    mpe = [r for r in data["results"] if r["kind"] == "mpe"]
    if mpe:
        assert sorted(r["agents"] for r in mpe) == [3, 6, 10]
        assert _positive(data["ratios"]["petswarm_vs_mpe_6"])
    else:
        assert data["ratios"]["petswarm_vs_mpe_6"] is None
        assert any("mpe" in s["name"] and s["reason"] for s in data["skipped"])
    assert _positive(data["ratios"]["petswarm_vs_floor_6"])
    assert _positive(data["ratios"]["cost_9_vs_5_slaves"])
    for t in data["targets"].values():
        assert {"measured", "target", "met"} <= set(t)


def test_memory_breakdown_training_and_machine(bench):
    result = bench[0]
    mem = result["memory_mb"]
    assert mem["first"]["steps"] == 20 and mem["last"]["steps"] == 60
    for sample in (mem["first"], mem["last"]):
        assert _positive(sample["rss"]) and _positive(sample["peak_rss"]) and sample["py_blocks"] > 0
    assert len(mem["tracemalloc"]["episodes"]) >= 2
    assert all(_positive(e["current"]) for e in mem["tracemalloc"]["episodes"])
    assert isinstance(mem["no_growth"], bool)

    b = result["breakdown"]
    assert set(b["shares"]) == set(CATEGORIES)
    assert all(v >= 0 for v in b["shares"].values())
    assert sum(b["shares"].values()) == pytest.approx(1.0)
    assert b["shares"]["physics"] > 0 and b["shares"]["radio_middleware"] > 0 and b["shares"]["observation"] > 0
    assert b["top_functions"] and _positive(b["profiled_ms_per_step"])

    tr = result["training"]
    if "skipped" not in tr:
        assert tr["runs"] and all(_positive(r["samples_per_s"]) and r["samples"] >= 64 for r in tr["runs"])

    m = result["machine"]
    assert m["cpu_count"] >= 1 and m["python"] and m["versions"]["numpy"]


def test_report_and_markdown(bench):
    result, _, md_path, plot_path = bench
    text = format_report(result)
    assert "targets" in text and "petswarm scripted (1+5)" in text
    md = md_path.read_text()
    assert "| petswarm scripted (1+5) | 6 |" in md
    assert "](benchmarks_steps.png)" in md  # the plot, linked relative to the markdown
    assert "## Where a step's time goes" in md and "Method:" in md
    assert plot_path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in md_path.parent.iterdir()) == ["benchmarks.md", "benchmarks_steps.png"]  # no temp files


def test_profile_attribution_rules():
    site = "/venv/lib/python3.11/site-packages"
    assert _category((f"{site}/pymunk/space.py", 1, "step")) == "physics"
    assert _category((f"{site}/pymunk/body.py", 1, "position")) is None  # accessor: counts for its caller
    assert _category(("~", 0, "<built-in method math.hypot>")) is None
    assert _category((f"{site}/simpy/core.py", 1, "step")) == "radio_middleware"
    assert _category(("/repo/petswarm_env/comms/radio.py", 1, "_deliver")) == "radio_middleware"
    assert _category(("/repo/petswarm_env/env.py", 1, "_formation_errors")) == "reward_metrics"
    assert _category(("/repo/petswarm_env/sim/world.py", 1, "ultrasonic_ranges")) == "observation"
    assert _category(("/repo/petswarm_env/sim/robot.py", 1, "apply")) == "physics"
    assert _category(("/repo/petswarm_env/env.py", 1, "step")) == "other"


def test_missing_mpe_is_recorded_as_skipped(monkeypatch):
    import training.bench as bench_mod

    monkeypatch.setattr(bench_mod, "mpe_available", lambda: (False, "mpe2 is not installed"))
    result = main_bench(True, None, settings=tiny_settings(slaves=(5,), training_workers=()), verbose=False)
    assert not [r for r in result["results"] if r["kind"] == "mpe"]
    assert result["skipped"] == [{"name": "mpe_simple_spread", "reason": "mpe2 is not installed"}]
    assert result["ratios"]["petswarm_vs_mpe_6"] is None and result["targets"]["petswarm_vs_mpe_6"]["met"] is None
    assert result["ratios"]["cost_9_vs_5_slaves"] is None  # no 9-slave run in these settings
    assert _positive(result["ratios"]["petswarm_vs_floor_6"])
    assert "skipped" in result["training"]
    assert "skipped: mpe2 is not installed" in format_report(result)


def test_sampled_breakdown_charges_the_innermost_non_neutral_frame_below_env_step():
    site = "/venv/lib/python3.11/site-packages"
    outside = ("/repo/training/bench.py", 1, "run", "_EnvLoop.run")
    step = ("/repo/petswarm_env/env.py", 1, "step", "PetSwarmEnv.step")
    deliver = ("/repo/petswarm_env/comms/radio.py", 1, "_deliver", "RadioMedium._deliver")
    rays = ("/repo/petswarm_env/sim/world.py", 1, "ultrasonic_ranges", "World.ultrasonic_ranges")
    clip = (f"{site}/numpy/_core/fromnumeric.py", 1, "clip", "clip")  # neutral: counts for its caller
    stacks = Counter({(outside, step, deliver): 3, (outside, step, rays, clip): 1, (outside,): 5})  # last: not in a step
    r = breakdown_from_samples(stacks)
    assert r["samples"] == 4
    assert r["shares"]["radio_middleware"] == pytest.approx(0.75)
    assert r["shares"]["observation"] == pytest.approx(0.25)
    assert sum(r["shares"].values()) == pytest.approx(1.0)
    inclusive = {f["function"].rsplit("/", 1)[-1]: f["share"] for f in r["inclusive"]}
    assert inclusive["env.py:PetSwarmEnv.step"] == pytest.approx(1.0)
    assert inclusive["radio.py:RadioMedium._deliver"] == pytest.approx(0.75)
    assert {f["function"].rsplit("/", 1)[-1] for f in r["self"]} == {"radio.py:RadioMedium._deliver", "fromnumeric.py:clip"}
