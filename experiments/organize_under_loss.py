"""Organizing under loss: how often every required slave joins, the join
retries, the organize time and the token recoveries against ``radio.loss_prob``.

Usage:
    python -m petswarm.experiments.organize_under_loss [--resets N] [--steps S] [--loss P1,P2,...] [--seed S]
                                              [--set KEY=VALUE ...] [--json OUT]

For each loss probability, ``--resets`` resets of the default scenario (seeds ``seed, seed+1, …``)
through ``PetSwarmEnv.reset`` — the pairing, the start-up commands and the join protocol of seed
000 §3.4 on the 802.15.4 medium — then ``--steps`` steps of the scripted reference (the IR token
ring runs under the same loss; its token recoveries are counted, and the formation RMSE over those
steps). A reset that raises (a swarm did not organize) counts as not full and as 0 slaves. With
several users (``--set world.num_users=2``) a reset is full when every swarm is; retries add up over
the swarms, the organize time is the slowest swarm's.

Targets (chosen; seed 000 §4.5 retries until organized): every slave joins in all resets at loss ≤ 0.2, in ≥ 99 % at 0.3.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.cli.errors import OneLineParser, run_program
from petswarm_env.config import load_config, parse_override
from petswarm_env.files import write_json_atomic

DEFAULT_LOSSES = (0.0, 0.1, 0.2, 0.3, 0.5)


def trial(env, policy, seed: int, steps: int) -> dict[str, Any]:
    """One reset (and ``steps`` scripted steps) at ``seed``: what the organization gave."""
    required = env.cfg.swarm.num_slaves * env.cfg.world.num_users
    try:
        obs, infos = env.reset(seed=seed)
    except RuntimeError as e:
        retries = sum(sw.organize_result.retries for sw in env.truth.swarms) if env.truth.swarms else 0
        return {"seed": seed, "slaves": 0, "required": required, "full": False, "retries": retries,
                "organize_s": math.nan, "token_recoveries": 0, "rmse_m": math.nan, "building_s": math.nan,
                "error": str(e)}
    results = [sw.organize_result for sw in env.truth.swarms]
    slaves = sum(len(sw.slave_ids()) for sw in env.truth.swarms)
    policy.reset(seed)
    for _ in range(steps):
        if not env.agents:
            break
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.active_agents}))
    s = env.episode_summary()
    return {"seed": seed, "slaves": slaves, "required": required, "full": slaves == required,
            "retries": sum(r.retries for r in results), "organize_s": max(r.elapsed_s for r in results),
            "token_recoveries": s["token_recoveries"], "rmse_m": s["formation_rmse_m"],
            "building_s": s["building_time_s"]}


def summarize(trials: list[dict[str, Any]]) -> dict[str, Any]:
    times = np.array([t["organize_s"] for t in trials if math.isfinite(t["organize_s"])])
    rmse = [t["rmse_m"] for t in trials if math.isfinite(t["rmse_m"])]
    building = np.array([t["building_s"] for t in trials if math.isfinite(t["building_s"])])
    return {
        "resets": len(trials),
        "full": sum(t["full"] for t in trials),
        "full_pct": 100.0 * sum(t["full"] for t in trials) / len(trials),
        "failed_resets": sum("error" in t for t in trials),
        "slaves_missing": sum(t["required"] - t["slaves"] for t in trials),
        "retries_mean": float(np.mean([t["retries"] for t in trials])),
        "retries_max": int(max(t["retries"] for t in trials)),
        "organize_mean_s": float(times.mean()) if times.size else math.nan,
        "organize_max_s": float(times.max()) if times.size else math.nan,
        "token_recoveries": sum(t["token_recoveries"] for t in trials),
        "rmse_m": float(np.mean(rmse)) if rmse else math.nan,
        # building: from organized to every slave within 0.3 m of its reference (metrics.BUILT_WITHIN_M);
        # NaN (not built within the trial's steps) counts as not built
        "built": int(building.size),
        "building_median_s": float(np.median(building)) if building.size else math.nan,
        "building_max_s": float(building.max()) if building.size else math.nan,
        "short_seeds": [t["seed"] for t in trials if not t["full"]][:20],
    }


def sweep(losses, resets: int, steps: int, seed: int, overrides: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for p in losses:
        cfg = load_config(overrides={**overrides, "radio.loss_prob": p, "max_cycles": max(steps, 1)})
        env = petswarm_env.parallel_env(cfg)
        policy = make_policy("scripted", PolicySpec.from_env(env), seed)
        t0 = time.perf_counter()
        trials = [trial(env, policy, seed + i, steps) for i in range(resets)]
        env.close()
        out[str(p)] = {**summarize(trials), "wall_s": round(time.perf_counter() - t0, 1)}
        s = out[str(p)]
        print(f"loss {p:4.2f}: full {s['full']}/{s['resets']} ({s['full_pct']:.1f} %), slaves missing {s['slaves_missing']}, "
              f"failed resets {s['failed_resets']}, retries mean {s['retries_mean']:.2f} max {s['retries_max']}, "
              f"organize mean {s['organize_mean_s']:.2f} s max {s['organize_max_s']:.2f} s, "
              f"token recoveries {s['token_recoveries']}, rmse {s['rmse_m']:.3f} m over {steps} steps, "
              f"built {s['built']}/{s['resets']} (median {s['building_median_s']:.1f} s, max {s['building_max_s']:.1f} s)"
              + (f", short seeds {s['short_seeds']}" if s["short_seeds"] else ""), flush=True)
    return out


def main() -> None:
    parser = OneLineParser(prog="python -m petswarm.experiments.organize_under_loss", description=__doc__.splitlines()[0])
    parser.add_argument("--resets", type=int, default=1000, help="resets per loss probability (default 1000)")
    parser.add_argument("--steps", type=int, default=50, help="scripted steps after each reset (default 50 = 5 s)")
    parser.add_argument("--loss", default=",".join(str(p) for p in DEFAULT_LOSSES), help="loss probabilities, comma-separated")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first reset")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="config override (repeatable)")
    parser.add_argument("--json", help="write the figures as JSON here")
    args = parser.parse_args()
    overrides = dict(parse_override(s) for s in args.set)
    losses = [float(p) for p in args.loss.split(",")]
    out = sweep(losses, args.resets, args.steps, args.seed, overrides)
    if args.json:
        write_json_atomic(args.json, {"resets": args.resets, "steps": args.steps, "seed": args.seed,
                                      "overrides": overrides, "by_loss": out})


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.organize_under_loss", main))
