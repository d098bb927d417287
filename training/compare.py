"""Is a retrained policy better? ``petswarm eval`` over a grid of settings, for several policies on
the same seeds, as one table (``python -m petswarm.training.compare``).

Each cell is the default env config with a few dotted overrides (a formation, a driving mode, a
slave count, a loss, two users); every policy runs :func:`petswarm.evaluation.evaluate.evaluate` on the
cell's scenarios with the same seeds (pick seeds training never used: training draws its episode
seeds from ``seed + copy`` and a stream of 31-bit integers, the periodic evaluation uses 1000 +).
The table gives each policy's mean formation RMSE per cell, its ratio to the first policy
(``scripted``), and its collisions; ``--json`` keeps every cell's figures.

    python -m petswarm.training.compare --policies scripted,learned,runs/mappo/policy.npz --seed 5000 --episodes 2
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import time
from typing import Any

import numpy as np

from petswarm.evaluation.evaluate import evaluate
from petswarm_env.config import load_config
from petswarm_env.files import write_json_atomic

FORMATIONS = ("wedge", "column", "row", "grid")
MODES = ("following", "leading")
# cells beyond formation x mode: other slave counts, loss, two users (wedge, following)
EXTRA = ({"swarm.num_slaves": 2}, {"swarm.num_slaves": 6}, {"radio.loss_prob": 0.3}, {"world.num_users": 2})


def cells(formations=FORMATIONS, modes=MODES, extra=EXTRA) -> list[dict[str, Any]]:
    """The grid's cells as dotted overrides: every formation in every mode, then ``extra``."""
    grid = [{"swarm.formation": f, "swarm.mode": m} for f, m in itertools.product(formations, modes)]
    return grid + [dict(e) for e in extra]


def label(cell: dict[str, Any]) -> str:
    return " ".join(f"{k.split('.')[-1]}={v}" for k, v in cell.items())


def compare(policies: list[str], grid: list[dict[str, Any]], scenarios: list[str], episodes: int, seed: int,
            max_cycles: int, progress=print, reuse: dict[str, dict[str, Any]] | None = None) -> list[dict[str, Any]]:
    """One row per cell: each policy's mean RMSE over the cell's scenarios x seeds and its collisions
    (``reuse``: figures of an earlier run with the same settings, by cell label, taken instead of re-running)."""
    rows = []
    for cell in grid:
        cfg = load_config(overrides={**cell, "max_cycles": max_cycles})
        row: dict[str, Any] = {"cell": label(cell), "overrides": cell, "policies": {}}
        for policy in policies:
            if reuse and policy in reuse.get(label(cell), {}):
                row["policies"][policy] = reuse[label(cell)][policy]
                continue
            t0 = time.time()
            result = evaluate(cfg, policy, scenarios=scenarios, episodes=episodes, seed=seed)
            eps = result["episodes"]
            rmse = [e["formation_rmse_m"] for e in eps if math.isfinite(e["formation_rmse_m"])]
            row["policies"][policy] = {
                "formation_rmse_m": float(np.mean(rmse)) if rmse else math.nan,
                "collisions": int(sum(sum(e["collisions"].values()) for e in eps)),
                "episodes": len(eps),
                "wall_time_s": round(time.time() - t0, 1),
            }
        progress(format_row(row, policies))
        rows.append(row)
    return rows


def format_row(row: dict[str, Any], policies: list[str]) -> str:
    ref = row["policies"][policies[0]]["formation_rmse_m"]
    parts = [f"| {row['cell']} "]
    for p in policies:
        r = row["policies"][p]
        ratio = r["formation_rmse_m"] / ref if ref else math.nan
        parts.append(f"| {r['formation_rmse_m']:.3f} ({ratio:.2f}x, {r['collisions']} coll.) ")
    return "".join(parts) + "|"


def summary(rows: list[dict[str, Any]], policies: list[str]) -> str:
    """Geometric mean of each policy's ratio to the first over the cells, its worst ratio, its
    cells won against each other policy."""
    lines = []
    for p in policies[1:]:
        ratios = [r["policies"][p]["formation_rmse_m"] / r["policies"][policies[0]]["formation_rmse_m"] for r in rows]
        ratios = [x for x in ratios if math.isfinite(x) and x > 0]
        gm = float(np.exp(np.mean(np.log(ratios)))) if ratios else math.nan
        coll = sum(r["policies"][p]["collisions"] for r in rows)
        lines.append(f"{p}: geometric mean {gm:.2f}x {policies[0]}, worst {max(ratios, default=math.nan):.2f}x, "
                     f"{coll} collisions ({sum(r['policies'][policies[0]]['collisions'] for r in rows)} for {policies[0]})")
    for a, b in itertools.combinations(policies[1:], 2):
        wins = sum(r["policies"][b]["formation_rmse_m"] < r["policies"][a]["formation_rmse_m"] for r in rows)
        lines.append(f"{b} has the lower RMSE than {a} in {wins} of {len(rows)} cells")
    return "\n".join(lines)


def read_json(path: str) -> dict[str, Any]:
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m petswarm.training.compare", description=__doc__.split("\n\n")[0])
    ap.add_argument("--policies", default="scripted,learned", help="comma-separated: scripted, learned, a policy.npz path")
    ap.add_argument("--scenarios", default="zigzag,u_turn", help="comma-separated scenarios of every cell")
    ap.add_argument("--episodes", type=int, default=2, help="seeds per scenario and cell")
    ap.add_argument("--seed", type=int, default=5000, help="first seed (one training never used)")
    ap.add_argument("--max-cycles", type=int, default=400)
    ap.add_argument("--json", help="write every cell's figures here")
    ap.add_argument("--reuse", help="a --json of an earlier run with the same settings: its policies' figures are taken from it")
    args = ap.parse_args(argv)
    policies = [p.strip() for p in args.policies.split(",") if p.strip()]
    reuse = None
    if args.reuse:
        old = read_json(args.reuse)
        same = all(old[k] == getattr(args, k) for k in ("scenarios", "episodes", "seed", "max_cycles"))
        if not same:
            raise SystemExit(f"--reuse {args.reuse}: it was run with other --scenarios/--episodes/--seed/--max-cycles")
        reuse = {r["cell"]: r["policies"] for r in old["rows"]}
    print("| cell " + "".join(f"| {p} " for p in policies) + "|")
    print("|---" * (len(policies) + 1) + "|")
    rows = compare(policies, cells(), [s.strip() for s in args.scenarios.split(",")], args.episodes, args.seed, args.max_cycles,
                   reuse=reuse)
    print(summary(rows, policies))
    if args.json:
        write_json_atomic(args.json, {"policies": policies, "scenarios": args.scenarios, "episodes": args.episodes,
                                      "seed": args.seed, "max_cycles": args.max_cycles, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
