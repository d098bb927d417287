"""How long the scripted reference takes to build its formation (seed 000 §3.5, Fig. 10: the robots
start scattered and drive to their slots), over many seeds, and who is still off when it is slow.

    python -m petswarm.experiments.measure_building --seeds 0-199 [--set user.scenario=straight] [--late 15]

One episode per seed (cut once built, or at ``--until`` s after organizing). Per seed it records
``building_time_s`` (petswarm_env/metrics.py: every slave within 0.3 m of its reference point) and,
for a seed not built within ``--late`` s (a straggler case), at that moment: each slave still off
(its member number, its error, its distance from the master, the scripted reference's step it was
in: ``1`` a reference neighbour's fresh fix, ``1b`` the master's alone, ``1c`` only the master's
last fix, ``1d`` nothing in IR sight), and the members removed as astray so far. The branch is
read from the slave's observation, the error from the experimenter's truth.

Prints a line per late seed, then: built within ``--late`` s n/N, the building time's median,
90th percentile and maximum, and the late seeds' count by the step their worst slave was in.
"""

from __future__ import annotations

import json
import math
import statistics
from collections import Counter
from typing import Any

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.cli.errors import OneLineParser, run_program
from petswarm.experiments.measure_succession import parse_seeds
from petswarm_env.config_yaml import parse_override
from petswarm_env.metrics import BUILT_WITHIN_M
from petswarm_env.observe import MAX_LINKS
from petswarm_env.files import write_json_atomic


def branch(spec: PolicySpec, o) -> str:
    """The scripted reference's step 1 branch (baselines/leader_follower.py) for observation ``o``."""
    st = {name: sl.start for name, sl in spec.layout.slices.items()}
    for k in range(MAX_LINKS):
        if o[st[f"link{k}.present"]] > 0.5 and o[st[f"link{k}.ir_valid"]] > 0.5 and o[st[f"link{k}.ir_age"]] < 1.0:
            return "1"
    if o[st["master.ir_valid"]] > 0.5 and o[st["master.ir_age"]] < 1.0:
        return "1b"
    if o[st["master.valid"]] > 0.5 and o[st["master.ir_valid"]] > 0.5:
        return "1c"
    return "1d"


def episode(seed: int, overrides: dict[str, Any], late_s: float, until_s: float) -> dict[str, Any]:
    env = petswarm_env.parallel_env(**overrides)
    obs, _ = env.reset(seed=seed)
    ep = env.episode
    spec = PolicySpec.from_env(env)
    policy = make_policy("scripted", spec, seed=seed)
    policy.reset(seed)
    organized_s = ep.world.now
    snapshot: dict[str, Any] | None = None
    while env.agents and ep.world.now - organized_s < until_s:
        obs, _, terms, truncs, _ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        if math.isfinite(ep.metrics.building_time_s):
            break
        if snapshot is None and ep.world.now - organized_s >= late_s:
            errors, _ = ep.experimenter.formation_errors(list(env.agents))
            swarm = ep.swarms[0]
            mxy = ep.world.robots[swarm.master.node_id].body.position
            off = []
            for a, e in sorted(errors.items(), key=lambda kv: -kv[1]):
                if e <= BUILT_WITHIN_M:
                    continue
                rid = ep.experimenter.agent_index[a]
                node = ep.fleet.nodes[rid] if rid is not None else None
                xy = ep.world.robots[rid].body.position if rid is not None else (math.nan, math.nan)
                off.append({"agent": a, "member": node.know.member if node is not None else None, "error_m": round(e, 2),
                            "from_master_m": round(math.hypot(xy[0] - mxy[0], xy[1] - mxy[1]), 2),
                            "step": branch(spec, obs[a]) if a in obs else "-"})
            snapshot = {"off": off, "astray": sum(len(n.recovery.astray) for n in ep.fleet.nodes.values())}
        if all(terms.values()) or all(truncs.values()):
            break
    return {"seed": seed, "organized_s": round(organized_s, 2), "building_time_s": ep.metrics.building_time_s,
            "late": snapshot}


def main(argv: list[str] | None = None) -> int:
    ap = OneLineParser(prog="python -m petswarm.experiments.measure_building", description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-199")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--late", type=float, default=15.0, help="seconds after organizing beyond which a build is late")
    ap.add_argument("--until", type=float, default=40.0, help="cut an episode not built by then")
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    overrides = dict(parse_override(item) for item in args.set)
    rows = []
    for seed in parse_seeds(args.seeds):
        r = episode(seed, overrides, args.late, args.until)
        rows.append(r)
        if not (r["building_time_s"] <= args.late):
            print(json.dumps(r), flush=True)
    times = sorted((r["building_time_s"] if math.isfinite(r["building_time_s"]) else math.inf) for r in rows)  # never: last
    built = [t for t in times if math.isfinite(t)]
    late = [r for r in rows if not (r["building_time_s"] <= args.late)]
    steps = Counter(r["late"]["off"][0]["step"] for r in late if r["late"] and r["late"]["off"])
    q90 = times[min(len(times) - 1, int(0.9 * len(times)))]
    print(f"built within {args.late:g} s: {len(rows) - len(late)}/{len(rows)}; built at all (by {args.until:g} s): "
          f"{len(built)}/{len(rows)}; building time median {statistics.median(times):.1f} s, 90th percentile {q90:.1f} s, "
          f"max {max(times):.1f} s, mean {statistics.fmean(min(t, args.until) for t in times):.2f} s (never built: {args.until:g} s); late seeds by their worst slave's step: {dict(steps)}")
    if args.json:
        write_json_atomic(args.json, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.measure_building", main))
