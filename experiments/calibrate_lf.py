"""Print the LF localisation accuracy (seed 002 §4.2, Table 3) for the LF parameters in a YAML file;
with --search, search the noise parameters that reproduce Table 3.

Usage: python -m experiments.calibrate_lf [CONFIG_YAML] [--seeds N] [--search] [--angles DEG ...]
(default CONFIG_YAML: the packaged default, petswarm_env/default.yaml = configs/default.yaml; any YAML
with a top-level ``lf:`` section works; default directions: ``EVAL_ANGLES_DEG`` of
experiments/lf_accuracy.py, −25°, 0°, 25°).

The search varies the three RSSI noise parameters inside the reliable region — the per-burst
common error ``noise_common_db``, the per-reading error ``noise_antenna_db`` and the register step
``rssi_step_db`` — and keeps every other ``lf`` value of the YAML. Score: the worst relative
deviation from Table 3 of the four RMSEs, each averaged over the seeds.
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import numpy as np
import yaml

from experiments.lf_accuracy import EVAL_ANGLES_DEG, PAPER_RMSE, PAPER_SAMPLES_PER_POINT, lf_accuracy_experiment
from petswarm_env.config import default_config_path
from petswarm_env.wearables.lf import LFConfig

COMMON_DB = np.round(np.arange(0.6, 1.41, 0.05), 2)
ANTENNA_DB = np.round(np.arange(0.0, 0.41, 0.025), 3)
STEP_DB = (0.0, 0.5, 1.0, 2.0)


def run(cfg: LFConfig, seed: int, angles_deg: np.ndarray) -> dict:
    return lf_accuracy_experiment(cfg, np.random.default_rng(seed), PAPER_SAMPLES_PER_POINT, angles_deg=angles_deg)


def mean_rmses(cfg: LFConfig, seeds: int, angles_deg: np.ndarray) -> tuple[dict[str, float], float]:
    runs = [run(cfg, s, angles_deg) for s in range(seeds)]
    sims = {key: float(np.mean([r[key]["sim"] for r in runs])) for key in PAPER_RMSE}
    return sims, float(np.mean([r["valid_fraction"] for r in runs]))


def worst_deviation(sims: dict[str, float]) -> float:
    return max(abs(sims[k] / PAPER_RMSE[k] - 1.0) for k in PAPER_RMSE)


def fmt(sims: dict[str, float]) -> str:
    return ", ".join(f"{k.removeprefix('rmse_')} {v:.2f} ({100 * (v / PAPER_RMSE[k] - 1):+.0f} %)" for k, v in sims.items())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default=default_config_path(), type=Path)
    parser.add_argument("--seeds", type=int, default=5, help="number of rng seeds (0..N-1) to run")
    parser.add_argument("--search", action="store_true", help="grid-search the noise parameters")
    parser.add_argument("--angles", type=float, nargs="+", default=list(EVAL_ANGLES_DEG), help="test directions, deg")
    args = parser.parse_args()
    angles = np.asarray(args.angles, dtype=float)
    cfg = LFConfig(**yaml.safe_load(args.config.read_text())["lf"])
    print("paper (Table 3): " + ", ".join(f"{k.removeprefix('rmse_')} {v}" for k, v in PAPER_RMSE.items()))
    print(f"directions {angles.tolist()} deg, 25-200 cm in 25 cm steps, {PAPER_SAMPLES_PER_POINT} samples a point")

    if args.search:
        scored = []
        for step, common, own in itertools.product(STEP_DB, COMMON_DB, ANTENNA_DB):
            trial = cfg.model_copy(
                update={"rssi_step_db": float(step), "noise_common_db": float(common), "noise_antenna_db": float(own)}
            )
            sims, _ = mean_rmses(trial, args.seeds, angles)
            scored.append((worst_deviation(sims), step, common, own, sims))
        scored.sort(key=lambda t: t[0])
        print(f"best of {len(scored)} (worst deviation, rssi_step_db, noise_common_db, noise_antenna_db):")
        for dev, step, common, own, sims in scored[:10]:
            print(f"  {100 * dev:5.1f} %  step {step}  common {common}  antenna {own}  | {fmt(sims)}")
        return

    for seed in range(args.seeds):
        res = run(cfg, seed, angles)
        sims = {k: res[k]["sim"] for k in PAPER_RMSE}
        print(f"seed {seed}: {fmt(sims)}, valid {res['valid_fraction']:.3f}")
    sims, valid = mean_rmses(cfg, args.seeds, angles)
    print(f"mean of {args.seeds} seeds: {fmt(sims)}, valid {valid:.3f}; worst {100 * worst_deviation(sims):.1f} %")


if __name__ == "__main__":
    main()
