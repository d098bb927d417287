"""The benchmark page, ``docs/benchmarks.md``, and its plot: the measured figures of a result, and
a hand-written section (what each part of a step does, what was optimised and why, what is left)
that the writer keeps as it is from the page it replaces: everything between
:data:`HAND_WRITTEN_BEGIN` and :data:`HAND_WRITTEN_END`."""

from __future__ import annotations

import os
from pathlib import Path

from petswarm.bench.console import find_result, fmt, target_rows, verdict
from petswarm.bench.parts import CATEGORIES, PART_TITLES, part_rules
from petswarm.bench.settings import TARGET_VS_MPE
from petswarm_env.files import write_atomic, write_text_atomic

HAND_WRITTEN_BEGIN = "<!-- hand-written: `petswarm bench --md` keeps this section as it is; edit it here -->"
HAND_WRITTEN_END = "<!-- end of the hand-written section -->"


def write_plot(result: dict, plot_path: str | os.PathLike) -> None:
    """Steps/s against swarm size (robots), log scale, one line per kind of measurement."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4.5), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    series = [
        ("floor", None, "physics floor (pymunk only)", "s--", "0.45"),
        ("mpe", None, "MPE simple_spread (mpe2)", "^-", "tab:orange"),
        ("petswarm", "random", "petswarm, random actions", "o-", "tab:cyan"),
        ("petswarm", "scripted", "petswarm, scripted policy", "o-", "tab:blue"),
    ]
    for kind, pol, label, style, color in series:
        pts = sorted((r["agents"], r["steps_per_s"]) for r in result["results"]
                     if r["kind"] == kind and (pol is None or r.get("policy") == pol))
        if pts:
            xs, ys = zip(*pts)
            ax.plot(xs, ys, style, color=color, label=label)
    mpe6 = find_result(result["results"], "mpe", 6)
    if mpe6 is not None:
        ax.plot([6], [TARGET_VS_MPE * mpe6["steps_per_s"]], "*", color="tab:red", markersize=12,
                label=f"target: {TARGET_VS_MPE:g}× MPE at 6 robots")
    ax.set_yscale("log")
    ax.set_xlabel("robots (master + slaves; MPE: agents)")
    ax.set_ylabel("env steps per second (log)")
    ax.set_xticks(sorted({r["agents"] for r in result["results"]}))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    m = result["machine"]
    ax.set_title(f"petswarm bench ({result['mode']}), {m['cpus_available']} CPUs, Python {m['python']}", fontsize=10)
    fig.tight_layout()
    write_atomic(plot_path, lambda tmp: fig.savefig(tmp, format="png"))


def part_description(part: str) -> str:
    """A part's title and the modules whose functions it counts (from :data:`petswarm.bench.parts.MODULE_PARTS`)."""
    modules = part_rules().get(part, [])
    return PART_TITLES.get(part, part) + (f" ({', '.join(f'`{m}`' for m in modules)})" if modules else "")


def _method_paragraph() -> str:
    rules = part_rules()
    by_part = "; ".join(f"{', '.join(f'`{m}`' for m in rules[p])} → {PART_TITLES[p]}" for p in CATEGORIES if p in rules)
    neutral = ", ".join(f"`{m}`" for m in rules.get(None, []))
    return ("Method: a function's time goes to the part of the module it lives in (the longest prefix of its module in "
            f"`bench/parts.py`: {by_part}; a function of any other package → other). Neutral functions (C built-ins such as "
            f"pymunk's cffi calls, the standard library, {neutral}) count for their caller: the sampler charges a sample to "
            "the innermost non-neutral frame of its stack, cProfile splits a neutral function's own time over its callers by "
            "its per-caller statistics. cProfile adds a fixed cost to every Python call, so it overweights call-heavy Python "
            "(the event-driven middleware) against C- and numpy-heavy code; the sampler has no per-call cost but a sampling "
            "error of about √(p(1−p)/n) (±1.5 points for a 30 % share from 1,000 samples). Neither profiler sees the "
            "compiled core (`petswarm_env/_core.py` `COMPILED`: " + ", ".join(f"`{m}`" for m in _compiled()) + "): its "
            "functions run without Python frames, so their time counts for the part of their nearest interpreted caller "
            "(mostly `env.step`'s: other); the instruction count above is the measure of the whole step.")


def _compiled() -> tuple[str, ...]:
    from petswarm_env._core import COMPILED

    return COMPILED


def _breakdown_markdown(b: dict) -> list[str]:
    """The "Where a step's time goes" section: shares by part (stack sampler and cProfile), the
    functions the sampler saw most, and cProfile's largest own times."""
    sm = b.get("sampled") or {}
    has_sm = bool(sm.get("samples"))
    unprof = f", against {b['unprofiled_ms_per_step']:.2f} ms unprofiled" if b.get("unprofiled_ms_per_step") else ""
    out: list[str] = []
    if has_sm:
        out += [
            (f"{b['env']}: two profiles of `env.step` alone, each over its own run of the same loop: a **stack "
             f"sampler** ({sm['samples']:,} samples over {sm['steps']:,} steps, one per ~"
             f"{fmt(sm.get('effective_interval_ms'), '.1f')} ms of CPU time; the sampled step took "
             f"{sm['sampled_ms_per_step']:.2f} ms) and **cProfile** ({b['steps']:,} steps; tracing inflates the step "
             f"to {b['profiled_ms_per_step']:.2f} ms{unprof}). *ms/step* applies the sampled share to the "
             "unprofiled step time."),
            "",
            "| part | share (sampled) | ms/step | share (cProfile) |",
            "|---|---:|---:|---:|",
        ]
        for k in CATEGORIES:
            ms = (b.get("ms_per_step") or {}).get(k)
            out.append(f"| {part_description(k)} | {100 * sm['shares'].get(k, 0.0):.1f}% | {fmt(ms, '.3f')} | "
                       f"{100 * b['shares'].get(k, 0.0):.1f}% |")
    else:
        out += [
            (f"cProfile of `env.step` only ({b['env']}, {b['steps']:,} steps; profiling inflates the step to "
             f"{b['profiled_ms_per_step']:.2f} ms{unprof}). *ms/step* applies the share to the unprofiled step time."),
            "",
            "| part | share | ms/step |",
            "|---|---:|---:|",
        ]
        for k in CATEGORIES:
            ms = (b.get("ms_per_step") or {}).get(k)
            out.append(f"| {part_description(k)} | {100 * b['shares'].get(k, 0.0):.1f}% | {fmt(ms, '.3f')} |")
    out += [
        "",
        _method_paragraph(),
        "",
    ]
    if has_sm:
        out += [
            ("Functions the sampler saw most (*inclusive*: share of the samples with the function anywhere on the "
             "stack below `env.step`; nested entries overlap):"),
            "",
            "| function | inclusive share |",
            "|---|---:|",
        ]
        out += [f"| `{f['function']}` | {100 * f['share']:.1f}% |" for f in sm["inclusive"][:30]]
        out += ["", "Innermost Python frame of the samples (own time, the C calls it makes included):", "",
                "| function | own share |", "|---|---:|"]
        out += [f"| `{f['function']}` | {100 * f['share']:.1f}% |" for f in sm["self"][:12]]
        out.append("")
    out += ["cProfile's largest own times:", "", "| function | own share | part |", "|---|---:|---|"]
    out += [f"| `{f['function']}` | {100 * f['self_share']:.1f}% | {f['category']} |" for f in b["top_functions"][:10]]
    out.append("")
    return out


def _bounds_markdown(result: dict) -> list[str]:
    """The measured part of the "What bounds the speed" section: the target in ms per step against
    the parts of the step (from the breakdown). What the hot path does, what was optimised and
    which levers are left is hand-written prose on the page (:data:`HAND_WRITTEN_BEGIN`)."""
    b = result["breakdown"]
    ps6 = find_result(result["results"], "petswarm", 6, "scripted")
    mpe6 = find_result(result["results"], "mpe", 6)
    ms = b.get("ms_per_step") or {}
    sbs = result.get("side_by_side")
    if sbs and ps6 is not None and mpe6 is not None and ms:  # the side-by-side step times, the parts scaled to them
        k = sbs["petswarm_ms_per_step"] / ps6["ms_per_step"]
        ms = {name: v * k for name, v in ms.items()}
        ps6 = dict(ps6, ms_per_step=sbs["petswarm_ms_per_step"])
        mpe6 = dict(mpe6, ms_per_step=sbs["mpe_ms_per_step"], steps_per_s=1e3 / sbs["mpe_ms_per_step"])
    out = ["## What bounds the speed", ""]
    if ps6 is not None and mpe6 is not None and ms:
        need = mpe6["ms_per_step"] / TARGET_VS_MPE
        parts = sorted(ms.items(), key=lambda kv: -kv[1])
        big_ms = parts[0][1]
        # what would be left if everything but the radio and middleware cost nothing
        radio = ms.get("radio_middleware", 0.0)
        out += [
            (f"{TARGET_VS_MPE:g}× MPE's {mpe6['steps_per_s']:,.0f} steps/s means ≤ {need:.2f} ms per step for 1 master + "
             f"5 slaves; the step takes {ps6['ms_per_step']:.2f} ms "
             + (f"({ps6['ms_per_step'] / need:.2f}× the budget). " if ps6["ms_per_step"] > need else "(within the budget). ")
             + "By part (sampled shares of the unprofiled step): "
             + ", ".join(f"{PART_TITLES.get(k, k)} {v:.2f} ms" for k, v in parts) + "."
             + f" The largest part alone ({big_ms:.2f} ms) is {100 * big_ms / need:.0f} % of the whole budget;"
             + f" the radio and middleware events ({radio:.2f} ms) are what a step costs with every other part free."),
            "",
        ]
    return out


def _side_by_side_markdown(sbs: dict | None) -> list[str]:
    if not sbs:
        return []
    pr = sbs["per_round"]
    return [
        (f"* **side by side** (the target's ratio): petswarm {sbs['petswarm']} and MPE {sbs['mpe']} timed in "
         f"alternating bursts of {sbs['burst_s']:g} s of `env.step` time, {sbs['rounds']} each (which goes first "
         "alternates), so that a change of the machine's speed during the run (it is shared; minutes apart "
         "the same MPE run has measured 30 % faster or slower) falls on both: petswarm "
         f"{sbs['petswarm_ms_per_step']:.3f} ms/step ({sbs['petswarm_cpu_ms_per_step']:.3f} CPU) over "
         f"{sbs['petswarm_steps']:,} steps, MPE {sbs['mpe_ms_per_step']:.3f} ms/step "
         f"({sbs['mpe_cpu_ms_per_step']:.3f} CPU) over {sbs['mpe_steps']:,} steps: {sbs['ratio']:.2f}× "
         f"(per round {min(pr):.2f}–{max(pr):.2f}×)."),
    ]


def _header_markdown(result: dict) -> list[str]:
    """The title, how the page was made, the machine and the targets."""
    m = result["machine"]
    v = m["versions"]
    cmd = "petswarm bench" + (" --quick" if result["mode"] == "quick" else "")
    git = m.get("git") or {}
    out = [
        "# Benchmarks",
        "",
        f"Generated by `{cmd}` (`bench/`) on {m.get('timestamp_utc', '?')}"
        + (f", commit `{git['commit'][:10]}`{' (with local changes)' if git.get('dirty') else ''}" if git.get("commit") else "")
        + ". Regenerate with `petswarm bench --json bench.json --md docs/benchmarks.md`.",
        "",
        (f"Machine: {m['cpus_available']} CPUs ({m.get('cpu_model') or 'unknown CPU'}), {m['platform']}, "
        f"Python {m['python']}; numpy {v.get('numpy')}, pymunk {v.get('pymunk')}, simpy {v.get('simpy')}, "
        f"pettingzoo {v.get('pettingzoo')}, mpe2 {v.get('mpe2') or 'not installed'}, "
        f"stable-baselines3 {v.get('stable-baselines3') or 'not installed'}, torch {v.get('torch') or 'not installed'}. "
        f"Load average {m.get('loadavg_start')} at the start, {m.get('loadavg_end')} at the end "
        "(1, 5, 15 min; anything near the CPU count means the numbers are depressed). "
        f"The whole run took {result['wall_s']:.0f} s."),
        "",
        "## Targets",
        "",
        "| | measured | target | |",
        "|---|---:|---:|---|",
    ]
    for name, measured, target, met in target_rows(result):
        out.append(f"| {name} | {measured} | {target} | {met} |")
    return out


def _speed_markdown(result: dict, plot_rel: str) -> list[str]:
    """Steps per second: the plot, the table and how each measurement is made."""
    s = result["settings"]
    out = [
        "## Steps per second",
        "",
        f"![steps/s against swarm size]({plot_rel})",
        "",
        "| measurement | robots | slaves joined | steps/s | agent-steps/s | ms/step | CPU ms/step | policy ms/step | reset ms | timed steps |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in result["results"]:
        out.append(
            f"| {r['label']} | {r['agents']} | {fmt(r.get('mean_slaves_joined'), '.2f')} | {r['steps_per_s']:,.0f} | {r['agent_steps_per_s']:,.0f} | "
            f"{r['ms_per_step']:.3f} | {fmt(r.get('cpu_ms_per_step'), '.3f')} | {fmt(r.get('policy_ms_per_step'), '.3f')} | "
            f"{fmt(r.get('reset_ms'), '.1f')} | {r['steps']:,} |"
        )
    for sk in result.get("skipped", []):
        out.append(f"| {sk['name']} | | | skipped: {sk['reason']} | | | | | | |")
    out += [
        "",
        ("* **petswarm**: `petswarm_env.parallel_env(**{\"swarm.num_slaves\": n})`, full middleware (join "
        f"protocol, radio medium, IR token ring, master broadcasts), {s['warmup_steps']} warm-up steps, then "
        f"`env.step` timed with `time.perf_counter` until ≥ {s['target_s']:g} s and ≥ {s['min_steps']} steps "
        "(*CPU ms/step*: `time.process_time` over the same calls, which other processes' load disturbs less). "
        "The policy's time (scripted leader–follower, or uniform random actions) is timed apart (*policy "
        "ms/step*), as is `reset` (*reset ms*; it runs the join protocol on the clock). Episodes reset as they "
        "end (seeds 0, 1, …). *agent-steps/s* counts the acting agents (the slaves) per step; *robots* "
        "counts the master too; *slaves joined* is the mean number of slaves in the episodes timed (a candidate "
        "whose RSSI distance estimate puts it beyond the join radius stays out, Table 1)."),
        "* **physics floor**: the env's own `World` with the same bodies (robots with the configured radius "
        "and mass, the user as a kinematic circle, the arena walls), stepped `physics_substeps` times per "
        "control step, setting every body's velocity and angular velocity before each substep with pymunk's "
        "public setters (`Body.velocity`, `Body.angular_velocity`), and nothing else: no clock, radio, sensors or "
        "rewards. The bodies drive one circle together, so there are no contacts. `Space.step` alone (no writes) runs at "
        + ", ".join(f"{r['bare_steps_per_s']:,.0f}" for r in result["results"] if r["kind"] == "floor")
        + " control steps/s for "
        + ", ".join(str(r["agents"]) for r in result["results"] if r["kind"] == "floor") + " robots.",
        ("* **MPE simple_spread**: `mpe2.simple_spread_v3.parallel_env(N=robots, continuous_actions=True, "
        "max_cycles=<petswarm max_cycles>)`, uniform random actions drawn outside the timed call; resets "
        "timed apart, as for petswarm."),
        *_side_by_side_markdown(result.get("side_by_side")),
        "",
    ]
    return out


def _memory_markdown(mem: dict) -> list[str]:
    """Memory: the untraced run's checkpoints, tracemalloc over whole episodes, the growth."""
    out = [
        "## Memory",
        "",
        f"{mem['env']}"
        + (", in a fresh process (so peak RSS is this run's own)" if mem.get("isolated_process") else ", in the benchmark's process")
        + ". First an untraced run: after `gc.collect()` at each checkpoint, the current RSS (`/proc/self/statm`), the "
        "peak RSS (`resource.getrusage` `ru_maxrss`), the live pymalloc blocks (`sys.getallocatedblocks`) and the "
        "gc-tracked objects. MB = 2^20 bytes.",
        "",
        "| env steps | RSS MB | peak RSS MB | live pymalloc blocks | gc objects | resets |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for x in mem["samples"]:
        out.append(
            f"| {x['steps']:,} | {fmt(x['rss'], '.1f')} | {fmt(x['peak_rss'], '.1f')} | {x['py_blocks']:,} | "
            f"{x['gc_objects']:,} | {x['resets']} |"
        )
    g = mem["growth"]
    tm = mem["tracemalloc"]
    out += [
        "",
        ("Then tracemalloc, over whole episodes run right after the untraced run: tracing starts at an episode "
        "boundary and the traced size (memory allocated since tracing began and still alive, after "
        "`gc.collect()`) is read at the end of each episode, when the episode's world — allocated under tracing — "
        "is still alive; the mean growth from one episode end to the next is what a leak would add per episode "
        f"({tm['episode_steps']} steps). tracemalloc is not on for the whole run: it slows the env about 5×."),
        "",
        "| env steps | tracemalloc current MB | tracemalloc peak MB |",
        "|---:|---:|---:|",
    ]
    for e in tm["episodes"]:
        out.append(f"| {e['steps']:,} | {e['current']:.3f} | {e['peak']:.3f} |")
    tol = mem["tolerance"]
    out += [
        "",
        (f"Growth from {mem['steps_first']:,} to {mem['steps_last']:,} steps: RSS {fmt(g['rss'], '+.1f')} MB, "
        f"peak RSS {fmt(g['peak_rss'], '+.1f')} MB, live blocks {g['py_blocks']:+,} ({100 * g['py_blocks_rel']:+.2f} %), "
        f"gc objects {g['gc_objects']:+,}; tracemalloc {g['tracemalloc_per_episode']:+.3f} MB per episode. "
        f"\"No growth\" = live blocks grow by less than {100 * tol['py_blocks_rel']:g} % and tracemalloc by less than "
        f"{tol['tracemalloc_mb_per_episode']:g} MB per episode: {verdict(mem['no_growth'])}."),
        "",
    ]
    return out


def _percent(share: float | None) -> str:
    return "–" if share is None else f"{100 * share:.0f} %"


def _training_markdown(tr: dict) -> list[str]:
    """Training throughput: PPO samples/s per vector env and worker setting."""
    out = ["## Training throughput", ""]
    if "skipped" in tr:
        out.append(f"Skipped: {tr['skipped']}")
    else:
        out += [
            f"PPO (stable-baselines3), {tr['env']}, net {tr['net_arch']}, torch threads {tr['torch_threads']}.",
            "",
            "| vector env | num_envs | processes | vector rows | n_steps | rollout | batch | epochs | samples | s | samples/s | samples per CPU-s | env share |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in tr["runs"]:
            out.append(
                f"| {r.get('path', 'supersuit')} | {r['num_envs']} | {r['num_cpus']} | {r['vector_rows']} | {r['n_steps']} | "
                f"{r['rollout_samples']} | {r['batch_size']} | {r['n_epochs']} | {r['samples']:,} | {r['wall_s']:.1f} | "
                f"{r['samples_per_s']:,.0f} | {fmt(r.get('samples_per_cpu_s'), ',.0f')} | "
                f"{_percent(r.get('env_cpu_share'))} |"
            )
        out += ["", tr["method"]]
    out.append("")
    return out


def _vector_markdown(vec: dict | None) -> list[str]:
    """Many envs in one process: the vector env at several sizes beside the single env and VMAS."""
    if not vec:
        return []
    out = [
        "## Many envs in one process",
        "",
        (f"Side by side in one run: {vec['rounds']} rounds of one {vec['burst_s']:g} s burst of step time per system, "
         "the order rotating from round to round; uniform random actions drawn outside the timed call; one thread "
         "each. *env-steps*: steps of one env copy (a `vector_env(64).step` is 64). The vector env's auto-resets "
         "are inside its step (*auto-resets*: their CPU µs per env-step, in the timed steps); the single env's "
         "resets are timed apart; VMAS is never reset. *per CPU-s*: over "
         "`time.process_time`, which the other processes' load disturbs less than wall time."),
        "",
        "| system | envs | env-steps/s | env-steps per CPU-s | µs per env-step | auto-resets µs | vs parallel_env (wall) | vs parallel_env (CPU) | per round (wall) | reset s |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|---:|",
    ]
    for r in vec["rows"]:
        pr = r["per_round_vs_single"]
        out.append(
            f"| {r['label']} | {r['num_envs']} | {r['env_steps_per_s']:,.0f} | {fmt(r['env_steps_per_cpu_s'], ',.0f')} | "
            f"{r['us_per_env_step']:.1f} | {fmt(r.get('auto_reset_cpu_us_per_env_step'), '.1f')} | "
            f"{r['vs_single']:.2f}× | {fmt(r['vs_single_cpu'])}× | "
            f"{min(pr):.2f}–{max(pr):.2f}× | {fmt(r.get('reset_s'), '.1f')} |")
    if vec.get("vmas_skipped"):
        out += ["", f"VMAS: skipped: {vec['vmas_skipped']}"]
    out.append("")
    return out


def benchmarks_markdown(result: dict, plot_rel: str, hand_written: str = "") -> str:
    """The whole page: the measured sections and, after "What bounds the speed", the
    ``hand_written`` section (from the page being replaced, :func:`hand_written_section`)."""
    out = [
        *_header_markdown(result),
        *_speed_markdown(result, plot_rel),
        "## Where a step's time goes",
        "",
        *_breakdown_markdown(result["breakdown"]),
        *_bounds_markdown(result),
    ]
    if hand_written:
        out += [hand_written, ""]
    out += [*_memory_markdown(result["memory_mb"]), *_vector_markdown(result.get("vector")),
            *_training_markdown(result["training"])]
    return "\n".join(out)


def hand_written_section(path: Path) -> str:
    """The hand-written section of the page at ``path`` (its markers included), or "" if there is
    no page or no section."""
    try:
        text = path.read_text(encoding="utf-8")
    except (FileNotFoundError, IsADirectoryError, UnicodeDecodeError):
        return ""
    start = text.find(HAND_WRITTEN_BEGIN)
    end = text.find(HAND_WRITTEN_END, start)
    return text[start:end + len(HAND_WRITTEN_END)] if start >= 0 and end >= 0 else ""


def write_benchmarks_md(result: dict, path: str | os.PathLike, plot_path: str | os.PathLike) -> None:
    """Write the markdown report to ``path`` and the steps/s plot to ``plot_path`` (PNG), each
    atomically (temporary file beside it, then rename); the markdown links the plot relatively. The
    hand-written section of the page already at ``path`` is kept as it is."""
    path, plot_path = Path(path), Path(plot_path)
    write_plot(result, plot_path)
    rel = os.path.relpath(plot_path.resolve(), path.resolve().parent).replace(os.sep, "/")
    write_text_atomic(path, benchmarks_markdown(result, rel, hand_written_section(path)))
