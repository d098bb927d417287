"""``petswarm bench``: every measurement, one after the other, in one result dict (the JSON).

    result = main_bench(quick=True, json_out="bench.json", md_out="docs/benchmarks.md")
"""

from __future__ import annotations

import datetime as _dt
import os
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

from petswarm.bench.console import find_result, format_report
from petswarm.bench.machine import loadavg, machine_info
from petswarm.bench.memory import bench_memory
from petswarm.bench.page import write_benchmarks_md
from petswarm.bench.profile import bench_breakdown
from petswarm.bench.settings import (
    FULL,
    MEMORY_BLOCKS_TOLERANCE,
    MEMORY_GROWTH_TOLERANCE_MB,
    QUICK,
    TARGET_SCALING,
    TARGET_SCALING_16,
    TARGET_TRAINING,
    TARGET_VECTOR_PER_CORE,
    TARGET_VS_MPE,
    BenchSettings,
    log,
)
from petswarm.bench.instructions import bench_instructions, valgrind_available
from petswarm.bench.speed import bench_floor, bench_mpe, bench_petswarm, bench_side_by_side, mpe_available
from petswarm.bench.throughput import bench_training
from petswarm.bench.vector import bench_vector_side_by_side
from petswarm_env.config import load_config
from petswarm_env.files import jsonable, write_json_atomic


def _ratio(a: dict | None, b: dict | None) -> float | None:
    if a is None or b is None:
        return None
    return a["steps_per_s"] / b["steps_per_s"]


def _cpu_ratio(a: dict | None, b: dict | None) -> float | None:
    """Speed ratio a/b from CPU time per step (process_time), or None."""
    if a is None or b is None or not a.get("cpu_ms_per_step") or not b.get("cpu_ms_per_step"):
        return None
    return b["cpu_ms_per_step"] / a["cpu_ms_per_step"]


def _speeds(s: BenchSettings, verbose: bool, phase: Callable[[str], None]) -> tuple[list[dict], list[dict], dict | None]:
    """petswarm (scripted and random), the physics floor and MPE at every size; the side-by-side
    run; the skipped measurements."""
    results: list[dict] = []
    skipped: list[dict] = []
    side_by_side = None
    for n in s.slaves:
        for pol in ("scripted", "random"):
            log(verbose, f"petswarm 1+{n} {pol}")
            results.append(bench_petswarm(n, pol, s))
    phase("petswarm")
    for n in s.slaves:
        log(verbose, f"physics floor {n + 1} bodies")
        results.append(bench_floor(n + 1, s))
    phase("floor")
    ok, reason = mpe_available() if s.mpe else (False, "disabled in the settings")
    if ok:
        max_cycles = load_config().max_cycles
        for n in s.slaves:
            log(verbose, f"MPE simple_spread N={n + 1}")
            results.append(bench_mpe(n + 1, s, max_cycles))
        if 5 in s.slaves and s.side_by_side_rounds > 0:
            log(verbose, "petswarm 1+5 and MPE N=6 side by side")
            side_by_side = bench_side_by_side(s, max_cycles)
    else:
        skipped.append({"name": "mpe_simple_spread", "reason": reason})
    phase("mpe")
    return results, skipped, side_by_side


def _breakdown(s: BenchSettings, prof_slaves: int, results: list[dict], verbose: bool) -> dict:
    """The step's breakdown, with ms per step of each part from the unprofiled step time."""
    log(verbose, f"breakdown (cProfile) 1+{prof_slaves}")
    breakdown = bench_breakdown(prof_slaves, s)
    ref = find_result(results, "petswarm", prof_slaves + 1, "scripted")
    if ref is not None:
        breakdown["unprofiled_ms_per_step"] = ref["ms_per_step"]
        # the sampler's shares when there are any (no per-call bias), else cProfile's
        sampled = breakdown.get("sampled") or {}
        shares = sampled["shares"] if sampled.get("samples") else breakdown["shares"]
        breakdown["ms_per_step"] = {k: v * ref["ms_per_step"] for k, v in shares.items()}
    return breakdown


def _ratios(results: list[dict], side_by_side: dict | None) -> dict[str, float | None]:
    ps6 = find_result(results, "petswarm", 6, "scripted")
    mpe6 = find_result(results, "mpe", 6)
    sequential = _ratio(ps6, mpe6)
    return {
        # the target: from the side-by-side bursts when there are any, else from the runs minutes apart
        "petswarm_vs_mpe_6": side_by_side["ratio"] if side_by_side else sequential,
        "petswarm_vs_mpe_6_cpu": side_by_side["ratio_cpu"] if side_by_side else _cpu_ratio(ps6, mpe6),
        "petswarm_vs_mpe_6_sequential": sequential,
        "petswarm_vs_floor_6": _ratio(ps6, find_result(results, "floor", 6)),
        "cost_9_vs_5_slaves": _ratio(ps6, find_result(results, "petswarm", 10, "scripted")),
        "cost_16_vs_5_slaves": _ratio(ps6, find_result(results, "petswarm", 17, "scripted")),
    }


def _vector_row(vector: dict | None, num_envs: int) -> dict | None:
    for r in (vector or {}).get("rows", []):
        if r["label"].startswith("petswarm vector_env") and r["num_envs"] == num_envs:
            return r
    return None


def _met(measured: float | None, ok) -> bool | None:
    return None if measured is None else bool(ok(measured))


def _targets(ratios: dict[str, float | None], memory: dict, vector: dict | None = None,
             training: dict | None = None) -> dict[str, dict[str, Any]]:
    g = memory["growth"]
    vs_mpe, scaling = ratios["petswarm_vs_mpe_6"], ratios["cost_9_vs_5_slaves"]
    scaling16 = ratios.get("cost_16_vs_5_slaves")
    v64 = _vector_row(vector, 64)
    per_core = v64["vs_single_cpu"] if v64 else None
    sb3 = (training or {}).get("vector_vs_supersuit_1")
    return {
        "cost_16_vs_5_slaves": {"measured": scaling16, "target": f"<= {TARGET_SCALING_16:g}",
                                "met": _met(scaling16, lambda x: x <= TARGET_SCALING_16)},
        "vector_64_per_core": {"measured": per_core, "target": f">= {TARGET_VECTOR_PER_CORE:g}",
                               "met": _met(per_core, lambda x: x >= TARGET_VECTOR_PER_CORE)},
        "sb3_vector_vs_one_copy": {"measured": sb3, "target": f">= {TARGET_TRAINING:g}",
                                   "met": _met(sb3, lambda x: x >= TARGET_TRAINING)},
        "petswarm_vs_mpe_6": {"measured": vs_mpe, "target": f">= {TARGET_VS_MPE:g}",
                              "met": None if vs_mpe is None else vs_mpe >= TARGET_VS_MPE},
        "cost_9_vs_5_slaves": {"measured": scaling, "target": f"<= {TARGET_SCALING:g}",
                               "met": None if scaling is None else scaling <= TARGET_SCALING},
        "memory_growth": {
            "measured": {"tracemalloc_mb_per_episode": g["tracemalloc_per_episode"], "py_blocks_rel": g["py_blocks_rel"],
                         "rss_mb": g["rss"], "peak_rss_mb": g["peak_rss"]},
            "target": f"none (tracemalloc < {MEMORY_GROWTH_TOLERANCE_MB:g} MB per episode, live blocks < "
                      f"{100 * MEMORY_BLOCKS_TOLERANCE:g} % over the run)",
            "met": memory["no_growth"],
        },
    }


def run_bench(s: BenchSettings, mode: str = "custom", verbose: bool = False) -> dict:
    """Every measurement with settings ``s``; returns the result dict (see :mod:`bench`)."""
    started = time.perf_counter()
    machine = machine_info()
    machine["timestamp_utc"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    phases: dict[str, float] = {}
    mark = time.perf_counter()

    def phase(name: str) -> None:
        nonlocal mark
        now = time.perf_counter()
        phases[name] = now - mark
        mark = now

    results, skipped, side_by_side = _speeds(s, verbose, phase)
    instructions = None
    if s.instructions_steps is not None:
        ok, reason = valgrind_available()
        if ok:
            log(verbose, f"instructions per step (callgrind), 1+5, {s.instructions_steps} replayed steps")
            instructions = bench_instructions(5, s.seed, s.instructions_steps)
        else:
            skipped.append({"name": "instructions", "reason": reason})
        phase("instructions")
    prof_slaves = 5 if 5 in s.slaves else s.slaves[len(s.slaves) // 2]
    breakdown = _breakdown(s, prof_slaves, results, verbose)
    phase("breakdown")
    log(verbose, f"memory 1+{prof_slaves}: {s.memory_steps[0]} vs {s.memory_steps[1]} steps")
    memory = bench_memory(prof_slaves, s)
    phase("memory")
    vector = None
    if s.vector_envs:
        log(verbose, "vector envs side by side")
        vector = bench_vector_side_by_side(s, verbose)
        phase("vector")
    log(verbose, "training throughput")
    training = bench_training(s, verbose) if s.training_workers else {"skipped": "disabled in the settings"}
    phase("training")
    ratios = _ratios(results, side_by_side)
    machine["loadavg_end"] = loadavg()
    return jsonable({
        "mode": mode,
        "settings": asdict(s),
        "results": results,
        "skipped": skipped,
        "ratios": ratios,
        "side_by_side": side_by_side,
        "instructions": instructions,
        "targets": _targets(ratios, memory, vector, training),
        "vector": vector,
        "memory_mb": memory,
        "breakdown": breakdown,
        "training": training,
        "machine": machine,
        "wall_s": time.perf_counter() - started,
        "phase_wall_s": phases,
    })


def default_plot_path(md_path: str | os.PathLike) -> str:
    p = Path(md_path)
    return str(p.with_name(p.stem + "_steps.png"))


def main_bench(quick: bool, json_out: str | None, md_out: str | None = None, plot_out: str | None = None,
               settings: BenchSettings | None = None, verbose: bool = True) -> dict:
    """``petswarm bench [--quick] [--json OUT] [--md OUT]``: run, optionally write the JSON
    (atomically) and the markdown report with its plot; return the result dict."""
    s = settings or (QUICK if quick else FULL)
    mode = "custom" if settings is not None else ("quick" if quick else "full")
    result = run_bench(s, mode, verbose)
    if json_out:
        write_json_atomic(json_out, result)
    if md_out:
        write_benchmarks_md(result, md_out, plot_out or default_plot_path(md_out))
    return result


def bench_command(quick: bool, json_out: str | None, md_out: str | None) -> int:
    """``petswarm bench``: run, print the report and what was written."""
    result = main_bench(quick, json_out, md_out=md_out)
    print(format_report(result))
    if json_out:
        print(f"wrote {json_out}")
    if md_out:
        print(f"wrote {md_out} and {default_plot_path(md_out)}")
    return 0
