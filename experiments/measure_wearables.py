"""Measure the smart belt (seed 002 §3.4, Table 2) and the smart watch (Table 1) with the default config.

Usage: python -m petswarm.experiments.measure_wearables [--trials N] [--seed S]

Prints: the belt's steady-state activity recognition per activity, its transition latencies, the
rotation-flag latency distribution (input to the reaction-time experiment of seed 000 §4.4), the
accumulated angle of ±45°/±90° turns (compare seed 002 Table 4, which measures the robot's arc),
the per-call cost of ``SmartBelt.advance``, and the watch's gesture recognition rate.
"""

from __future__ import annotations

import math
import time

import numpy as np

from petswarm.cli.errors import OneLineParser, run_program
from petswarm_env.config import load_config
from petswarm_env.wearables.belt import ACTIVITIES, BeltConfig, SmartBelt
from petswarm_env.wearables.watch import GESTURES, gesture_trace, recognise_gesture

STEP_S = 0.1  # the env's control period
SPEEDS = {"stop": 0.0, "rest": 0.0, "walk": 1.0, "run": 2.5}
_SLACK_S = 1e-9  # times are compared with this slack (float accumulation of 0.1 s steps), as the belt does


def _run(belt, t, duration_s, speed, turn_rps, posture, step_s=STEP_S):
    """Advance in env steps of ``step_s`` (the last one shorter if needed) for ``duration_s``."""
    t_end = t + duration_s
    while t < t_end - _SLACK_S:
        t = min(t + step_s, t_end)
        belt.advance(t, speed, turn_rps, posture)
    return t


def recognition_latency_experiment(
    cfg: BeltConfig,
    rng: np.random.Generator,
    trials: int,
    *,
    turn_rate_dps: float = 60.0,
    speed_mps: float = 1.0,
    posture: str = "walk",
    step_s: float = 0.1,
    timeout_s: float = 3.0,
) -> np.ndarray:
    """Latency (s) from the start of a user rotation to the belt's rotation flag, per trial.

    Each trial: a fresh belt, the user walks straight for a random 3–4 s (windows filled, rotation
    start at a random phase of the 70 ms gyro grid and of the gait), then turns at
    ``turn_rate_dps`` (positive = CCW). The belt is advanced in ``step_s`` steps, as the env does.
    The latency is the gyro sample time at which the flag rises minus the rotation start; NaN if
    it does not rise within ``timeout_s``. An input to the reaction-time experiment (seed 000 §4.4).
    """
    out = np.full(trials, np.nan)
    rate = math.radians(turn_rate_dps)
    for i in range(trials):
        belt = SmartBelt(cfg, rng)
        t_start = float(rng.uniform(3.0, 4.0))
        t = _run(belt, 0.0, t_start, speed_mps, 0.0, posture, step_s)
        while t < t_start + timeout_s:
            t += step_s
            belt.advance(t, speed_mps, rate, posture)
            r = belt.reading()
            if r.rotating and r.rotation_since_s > t_start:
                out[i] = r.rotation_since_s - t_start
                break
    return out


def _q(x):
    x = np.asarray(x)
    return f"mean {x.mean():.3f}, median {np.median(x):.3f}, p90 {np.quantile(x, 0.9):.3f}, min {x.min():.3f}, max {x.max():.3f}"


def main() -> None:
    parser = OneLineParser(prog="python -m petswarm.experiments.measure_wearables", description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    cfg = load_config()
    belt_cfg, watch_cfg = cfg.belt, cfg.watch
    rng = np.random.default_rng(args.seed)

    print("Belt: steady-state recognition (60 s per activity after the window filled, one reading per 0.1 s)")
    for posture in ACTIVITIES:
        for speed in [0.5, 1.0, 1.4] if posture == "walk" else [2.0, 2.5] if posture == "run" else [0.0]:
            belt = SmartBelt(belt_cfg, rng)
            t = _run(belt, 0.0, belt_cfg.window_s, speed, 0.0, posture)
            seen = []
            for _ in range(600):
                t += STEP_S
                belt.advance(t, speed, 0.0, posture)
                seen.append(belt.reading().activity)
            share = {a: seen.count(a) / len(seen) for a in ACTIVITIES if seen.count(a)}
            print(f"  {posture:5s} {speed:.1f} m/s -> " + ", ".join(f"{a} {p:.1%}" for a, p in share.items()))

    print(f"Belt: transition latency (s), {args.trials} trials each, from the change to the recognised activity")
    for a, b in [("walk", "stop"), ("stop", "walk"), ("walk", "run"), ("run", "walk"), ("stop", "rest")]:
        lat, via = [], set()
        for _ in range(args.trials):
            belt = SmartBelt(belt_cfg, rng, t0_s=-float(rng.uniform(0.0, 0.1)))
            t0 = _run(belt, 0.0, 4.0, SPEEDS[a], 0.0, a)
            t, seq = t0, []
            while t < t0 + 8.0 and belt.reading().activity != b:
                t = _run(belt, t, STEP_S, SPEEDS[b], 0.0, b)
                seq.append(belt.reading().activity)
            lat.append(belt.reading().activity_since_s - t0 if belt.reading().activity == b else math.nan)
            via |= set(seq) - {a, b}
        lat = np.array(lat)
        ok = lat[np.isfinite(lat)]
        note = f"; passes through {sorted(via)} on the way" if via else ""
        print(f"  {a} -> {b}: {_q(ok)}; not recognised within 8 s: {np.count_nonzero(~np.isfinite(lat))}{note}")

    lat = recognition_latency_experiment(belt_cfg, rng, args.trials)
    print(
        f"Belt: rotation-flag latency (s), 60°/s turn while walking 1 m/s, {args.trials} trials: {_q(lat[np.isfinite(lat)])}"
        f", missed {np.count_nonzero(~np.isfinite(lat))}"
    )

    print(f"Belt: accumulated angle of a turn at 60°/s (°), {args.trials} trials, random sampling phase")
    for posture in ("stop", "walk"):
        for target in (-90.0, -45.0, 45.0, 90.0):
            angles = []
            for _ in range(args.trials):
                belt = SmartBelt(belt_cfg, rng, t0_s=-float(rng.uniform(0.0, belt_cfg.gyro_period_s)))
                t = _run(belt, 0.0, 3.0, SPEEDS[posture], 0.0, posture)
                t = _run(belt, t, abs(target) / 60.0, SPEEDS[posture], math.copysign(math.radians(60.0), target), posture)
                _run(belt, t, 2.0, SPEEDS[posture], 0.0, posture)
                angles.append(math.degrees(belt.reading().accumulated_angle_rad))
            print(f"  {posture:4s} turn {target:+6.1f}°: measured {np.mean(angles):+7.2f} ± {np.std(angles):.2f}°")

    belt = SmartBelt(belt_cfg, np.random.default_rng(1))
    t, n = 0.0, 5000
    start = time.perf_counter()
    for _ in range(n):
        t += STEP_S
        belt.advance(t, 1.0, 0.3, "walk")
        belt.reading()
    print(f"Belt: advance(0.1 s) + reading() {1e6 * (time.perf_counter() - start) / n:.0f} µs per call")

    errors = 0
    for g in GESTURES:
        errors += sum(recognise_gesture(watch_cfg, gesture_trace(watch_cfg, g, rng)) != g for _ in range(args.trials))
    print(
        f"Watch: gesture misrecognitions {errors} / {len(GESTURES) * args.trials}; "
        f"recognised {watch_cfg.recognition_delay_s} s after the gesture starts"
    )


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.measure_wearables", main))
