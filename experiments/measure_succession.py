"""The swarm outlives its master (middleware/succession.py): the master dies or goes radio-silent
at ``--at`` s of a straight walk; per seed, when a slave took its place, when the belt paired with
it, whether the episode ran to ``max_cycles``, whether the new master drives its user at the end (its
session following or leading, the robot within 2 m of the user: a swarm that stopped in an emergency
or an obstacle exception while its user walked on runs to ``max_cycles`` too), and the formation error
afterwards.

    python -m petswarm.experiments.measure_succession --seeds 0-19 --kinds dead radio_silent

Times are seconds after the fault. Targets: a new master within 5 s, the belt paired again, the
episode to ``max_cycles`` with the new master driving its user, in every seed. The robots learn of the loss only from their radio (the
slaves' status timeout, the master's cut-off) and the belt from its BLE supervision timeout.
"""

from __future__ import annotations

import math
import statistics

from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
import petswarm_env
from petswarm.cli.errors import OneLineParser, run_program
from petswarm_env.config import parse_override


DRIVING_M = 2.0  # the new master within this of its user at the end (as experiments/sensor_faults.py)


def master_user_distance(truth) -> float:
    """The true distance from user 0's master to the user (``env.episode.truth``; no robot reads it)."""
    user_xy = truth.users[0].position
    master_xy = truth.robots[truth.swarms[0].master.node_id].position
    return math.dist(user_xy, master_xy)


def drives_its_user(truth) -> bool:
    """Whether user 0's master drives its user: its session following or leading, within ``DRIVING_M`` of them."""
    return truth.sessions[0].state in ("following", "leading") and master_user_distance(truth) <= DRIVING_M


def parse_seeds(text: str) -> list[int]:
    """Seeds from ``0-19``, ``3,5,8`` or both (``0-2,5``); anything else is a ``ValueError`` naming the form."""
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.strip().partition("-")
        if not lo.isdigit() or not (hi or lo).isdigit() or int(hi or lo) < int(lo):
            raise ValueError(f"--seeds '{text}': give whole numbers >= 0 as a range lo-hi (lo <= hi) or a comma list, "
                             "e.g. --seeds 0-19 or --seeds 3,5,8")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def run(kind: str, seed: int, at_s: float, max_cycles: int, overrides: dict) -> dict:
    env = petswarm_env.parallel_env(**{"user.scenario": "straight", "max_cycles": max_cycles,
                                       "faults": [{"at_s": at_s, "robot": "master", "kind": kind}], **overrides})
    obs, _ = env.reset(seed=seed)
    t0 = env.episode.world.now
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    errors_after: list[float] = []
    while env.agents:
        obs, _, _, _, infos = env.step(policy.act_all({a: obs[a] for a in env.active_agents}))
        if env.episode.world.now - t0 >= at_s + 15.0:  # the formation 15 s after the fault
            errors_after += [i["formation_error_m"] for i in infos.values() if i["active"]]
    # each robot logs on its own clock (seed 000 §3.3): the experimenter reads the true time
    elections = [(n.clock.true_time(a), n.clock.true_time(b), lost, new)
                 for n in env.episode.fleet.nodes.values() for a, b, lost, new in n.succession.elections]
    session = env.episode.sessions[0]
    t_fault = t0 + at_s
    new_master = min((t for _, t, _, _ in elections), default=math.inf) - t_fault
    paired = min((t for t, _ in session.pairings), default=math.inf) - t_fault
    driving = drives_its_user(env.episode.truth)
    return {"seed": seed, "new_master_s": new_master, "paired_s": paired, "cycles": env.num_cycles,
            "full": env.num_cycles == max_cycles, "driving_user": driving, "successions": len(elections),
            "rmse_after_m": math.sqrt(statistics.fmean(e * e for e in errors_after)) if errors_after else math.nan}


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(prog="python -m petswarm.experiments.measure_succession", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-19")
    parser.add_argument("--kinds", nargs="+", default=["dead", "radio_silent"])
    parser.add_argument("--at", type=float, default=20.0, help="episode time of the fault (s)")
    parser.add_argument("--max-cycles", type=int, default=600)
    parser.add_argument("--set", nargs="*", default=[], help="config overrides key=value")
    args = parser.parse_args(argv)
    overrides = dict(parse_override(item) for item in args.set)
    for kind in args.kinds:
        rows = [run(kind, seed, args.at, args.max_cycles, overrides) for seed in parse_seeds(args.seeds)]
        for r in rows:
            print(f"{kind:12s} seed {r['seed']:3d}: new master {r['new_master_s']:5.2f} s, paired {r['paired_s']:5.2f} s, "
                  f"cycles {r['cycles']}, driving its user {'yes' if r['driving_user'] else 'NO'}, "
                  f"formation RMSE 15 s on {r['rmse_after_m']:.2f} m")
        ok = [r for r in rows if r["new_master_s"] <= 5.0 and math.isfinite(r["paired_s"]) and r["full"] and r["driving_user"]]
        finite = [r["paired_s"] for r in rows if math.isfinite(r["paired_s"])]
        print(f"{kind}: {len(ok)} of {len(rows)} seeds meet the target (new master within 5 s, paired, "
              f"{args.max_cycles} cycles, driving its user at the end); "
              f"driving its user at the end in {sum(r['driving_user'] for r in rows)} of {len(rows)}; "
              f"new master median {statistics.median(r['new_master_s'] for r in rows):.2f} s, "
              f"paired median {statistics.median(finite) if finite else math.nan:.2f} s (max {max(finite) if finite else math.nan:.2f}), "
              f"RMSE 15 s on median {statistics.median(r['rmse_after_m'] for r in rows):.2f} m; "
              f"failing seeds {[r['seed'] for r in rows if r not in ok] or 'none'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.measure_succession", main))
