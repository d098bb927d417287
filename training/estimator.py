"""The estimating student (``recurrent.target: estimate``, ``configs/train/estimator.yaml``;
docs/training.md "An estimating student").

The recurrent student of training/recurrent.py learns the privileged teacher's *action*; its
corrections did not carry to new episodes (docs/training.md, "Where the student loses to its
teacher"). The teacher's advantage is what it reads — the true reference point, its velocity, the
master's heading — so this student learns to **estimate** that from its own observation history
(supervised labels from ground truth at training time only: :meth:`PrivilegedTeacher.reads`), and
acts with the teacher's law on the estimate (:mod:`petswarm.baselines.estimator`, the file that
ships). The trainer is the recurrent one — the same DAgger rounds, ``collect_sequences``, ``fit``,
export and periodic evaluation — with this module's labels as the GRU's targets.

It also measures the estimate's own error (:func:`estimate_error`; ``python -m
petswarm.training.estimator``): on episodes no training used, the RMS of the GRU's offset estimate
against the truth, beside the scripted reference's estimate of the same offset from its one frame
(:func:`scripted_offset`: leader_follower.py's step 1 reference location, or step 1b's goal while
building) and beside no estimate at all (zero offset). That says directly whether the memory
estimates better than one frame does.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from typing import Any

import numpy as np

from petswarm.baselines.estimator import LAW_KEYS, OUTPUTS, EstimatorPolicy, fix_indices, lost_mask
from petswarm.baselines.leader_follower import LeaderFollowerPolicy
from petswarm.baselines.policy import PolicySpec
from petswarm.training.teacher import TeacherGains

HOLDING_M = 0.3  # a step counts as holding while the true offset to the reference point is at most this


def estimator_meta(clip_m: float, spec: PolicySpec, gains: TeacherGains | None = None) -> dict[str, Any]:
    """The file's ``estimator`` record: the outputs, their scale (the clip for the offset, the
    speed limits for the velocities) and the law's constants (the teacher's)."""
    g = gains or TeacherGains()
    v, w = spec.max_speed_mps, spec.max_omega_rps
    return {"outputs": list(OUTPUTS), "scale": [clip_m, clip_m, v, v, 1.0, 1.0, w],
            "law": {k: float(getattr(g, k)) for k in LAW_KEYS}}


def clip_length(xy: np.ndarray, clip_m: float) -> np.ndarray:
    """Vectors (…, 2) with their length clipped to ``clip_m``."""
    n = np.hypot(xy[..., 0], xy[..., 1])
    return xy * np.minimum(1.0, clip_m / np.maximum(n, 1e-12))[..., None]


def estimate_target(read: tuple[float, ...], scale: np.ndarray) -> np.ndarray:
    """The GRU's target for one teacher read ``(ex, ey, vx, vy, dθ, ω_m)``: :data:`OUTPUTS`, the
    offset clipped to ``scale[0]``, each divided by its scale."""
    ex, ey, vx, vy, dth, w = read
    off = clip_length(np.array([ex, ey]), float(scale[0]))
    return (np.array([off[0], off[1], vx, vy, math.sin(dth), math.cos(dth), w]) / scale).astype(np.float32)


class EstimateLabels:
    """Targets and validity of each live robot's step, from the labeller's teacher (after the
    labeller was called for that step): a step counts (weight kept) when the robot has a reference
    point and a fresh IR fix — a lost robot drives by the reference's rejoin and search, whose
    estimate the law never reads."""

    def __init__(self, env, clip_m: float):
        spec = PolicySpec.from_env(env)
        self.scale = np.asarray(estimator_meta(clip_m, spec)["scale"], dtype=np.float64)
        self.fixes = fix_indices(env.layout)
        self.n = env.layout.size

    def __call__(self, teacher, rows: dict[str, np.ndarray]) -> dict[str, tuple[np.ndarray, bool]]:
        agents = list(rows)
        reads = teacher.reads(agents)
        lost = lost_mask(np.stack([rows[a][:self.n] for a in agents]), self.fixes)
        zero = np.zeros(len(OUTPUTS), np.float32)
        return {a: (zero, False) if reads[a] is None else (estimate_target(reads[a], self.scale), not lost[k])
                for k, a in enumerate(agents)}


def scripted_offset(reference: tuple[LeaderFollowerPolicy, LeaderFollowerPolicy], obs: np.ndarray, vmax: float) -> np.ndarray:
    """The scripted reference's own estimate of the offset to its reference location (body frame,
    m) from one observation: step 1's mean of the neighbours' reference locations (moved out of the
    user's way), or while building step 1b's goal. Read as the difference of the reference's
    unclipped command with position gain 1 (and no approach cap) and with gain 0 — everything else
    in its command (feed-forward, arc, heading, ultrasonic push, orbit) is the same in both.
    ``reference``: those two policies (:func:`scripted_pair`)."""
    one, none = reference
    x = np.asarray(obs, dtype=np.float32)
    a = one._act(x.tolist(), (x * one._scale32).tolist())
    b = none._act(x.tolist(), (x * none._scale32).tolist())
    return np.array([a[0] - b[0], a[1] - b[1]]) * vmax


def scripted_pair(spec: PolicySpec) -> tuple[LeaderFollowerPolicy, LeaderFollowerPolicy]:
    return (LeaderFollowerPolicy(spec, position_gain=1.0, approach_mps=1e12), LeaderFollowerPolicy(spec, position_gain=0.0))


def rms(squares: list[float], mask: np.ndarray | None = None) -> float | None:
    """The root of the mean of ``squares`` (where ``mask``); None if there are none."""
    v = np.asarray(squares, dtype=np.float64)
    v = v if mask is None else v[mask]
    return float(np.sqrt(v.mean())) if v.size else None


def median(squares: list[float], mask: np.ndarray | None = None) -> float | None:
    """The median length of the errors whose ``squares`` are given (where ``mask``); None if none."""
    v = np.asarray(squares, dtype=np.float64)
    v = v if mask is None else v[mask]
    return float(np.sqrt(np.median(v))) if v.size else None


def estimate_error(env, policy: EstimatorPolicy | None, seeds: list[int], clip_m: float, driver: str = "student",
                   noise_std: float = 0.0) -> dict[str, Any]:
    """The estimate's error on the episodes ``seeds`` of ``env`` (a fixed-agents training env): the
    student (``policy``, its memory running every step) or the teacher (``driver``) drives; on every
    step of a robot with a reference point and a fresh fix, the RMS (m) of the offset estimate's
    error — the GRU's, the scripted reference's one-frame one, and no estimate (zero) — all with the
    offset clipped to ``clip_m`` as the label is, overall and split by holding (true offset ≤
    :data:`HOLDING_M`) and building (and the median error length of each: the RMS weighs the rare
    large errors); and the GRU's RMS error of the reference point's velocity
    (m/s), of the heading error (rad) and of the master's turn rate (rad/s)."""
    from petswarm.training.warm_start import TeacherLabels

    rng = np.random.default_rng(seeds[0] if seeds else 0)
    sq: dict[str, list[float]] = {k: [] for k in ("gru", "scripted", "zero")}
    phase: list[bool] = []
    extra: dict[str, list[float]] = {"ref_velocity": [], "heading": [], "turn_rate": []}
    t0 = time.time()
    for seed in seeds:
        try:
            rows, infos = env.reset(seed=seed)
        except RuntimeError:
            continue
        spec = PolicySpec.from_env(env)
        label = TeacherLabels(env)
        labels = EstimateLabels(env, clip_m)
        pair = scripted_pair(spec)
        if policy is not None:
            policy.reset()
        while env.agents:
            live = [a for a in env.agents if infos[a]["active"]]
            if not live:
                rows, _, _, _, infos = env.step({})
                continue
            seen = {a: rows[a] for a in live}
            target = label(seen)
            executed = policy.act_all(seen) if policy is not None else {}
            if driver == "teacher" or policy is None:
                executed = target
            reads = label.teacher.reads(live)
            valid = labels(label.teacher, seen)
            for a in live:
                if reads[a] is None or not valid[a][1]:
                    continue
                true = clip_length(np.array(reads[a][:2]), clip_m)
                guesses = {"scripted": clip_length(scripted_offset(pair, rows[a], spec.max_speed_mps), clip_m),
                           "zero": np.zeros(2)}
                if policy is not None:
                    est = policy.last_estimate[a]
                    guesses["gru"] = clip_length(est[:2], clip_m)
                    extra["ref_velocity"].append(float(np.sum((est[2:4] - reads[a][2:4]) ** 2)))
                    dth = math.atan2(est[4], est[5]) - reads[a][4]
                    extra["heading"].append(math.remainder(dth, 2 * math.pi) ** 2)
                    extra["turn_rate"].append((est[6] - reads[a][5]) ** 2)
                for k, g in guesses.items():
                    sq[k].append(float(np.sum((g - true) ** 2)))
                phase.append(math.hypot(reads[a][0], reads[a][1]) <= HOLDING_M)
            noisy = {a: np.clip(v + rng.normal(0.0, noise_std, 3), -1.0, 1.0).astype(np.float32) if noise_std else v
                     for a, v in executed.items()}
            rows, _, _, _, infos = env.step(noisy)
    hold = np.array(phase, dtype=bool)

    out: dict[str, Any] = {"samples": len(phase), "holding_samples": int(hold.sum()), "driver": driver,
                           "clip_m": clip_m, "wall_time_s": round(time.time() - t0, 1), "offset_rms_m": {}, "offset_median_m": {}}
    for k, v in sq.items():
        if v:
            out["offset_rms_m"][k] = {"all": rms(v), "holding": rms(v, hold), "building": rms(v, ~hold)}
            out["offset_median_m"][k] = {"all": median(v), "holding": median(v, hold), "building": median(v, ~hold)}
    if extra["heading"]:
        out["gru_other_rms"] = {"ref_velocity_mps": rms(extra["ref_velocity"]), "heading_rad": rms(extra["heading"]),
                                "turn_rate_rps": rms(extra["turn_rate"])}
    return out


def law_ceiling(grid_path: str, episodes: int, progress=print) -> list[dict[str, Any]]:
    """A student with **no estimation error**: on each cell of a comparison grid (its first
    ``episodes`` seeds), the hold ratio to the scripted reference and the collisions of the
    teacher's law acting on the truth it reads with only the robot's own ultrasonic avoidance (what
    an estimating policy's law is: :class:`~petswarm.training.teacher.TeacherGains` with ``push``
    0), beside the full teacher (its avoidance of other bodies from their true positions) — lost
    robots drive by the scripted reference in both, as the DAgger labeller. Ratios: the mean
    ``formation_hold_rmse_m`` over the seeds both built, as :mod:`petswarm.training.student_gap`."""
    from petswarm.baselines.registry import make_policy
    from petswarm.evaluation.grid_spec import load_grid
    from petswarm.evaluation.runner import run_episode
    from petswarm.training.student_gap import LabelDriver, _hold_ratio
    from petswarm_env.config import load_config
    from petswarm_env.env import PetSwarmEnv

    class LawOnTruth(LabelDriver):
        def __init__(self, env, gains: TeacherGains):
            self.gains = gains
            super().__init__(env, None)

        def reset(self, seed: int | None = None) -> None:
            super().reset(seed)
            self.label.teacher.g = self.gains

    grid = load_grid(grid_path, load_config(), "scripted")
    seeds = grid.seeds()[:episodes]
    rows = []
    for cell in grid.cells:
        if cell.mix:
            continue
        env = PetSwarmEnv(cell.config)
        ref = [run_episode(env, make_policy("scripted", PolicySpec.from_env(env)), s) for s in seeds]
        row: dict[str, Any] = {"cell": cell.name, "scripted_collisions": sum(sum(r["collisions"].values()) for r in ref)}
        for name, gains in (("teacher", TeacherGains()), ("law_on_truth", TeacherGains(push=0.0))):
            res = [run_episode(env, LawOnTruth(env, gains), s) for s in seeds]
            row[name] = _hold_ratio([e["formation_hold_rmse_m"] for e in res], [e["formation_hold_rmse_m"] for e in ref])
            row[name + "_collisions"] = sum(sum(e["collisions"].values()) for e in res)
        env.close()
        rows.append(row)
        if progress:
            progress(json.dumps(row))
    return rows


def relaw(path: str, out: str, changes: dict[str, float]) -> None:
    """A copy of the estimating policy file ``path`` at ``out`` with the law's constants ``changes``
    (the weights as they are): a law chosen after training, by measurement."""
    from petswarm.baselines.learned import read_policy
    from petswarm_env.files import read_npz, write_atomic

    meta, _, _ = read_policy(path)  # checked as any policy file
    if "estimator" not in meta:
        raise SystemExit(f"'{path}' is not an estimating policy (no 'estimator' record)")
    unknown = sorted(set(changes) - set(LAW_KEYS))
    if unknown:
        raise SystemExit(f"--law {unknown[0]}: not a law constant; the law's are {', '.join(LAW_KEYS)}")
    arrays = read_npz(path, 256_000_000)
    meta["estimator"]["law"].update(changes)
    meta["info"] = {**meta.get("info", {}), "law_changed": changes}
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    write_atomic(out, lambda tmp: np.savez(tmp, **arrays), suffix=".npz")


def main(argv: list[str] | None = None) -> int:
    """``python -m petswarm.training.estimator --policy runs/estimator/policy.npz --draws estimator``:
    the estimate's error (:func:`estimate_error`) on fresh draws of a training config's pools;
    ``--ceiling GRID``: :func:`law_ceiling`; ``--policy P --law gain=2 --out Q``: :func:`relaw`."""
    from petswarm import shipped
    from petswarm.baselines.learned import LearnedPolicy
    from petswarm.training.config import load_train_config
    from petswarm.training.vec_env import training_env
    from petswarm_env.env import PetSwarmEnv

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--policy", help="an estimating policy file (policy.npz of a recurrent.target: estimate run)")
    p.add_argument("--ceiling", metavar="GRID", help="instead: the law on the truth (no estimation error) on GRID's cells")
    p.add_argument("--episodes", type=int, default=2, help="--ceiling: seeds per cell")
    p.add_argument("--law", nargs="+", metavar="KEY=VALUE", help="with --out: rewrite these law constants of --policy")
    p.add_argument("--out", help="--law: the new policy file")
    p.add_argument("--draws", default="estimator", help="the training config whose env and pools are drawn (path or shipped name)")
    p.add_argument("--seeds", default="777000-777011", help="episode seeds FIRST-LAST (never training's: it draws from 100 000)")
    p.add_argument("--driver", choices=("student", "teacher"), default="student")
    p.add_argument("--json", default=None)
    a = p.parse_args(argv)
    if a.ceiling:
        rows = law_ceiling(a.ceiling, a.episodes)
        if a.json:
            with open(a.json, "w") as f:
                f.write(json.dumps(rows, indent=1) + "\n")
        return 0
    if not a.policy:
        p.error("--policy is required (or --ceiling GRID)")
    if a.law:
        if not a.out:
            p.error("--law needs --out (the new policy file)")
        relaw(a.policy, a.out, {k: float(v) for k, v in (kv.split("=", 1) for kv in a.law)})
        print(f"wrote {a.out}")
        return 0
    cfg = load_train_config(shipped(a.draws) or a.draws)
    first, _, last = a.seeds.partition("-")
    seeds = list(range(int(first), int(last or first) + 1))
    env = training_env(cfg.env_config(), cfg.randomize, cfg.env, False)
    try:
        policy = LearnedPolicy.load(a.policy, PolicySpec.from_env(PetSwarmEnv(cfg.env_config())))  # before the env's first draw
        if not isinstance(policy, EstimatorPolicy):
            p.error(f"'{a.policy}' is not an estimating policy (its file has no 'estimator' record); train one with "
                    "recurrent.target: estimate")
        res = estimate_error(env, policy, seeds, cfg.recurrent.estimate_clip_m, a.driver)
    finally:
        env.close()
    text = json.dumps(res, indent=1)
    print(text)
    if a.json:
        with open(a.json, "w") as f:
            f.write(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
