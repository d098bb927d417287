"""Where a distilled student loses to its teacher, on a comparison grid's cells
(``python -m petswarm.training.student_gap --grid configs/eval/heldout_recurrent.yaml --policy learned``).

Two measurements, per cell, on the first ``--episodes`` seeds of the grid:

1. **The imitation error by phase.** The student drives (as at evaluation); at every step the
   DAgger labeller (:class:`petswarm.training.warm_start.TeacherLabels`: the privileged teacher, or
   the scripted reference's rejoin and search for a robot with no fresh IR fix) and the scripted
   reference are asked for their actions in the same observation. Per phase — *holding* (the
   robot's true formation error at most ``building_error_m``), *building* (above it) and *lost* (no
   fresh fix of anyone; *holding_late*: holding from step 300 on, longer than any training
   episode) — the RMS of the student's error to the label, of the correction the label
   asks of the reference (label − reference: what a residual student has to learn), of the
   student's own correction (student − reference) and the share of
   that correction's square the student explains, ``1 − err² / correction²`` (1: the teacher's
   action; 0: no better than the reference; below 0: worse). Ground truth is read for the phase
   and the label only, as in training.
2. **The ceiling of the residual parametrization.** :class:`LabelDriver` executes the label itself
   through the residual's bound — ``clip(reference + s · clip((label − reference) / s, −1, 1), −1, 1)``
   for ``residual_scale`` s — i.e. a student with no imitation error at all; its hold ratio to the
   scripted reference on the same seeds bounds what a student of that config can reach.

Ratios are the mean of ``formation_hold_rmse_m`` over the seeds where both built, as the grid
scores a cell. A diagnosis for the next step (docs/training.md), not a benchmark: few episodes.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

import numpy as np

from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.evaluation.grid_spec import load_grid
from petswarm.evaluation.runner import run_episode
from petswarm.training.warm_start import TeacherLabels
from petswarm_env.config import load_config
from petswarm_env.env import PetSwarmEnv

PHASES = ("holding", "building", "lost", "holding_late")
TRAIN_CYCLES = 300  # the training episodes' length (configs/train/recurrent.yaml env.max_cycles): a GRU never ran longer


class LabelDriver:
    """The DAgger label (teacher, or reference when lost) executed through a residual bound ``scale``
    (None: unbounded, the label itself): a student with zero imitation error. Evaluation only — it
    reads ground truth through the labeller."""

    def __init__(self, env: PetSwarmEnv, scale: float | None):
        self.env, self.scale = env, scale
        self.spec = PolicySpec.from_env(env)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.label = TeacherLabels(self.env)
        self.reference = make_policy("scripted", self.spec)

    def act_all(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        target = self.label(observations)
        if self.scale is None:
            return target
        base = self.reference.act_all(observations)
        s = self.scale
        return {a: np.clip(base[a] + s * np.clip((target[a] - base[a]) / s, -1.0, 1.0), -1.0, 1.0).astype(np.float32)
                for a in observations}


def imitation_by_phase(env: PetSwarmEnv, policy_name: str, seed: int, building_error_m: float,
                       split_at: int = TRAIN_CYCLES) -> tuple[dict, dict]:
    """One episode driven by ``policy_name``: per phase the sums of squared errors (student − label,
    label − reference, student − reference) and counts, and the episode summary. Holding steps from
    step ``split_at`` on count as ``holding_late`` (longer than any training episode), not ``holding``."""
    spec = PolicySpec.from_env(env)
    student = make_policy(policy_name, spec, seed)
    rows, infos = env.reset(seed=seed)
    student.reset(seed)
    label, reference = TeacherLabels(env), make_policy("scripted", spec)
    acc = {p: np.zeros(4) for p in PHASES}  # err², label's correction², student's correction², count
    while env.agents:
        live = [a for a in env.active_agents]
        seen = {a: rows[a] for a in live}
        act = student.act_all(seen) if live else {}
        if live:
            target, base = label(seen), reference.act_all(seen)
            for a in live:
                phase = "lost" if label.lost(rows[a]) else "building" if infos[a]["formation_error_m"] > building_error_m else \
                    "holding" if env.num_cycles < split_at else "holding_late"
                acc[phase] += (float(np.sum((act[a] - target[a]) ** 2)), float(np.sum((target[a] - base[a]) ** 2)),
                               float(np.sum((act[a] - base[a]) ** 2)), 1.0)
        rows, _, _, _, infos = env.step(act)
    return acc, env.episode_summary()


def _hold_ratio(cand: list[float], ref: list[float]) -> float:
    pairs = [(c, r) for c, r in zip(cand, ref) if math.isfinite(c) and math.isfinite(r)]
    return sum(c for c, _ in pairs) / sum(r for _, r in pairs) if pairs else math.nan


def diagnose(grid_path: str, policy: str, episodes: int, scales: list[float | None], building_error_m: float = 0.3,
             progress=print) -> dict[str, Any]:
    grid = load_grid(grid_path, load_config(), policy)
    seeds = grid.seeds()[:episodes]
    cells = []
    for cell in grid.cells:
        if cell.mix:
            continue
        env = PetSwarmEnv(cell.config)
        acc = {p: np.zeros(4) for p in PHASES}
        student_hold = []
        for s in seeds:
            a, summary = imitation_by_phase(env, policy, s, building_error_m)
            for p in PHASES:
                acc[p] += a[p]
            student_hold.append(summary["formation_hold_rmse_m"])
        ref_hold = [run_episode(env, make_policy("scripted", PolicySpec.from_env(env)), s)["formation_hold_rmse_m"] for s in seeds]
        phases = _phases(acc)
        ceilings = {}
        for scale in scales:
            hold = [run_episode(env, LabelDriver(env, scale), s)["formation_hold_rmse_m"] for s in seeds]
            ceilings["label" if scale is None else f"label@{scale:g}"] = _hold_ratio(hold, ref_hold)
        env.close()
        row = {"name": cell.name, "student_hold_ratio": _hold_ratio(student_hold, ref_hold), "phases": phases, "ceilings": ceilings}
        cells.append(row)
        if progress:
            progress(format_row(row))
    return {"grid": grid_path, "policy": policy, "seeds": seeds, "cells": cells}


def diagnose_draws(train_config: str, policy: str, seeds: list[int], building_error_m: float = 0.3) -> dict[str, Any]:
    """The imitation error by phase (no ceilings) on fresh episodes of a training config's own draws
    (its ``env`` and ``randomize`` pools, one config drawn per seed, as training draws them): whether
    the student generalizes inside its training distribution. A seed whose start-up fails is skipped."""
    from petswarm.training.config import load_train_config
    from petswarm.training.randomize import draw_config

    cfg = load_train_config(train_config)
    acc = {p: np.zeros(4) for p in PHASES}
    used = []
    for s in seeds:
        env = PetSwarmEnv(draw_config(cfg.env, cfg.randomize, s))
        try:
            a, _ = imitation_by_phase(env, policy, s, building_error_m)
        except RuntimeError:  # the draw's swarm never organized
            continue
        finally:
            env.close()
        used.append(s)
        for p in PHASES:
            acc[p] += a[p]
    return {"name": f"draws of {train_config}", "seeds": used, "phases": _phases(acc)}


def _phases(acc: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    out = {}
    for p in PHASES:
        err, corr, own, n = acc[p]
        out[p] = {"steps": int(n), "rms_error": math.sqrt(err / n) if n else math.nan,
                  "rms_correction": math.sqrt(corr / n) if n else math.nan,
                  "rms_student_correction": math.sqrt(own / n) if n else math.nan,
                  "explained": 1.0 - err / corr if corr > 0 else math.nan}
    return out


def format_row(row: dict[str, Any]) -> str:
    ph = "  ".join(f"{p} {v['steps']}: err {v['rms_error']:.2f} corr {v['rms_correction']:.2f} "
                   f"own {v['rms_student_correction']:.2f} expl {v['explained']:+.2f}"
                   for p, v in row["phases"].items() if v["steps"])
    if "ceilings" not in row:
        return f"{row['name']}  |  {ph}"
    ce = "  ".join(f"{k} {v:.2f}" for k, v in row["ceilings"].items())
    return f"{row['name']:<22} student {row['student_hold_ratio']:.2f}  ceilings: {ce}  |  {ph}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m petswarm.training.student_gap", description=__doc__.split("\n\n")[0])
    ap.add_argument("--grid", default="configs/eval/heldout_recurrent.yaml")
    ap.add_argument("--policy", default="learned", help="learned or the path of a policy file")
    ap.add_argument("--episodes", type=int, default=2, help="the grid's first seeds per cell")
    ap.add_argument("--scales", default="0.5,1.0,none", help="residual bounds of the zero-error ceilings (none: the label "
                                                             "itself; empty: no ceilings)")
    ap.add_argument("--draws", default=None, metavar="TRAIN_CONFIG",
                    help="instead of the grid: fresh episodes of this training config's draws (seeds from --seed, --episodes of them)")
    ap.add_argument("--seed", type=int, default=777000, help="with --draws: the first seed")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    scales = [None if s.strip() == "none" else float(s) for s in a.scales.split(",") if s.strip()]
    if a.draws:
        out = diagnose_draws(a.draws, a.policy, list(range(a.seed, a.seed + a.episodes)))
        print(format_row(out))
    else:
        out = diagnose(a.grid, a.policy, a.episodes, scales)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
