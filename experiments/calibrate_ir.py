"""Print the IR accuracy (seed 000 §4.3, Table 4) for the IR parameters in a YAML file, the fitted
figures and the held-out ones apart.

Usage: python -m petswarm.experiments.calibrate_ir [CONFIG_YAML] [--seeds N] [--fit distance,direction]
(default CONFIG_YAML: the packaged default, petswarm_env/default.yaml = configs/default.yaml; any YAML
with a top-level ``ir:`` section works).

Table 4 has two figures, the distance and the direction RMSE over one grid, and the nine ``ir.*``
values were fitted to both: ``--fit`` names the figures the YAML's values were fitted to (default
``ir_accuracy.IR_FIT``, both), and a figure left out is printed as held out. With the default
nothing is held out, so ``petswarm reproduce`` shows both rows as calibrated.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

from petswarm.cli.errors import OneLineParser, run_program
from petswarm.experiments import ir_accuracy as exp
from petswarm_env.comms.ir import IRConfig
from petswarm_env.config import default_config_path


def _fit_set(text: str) -> tuple[str, ...]:
    names = tuple(v.strip() for v in text.split(",") if v.strip())
    if not names or any(v not in exp.IR_FIT for v in names):
        raise argparse.ArgumentTypeError(f"fit figures must be some of {', '.join(exp.IR_FIT)}, got '{text}'")
    return names


def main() -> None:
    parser = OneLineParser(prog="python -m petswarm.experiments.calibrate_ir", description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default=default_config_path(), type=Path)
    parser.add_argument("--seeds", type=int, default=5, help="number of rng seeds (0..N-1) to run")
    parser.add_argument("--fit", type=_fit_set, default=exp.IR_FIT, metavar="FIGURE,...",
                        help="figures of Table 4 the YAML's values were fitted to: distance, direction (default both; the others are held out)")
    args = parser.parse_args()
    cfg = IRConfig(**yaml.safe_load(args.config.read_text())["ir"])
    held = [k for k in exp.IR_FIT if k not in args.fit]
    print(f"paper (Table 4): distance {exp.PAPER_DISTANCE_RMSE_CM:.3f} cm, direction {exp.PAPER_DIRECTION_RMSE_DEG:.2f} deg; "
          f"fitted: {', '.join(args.fit)}; held out: {', '.join(held) or 'none (Table 4 has no other figure)'}")
    for seed in range(args.seeds):
        res = exp.accuracy_experiment(
            cfg, np.random.default_rng(seed), exp.PAPER_DISTANCES_M, exp.PAPER_ANGLES_DEG, exp.PAPER_SAMPLES_PER_POINT
        )
        cells = [f"{r.metric} {r.sim:.3f} ({100 * (r.sim / r.paper - 1):+.0f} %, {'fit' if r.basis == 'calibrated' else 'held out'}"
                 f"{'' if r.ok else ', outside ±20 %'})" for r in exp.ir_rows(res, args.fit)]
        print(f"seed {seed}: {', '.join(cells)}, valid {res['valid_fraction']:.3f}")


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.calibrate_ir", main))
