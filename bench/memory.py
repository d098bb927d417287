"""Memory growth over a long run: RSS, peak RSS, live pymalloc blocks and gc objects of an
untraced run, then tracemalloc over whole episodes, in a fresh process."""

from __future__ import annotations

import gc
import os
import sys
import time

from petswarm.bench.loops import EnvLoop
from petswarm.bench.settings import MEMORY_BLOCKS_TOLERANCE, MEMORY_GROWTH_TOLERANCE_MB, BenchSettings


def _rss_mb() -> float | None:
    """Current resident set size (Linux /proc), MB."""
    try:
        with open("/proc/self/statm") as f:
            pages = int(f.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def _peak_rss_mb() -> float | None:
    try:
        import resource
    except ImportError:
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024  # bytes on macOS, KiB on Linux


def _memory_sample(loop: EnvLoop) -> dict:
    gc.collect()
    return {
        "steps": loop.steps,
        "rss": _rss_mb(),
        "peak_rss": _peak_rss_mb(),
        "py_blocks": sys.getallocatedblocks(),  # live pymalloc blocks (count, not MB)
        "gc_objects": len(gc.get_objects()),  # live container objects (count)
        "resets": loop.resets,
    }


def memory_run(num_slaves: int, marks: tuple[int, ...], trace_episodes: int, seed: int,
               max_cycles: int | None = None) -> dict:
    """Step the env (scripted policy, resets as episodes end) without tracing, sampling RSS, peak
    RSS, live pymalloc blocks and gc objects at each of ``marks`` (env steps); then run to the end
    of the current episode and trace ``trace_episodes`` whole episodes with tracemalloc, reading the
    traced size at the end of each (same phase: just before the next reset)."""
    import tracemalloc

    overrides = {"max_cycles": max_cycles} if max_cycles else {}
    loop = EnvLoop(num_slaves, "scripted", seed, **overrides)
    loop.run(steps=50)  # imports, caches, first episode
    loop.clear()
    samples = []
    t0 = time.perf_counter()
    for mark in sorted(set(marks)):
        loop.run(steps=mark)
        samples.append(_memory_sample(loop))
    untraced_s = time.perf_counter() - t0
    loop.finish_episode()
    gc.collect()
    traced = []
    t1 = time.perf_counter()
    tracemalloc.start()
    for _ in range(trace_episodes):
        loop.run_episode()
        gc.collect()
        current, peak = tracemalloc.get_traced_memory()
        traced.append({"steps": loop.steps, "current": current / 2**20, "peak": peak / 2**20})
    tracemalloc.stop()
    return {"samples": samples, "traced": traced, "untraced_s": untraced_s, "traced_s": time.perf_counter() - t1,
            "episode_steps": loop.env.cfg.max_cycles}


def bench_memory(num_slaves: int, s: BenchSettings) -> dict:
    a, b = s.memory_steps
    marks = tuple(sorted({a, b, *(m for m in (b // 4, b // 2) if a < m < b)}))
    args = (num_slaves, marks, max(2, s.memory_trace_episodes), s.seed, s.memory_max_cycles)
    isolated = False
    note = ""
    if s.memory_isolated:
        try:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("spawn")) as pool:
                out = pool.submit(memory_run, *args).result()
            isolated = True
        except (OSError, RuntimeError, ImportError) as exc:  # no process spawning here: measure in-process
            note = f"measured in the benchmark's process ({type(exc).__name__}: {exc})"
            out = memory_run(*args)
    else:
        out = memory_run(*args)
    samples = out["samples"]
    first = next(x for x in samples if x["steps"] == a)
    last = next(x for x in samples if x["steps"] == b)

    def diff(key: str) -> float | None:
        return None if first[key] is None or last[key] is None else last[key] - first[key]

    traced = out["traced"]
    tm_growth = (traced[-1]["current"] - traced[0]["current"]) / (len(traced) - 1)  # mean per episode
    blocks_rel = diff("py_blocks") / max(first["py_blocks"], 1)
    growth = {
        "rss": diff("rss"),
        "peak_rss": diff("peak_rss"),
        "py_blocks": diff("py_blocks"),
        "py_blocks_rel": blocks_rel,
        "gc_objects": diff("gc_objects"),
        "tracemalloc_per_episode": tm_growth,
    }
    result = {
        "env": f"1 master + {num_slaves} slaves, scripted policy, resets as episodes end",
        "steps_first": a,
        "steps_last": b,
        "first": first,
        "last": last,
        "samples": samples,
        "tracemalloc": {
            "episodes": traced,
            "episode_steps": out["episode_steps"],
            "growth_per_episode": tm_growth,
        },
        "growth": growth,
        "no_growth": abs(tm_growth) < MEMORY_GROWTH_TOLERANCE_MB and blocks_rel < MEMORY_BLOCKS_TOLERANCE,
        "tolerance": {"tracemalloc_mb_per_episode": MEMORY_GROWTH_TOLERANCE_MB, "py_blocks_rel": MEMORY_BLOCKS_TOLERANCE},
        "isolated_process": isolated,
        "untraced_s": out["untraced_s"],
        "traced_s": out["traced_s"],
        "unit": "MB (2^20 bytes); py_blocks and gc_objects are counts",
        "method": "untraced run: RSS (/proc/self/statm), peak RSS (getrusage ru_maxrss), live pymalloc blocks "
        "(sys.getallocatedblocks) and gc-tracked objects after gc.collect() at each checkpoint; then tracemalloc over "
        "whole episodes after the untraced run (tracing from an episode boundary, read at the end of each episode, "
        "so the live world was allocated under tracing every time): growth between consecutive episode ends. "
        "tracemalloc is not on for the whole run because it slows the env about 5x.",
    }
    if note:
        result["note"] = note
    return result
