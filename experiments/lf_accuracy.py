"""``lf_accuracy``: the LF user-location accuracy (seed 002 §4.2, Fig. 16, Table 3).

The belt is placed on a grid in front of the robot's LF antennas and located through the LF
physics and the paper's estimator (:func:`petswarm_env.wearables.lf.locate`, Eqs. 1–3): the X, Y,
distance and direction RMSEs of Table 3, and the measured positions of Fig. 16.
"""

from __future__ import annotations

import numpy as np

from petswarm.experiments.results import RMSE_TOLERANCE_REL, Experiment, ExperimentResult, Progress, Row
from petswarm_env.config import Config
from petswarm_env.config import LFConfig
from petswarm_env.sim.geometry import wrap_angle
from petswarm_env.wearables.lf import LFFix, locate

# Seed 002 §4.2 (Fig. 16, Table 3): the location-identification test. The text gives the range
# (25–200 cm) and 50 RSSI samples a point; Fig. 16 (the positions, hence the test directions) is lost
# in the extraction, and Table 3 gives four aggregate figures only, no per-point ones.
PAPER_DISTANCES_M = np.round(np.arange(0.25, 2.0 + 1e-9, 0.25), 2)  # chosen: 25 cm steps
PAPER_SAMPLES_PER_POINT = 50
# Seed 002 Table 3. The paper's X is lateral (to the right), its Y is forward.
PAPER_RMSE = {
    "rmse_x_cm": 15.57,
    "rmse_y_cm": 8.96,
    "rmse_distance_cm": 5.10,
    "rmse_direction_deg": 6.52,
}
# What was fitted to which figure of Table 3 (python -m petswarm.experiments.calibrate_lf --search):
# * the LF noise (lf.noise_common_db, lf.noise_antenna_db, lf.rssi_step_db) to the distance and
#   direction RMSEs, the two figures the text states ("5.10-cm RMSE and 6.52° RMSE");
# * the test directions, unknown (Fig. 16 lost), to the Y RMSE, the one figure they move: uniform
#   grids over the reliable ±25° region (seed 002 §3.5) with 3, 5 or 11 directions give distance and
#   direction within 2 % of each other but Y +5 %, −11 %, −21 % of Table 3 (the forward error grows
#   off-axis), so the 3-direction grid −25°, 0°, 25° is a fit to Y, not a neutral choice;
# * the X RMSE is held out: predicted by the fitted noise and directions.
DIRECTION_GRIDS_DEG = {n: np.linspace(-25.0, 25.0, n) for n in (3, 5, 11)}  # the candidates of the fit
EVAL_ANGLES_DEG = DIRECTION_GRIDS_DEG[3]
LF_FIT = ("rmse_distance_cm", "rmse_direction_deg", "rmse_y_cm")
LF_CALIBRATION = ("lf.noise_common_db, noise_antenna_db, rssi_step_db to distance and direction; the test directions (Fig. 16 "
                  "lost: -25°, 0°, 25°, of uniform grids of 3, 5, 11) to Y; X held out (python -m petswarm.experiments.calibrate_lf --search)")


def lf_accuracy_experiment(
    cfg: LFConfig,
    rng: np.random.Generator,
    samples_per_point: int = PAPER_SAMPLES_PER_POINT,
    *,
    distances_m: np.ndarray = PAPER_DISTANCES_M,
    angles_deg: np.ndarray = EVAL_ANGLES_DEG,
) -> dict:
    """Seed 002 §4.2 location-identification test (Fig. 16, Table 3), on the simulated LF chain.

    The belt is placed at each (distance, direction) of the grid, measured from the antenna
    midpoint and counter-clockwise from the robot's forward axis, and located
    ``samples_per_point`` times. Paper: 25–200 cm, 50 samples a point; steps and directions not
    given (Fig. 16 lost) — 25 cm steps and, by default, the directions fitted to Table 3's Y
    (:data:`EVAL_ANGLES_DEG`, −25°, 0°, 25°).

    Errors over all valid samples: X = lateral (the paper's x, our −y_left), Y = forward (the
    paper's y, our x_fwd), distance (Eq. 3 d minus true), direction (θ minus true, wrapped).

    Returns:
        ``rmse_x_cm``, ``rmse_y_cm``, ``rmse_distance_cm``, ``rmse_direction_deg``: each
        ``{"paper": float, "sim": float}``; ``valid_fraction``; ``actual_m`` and ``estimated_m``
        (M, 2) body-frame positions relative to the robot's centre (nan rows where no fix), ``valid``
        (M,); ``distances_m``, ``angles_deg``, ``samples_per_point``; ``points``: per grid point
        distance, angle, distance/direction RMSE and valid fraction.
    """
    # seed 002, §4.2, Table 3
    dist_grid, ang_grid = np.meshgrid(
        np.asarray(distances_m, dtype=float), np.asarray(angles_deg, dtype=float), indexing="ij"
    )
    point_d = dist_grid.reshape(-1)
    point_a = np.deg2rad(ang_grid.reshape(-1))
    true_d = np.repeat(point_d, samples_per_point)
    true_a = np.repeat(point_a, samples_per_point)
    actual = np.stack([cfg.antenna_forward_m + true_d * np.cos(true_a), true_d * np.sin(true_a)], axis=1)
    fixes = [locate(cfg, x, y, rng) for x, y in actual.tolist()]
    fix = LFFix(*(np.array(field) for field in zip(*fixes)))
    ok = fix.valid

    err_x_cm = -(fix.y_left - actual[:, 1]) * 100.0  # the paper's x points right
    err_y_cm = (fix.x_fwd - actual[:, 0]) * 100.0
    err_d_cm = (fix.distance - true_d) * 100.0
    err_t_deg = np.rad2deg(wrap_angle(fix.direction - true_a))

    def rmse(err: np.ndarray, mask: np.ndarray) -> float:
        return float(np.sqrt(np.mean(err[mask] ** 2))) if mask.any() else float("nan")

    sims = {
        "rmse_x_cm": rmse(err_x_cm, ok),
        "rmse_y_cm": rmse(err_y_cm, ok),
        "rmse_distance_cm": rmse(err_d_cm, ok),
        "rmse_direction_deg": rmse(err_t_deg, ok),
    }
    shape = (point_d.size, samples_per_point)
    points = [
        {
            "distance_cm": float(point_d[p] * 100.0),
            "angle_deg": float(np.rad2deg(point_a[p])),
            "rmse_distance_cm": rmse(err_d_cm.reshape(shape)[p], ok.reshape(shape)[p]),
            "rmse_direction_deg": rmse(err_t_deg.reshape(shape)[p], ok.reshape(shape)[p]),
            "valid_fraction": float(ok.reshape(shape)[p].mean()),
        }
        for p in range(point_d.size)
    ]
    out: dict = {key: {"paper": PAPER_RMSE[key], "sim": sims[key]} for key in PAPER_RMSE}
    out.update(
        valid_fraction=float(ok.mean()),
        actual_m=actual,
        estimated_m=np.stack([fix.x_fwd, fix.y_left], axis=1),
        valid=ok,
        distances_m=[float(v) for v in np.asarray(distances_m)],
        angles_deg=[float(v) for v in np.asarray(angles_deg)],
        samples_per_point=int(samples_per_point),
        points=points,
    )
    return out


_ROW_LABELS = {"rmse_x_cm": "X RMSE (cm)", "rmse_y_cm": "Y RMSE (cm)", "rmse_distance_cm": "distance RMSE (cm)",
               "rmse_direction_deg": "direction RMSE (°)"}


def lf_rows(sims: dict[str, float], fit: tuple[str, ...] = LF_FIT) -> list[Row]:
    """A row per RMSE of Table 3 within ±20 %: ``calibrated`` for a figure of ``fit``, else ``validated``."""
    return [Row.within(_ROW_LABELS[k], p, float(sims[k]), RMSE_TOLERANCE_REL * p, basis="calibrated" if k in fit else "validated")
            for k, p in PAPER_RMSE.items()]


def lf_accuracy(cfg: Config, seed: int, quick: bool, progress: Progress) -> ExperimentResult:
    """Seed 002 §4.2: the belt 25–200 cm from the LF antennas at the fitted directions, 50 samples a
    point (:func:`lf_accuracy_experiment` on ``cfg.lf``); a row per RMSE of Table 3 within ±20 %
    (:data:`LF_FIT` calibrated, X validated)."""
    n = PAPER_SAMPLES_PER_POINT
    progress(0, 1)
    res = lf_accuracy_experiment(cfg.lf, np.random.default_rng(seed), n)
    progress(1, 1)
    rows = lf_rows({k: res[k]["sim"] for k in PAPER_RMSE})
    missed = [r.metric for r in rows if r.basis == "validated" and not r.ok]
    note = ("held out and outside tolerance (not re-fitted): " + ", ".join(missed)) if missed else ""
    valid, est, act = res["valid"], res["estimated_m"], res["actual_m"]
    data = {
        "samples_per_point": n,
        "angles_deg": res["angles_deg"],
        "fit": list(LF_FIT),
        "valid_fraction": res["valid_fraction"],
        "points": res["points"],
        # Fig. 16 style scatter, body frame (x forward, y left), m; one point in five kept
        "actual_m": np.round(np.unique(act, axis=0), 3).tolist() if act.size else [],
        "estimated_m": np.round(est[valid][::5], 3).tolist() if est.size else [],
    }
    return ExperimentResult(rows, data, note=note, calibration=LF_CALIBRATION)


EXPERIMENT = Experiment("lf_accuracy", "LF user-location accuracy (seed 002 §4.2, Fig. 16, Table 3)", lf_accuracy)
