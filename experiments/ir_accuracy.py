"""``ir_accuracy``: the IR module's relative-location accuracy (seed 000 §4.3, Fig. 18–19, Table 4).

The receiving robot is placed on the paper's grid around a transmitter and measures the IR signal
through the module's physics (:func:`petswarm_env.comms.ir.received_strengths`) and the
paper's estimator (:func:`petswarm_env.comms.ir.estimate`): the distance and direction RMSEs
of Table 4, and the estimated positions of Fig. 19.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from petswarm.experiments.results import RMSE_TOLERANCE_REL, Experiment, ExperimentResult, Progress, Row
from petswarm_env.config import Config
from petswarm_env.config import IRConfig
from petswarm_env.comms.ir import estimate, received_strengths
from petswarm_env.sim.geometry import wrap_angle

# Seed 000, §4.3 (Fig. 18, Table 4): the accuracy-evaluation grid and the reported RMSEs.
PAPER_DISTANCES_M = np.round(np.arange(0.40, 2.0 + 1e-9, 0.20), 2)
PAPER_ANGLES_DEG = np.arange(0.0, 180.0 + 1e-9, 30.0)
PAPER_SAMPLES_PER_POINT = 300
PAPER_DISTANCE_RMSE_CM = 7.898
PAPER_DIRECTION_RMSE_DEG = 5.8  # Table 4; the running text says 6.52°

# What was fitted: all nine ir.* values of default.yaml (receivers, strength, lobe, noise, saturation,
# threshold, occlusion, range) to Table 4's two figures on this grid (python -m petswarm.experiments.calibrate_ir).
# The paper gives no other IR figure to hold out: Fig. 18–19 (the setup and the per-point positions)
# are lost from the text, and its running text's 6.52° differs from Table 4's 5.8° (it is seed 002
# Table 3's LF direction RMSE). So both rows are calibrated: they check that the fit still holds.
IR_FIT = ("distance", "direction")
IR_CALIBRATION = "all nine ir.* values to both figures (python -m petswarm.experiments.calibrate_ir); nothing to hold out (Fig. 18-19 lost)"

IR_QUICK_SAMPLES_PER_POINT = 100  # --quick: 100 samples a point instead of the paper's 300
FIG19_SAMPLES_PER_POINT = 20  # estimated positions drawn in the Fig. 19 style plot


def accuracy_experiment(
    cfg: IRConfig,
    rng: np.random.Generator,
    distances_m: np.ndarray,
    angles_deg: np.ndarray,
    samples_per_point: int,
) -> dict:
    """Seed 000 §4.3 accuracy evaluation (Fig. 18, Table 4), run on the simulated module.

    The transmitting robot sits at the origin; the receiving robot is placed at each
    ``(distance, angle)`` of the grid, i.e. at ``distance·(cos angle, sin angle)``, and measures
    the IR signal ``samples_per_point`` times (clear line of sight). The paper grid is 40–200 cm
    in 20 cm steps, 0–180° in 30° steps, 300 samples a point (``PAPER_*`` constants).

    Orientation choice: the text does not say how the receiver is oriented (Fig. 18 is lost).
    Fig. 19 plots estimated against actual receiver locations in one 2-D plane, which is natural
    when every robot keeps the same heading. So the receiving robot always faces +x (parallel to
    the transmitter) and the source bearing in its body frame is ``angle + 180°``; over the grid
    the source is seen on-axis of a receiver and between receivers, which exercises the
    estimator's interpolation.

    Errors: distance error is estimated minus true distance; direction error is the wrapped
    difference between estimated and true bearing. RMSEs are over all valid samples.

    Returns:
        dict with ``distance_rmse_cm``, ``direction_rmse_deg``, ``valid_fraction`` and ``points``:
        one dict per grid point with ``distance_cm``, ``angle_deg``, ``distance_rmse_cm``,
        ``direction_rmse_deg``, ``valid_fraction``.
    """
    # seed 000, §4.3, Table 4
    dist_grid, ang_grid = np.meshgrid(
        np.asarray(distances_m, dtype=float), np.asarray(angles_deg, dtype=float), indexing="ij"
    )
    point_d = dist_grid.reshape(-1)
    point_bearing = wrap_angle(np.deg2rad(ang_grid.reshape(-1)) + np.pi)
    n_points = point_d.size
    true_d = np.repeat(point_d, samples_per_point)
    true_bearing = np.repeat(point_bearing, samples_per_point)
    strengths = received_strengths(cfg, true_d.tolist(), true_bearing.tolist(), [False] * true_d.size, rng)
    est_d, est_bearing, valid = (np.array(v) for v in estimate(cfg, strengths))

    err_d_cm = ((est_d - true_d) * 100.0).reshape(n_points, samples_per_point)
    err_b_deg = np.rad2deg(wrap_angle(est_bearing - true_bearing)).reshape(n_points, samples_per_point)
    ok = valid.reshape(n_points, samples_per_point)

    def rmse(err: np.ndarray, mask: np.ndarray) -> float:
        return float(np.sqrt(np.mean(err[mask] ** 2))) if mask.any() else float("nan")

    points = [
        {
            "distance_cm": float(point_d[p] * 100.0),
            "angle_deg": float(ang_grid.reshape(-1)[p]),
            "distance_rmse_cm": rmse(err_d_cm[p], ok[p]),
            "direction_rmse_deg": rmse(err_b_deg[p], ok[p]),
            "valid_fraction": float(ok[p].mean()),
        }
        for p in range(n_points)
    ]
    return {
        "distance_rmse_cm": rmse(err_d_cm, ok),
        "direction_rmse_deg": rmse(err_b_deg, ok),
        "valid_fraction": float(ok.mean()),
        "points": points,
    }


def fig19_positions(cfg_ir, rng: np.random.Generator, samples_per_point: int) -> dict[str, Any]:
    """Estimated against actual positions of the receiving robot (seed 000 Fig. 19), on the
    accuracy grid of :func:`accuracy_experiment` with its geometry: transmitter at the origin,
    receiver at ``d·(cos a, sin a)`` facing +x, so it sees the source at bearing ``a + 180°``.
    The receiver's estimate of the source (d̂, θ̂) puts the receiver at ``−d̂·(cos θ̂, sin θ̂)``."""
    d, a = np.meshgrid(PAPER_DISTANCES_M, np.deg2rad(PAPER_ANGLES_DEG), indexing="ij")
    d, a = d.reshape(-1), a.reshape(-1)
    true_d = np.repeat(d, samples_per_point)
    bearing = wrap_angle(np.repeat(a, samples_per_point) + np.pi)
    strengths = received_strengths(cfg_ir, true_d.tolist(), bearing.tolist(), [False] * true_d.size, rng)
    est_d, est_b, valid = (np.array(v) for v in estimate(cfg_ir, strengths))
    est = np.stack([-est_d * np.cos(est_b), -est_d * np.sin(est_b)], axis=1)[valid]
    actual = np.stack([d * np.cos(a), d * np.sin(a)], axis=1)
    return {
        "actual_m": np.round(actual, 3).tolist(),
        "estimated_m": np.round(est, 3).tolist(),
        "samples_per_point": samples_per_point,
    }


def ir_rows(res: dict, fit: tuple[str, ...] = IR_FIT) -> list[Row]:
    """Table 4's two rows within ±20 %: ``calibrated`` for a figure of ``fit``, else ``validated``."""
    return [Row.within(f"{key} RMSE ({unit})", paper, res[f"{key}_rmse_{unit_key}"], RMSE_TOLERANCE_REL * paper,
                       basis="calibrated" if key in fit else "validated")
            for key, unit, unit_key, paper in (("distance", "cm", "cm", PAPER_DISTANCE_RMSE_CM),
                                               ("direction", "°", "deg", PAPER_DIRECTION_RMSE_DEG))]


def ir_accuracy(cfg: Config, seed: int, quick: bool, progress: Progress, *, samples_per_point: int | None = None) -> ExperimentResult:
    """Seed 000 §4.3: receiver at 40–200 cm (20 cm steps), 0–180° (30° steps), 300 samples a
    point; the IR module's physics and the paper's estimator (:mod:`petswarm_env.comms.ir`)."""
    n = samples_per_point or (IR_QUICK_SAMPLES_PER_POINT if quick else PAPER_SAMPLES_PER_POINT)
    rng_rmse, rng_fig = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2))
    progress(0, 2)
    res = accuracy_experiment(cfg.ir, rng_rmse, PAPER_DISTANCES_M, PAPER_ANGLES_DEG, n)
    progress(1, 2)
    fig = fig19_positions(cfg.ir, rng_fig, FIG19_SAMPLES_PER_POINT)
    progress(2, 2)
    rows = ir_rows(res)
    data = {
        "samples_per_point": n,
        "valid_fraction": res["valid_fraction"],
        "points": res["points"],
        "fig19": fig,
    }
    return ExperimentResult(rows, data, calibration=IR_CALIBRATION)


EXPERIMENT = Experiment("ir_accuracy", "IR relative-location accuracy (seed 000 §4.3, Fig. 19, Table 4)", ir_accuracy)
