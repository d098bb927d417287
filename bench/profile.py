"""The breakdown of a step's cost by part (:mod:`petswarm.bench.parts`), two ways: cProfile self times
(:func:`breakdown_from_stats`) and a statistical stack sampler (:class:`StackSampler`, SIGPROF on
CPU time), which has no per-call cost and so does not inflate call-heavy Python code."""

from __future__ import annotations

import collections
import cProfile
import gc
import inspect
import pstats
import signal
from typing import Any, Self

from petswarm.bench.loops import EnvLoop
from petswarm.bench.parts import CATEGORIES, ROOT, norm_path, part_of
from petswarm.bench.settings import BenchSettings


def breakdown_from_stats(stats: pstats.Stats) -> dict[str, Any]:
    """Share of profiled time per category, by *self time attribution*.

    Every function's own time (cProfile ``tottime``) goes to the part of the module it lives in
    (:func:`petswarm.bench.parts.part_of`). *Neutral* functions — C built-ins (pymunk's cffi calls, math,
    list methods), numpy, the standard library, pymunk's property accessors, the geometry helpers —
    pass their own time to their callers, in proportion to the time spent in them from each caller
    (cProfile's per-caller statistics), recursively. So ``cpSpaceStep`` and the contact callbacks
    count as physics, a numpy call inside ``observe.py`` as observation, a ``body.position`` read
    from the reward code as reward/metrics.
    """
    raw = stats.stats  # func -> (cc, nc, tt, ct, callers{caller: (nc, cc, tt, ct)})
    memo: dict[tuple, dict[str, float]] = {}

    def resolve(func: tuple, stack: set) -> dict[str, float]:
        if func in memo:
            return memo[func]
        cat = part_of(func)
        if cat is not None:
            memo[func] = {cat: 1.0}
            return memo[func]
        if func in stack or func not in raw:
            return {"other": 1.0}
        callers = raw[func][4]
        weights = {c: v[2] for c, v in callers.items()}
        total = sum(weights.values())
        if total <= 0:
            weights = {c: v[0] for c, v in callers.items()}
            total = sum(weights.values())
        if total <= 0:
            memo[func] = {"other": 1.0}
            return memo[func]
        dist: dict[str, float] = {}
        stack = stack | {func}
        for c, w in weights.items():
            for k, f in resolve(c, stack).items():
                dist[k] = dist.get(k, 0.0) + f * w / total
        memo[func] = dist
        return dist

    totals = dict.fromkeys(CATEGORIES, 0.0)
    per_func = []
    for func, (_cc, _nc, tt, _ct, _callers) in raw.items():
        if "_lsprof" in func[2]:  # the profiler's own enable/disable
            continue
        dist = resolve(func, set())
        for k, f in dist.items():
            totals[k] += tt * f
        per_func.append((tt, func, max(dist, key=dist.get)))
    total = sum(totals.values()) or 1.0
    per_func.sort(reverse=True)
    top = [
        {"function": _func_label(func), "self_share": tt / total, "category": cat}
        for tt, func, cat in per_func[:12]
    ]
    return {"shares": {k: v / total for k, v in totals.items()}, "profiled_s": total, "top_functions": top}


def _func_label(func: tuple[str, int, str]) -> str:
    filename, line, name = func
    if filename == "~":
        return name
    path = norm_path(filename)
    for marker in ("/site-packages/", norm_path(str(ROOT)) + "/"):
        if marker in path:
            path = path.split(marker, 1)[1]
            break
    return f"{path}:{line}({name})"


class StackSampler:
    """A statistical profiler: every ``interval_s`` of process CPU time (``ITIMER_PROF``) the
    SIGPROF handler records the interrupted Python stack, while :attr:`active` is set.

    Unlike cProfile it adds no cost per Python call, so call-heavy code (the event-driven
    middleware) is not inflated against C-heavy code (pymunk, numpy); the price is sampling noise
    (a share from n samples has a standard error of about sqrt(p(1-p)/n)). Time in C functions is
    charged to the Python frame that called them. Unix only (:meth:`available`)."""

    def __init__(self, interval_s: float = 0.001):
        self.interval_s = interval_s
        self.active = False
        self.stacks: collections.Counter = collections.Counter()  # stack (root first) -> samples
        self._old_handler: Any = None

    @staticmethod
    def available() -> bool:
        return hasattr(signal, "setitimer") and hasattr(signal, "SIGPROF")

    def _handler(self, signum, frame) -> None:
        if not self.active:
            return
        stack = []
        while frame is not None:
            code = frame.f_code
            stack.append((code.co_filename, code.co_firstlineno, code.co_name, code.co_qualname))
            frame = frame.f_back
        stack.reverse()
        self.stacks[tuple(stack)] += 1

    def __enter__(self) -> Self:
        self._old_handler = signal.signal(signal.SIGPROF, self._handler)
        signal.setitimer(signal.ITIMER_PROF, self.interval_s, self.interval_s)
        return self

    def __exit__(self, *exc) -> None:
        signal.setitimer(signal.ITIMER_PROF, 0.0, 0.0)
        signal.signal(signal.SIGPROF, self._old_handler or signal.SIG_DFL)


def _frame_label(fr: tuple) -> str:
    return _func_label((fr[0], fr[1], fr[3])).rsplit("(", 1)[0].rsplit(":", 1)[0] + f":{fr[3]}"


def code_key(fn) -> tuple[str, int, str]:
    """``(filename, first line, name)`` of a function's code: how the sampler's frames name it."""
    code = inspect.unwrap(fn).__code__
    return code.co_filename, code.co_firstlineno, code.co_name


def breakdown_from_samples(stacks: collections.Counter, step: tuple[str, int, str], top: int = 40) -> dict[str, Any]:
    """Shares of ``env.step`` (the frames whose :func:`code_key` is ``step``) per category from
    stack samples: a sample counts for the category of its innermost frame that has one (neutral
    frames — numpy, pymunk accessors, the standard library, geometry helpers — defer to their
    caller, as in :func:`breakdown_from_stats`). Also the inclusive share of the functions seen
    most (a function counts once per sample)."""
    totals = dict.fromkeys(CATEGORIES, 0)
    inclusive: collections.Counter = collections.Counter()
    leaf: collections.Counter = collections.Counter()
    n = 0
    for stack, count in stacks.items():
        idx = next((i for i, fr in enumerate(stack) if fr[:3] == step), None)
        if idx is None:
            continue
        inner = stack[idx:]
        n += count
        cat = "other"
        for fr in reversed(inner):
            c = part_of((fr[0], fr[1], fr[2]))
            if c is not None:
                cat = c
                break
        totals[cat] += count
        for label in {_frame_label(fr) for fr in inner}:
            inclusive[label] += count
        leaf[_frame_label(inner[-1])] += count
    if n == 0:
        return {"samples": 0, "shares": dict.fromkeys(CATEGORIES, 0.0), "inclusive": [], "self": []}
    return {
        "samples": n,
        "shares": {k: v / n for k, v in totals.items()},
        "inclusive": [{"function": f, "share": c / n} for f, c in inclusive.most_common(top)],
        "self": [{"function": f, "share": c / n} for f, c in leaf.most_common(top // 2)],
    }


def bench_breakdown(num_slaves: int, s: BenchSettings) -> dict:
    """cProfile of env.step only (enabled around each call) for the scripted policy."""
    loop = EnvLoop(num_slaves, "scripted", s.seed)
    loop.run(steps=s.warmup_steps)
    loop.clear()
    gc.collect()
    prof = cProfile.Profile()
    on = [False]

    def toggle() -> None:
        if on[0]:
            prof.disable()
        else:
            prof.enable()
        on[0] = not on[0]

    loop.run(seconds=s.profile_target_s, min_steps=max(20, s.min_steps // 2), step_hook=toggle)
    result = breakdown_from_stats(pstats.Stats(prof))
    result.update(steps=loop.steps, profiled_ms_per_step=1e3 * loop.step_s / loop.steps)
    if StackSampler.available():  # the same loop again, sampled instead of traced
        sampler = StackSampler()
        loop.clear()

        def flip() -> None:
            sampler.active = not sampler.active

        with sampler:
            loop.run(seconds=s.profile_target_s, min_steps=max(20, s.min_steps // 2), step_hook=flip)
        sampler.active = False
        result["sampled"] = breakdown_from_samples(sampler.stacks, code_key(type(loop.env).step))
        n = result["sampled"]["samples"]
        result["sampled"].update(
            interval_ms=1e3 * sampler.interval_s, steps=loop.steps, sampled_ms_per_step=1e3 * loop.step_s / max(loop.steps, 1),
            # the kernel delivers SIGPROF at its tick at best: the effective interval, over env.step time
            effective_interval_ms=1e3 * loop.step_s / n if n else None)
    result.update(
        env=f"1 master + {num_slaves} slaves, scripted policy",
        slaves=num_slaves,
        method="cProfile around env.step only; self time (tottime) attributed by the module the function lives in, "
        "neutral functions (C built-ins, numpy, stdlib, pymunk accessors) to their callers; then the same "
        "loop under a SIGPROF stack sampler, each sample to the category of its innermost non-neutral frame",
    )
    return result
