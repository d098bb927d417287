"""Print the IR accuracy (seed 000 §4.3, Table 4) for the IR parameters in a YAML file.

Usage: python scripts/calibrate_ir.py [CONFIG_YAML] [--seeds N]
(default CONFIG_YAML: configs/default.yaml; any YAML with a top-level ``ir:`` section works).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

from petswarm_env.middleware.ir import (
    PAPER_ANGLES_DEG,
    PAPER_DIRECTION_RMSE_DEG,
    PAPER_DISTANCE_RMSE_CM,
    PAPER_DISTANCES_M,
    PAPER_SAMPLES_PER_POINT,
    IRConfig,
    accuracy_experiment,
)

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default=ROOT / "configs" / "default.yaml", type=Path)
    parser.add_argument("--seeds", type=int, default=5, help="number of rng seeds (0..N-1) to run")
    args = parser.parse_args()
    cfg = IRConfig(**yaml.safe_load(args.config.read_text())["ir"])
    print(f"paper (Table 4): distance {PAPER_DISTANCE_RMSE_CM:.3f} cm, direction {PAPER_DIRECTION_RMSE_DEG:.2f} deg")
    for seed in range(args.seeds):
        res = accuracy_experiment(
            cfg, np.random.default_rng(seed), PAPER_DISTANCES_M, PAPER_ANGLES_DEG, PAPER_SAMPLES_PER_POINT
        )
        print(
            f"seed {seed}: distance {res['distance_rmse_cm']:.3f} cm, "
            f"direction {res['direction_rmse_deg']:.2f} deg, valid {res['valid_fraction']:.3f}"
        )


if __name__ == "__main__":
    main()
