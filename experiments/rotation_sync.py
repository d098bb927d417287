"""``rotation_sync``: rotation recognition and synchronization in leading mode (seed 002 §4.3,
Table 4): a robot leads 100 cm ahead of its standing user, who turns on the spot; the robot's arc
angle around the user, through ``env.step``: the mean arc (±3° of the paper's), the accuracy and
the σ of each target.
"""

from __future__ import annotations

import math

import numpy as np

import petswarm_env
from petswarm.experiments.results import Experiment, ExperimentResult, Progress, Row
from petswarm.experiments.user_loop import SETTLE_S, TURN_RATE_DPS, scripted_policy, step, turn_on_the_spot
from petswarm_env.config import Config

# seed 002 Table 4: target (°) -> the robot's mean arc (°), its σ (°) and the accuracy (%)
PAPER_ROTATION = {-90.0: (-87.4, 3.2, 96.04), -45.0: (-43.8, 3.6, 94.31), 45.0: (45.16, 3.0, 94.67), 90.0: (87.56, 3.5, 95.78)}
ROTATION_MEAN_TOLERANCE_DEG = 3.0  # chosen: the mean arc within ±3° of the paper's
ROTATION_MIN_ACCURACY_PCT = 94.0  # seed 002 §4.3: accuracy over 94 %
ROTATION_MAX_SIGMA_DEG = 4.0  # standard deviation within 4°
# The paper's test has one robot; the env needs a slave: it stands in a row 2 m beside the master, out of
# the way of the master's arc (at the default 1 m a row slave lags into the master's path on 90° turns and
# stops it with the obstacle exception).
ROTATION_SETUP = {"swarm.mode": "leading", "swarm.num_slaves": 1, "swarm.formation": "row", "swarm.spacing_m": 2.0,
                  "user.scenario": "straight", "swarm.spawn": "at_slots"}  # from a built formation (seed 002 §4.3)
ROTATION_TRIALS = 20  # per target angle (the paper does not say how many)
ROTATION_SETTLE_S = 4.0  # the arc angle is read this long after the user's turn ends


def rotation_trial(cfg: Config, seed: int, target_deg: float) -> float:
    """One trial of seed 002 §4.3 through the env: a leading robot 100 cm ahead of its standing user
    (row formation: the master's leading distance is the standard 1 m); the user turns
    ``target_deg`` on the spot; the robot's arc angle is how far its bearing around the user
    turned once everything has settled (degrees, CCW +)."""
    env = petswarm_env.parallel_env(cfg, **ROTATION_SETUP)
    obs, _ = env.reset(seed=seed)
    turn_on_the_spot(env, target_deg)
    pol = scripted_policy(env)
    m = env.truth.swarms[0].master.node_id

    def bearing() -> float:
        ux, uy = env.truth.user.position
        x, y = env.truth.robots[m].position
        return math.atan2(y - uy, x - ux)

    steps_before = int(round(SETTLE_S / cfg.control_period_s)) - 2
    for _ in range(steps_before):
        obs = step(env, pol, obs)
    b0 = bearing()
    for _ in range(int(round((abs(target_deg) / TURN_RATE_DPS + ROTATION_SETTLE_S) / cfg.control_period_s))):
        obs = step(env, pol, obs)
    env.close()
    return math.degrees(math.remainder(bearing() - b0, 2 * math.pi))


ROTATION_CALIBRATION = "nothing (belt.* and the master's arc, master.arc_sync_gain, arc_sync_done_deg, arc_brake_mps2, are chosen)"


def rotation_rows(target: float, arcs: np.ndarray) -> list[Row]:
    """Seed 002 Table 4 for one target: the mean arc within ±3° of the paper's, accuracy > 94 %
    and σ ≤ 4° (the last two one-sided, the paper's own criteria: the tolerance column is the
    margin the paper had). All validated: nothing was fitted to them."""
    p_mean, p_sigma, p_acc = PAPER_ROTATION[target]
    acc = 100.0 * (1.0 - float(np.mean(np.abs(arcs - target))) / abs(target))
    sigma = float(np.std(arcs, ddof=1)) if len(arcs) > 1 else math.nan
    return [
        Row.within(f"{target:+.0f}°: mean arc (°)", p_mean, float(np.mean(arcs)), ROTATION_MEAN_TOLERANCE_DEG, basis="validated"),
        Row(f"{target:+.0f}°: accuracy (%) > {ROTATION_MIN_ACCURACY_PCT:.0f}", p_acc, acc, p_acc - ROTATION_MIN_ACCURACY_PCT,
            bool(acc > ROTATION_MIN_ACCURACY_PCT), "validated"),
        Row(f"{target:+.0f}°: σ (°) ≤ {ROTATION_MAX_SIGMA_DEG:.0f}", p_sigma, sigma, ROTATION_MAX_SIGMA_DEG - p_sigma,
            bool(math.isfinite(sigma) and sigma <= ROTATION_MAX_SIGMA_DEG), "validated"),
    ]


def rotation_sync(cfg: Config, seed: int, quick: bool, progress: Progress) -> ExperimentResult:
    """Seed 002 §4.3, Table 4: leading at 100 cm, the user turns −90/−45/45/90°; the robot's arc
    angle. Accuracy = 100·(1 − mean|arc − target| / |target|) (reproduces the paper's 96.04 % from
    its mean −87.4° and σ 3.2°). Rows (:func:`rotation_rows`): the mean arc ±3°, accuracy > 94 %
    and σ ≤ 4° per target."""
    n = 5 if quick else ROTATION_TRIALS
    total = n * len(PAPER_ROTATION)
    rows, data = [], {"targets": {}}
    done = 0
    for target, (p_mean, _, _) in PAPER_ROTATION.items():
        arcs = []
        for k in range(n):
            arcs.append(rotation_trial(cfg, seed + k, target))
            done += 1
            progress(done, total)
        a = np.array(arcs)
        target_rows = rotation_rows(target, a)
        rows += target_rows
        data["targets"][str(target)] = {"paper_mean_deg": p_mean, "sim_mean_deg": target_rows[0].sim, "arcs_deg": a.round(2).tolist(),
                                        "sim_sigma_deg": target_rows[2].sim, "sim_accuracy_pct": target_rows[1].sim}
    missed = [r.metric for r in rows if not r.ok]
    note = ("outside tolerance: " + ", ".join(missed)) if missed else ""
    return ExperimentResult(rows, data, note=note, calibration=ROTATION_CALIBRATION)


EXPERIMENT = Experiment("rotation_sync", "Rotation recognition and synchronization in leading mode (seed 002 §4.3, Table 4)", rotation_sync)
