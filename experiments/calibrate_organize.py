"""Fit the radio parameter behind the retry probability (seed 000 §4.5, Table 5) on part of the
slave counts and print, for each candidate, paper vs simulation on the fitted counts and on the
held-out ones.

Usage:
    python -m petswarm.experiments.calibrate_organize [--fit 2,4] [--set KEY=V1,V2,... ...] [--trials N] [--seed S] [--config FILE]

``--fit`` names the slave counts whose retry probabilities the fit may use (default
``organize_time.RETRY_FIT_COUNTS``, 2 and 4); the others (1, 3, 5) are held out: the candidate with
the smallest RMS deviation on the fitted counts is chosen (marked ``<- best on the fit set``) whatever
the held-out counts say, and the held-out columns are what ``petswarm reproduce`` validates.

Without ``--set`` it sweeps ``radio.processing_jitter_s`` (the spread of the MCU's response time
to a received frame, which decides how often two answers to one broadcast start within one
802.15.4 turnaround of each other and collide). Several ``--set`` options sweep their product,
e.g. ``--set radio.processing_jitter_s=0.004,0.006 --set radio.min_be=2,3``.

Every candidate runs the ``organize_time`` experiment of ``petswarm reproduce`` (the join protocol
through ``PetSwarmEnv.reset``, 1–5 slaves) with ``--trials`` organizations per slave count
(default 200, four times the paper's 50, so the probabilities are estimated to about ±3 points),
seeds from 10 000 (apart from reproduce's). The chosen value goes to ``petswarm_env/default.yaml``
(and its mirror ``configs/default.yaml``).
"""

from __future__ import annotations

import argparse
import itertools
import time

import yaml

from petswarm.cli.errors import OneLineParser, run_program
from petswarm.experiments.organize_time import (
    PAPER_MIN_ORGANIZE_S,
    PAPER_RETRY_PCT,
    PAPER_SLAVE_COUNTS,
    RETRY_FIT_COUNTS,
    RETRY_TOLERANCE_PCT,
    organize_rows,
    organize_summary,
    organize_trials,
)
from petswarm_env.config import flatten_dotted, load_config


FIT_SEED = 10_000  # the calibration's first seed, apart from reproduce's


def _values(text: str) -> tuple[str, list]:
    key, _, vals = text.partition("=")
    if not key or not vals:
        raise argparse.ArgumentTypeError(f"expected KEY=V1,V2,..., got '{text}'")
    return key.strip(), [yaml.safe_load(v) for v in vals.split(",")]


def _counts(text: str) -> tuple[int, ...]:
    try:
        counts = tuple(sorted({int(v) for v in text.split(",") if v.strip()}))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected slave counts like 2,4, got '{text}'") from None
    bad = [n for n in counts if n not in PAPER_RETRY_PCT]
    if bad or not counts:
        raise argparse.ArgumentTypeError(f"fit counts must be some of {', '.join(map(str, PAPER_SLAVE_COUNTS))}, got '{text}'")
    return counts


def _rms(summary: dict[int, dict], counts) -> float:
    return (sum((summary[n]["retry_pct"] - PAPER_RETRY_PCT[n]) ** 2 for n in counts) / len(counts)) ** 0.5 if counts else float("nan")


def candidate_line(over: dict, summary: dict[int, dict], fit: tuple[int, ...], wall_s: float) -> str:
    """One candidate: min / mean times, the retry % with the fitted counts marked *, RMS deviation
    on the fit set and on the held-out counts, and which held-out rows are outside tolerance."""
    counts = PAPER_SLAVE_COUNTS
    held = [n for n in counts if n not in fit]
    rows = organize_rows(summary, fit)
    missed = [r.metric.removeprefix("retry probability, ") for r in rows if r.basis == "validated" and not r.ok]
    failed = sum(s["failed"] for s in summary.values())
    return (", ".join(f"{k}={v}" for k, v in over.items())
            + " | min s " + " ".join(f"{summary[n]['min_s']:.2f}" for n in counts)
            + " | mean s " + " ".join(f"{summary[n]['mean_s']:.2f}" for n in counts)
            + " | retry % " + " ".join(f"{summary[n]['retry_pct']:4.1f}{'*' if n in fit else ' '}" for n in counts)
            + f" | rms dev fit {_rms(summary, fit):4.1f}, held out {_rms(summary, held):4.1f} pts"
            + (f" | held out outside ±{RETRY_TOLERANCE_PCT:g}: {', '.join(missed)}" if missed else " | held out all within tolerance")
            + (f" | {failed} failed" if failed else "")
            + f" | {wall_s:.0f} s")


def sweep(grid: dict[str, list], fit: tuple[int, ...], trials: int, seed: int = FIT_SEED, config: str | None = None) -> dict:
    """Organize ``trials`` times per slave count for every candidate of ``grid`` (the product of its
    values), print paper vs simulation per candidate (fit vs held out), and return the candidate
    (``{key: value}``) with the smallest RMS deviation on the ``fit`` counts."""
    counts = PAPER_SLAVE_COUNTS
    current = flatten_dotted(load_config(config).to_dict())
    print("current: " + ", ".join(f"{k}={current.get(k)}" for k in grid))
    print(f"fit on {', '.join(map(str, fit))} slaves (*); held out: {', '.join(str(n) for n in counts if n not in fit) or 'none'}")
    print("paper:   min s " + " ".join(f"{PAPER_MIN_ORGANIZE_S[n]:.2f}" if n in PAPER_MIN_ORGANIZE_S else "  - " for n in counts)
          + " | retry % " + " ".join(f"{PAPER_RETRY_PCT[n]:4.0f}{'*' if n in fit else ' '}" for n in counts))
    scored = []
    for combo in itertools.product(*grid.values()):
        over = dict(zip(grid, combo))
        cfg = load_config(config, over)
        t0 = time.perf_counter()
        summary = {n: organize_summary(organize_trials(cfg, n, range(seed, seed + trials))) for n in counts}
        print(candidate_line(over, summary, fit, time.perf_counter() - t0), flush=True)
        scored.append((_rms(summary, fit), over, summary))
    _, over, summary = min(scored, key=lambda t: t[0])
    print("best on the fit set: " + candidate_line(over, summary, fit, 0.0).rsplit(" | ", 1)[0])
    return over


def main() -> None:
    parser = OneLineParser(prog="python -m petswarm.experiments.calibrate_organize", description=__doc__.splitlines()[0])
    parser.add_argument("--fit", type=_counts, default=RETRY_FIT_COUNTS, metavar="N,N,...",
                        help=f"slave counts the fit may use (default {','.join(map(str, RETRY_FIT_COUNTS))}; the others are held out)")
    parser.add_argument("--set", type=_values, action="append", default=[], metavar="KEY=V1,V2,...",
                        help="a config key and the values to sweep (repeatable: the product is swept)")
    parser.add_argument("--trials", type=int, default=200, help="organizations per slave count (paper: 50)")
    parser.add_argument("--seed", type=int, default=FIT_SEED, help=f"first seed (default {FIT_SEED}: apart from reproduce's seeds)")
    parser.add_argument("--config", help="YAML merged over the defaults")
    args = parser.parse_args()
    grid = dict(args.set) or {"radio.processing_jitter_s": [0.004, 0.005, 0.0055, 0.006, 0.007, 0.008, 0.010]}
    sweep(grid, args.fit, args.trials, args.seed, args.config)


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.calibrate_organize", main))
