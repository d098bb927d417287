"""Large swarms: whether 1 master + N slaves organize, build their formation and hold it, and what
the IR token ring (seed 000 §3.3, Fig. 7) costs at that size.

    python -m petswarm.experiments.measure_scale --slaves 9 16 --seeds 0-19 --loss 0 0.1

For each slave count and loss, one episode per seed of the default scenario (scattered start,
zigzag, 60 s) with the scripted reference. Per case it prints:

* ``joined``: resets in which every required slave joined (a reset that cannot organize counts as not
  joined and its episode as not built);
* ``built``: episodes whose formation was built (``building_time_s`` finite: every slave within
  0.3 m of its reference point at once, petswarm_env/metrics.py), and the mean building time;
* ``hold``: the mean of ``formation_hold_rmse_m`` over the built episodes (the RMSE from the moment
  built), and ``rmse``: the mean ``formation_rmse_m``;
* ``contacts``: robot–robot contacts, summed over the episodes;
* ``round``: the ring's mean round time (between the master's start signs) and ``collided``: the
  share of receptions destroyed by overlapping frames (radio trace, the experimenter's tool);
* ``stale``: the mean slave-seconds per episode without a fresh IR fix of a reference neighbour;
* ``astray``: members the master removed as astray (``middleware/recovery.py``: its RSSI range of
  them beyond their slot's distance plus a margin, no IR fix of them, for 3 s), summed over the
  episodes: each renumbers the swarm, and its formation is re-built;
* ``full``: episodes built with every slave still in the swarm (a member removed as astray or lost
  leaves a smaller formation to build, which counts as built too);
* ``standing``: episodes built before their user walked off (the user stands until the formation is
  built, ``user.formation_wait_s`` at most, petswarm_env/episode.py); of the others, ``off@walk``: the
  mean number of slaves farther than 0.3 m from their reference point when the user walked off, and
  ``worst@walk_m``: the mean of the largest such error (one straggler far off, or many slaves just
  short).

``why``: for each episode not built with every slave (the target: built, all still members), the
first of these that fits (:func:`cause`), counted per case:

* ``unjoined``: the reset did not organize, or not every slave joined;
* ``cascade``: the master removed :data:`CASCADE` or more members as astray (each removal renumbers
  the swarm and re-plans its slots, and the members then take new references);
* ``removed``: built, but only after one or two members were removed (a smaller formation);
* ``straggler``: when the user walked off, at most :data:`FEW` slaves were off their point and the
  worst more than :data:`FAR_M` (the rest stood at their slots);
* ``short``: never built otherwise: more slaves off, or the few off nearer than that (the
  formation was still building when the user walked off, and did not build while walking).

``--set KEY=VALUE`` overrides any config key (``--set swarm.formation=column``). ``--json OUT`` writes
every case's summary and its episodes' rows (the ``--verbose`` lines) to ``OUT`` (checked before the first
episode, written atomically at the end).
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

import numpy as np

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.cli.errors import OneLineParser, run_program
from petswarm.experiments.measure_succession import parse_seeds
from petswarm_env.config import parse_override
from petswarm_env.files import check_output_path, write_json_atomic
from petswarm_env.metrics import BUILT_WITHIN_M
from petswarm_env.middleware import messages as msg


class _RingTrace:
    """The radio trace hook (comms/radio.py): when the master put its start signs on the air."""

    def __init__(self):
        self.master: int | None = None
        self.starts: list[float] = []

    def on_air(self, now: float, station: int, frame, start_s: float, end_s: float) -> None:
        if frame.kind == msg.TX_START and station == self.master:
            self.starts.append(now)

    def reception(self, now: float, frame, receiver: int, outcome: str, distance_est_m: float) -> None:
        pass

    def busy(self, now: float, station: int, frame) -> None:
        pass


CASCADE = 3  # astray removals in one episode from which its failure counts as a cascade of them
FEW = 2  # slaves off when the user walked off, at most, for a straggler case
FAR_M = 1.5  # the worst slave's error when the user walked off, beyond which it is a straggler


def cause(row: dict[str, Any]) -> str | None:
    """Why an episode was not built with every slave (the module docstring's ``why``), or None if it was."""
    if not row.get("organized") or not row.get("joined"):
        return "unjoined"
    if row.get("built_full"):
        return None
    if row["astray"] >= CASCADE:
        return "cascade"
    if math.isfinite(row["building_time_s"]):
        return "removed"
    if row["off_at_walk"] <= FEW and row["worst_at_walk_m"] > FAR_M:
        return "straggler"
    return "short"


def episode(slaves: int, loss: float, seed: int, overrides: dict[str, Any]) -> dict[str, Any]:
    """One episode of 1 master + ``slaves`` at radio loss ``loss``: what it gave."""
    env = petswarm_env.parallel_env(**{"swarm.num_slaves": slaves, "radio.loss_prob": loss, **overrides})
    trace = _RingTrace()
    env.radio_trace = trace
    try:
        obs, _ = env.reset(seed=seed)
    except RuntimeError as e:  # the swarm did not organize (OrganizeError)
        return {"seed": seed, "joined": False, "organized": False, "error": str(e).splitlines()[0]}
    joined = len(env.agents) == slaves
    ep = env.episode
    trace.master = ep.swarms[0].master.node_id
    organized_s = ep.world.now
    st = ep.radio.stats
    before = (st.receptions, st.frames_collided)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    policy.reset(seed)
    walk_s, off_at_walk, worst_at_walk = math.nan, 0, 0.0
    built_with = 0  # how many slaves the swarm had when its formation was built
    while env.agents:
        obs, _, terms, truncs, _ = env.step(policy.act_all({a: obs[a] for a in env.agents}))
        if not built_with and math.isfinite(ep.metrics.building_time_s):
            built_with = len(ep.swarms[0].slave_ids())
        if math.isnan(walk_s) and any(se.user.walking for se in ep.sessions):
            # the user walks off (the formation built, or user.formation_wait_s over): who is still off
            walk_s = ep.world.now - organized_s
            errors, _ = ep.experimenter.formation_errors(list(env.agents))
            off_at_walk = sum(e > BUILT_WITHIN_M for e in errors.values())
            worst_at_walk = max(errors.values(), default=0.0)
        if all(terms.values()) or all(truncs.values()):
            break
    s = env.episode_summary()
    starts = np.array([t for t in trace.starts if t >= organized_s])
    receptions, collided = st.receptions - before[0], st.frames_collided - before[1]
    return {
        "seed": seed, "joined": joined, "organized": True,
        "building_time_s": s["building_time_s"], "hold_rmse_m": s["formation_hold_rmse_m"],
        "rmse_m": s["formation_rmse_m"], "contacts": s["collisions"]["robot_robot"],
        "round_s": float(np.mean(np.diff(starts))) if starts.size > 2 else math.nan,
        "collided": collided / receptions if receptions else math.nan,
        "stale_fix_s": s["stale_fix_s"],
        "astray": sum(len(node.recovery.astray) for node in ep.fleet.nodes.values()),
        "walk_s": walk_s, "off_at_walk": off_at_walk, "worst_at_walk_m": worst_at_walk,
        "built_full": bool(built_with) and built_with == slaves,
    }


def _with_cause(row: dict[str, Any]) -> dict[str, Any]:
    row["cause"] = cause(row)
    return row


def summarize(rows: list[dict[str, Any]]) -> dict[str, Any]:
    def mean(key: str, among: list[dict[str, Any]]) -> float:
        vals = [r[key] for r in among if math.isfinite(r.get(key, math.nan))]
        return float(np.mean(vals)) if vals else math.nan

    ran = [r for r in rows if r["organized"]]
    built = [r for r in ran if math.isfinite(r["building_time_s"])]
    standing = [r for r in built if r["building_time_s"] <= r["walk_s"] + 1e-9]
    missed = [r for r in ran if r not in standing]
    return {
        "episodes": len(rows), "joined": sum(r["joined"] for r in rows), "built": len(built),
        "building_s": mean("building_time_s", built), "hold_rmse_m": mean("hold_rmse_m", built),
        "rmse_m": mean("rmse_m", ran), "contacts": sum(r["contacts"] for r in ran),
        "round_s": mean("round_s", ran), "collided": mean("collided", ran), "stale_fix_s": mean("stale_fix_s", ran),
        "astray": sum(r["astray"] for r in ran),
        "standing": len(standing), "full": sum(r.get("built_full", False) for r in built),
        "off_at_walk": mean("off_at_walk", missed), "worst_at_walk_m": mean("worst_at_walk_m", missed),
        "why": dict(sorted(Counter(c for c in map(cause, rows) if c is not None).items())),
    }


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(prog="python -m petswarm.experiments.measure_scale",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--slaves", type=int, nargs="+", default=[9, 16])
    parser.add_argument("--seeds", default="0-19", help="a range lo-hi (inclusive) or a comma list")
    parser.add_argument("--loss", type=float, nargs="+", default=[0.0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--verbose", action="store_true", help="a line per episode too")
    parser.add_argument("--json", metavar="OUT", help="write every case's summary and episodes here")
    args = parser.parse_args(argv)
    check_output_path(args.json, "--json")
    overrides = dict(parse_override(item) for item in args.set)
    seeds = parse_seeds(args.seeds)
    cases = []
    print("slaves  loss  episodes  joined  built  full  standing  building_s  hold_m  rmse_m  contacts  round_s  collided  stale_s  astray"
          "  off@walk  worst@walk_m  why")
    for slaves in args.slaves:
        for loss in args.loss:
            rows = []
            for seed in seeds:
                rows.append(_with_cause(episode(slaves, loss, seed, overrides)))
                if args.verbose:
                    print("   ", rows[-1], flush=True)
            s = summarize(rows)
            cases.append({"slaves": slaves, "loss": loss, "summary": s, "episodes": rows})
            print(f"{slaves:6d} {loss:5.2f} {s['episodes']:9d} {s['joined']:7d} {s['built']:6d} {s['full']:5d} {s['standing']:9d} "
                  f"{s['building_s']:11.1f} {s['hold_rmse_m']:7.3f} {s['rmse_m']:7.3f} {s['contacts']:9d} {s['round_s']:8.2f} "
                  f"{100 * s['collided']:8.1f}% {s['stale_fix_s']:8.1f} {s['astray']:7d} {s['off_at_walk']:9.1f} "
                  f"{s['worst_at_walk_m']:13.2f}  " + (" ".join(f"{k} {v}" for k, v in s["why"].items()) or "-"), flush=True)
    if args.json:
        write_json_atomic(args.json, {"seeds": seeds, "overrides": overrides, "cases": cases})
    return 0


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.measure_scale", main))
