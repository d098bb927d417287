"""Sensor faults detected by the robots themselves, and the swarm after it (docs/faults.md).

Per fault kind (``ir``, ``ultrasonic``, ``ahrs``) and seed: the user walks straight on, the
scripted reference drives the slaves, the fault starts at ``--at`` s of episode time on one slave
(``random_slave``) or on the master (``--target master``). Measured per run:

* **detected**: the faulty robot's own diagnosis (``node.diagnosis.detected``, middleware/diagnosis.py)
  found that part broken, and how long after the fault;
* **re-formed**: the largest formation error of the slaves still in slave-role driving
  (``formation_error_m`` of the env's infos) 10 s after the detection is at most 0.3 m;
* **RMSE**: the formation RMSE of those slaves over the 10 s after the detection;
* with ``--target master``: whether the master handed its user over (``master_after``, ``handovers``),
  and whether the episode ran to ``max_cycles`` with the swarm's master driving its user (the
  session ``following`` or ``leading``, the master within :data:`USER_FOLLOWED_M` of the user at the end).

A run that never detects counts as not re-formed; its RMSE is taken over the 10 s after the fault.

    python -m petswarm.experiments.sensor_faults [--kinds ir,ultrasonic,ahrs] [--seeds 0-19] [--target slave|master] [--set KEY=VALUE ...]

Prints one line per run, then per kind: detected n/N, median detection time, re-formed n/N, median RMSE,
and in how many runs a robot found a part broken that was not the one injected (a false detection).
"""

from __future__ import annotations

import json
import math
import statistics

import petswarm_env
from petswarm.cli.errors import OneLineParser, run_program
from petswarm.experiments.measure_succession import parse_seeds
from petswarm_env.config import parse_override
from petswarm_env.files import check_output_path, write_json_atomic

REFORM_AFTER_S = 10.0
REFORM_ERROR_M = 0.3
USER_FOLLOWED_M = 2.0  # a master that follows its user stands about master.distance_m (1 m) behind them


def run(kind: str, seed: int, at_s: float = 20.0, target: str = "random_slave", overrides: dict | None = None,
        on_step=None) -> dict:
    """One run; ``on_step(env)`` (tests) is called after every step."""
    from petswarm.baselines.policy import PolicySpec
    from petswarm.baselines.registry import make_policy

    env = petswarm_env.parallel_env(**{"user.scenario": "straight",
                                       "faults": [{"at_s": at_s, "robot": target, "kind": kind}],
                                       "max_cycles": int(round((at_s + 25.0) / 0.1)), **(overrides or {})})
    obs, _ = env.reset(seed=seed)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    errors: list[tuple[float, dict[str, float]]] = []  # (time, agent -> formation error)
    while env.agents:
        obs, _, _, _, infos = env.step(policy.act_all({a: obs[a] for a in env.active_agents}))
        live = set(env.active_agents)
        errors.append((env.episode.world.now, {a: i["formation_error_m"] for a, i in infos.items() if a in live}))
        if on_step is not None:
            on_step(env)
    log = env.episode.runtime.faults.log
    if not log:
        return {"kind": kind, "seed": seed, "injected": False}
    fault = log[0]
    node = env.episode.fleet.nodes[fault.robot]
    found = [t for t in (node.clock.true_time(t) for t, part in node.diagnosis.detected if part == kind)  # its own clock
             if t >= fault.time_s]
    detected_s = found[0] if found else None
    t0 = detected_s if detected_s is not None else fault.time_s
    window = [e for t, e in errors if t0 < t <= t0 + REFORM_AFTER_S]
    sq = [v * v for e in window for v in e.values()]
    at = [e for t, e in errors if t >= t0 + REFORM_AFTER_S]
    largest = max(at[0].values(), default=math.nan) if at else math.nan
    ep = env.episode
    swarm, session = ep.swarms[0], ep.sessions[0]
    user_xy, master_xy = ep.world.users[0].body.position, ep.world.robots[swarm.master.node_id].body.position
    return {"kind": kind, "seed": seed, "injected": True, "robot": fault.robot, "role": fault.role,
            "master_after": swarm.master.node_id, "handovers": [list(h) for h in swarm.fault_handovers],
            "cycles": ep.num_cycles, "session_state": session.state,
            "user_distance_end_m": math.hypot(user_xy[0] - master_xy[0], user_xy[1] - master_xy[1]),
            "detection_s": None if detected_s is None else detected_s - fault.time_s,
            "bid_request": bool(node.recovery.bid_requests),
            "other_detections": [(i, part) for i, n in env.episode.fleet.nodes.items() for _, part in n.diagnosis.detected
                                 if (i, part) != (fault.robot, kind)],
            "left_swarm": node.state != "slave" and fault.role != "master",
            "largest_error_m": largest, "reformed": detected_s is not None and largest <= REFORM_ERROR_M,
            "rmse_m": math.sqrt(sum(sq) / len(sq)) if sq else math.nan}


PROG = "python -m petswarm.experiments.sensor_faults"


def main(argv: list[str] | None = None) -> None:
    ap = OneLineParser(prog=PROG, description=__doc__.splitlines()[0])
    ap.add_argument("--kinds", default="ir,ultrasonic,ahrs")
    ap.add_argument("--seeds", default="0-19")
    ap.add_argument("--at", type=float, default=20.0)
    ap.add_argument("--target", default="slave", choices=("slave", "master"))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--json", metavar="OUT", help="write every run's row here")
    args = ap.parse_args(argv)
    check_output_path(args.json, "--json")
    overrides = dict(parse_override(item) for item in args.set)
    seeds = parse_seeds(args.seeds)
    target = "random_slave" if args.target == "slave" else "master"
    results = []
    for kind in args.kinds.split(","):
        rows = [run(kind, s, args.at, target, overrides) for s in seeds]
        for r in rows:
            print(json.dumps(r))
        rows = [r for r in rows if r["injected"]]
        det = [r["detection_s"] for r in rows if r["detection_s"] is not None]
        rmse = [r["rmse_m"] for r in rows if not math.isnan(r["rmse_m"])]
        if args.target == "master":
            handed = [r for r in rows if r["master_after"] != r["robot"]]
            full = sum(r["cycles"] == max(x["cycles"] for x in rows) and r["session_state"] in ("following", "leading")
                       and r["user_distance_end_m"] <= USER_FOLLOWED_M for r in handed)
            print(f"{kind} on the master: handed over in {len(handed)}/{len(rows)}; the new master drives its user "
                  f"(within {USER_FOLLOWED_M:g} m at the end, to max_cycles) in {full}/{len(rows)}")
        print(f"{kind} on the {args.target}: detected {len(det)}/{len(rows)}, median {statistics.median(det) if det else math.nan:.2f} s "
              f"(max {max(det, default=math.nan):.2f}); re-formed {sum(r['reformed'] for r in rows)}/{len(rows)}; "
              f"RMSE 10 s after detection median {statistics.median(rmse) if rmse else math.nan:.2f} m "
              f"(max {max(rmse, default=math.nan):.2f}); other parts or robots found broken in "
              f"{sum(bool(r['other_detections']) for r in rows)}/{len(rows)} runs")
        results += rows
    if args.json:
        write_json_atomic(args.json, results)


if __name__ == "__main__":
    raise SystemExit(run_program(PROG, main))
