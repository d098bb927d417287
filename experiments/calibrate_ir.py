"""Print the IR accuracy (seed 000 §4.3, Table 4) for the IR parameters in a YAML file.

Usage: python -m experiments.calibrate_ir [CONFIG_YAML] [--seeds N]
(default CONFIG_YAML: the packaged default, petswarm_env/default.yaml = configs/default.yaml; any YAML
with a top-level ``ir:`` section works).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

from experiments import ir_accuracy as exp
from petswarm_env.config import default_config_path
from petswarm_env.comms.ir import IRConfig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default=default_config_path(), type=Path)
    parser.add_argument("--seeds", type=int, default=5, help="number of rng seeds (0..N-1) to run")
    args = parser.parse_args()
    cfg = IRConfig(**yaml.safe_load(args.config.read_text())["ir"])
    print(f"paper (Table 4): distance {exp.PAPER_DISTANCE_RMSE_CM:.3f} cm, direction {exp.PAPER_DIRECTION_RMSE_DEG:.2f} deg")
    for seed in range(args.seeds):
        res = exp.accuracy_experiment(
            cfg, np.random.default_rng(seed), exp.PAPER_DISTANCES_M, exp.PAPER_ANGLES_DEG, exp.PAPER_SAMPLES_PER_POINT
        )
        print(
            f"seed {seed}: distance {res['distance_rmse_cm']:.3f} cm, "
            f"direction {res['direction_rmse_deg']:.2f} deg, valid {res['valid_fraction']:.3f}"
        )


if __name__ == "__main__":
    main()
