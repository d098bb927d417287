"""Sweep the radio / protocol parameters behind the organize time and the retry probability
(seed 000 §4.5, Fig. 22, Table 5) and print paper vs simulation for each candidate.

Usage:
    python -m experiments.calibrate_organize [--set KEY=V1,V2,... ...] [--trials N] [--seed S] [--config FILE]

Without ``--set`` it sweeps ``radio.processing_jitter_s`` (the spread of the MCU's response time
to a received frame, which decides how often two answers to one broadcast start within one
802.15.4 turnaround of each other and collide). Several ``--set`` options sweep their product,
e.g. ``--set radio.processing_jitter_s=0.004,0.006 --set radio.min_be=2,3``.

Every candidate runs the ``organize_time`` experiment of ``petswarm reproduce`` (the join protocol
through ``PetSwarmEnv.reset``, 1–5 slaves) with ``--trials`` organizations per slave count
(default 200, four times the paper's 50, so the probabilities are estimated to about ±3 points).
The chosen values go to ``petswarm_env/default.yaml`` (``calibrated to seed 000 Table 5 / Fig. 22``).
"""

from __future__ import annotations

import argparse
import itertools
import time

import yaml

from experiments.organize_time import (
    PAPER_MIN_ORGANIZE_S,
    PAPER_RETRY_PCT,
    PAPER_SLAVE_COUNTS,
    organize_rows,
    organize_summary,
    organize_trials,
)
from petswarm_env.config import flatten_dotted, load_config


def _values(text: str) -> tuple[str, list]:
    key, _, vals = text.partition("=")
    if not key or not vals:
        raise argparse.ArgumentTypeError(f"expected KEY=V1,V2,..., got '{text}'")
    return key.strip(), [yaml.safe_load(v) for v in vals.split(",")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", type=_values, action="append", default=[], metavar="KEY=V1,V2,...",
                        help="a config key and the values to sweep (repeatable: the product is swept)")
    parser.add_argument("--trials", type=int, default=200, help="organizations per slave count (paper: 50)")
    parser.add_argument("--seed", type=int, default=10_000, help="first seed (default 10000: apart from reproduce's seeds)")
    parser.add_argument("--config", help="YAML merged over the defaults")
    args = parser.parse_args()
    grid = dict(args.set) or {"radio.processing_jitter_s": [0.004, 0.005, 0.006, 0.007, 0.008, 0.010]}
    base = load_config(args.config)
    current = flatten_dotted(base.to_dict())
    print("current: " + ", ".join(f"{k}={current.get(k)}" for k in grid))
    counts = PAPER_SLAVE_COUNTS
    print("paper:   min s " + " ".join(f"{PAPER_MIN_ORGANIZE_S[n]:.2f}" for n in counts)
          + " | retry % " + " ".join(f"{PAPER_RETRY_PCT[n]:4.0f}" for n in counts))
    for combo in itertools.product(*grid.values()):
        over = dict(zip(grid, combo))
        cfg = load_config(args.config, over)
        t0 = time.perf_counter()
        summary = {n: organize_summary(organize_trials(cfg, n, range(args.seed, args.seed + args.trials))) for n in counts}
        rows = organize_rows(summary)
        dev = max(abs(summary[n]["retry_pct"] - PAPER_RETRY_PCT[n]) for n in counts)
        sq = sum((summary[n]["retry_pct"] - PAPER_RETRY_PCT[n]) ** 2 for n in counts) ** 0.5
        failed = sum(s["failed"] for s in summary.values())
        print(
            ", ".join(f"{k}={v}" for k, v in over.items())
            + " | min s " + " ".join(f"{summary[n]['min_s']:.2f}" for n in counts)
            + " | mean s " + " ".join(f"{summary[n]['mean_s']:.2f}" for n in counts)
            + " | retry % " + " ".join(f"{summary[n]['retry_pct']:4.1f}" for n in counts)
            + f" | max |dev| {dev:4.1f} pts, rms {sq:4.1f} | rows ok {sum(r.ok for r in rows)}/{len(rows)}"
            + (f" | {failed} failed" if failed else "")
            + f" | {time.perf_counter() - t0:.0f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
