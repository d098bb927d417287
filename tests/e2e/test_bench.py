"""`petswarm bench` with tiny settings: the JSON shape, positive numbers and the markdown report;
the parts of a step's breakdown come from the module a function lives in.
No timing is asserted (speeds depend on the machine and its load)."""

import importlib
import importlib.util
import inspect
import json
import math
import pkgutil
from collections import Counter

import pytest

import petswarm_env
from petswarm.bench.console import format_report
from petswarm.bench.page import HAND_WRITTEN_BEGIN, HAND_WRITTEN_END, write_benchmarks_md
from petswarm.bench.parts import CATEGORIES, MODULE_PARTS, Uncategorised, module_of, module_part, part_of
from petswarm.bench.profile import breakdown_from_samples
from petswarm.bench.run import main_bench
from petswarm.bench.settings import tiny_settings


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
    # the compiled core (petswarm_env/_core.py) has no Python frames: its time counts for its interpreted callers,
    # so a part whose modules are all compiled (the observation's) may read 0; pymunk and simpy stay interpreted
    assert b["shares"]["physics"] > 0 and b["shares"]["radio_middleware"] > 0
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
    assert "Neither profiler sees the compiled core" in md and "`petswarm_env.observe`" in md
    assert plot_path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in md_path.parent.iterdir()) == ["benchmarks.md", "benchmarks_steps.png"]  # no temp files


def test_profile_attribution_rules():
    site = "/venv/lib/python3.11/site-packages"
    assert part_of((f"{site}/pymunk/space.py", 1, "step")) == "physics"
    assert part_of((f"{site}/pymunk/body.py", 1, "position")) is None  # accessor: counts for its caller
    assert part_of((f"{site}/numpy/_core/fromnumeric.py", 1, "clip")) is None
    assert part_of(("~", 0, "<built-in method math.hypot>")) is None
    assert part_of((f"{site}/simpy/core.py", 1, "step")) == "radio_middleware"
    assert part_of((f"{site}/gymnasium/spaces/box.py", 1, "contains")) == "other"
    assert part_of(("/repo/petswarm_env/comms/radio.py", 1, "_deliver")) == "radio_middleware"
    assert part_of(("/repo/petswarm_env/middleware/token_ring.py", 1, "hold")) == "radio_middleware"
    assert part_of(("/repo/petswarm_env/middleware/user_session.py", 1, "step")) == "user_sensing"
    assert part_of(("/repo/petswarm_env/metrics.py", 1, "anything")) == "reward_metrics"
    assert part_of(("/repo/petswarm_env/observe.py", 1, "build_observation")) == "observation"
    assert part_of(("/repo/petswarm_env/sim/robot.py", 1, "apply")) == "physics"
    assert part_of(("/repo/petswarm_env/sim/geometry.py", 1, "ring_first_hits")) is None
    assert part_of(("/repo/petswarm_env/env.py", 1, "step")) == "other"
    assert part_of(("/repo/petswarm_env/nowhere/new.py", 1, "f")) == "other"  # uncategorised: see the next test


def test_a_function_part_comes_from_its_module_not_its_name():
    for name in ("apply", "renamed_apply", "_observe", "ultrasonic_ranges"):
        assert part_of(("/repo/petswarm_env/sim/robot.py", 7, name)) == "physics"
    assert module_of("/repo/petswarm_env/sim/__init__.py") == "petswarm_env.sim.__init__"
    assert module_part("petswarm_env.sim.__init__") == "physics"
    with pytest.raises(Uncategorised):
        module_part("petswarm_env.nowhere.zigzag")  # a package without a row


def _environment_modules():
    yield petswarm_env.__name__ + ".__init__", petswarm_env
    for info in pkgutil.walk_packages(petswarm_env.__path__, petswarm_env.__name__ + "."):
        mod = importlib.import_module(info.name)
        yield info.name + (".__init__" if info.ispkg else ""), mod


def test_every_function_of_the_environment_has_a_part():
    """A new module of petswarm_env must get its row in bench/parts.py MODULE_PARTS."""
    seen = 0
    for name, mod in _environment_modules():
        assert module_of(mod.__file__) == name
        functions = [f for _, f in inspect.getmembers(mod, inspect.isfunction) if f.__module__ == mod.__name__]
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if cls.__module__ == mod.__name__:
                functions += [f for f in vars(cls).values() if inspect.isfunction(f)]
        for f in functions:
            code = inspect.unwrap(f).__code__
            if code.co_filename == mod.__file__:  # not generated code (dataclass __init__, ...)
                module_part(module_of(code.co_filename))  # raises Uncategorised for a module without a part
                seen += 1
    assert seen > 100


def test_every_row_of_the_parts_table_names_a_module_that_exists():
    for key, part in MODULE_PARTS.items():
        assert part is None or part in CATEGORIES, key
        assert importlib.util.find_spec(key.removesuffix(".__init__")) is not None, f"{key} (a renamed module?)"


def test_the_page_keeps_its_hand_written_section_and_generates_only_measured_figures(bench, tmp_path):
    result = bench[0]
    page, plot = tmp_path / "benchmarks.md", tmp_path / "benchmarks_steps.png"
    write_benchmarks_md(result, page, plot)
    generated = page.read_text()
    assert HAND_WRITTEN_BEGIN not in generated and "Toward a 2× target" not in generated
    prose = f"{HAND_WRITTEN_BEGIN}\nWhat was optimised, and why.\n{HAND_WRITTEN_END}"
    page.write_text(generated + "\n" + prose + "\n")
    write_benchmarks_md(result, page, plot)
    text = page.read_text()
    assert text.count(prose) == 1
    assert text.index("## What bounds the speed") < text.index(prose) < text.index("## Memory")


def test_missing_mpe_is_recorded_as_skipped(monkeypatch):
    import petswarm.bench.run

    monkeypatch.setattr(petswarm.bench.run, "mpe_available", lambda: (False, "mpe2 is not installed"))
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
    outside = ("/repo/bench/loops.py", 1, "run", "EnvLoop.run")
    step = ("/repo/petswarm_env/env.py", 1, "step", "PetSwarmEnv.step")
    deliver = ("/repo/petswarm_env/comms/radio.py", 1, "_deliver", "RadioMedium._deliver")
    rays = ("/repo/petswarm_env/observe.py", 1, "build_observation", "build_observation")
    clip = (f"{site}/numpy/_core/fromnumeric.py", 1, "clip", "clip")  # neutral: counts for its caller
    stacks = Counter({(outside, step, deliver): 3, (outside, step, rays, clip): 1, (outside,): 5})  # last: not in a step
    r = breakdown_from_samples(stacks, step[:3])
    assert r["samples"] == 4
    assert r["shares"]["radio_middleware"] == pytest.approx(0.75)
    assert r["shares"]["observation"] == pytest.approx(0.25)
    assert sum(r["shares"].values()) == pytest.approx(1.0)
    inclusive = {f["function"].rsplit("/", 1)[-1]: f["share"] for f in r["inclusive"]}
    assert inclusive["env.py:PetSwarmEnv.step"] == pytest.approx(1.0)
    assert inclusive["radio.py:RadioMedium._deliver"] == pytest.approx(0.75)
    assert {f["function"].rsplit("/", 1)[-1] for f in r["self"]} == {"radio.py:RadioMedium._deliver", "fromnumeric.py:clip"}


def test_rllib_scaling_summary_takes_medians_of_interleaved_rounds():
    from petswarm.bench.rllib_scaling import summarize

    rows = [{"env_runners": n, "agent_steps_per_s": whole, "sampling_agent_steps_per_s": sampling}
            for n, whole, sampling in [(0, 100.0, 120.0), (2, 150.0, 200.0), (0, 80.0, 100.0), (2, 130.0, 170.0),
                                       (0, 90.0, 110.0), (2, 140.0, None)]]
    summary = summarize(rows)
    assert [s["env_runners"] for s in summary] == [0, 2] and [s["rows"] for s in summary] == [3, 3]
    two = summary[1]
    assert two["agent_steps_per_s"] == 140.0 and two["ratio_to_0_runners"] == round(140 / 90, 2)
    assert two["sampling_agent_steps_per_s"] == 185.0 and two["sampling_ratio_to_0_runners"] == round(185 / 110, 2)  # a missing timing left out
    assert [r["ratio_to_0_runners"] for r in rows] == [1.0, 1.5, 1.0, round(130 / 80, 2), 1.0, round(140 / 90, 2)]  # each round's own
    assert summarize([{"env_runners": 2, "agent_steps_per_s": 5.0, "sampling_agent_steps_per_s": 6.0}])[0]["ratio_to_0_runners"] is None


def test_env_loop_acts_only_for_the_agents_in_the_episode():
    """1+16, seed 0: a slave leaves the episode at step 544 while the policy still has its last
    observation; the loop must not pass an action for it (env.step raises KeyError for one)."""
    from petswarm.bench.loops import EnvLoop

    loop = EnvLoop(16, "scripted", 0)
    loop.run(steps=560)
    assert loop.steps == 560


def test_vector_envs_side_by_side_and_training_paths(bench):
    """The vector env's rows (per env-step, beside the single env and VMAS where installed) and the
    SB3 runs of both vector paths are in the result, the console report and the page."""
    result, _, md_path, _ = bench
    vec = result["vector"]
    labels = [r["label"] for r in vec["rows"]]
    assert labels[0] == "petswarm parallel_env 1+5" and "petswarm vector_env(2) 1+5" in labels
    for r in vec["rows"]:
        assert _positive(r["env_steps_per_s"]) and _positive(r["us_per_env_step"])
        assert r["env_steps"] == r["calls"] * r["num_envs"]
        assert len(r["per_round_vs_single"]) == vec["rounds"]
        resets = r["auto_reset_cpu_us_per_env_step"]  # the vector env's auto-resets, timed inside its step
        assert resets is None if r["label"].startswith(("petswarm parallel_env", "VMAS")) else 0.0 <= resets
    assert vec["rows"][0]["vs_single"] == pytest.approx(1.0)
    if importlib.util.find_spec("vmas") is not None:
        assert any(lb.startswith("VMAS simple_spread N=6") for lb in labels)
    else:
        assert "vmas is not installed" in vec["vmas_skipped"]
    assert "## Many envs in one process" in md_path.read_text() and "auto-resets µs" in md_path.read_text()
    assert "vector envs side by side" in format_report(result)
    tr = result["training"]
    if "skipped" not in tr:
        assert {r["path"] for r in tr["runs"]} == {"supersuit", "petswarm"}
        assert all(0.0 < r["env_cpu_share"] < 1.0 for r in tr["runs"])  # the env's share of learn()'s CPU time
        assert _positive(tr["vector_vs_supersuit_1"])
        assert "| petswarm | 1 | 0 |" in md_path.read_text()


def test_the_vector_step_timing_counts_the_auto_resets_apart(capsys):
    """``python -m petswarm.bench.step --vector N``: episodes of 3 steps, so the copies restart
    within the run; their auto-resets are reported as a share of the step time."""
    import re

    from petswarm.bench.step import vector

    vector(2, 16, {"max_cycles": 3})
    out = capsys.readouterr().out
    found = re.search(r"per env-step: (\d+) us, of which auto-resets (\d+) us; without them (\d+) us", out)
    assert found, out
    total, resets, rest = map(int, found.groups())
    assert 0 < resets < total and abs(total - resets - rest) <= 1
