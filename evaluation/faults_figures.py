"""The runtime-change scenarios' figures for the scripted reference, against their targets:

* ``dropout``: the fault's detection time, the time until every slot is filled again
  (``reassignment_time_s``), and how far the slaves are from their reference points after
  recovery — the largest formation error of any slave from ``SETTLE_S`` after the refill to the
  end, and over the episode's last 10 s;
* ``master_loss``: how far each slave moves after its status timeout (the instant its last status
  broadcast plus ``protocol.status_timeout_s``; from the robot's position at the last step before it)
  until 3 s after the episode ended (it ends when its last slave left slave-role driving: no agent
  is left; the world runs on without actions for the measurement): the largest;
* ``arrival``: whether the arrival joined and when.

    python -m petswarm.evaluation.faults_figures [--seeds 0-4] [--scenarios dropout,master_loss,arrival] [--set KEY=VALUE ...] [--json out.json]

Prints one line per scenario and seed, then the medians.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics

import petswarm_env

SETTLE_S = 10.0  # chosen: the refilled formation is judged from this long after the refill on


def _run(scenario: str, seed: int, overrides: dict | None = None) -> dict:
    from petswarm.baselines.policy import PolicySpec
    from petswarm.baselines.registry import make_policy

    env = petswarm_env.parallel_env(**{"user.scenario": scenario, **(overrides or {})})
    obs, _ = env.reset(seed=seed)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    t0 = env.truth.now
    track: list[tuple[float, list[tuple[float, float]]]] = []  # (time, every robot's position)
    errors: list[tuple[float, float]] = []  # (time, the largest slave formation error)
    while env.agents:
        obs, _, _, _, infos = env.step(policy.act_all({a: obs[a] for a in env.active_agents}))
        track.append((env.truth.now, [r.position for r in env.truth.robots]))
        if infos:
            errors.append((env.truth.now, max(i["formation_error_m"] if i["active"] else 0.0 for i in infos.values())))
    if scenario == "master_loss":  # the episode ended with its last slave: watch the robots stop, 3 s more of the world
        for _ in range(int(round(3.0 / env.cfg.control_period_s))):
            env.episode.tick()  # the world goes on: the masters driven by their users, no agent
            track.append((env.truth.now, [r.position for r in env.truth.robots]))
    summary = env.episode_summary()
    out = {k: summary[k] for k in ("faults_injected", "faults_detected", "detection_time_s", "reassignments",
                                   "reassignment_time_s", "slots_unfilled_s", "arrivals_joined", "formation_rmse_m")}
    out["collisions"] = summary["collisions"]
    log = env.truth.member_log
    joined = [t for t, event, _ in log if event == "joined"]
    if joined:
        since = joined[-1] + SETTLE_S
        out["max_error_after_refill_m"] = max((e for t, e in errors if t >= since), default=math.nan)
        out["refilled_at_s"] = joined[-1] - t0
    end = env.truth.now
    out["max_error_last_10s_m"] = max((e for t, e in errors if t >= end - 10.0), default=math.nan)
    if scenario == "master_loss":
        timeout = env.cfg.protocol.status_timeout_s
        moved = []
        fault_s = env.truth.faults[0].time_s
        for idx, node in env.truth.nodes.items():
            for _, master, t_local in node.seq.master_lost_at:
                t_timeout = node.clock.true_time(t_local)  # logged on the robot's own clock
                if t_timeout < fault_s:
                    continue  # an earlier timeout (under loss): not the master's loss
                # from the last step at or before the timeout instant (the slave notices at the next control step)
                before = [p for t, p in track if t <= t_timeout]
                start = before[-1][idx] if before else track[0][1][idx]
                moved.append(max(math.dist(start, p[idx]) for t, p in track if t >= t_timeout))
        out["slaves_stopped"] = len(moved)
        out["max_move_after_timeout_m"] = max(moved, default=math.nan)
        out["status_timeout_s"] = timeout
    return out


def _median(rows: list[dict], key: str) -> float:
    vals = [r[key] for r in rows if key in r and isinstance(r[key], (int, float)) and not math.isnan(r[key])]
    return statistics.median(vals) if vals else math.nan


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0-4", help="a range a-b or a comma list")
    parser.add_argument("--scenarios", default="dropout,master_loss,arrival")
    parser.add_argument("--json", default=None, help="write the rows here")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a config override (repeatable)")
    args = parser.parse_args(argv)
    from petswarm_env.config import parse_override

    overrides = dict(parse_override(item) for item in args.set)
    if "-" in args.seeds:
        a, b = args.seeds.split("-")
        seeds = list(range(int(a), int(b) + 1))
    else:
        seeds = [int(s) for s in args.seeds.split(",")]
    rows = {}
    for scenario in args.scenarios.split(","):
        rows[scenario] = []
        for seed in seeds:
            row = _run(scenario, seed, overrides)
            rows[scenario].append(row)
            print(scenario, seed, json.dumps({k: (round(v, 3) if isinstance(v, float) else v) for k, v in row.items()}))
        keys = sorted({k for r in rows[scenario] for k in r if isinstance(r[k], (int, float))})
        print(scenario, "median", json.dumps({k: round(_median(rows[scenario], k), 3) for k in keys}))
    if args.json:
        from petswarm_env.files import write_json_atomic

        write_json_atomic(args.json, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
