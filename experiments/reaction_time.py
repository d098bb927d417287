"""``reaction_time``: the swarm's reaction to a user-activity change (seed 000 §4.4, Fig. 20–21).

A leading swarm stands with its user, who starts turning on the spot; the times from the rotation
start to the start of the master's and the slaves' motion, through the whole user-in-the-loop
chain (belt, BLE, master controller, status broadcast, slaves) reached through ``env.step``.
"""

from __future__ import annotations

import math

import numpy as np

import petswarm_env
from petswarm.experiments.results import Experiment, ExperimentResult, Progress, Row
from petswarm.experiments.user_loop import SETTLE_S, scripted_policy, step, turn_on_the_spot
from petswarm_env.config import Config

MOTION_SPEED_MPS = 0.08  # a robot "starts moving" when its speed changes by more than this ...
MOTION_OMEGA_RPS = 0.15  # ... or its angular speed by more than this (truth, experimenter's view),
MOTION_NOISE_SIGMAS = 4.0  # ... and by more than 4 σ of its own standing jitter, two steps in a row
MOTION_BASELINE_STEPS = 15  # the standing velocity: mean and σ over the last 1.5 s before the turn

REACTION_SETUP = {"swarm.mode": "leading", "swarm.num_slaves": 2, "swarm.formation": "row", "user.scenario": "straight",
                  "swarm.spawn": "at_slots"}  # the paper's trials start from a built formation (seed 000 §4.4)
PAPER_REACTION_P90 = {"master": 1.1, "slave": 1.2, "slave_minus_master": 0.24}  # seed 000 §4.4, Fig. 20–21
# chosen: 90th-percentile reaction times within ±0.2 s; the slave − master interval within
# what Fig. 21 resolves, about ±0.1 s (±0.2 s on 0.24 s could not fail: any interval under 0.44 s passed)
REACTION_TOLERANCE_S = {"master": 0.2, "slave": 0.2, "slave_minus_master": 0.1}
REACTION_CALIBRATION = "nothing (belt.*, ble.report_period_s, the broadcast period and the control step are chosen, none tuned to these rows)"
PAPER_REACTION_TRIALS = 50


def reaction_trial(cfg: Config, seed: int) -> dict[str, float]:
    """One trial of seed 000 §4.4 through the env: a leading swarm stands with its user; the user
    starts turning on the spot (a user-activity change the belt recognises); the times from the
    rotation start to the start of the master's and of each slave's motion (first control step
    whose speed or angular speed differs from the standing one by more than the thresholds)."""
    env = petswarm_env.parallel_env(cfg, **REACTION_SETUP)
    obs, _ = env.reset(seed=seed)
    turn_on_the_spot(env, 90.0)
    pol = scripted_policy(env)
    robots = {"master": env.truth.swarms[0].master.node_id, **{f"slave{i}": n for i, n in enumerate(env.truth.swarms[0].slave_ids())}}
    t_turn = None
    standing: dict[str, list[tuple[float, float, float]]] = {k: [] for k in robots}
    started: dict[str, float] = {}
    pending: dict[str, float] = {}
    while env.agents and (t_turn is None or env.truth.now - t_turn < 4.0) and len(started) < len(robots):
        obs = step(env, pol, obs)
        user = env.truth.user
        if t_turn is None:
            if user.turn_rate_rps != 0.0:  # the turn began during the step just run
                t_turn = env.truth.now - (user.script_time_s - SETTLE_S)
                base = {k: np.mean(v[-MOTION_BASELINE_STEPS:], axis=0) for k, v in standing.items()}
                noise = {k: np.std(v[-MOTION_BASELINE_STEPS:], axis=0) for k, v in standing.items()}
            else:
                for k, i in robots.items():
                    standing[k].append(env.truth.robots[i].velocity_body)
                continue
        for k, i in robots.items():
            if k in started:
                continue
            d = np.abs(np.asarray(env.truth.robots[i].velocity_body) - base[k])
            lin = max(MOTION_SPEED_MPS, MOTION_NOISE_SIGMAS * float(np.hypot(noise[k][0], noise[k][1])))
            ang = max(MOTION_OMEGA_RPS, MOTION_NOISE_SIGMAS * float(noise[k][2]))
            if math.hypot(d[0], d[1]) > lin or d[2] > ang:  # moving: sustained over two steps
                if k in pending:
                    started[k] = pending[k]
                else:
                    pending[k] = env.truth.now - t_turn
            else:
                pending.pop(k, None)
    env.close()
    slaves = [v for k, v in started.items() if k.startswith("slave")]
    master = started.get("master", math.nan)
    slave = float(np.median(slaves)) if slaves else math.nan
    return {"seed": seed, "master_s": master, "slave_s": slave, "slave_minus_master_s": slave - master}


def reaction_time(cfg: Config, seed: int, quick: bool, progress: Progress) -> ExperimentResult:
    """Seed 000 §4.4: 50 trials, user rotation start → master / slave motion start (the slave's
    reaction is the median over the slaves of a trial). Rows: 90th percentiles against Fig. 20–21."""
    n = 15 if quick else PAPER_REACTION_TRIALS
    trials = []
    for k in range(n):
        trials.append(reaction_trial(cfg, seed + k))
        progress(k + 1, n)
    arr = {key: np.array([t[key + "_s"] for t in trials], float) for key in PAPER_REACTION_P90}
    labels = {"master": "master reaction, 90th percentile (s)", "slave": "slave reaction, 90th percentile (s)",
              "slave_minus_master": "slave − master, 90th percentile (s)"}
    rows = []
    for key, paper in PAPER_REACTION_P90.items():
        v = arr[key][np.isfinite(arr[key])]
        p90 = float(np.percentile(v, 90)) if v.size else math.nan
        rows.append(Row.within(labels[key], paper, p90, REACTION_TOLERANCE_S[key], basis="validated"))
    missed = int(sum(not np.isfinite(t["master_s"]) or not np.isfinite(t["slave_s"]) for t in trials))
    data = {"trials": trials, "cdf": {key: np.sort(arr[key][np.isfinite(arr[key])]).tolist() for key in arr}}
    notes = [f"{missed} of {n} trials without a measured motion start"] if missed else []
    if any(not r.ok and r.sim < r.paper for r in rows[:2]):
        notes.append(
            f"faster than the paper's prototype (belt rotation flag, BLE report every {cfg.ble.report_period_s:g} s, "
            f"{cfg.control_period_s:g} s control step); no mechanism in seeds 000/002 explains 1.1 s: neither the belt answering "
            "each 350 ms LF burst (seed 002 §3.3) nor a following swarm's walking turn brings the three rows in (docs/reproduce.md)")
    return ExperimentResult(rows, data, note="; ".join(notes), calibration=REACTION_CALIBRATION)


EXPERIMENT = Experiment("reaction_time", "Reaction time to a user-activity change (seed 000 §4.4, Fig. 20–21)", reaction_time)
