"""Reading a benchmark result: the console report (:func:`format_report`) and what the page
shares with it (the targets' rows, number formatting)."""

from __future__ import annotations

import math

from petswarm.bench.settings import TARGET_SCALING_16, TARGET_TRAINING, TARGET_VECTOR_PER_CORE, TARGET_VS_MPE


def find_result(results: list[dict], kind: str, agents: int, policy: str | None = None) -> dict | None:
    """The first measurement of ``kind`` with ``agents`` robots (and ``policy``), or None."""
    for r in results:
        if r["kind"] == kind and r["agents"] == agents and (policy is None or r.get("policy") == policy):
            return r
    return None


def fmt(x: float | None, spec: str = ".2f") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return format(x, spec)


def verdict(met: bool | None) -> str:
    return "n/a" if met is None else ("met" if met else "not met")


def target_rows(result: dict) -> list[tuple[str, str, str, str]]:
    t = result["targets"]
    m = result["memory_mb"]
    r = result["ratios"]
    return [
        ("petswarm (1+5) / MPE simple_spread N=6, steps/s" + (" (side by side, alternating bursts)" if result.get("side_by_side") else ""),
         fmt(t["petswarm_vs_mpe_6"]["measured"]) + "×", f"≥ {TARGET_VS_MPE:g}×", verdict(t["petswarm_vs_mpe_6"]["met"])),
        ("the same from CPU time per step (`time.process_time`: less sensitive to other processes' load)",
         fmt(r.get("petswarm_vs_mpe_6_cpu")) + "×", "(info)", ""),
        ("the same from the two runs of the table below (minutes apart)",
         fmt(r.get("petswarm_vs_mpe_6_sequential")) + "×", "(info)", ""),
        ("per-step cost 9 slaves / 5 slaves", fmt(t["cost_9_vs_5_slaves"]["measured"]) + "×", "≤ 2×",
         verdict(t["cost_9_vs_5_slaves"]["met"])),
        *_optional_rows(t),
        (f"memory growth {m['steps_first']:,} → {m['steps_last']:,} steps: RSS / live blocks",
         f"{fmt(m['growth']['rss'], '+.1f')} MB / {fmt(100 * m['growth']['py_blocks_rel'], '+.2f')} %", "none",
         verdict(t["memory_growth"]["met"])),
        ("memory growth per episode afterwards (tracemalloc)",
         fmt(m["growth"]["tracemalloc_per_episode"], "+.3f") + " MB", "none", ""),
        ("petswarm (1+5) / physics floor (6 bodies), steps/s", fmt(r["petswarm_vs_floor_6"], ".4f") + "×", "(info)", ""),
        *_instruction_rows(result.get("instructions")),
    ]


def _optional_rows(t: dict) -> list[tuple[str, str, str, str]]:
    """The targets a run measures only with some settings (16 slaves, the vector envs, training)."""
    rows = []
    for key, name, target in (
        ("cost_16_vs_5_slaves", "per-step cost 16 slaves / 5 slaves", f"≤ {TARGET_SCALING_16:g}×"),
        ("vector_64_per_core", "vector_env(64) 1+5 / parallel_env 1+5, env-steps per CPU-second (side by side)",
         f"≥ {TARGET_VECTOR_PER_CORE:g}×"),
        ("sb3_vector_vs_one_copy", "SB3 PPO samples/s, the vector env / SuperSuit's one copy (one core)",
         f"≥ {TARGET_TRAINING:g}×"),
    ):
        if key in t and t[key]["measured"] is not None:
            rows.append((name, fmt(t[key]["measured"]) + "×", target, verdict(t[key]["met"])))
    return rows


def _instruction_rows(ins: dict | None) -> list[tuple[str, str, str, str]]:
    if not ins:
        return []
    lo, hi = ins["steps"]
    return [(f"instructions per env.step, 1+5, scripted (callgrind: replays of {lo} and {hi} recorded steps, the difference)",
             f"{ins['instructions_per_step'] / 1e6:.2f} M", "(info)", "")]


def format_report(result: dict) -> str:
    m = result["machine"]
    lines = [
        (f"petswarm bench ({result['mode']}): {m['cpus_available']} CPUs ({m.get('cpu_model') or '?'}), "
        f"Python {m['python']}, load average {m.get('loadavg_start')} at start, {m.get('loadavg_end')} at end; "
        f"{result['wall_s']:.0f} s (" + ", ".join(f"{k} {v:.0f}" for k, v in result.get("phase_wall_s", {}).items()) + ")"),
        "",
        f"{'measurement':<34} {'robots':>6} {'steps/s':>10} {'agent-st/s':>11} {'ms/step':>8} {'policy ms':>9} {'reset ms':>8} {'steps':>7}",
    ]
    for r in result["results"]:
        lines.append(
            f"{r['label']:<34} {r['agents']:>6} {r['steps_per_s']:>10,.0f} {r['agent_steps_per_s']:>11,.0f} "
            f"{r['ms_per_step']:>8.3f} {fmt(r.get('policy_ms_per_step'), '.3f'):>9} {fmt(r.get('reset_ms'), '.1f'):>8} {r['steps']:>7}"
        )
    for sk in result.get("skipped", []):
        lines.append(f"{sk['name']:<34} skipped: {sk['reason']}")
    lines += ["", "targets (reported, not asserted):"]
    for name, measured, target, met in target_rows(result):
        lines.append(f"  {name:<56} {measured:>12}  target {target:<6} {met}")
    b = result["breakdown"]
    shares = ", ".join(f"{k} {100 * v:.0f}%" for k, v in b["shares"].items())
    lines += ["", f"breakdown of one step ({b['env']}, cProfile over {b['steps']} steps): {shares}"]
    sm = b.get("sampled") or {}
    if sm.get("samples"):
        lines.append(f"  sampled ({sm['samples']} stack samples): "
                     + ", ".join(f"{k} {100 * v:.0f}%" for k, v in sm["shares"].items()))
    for f in b["top_functions"][:5]:
        lines.append(f"  {100 * f['self_share']:5.1f}%  {f['function']}  [{f['category']}]")
    mem = result["memory_mb"]
    f0, f1, tm = mem["first"], mem["last"], mem["tracemalloc"]
    lines += [
        "",
        f"memory ({mem['env']}): after {mem['steps_first']:,} → {mem['steps_last']:,} steps RSS "
        f"{fmt(f0['rss'], '.1f')} → {fmt(f1['rss'], '.1f')} MB, peak RSS {fmt(f0['peak_rss'], '.1f')} → "
        f"{fmt(f1['peak_rss'], '.1f')} MB, live blocks {f0['py_blocks']:,} → {f1['py_blocks']:,}, gc objects "
        f"{f0['gc_objects']:,} → {f1['gc_objects']:,}; tracemalloc at the end of {len(tm['episodes'])} further episodes: "
        + ", ".join(f"{e['current']:.3f}" for e in tm["episodes"]) + " MB",
    ]
    tr = result["training"]
    if "skipped" in tr:
        lines.append(f"training throughput: skipped: {tr['skipped']}")
    else:
        parts = [f"{r.get('path', 'supersuit')} {r['num_envs']} cop{'ies' if r['num_envs'] > 1 else 'y'}/"
                 f"{r['num_cpus']} processes {r['samples_per_s']:,.0f} samples/s" for r in tr["runs"]]
        lines.append(f"training throughput (PPO, {tr['env']}): " + "; ".join(parts))
    vec = result.get("vector")
    if vec:
        lines.append("vector envs side by side (env-steps/s; per CPU-s; vs parallel_env): " + "; ".join(
            f"{r['label']} {r['env_steps_per_s']:,.0f}; {fmt(r['env_steps_per_cpu_s'], ',.0f')}; {r['vs_single']:.2f}×"
            for r in vec["rows"]))
    return "\n".join(lines)
