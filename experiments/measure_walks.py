"""Does the master still drive its user when a walk ends? The scripted swarm on the walks of
``petswarm_env/scenarios`` in one driving mode, per seed: the user session's state and the master's
distance from its user at the last step, the time spent in emergency, and how far the user's script got.

    python -m petswarm.experiments.measure_walks --mode leading --scenarios u_turn stop_and_go random_walk --seeds 0-19

"Driven to the end": the session following or leading (not in an emergency, an obstacle exception or
waiting for a robot) and the master within ``DRIVING_M`` of its user, judged from the simulator's truth
(``env.episode.truth``; no robot reads it). A walk whose user was lost and never came back ends in an
emergency, or with the swarm parked while its user walked on; one that ends mid-stop can end in a short
emergency that the user's return at the alert clears (docs/configuration.md).
"""

from __future__ import annotations

import statistics

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.cli.errors import OneLineParser, run_program
from petswarm.experiments.measure_succession import DRIVING_M, drives_its_user, master_user_distance, parse_seeds
from petswarm_env.config import parse_override


def run(scenario: str, seed: int, mode: str, max_cycles: int, overrides: dict) -> dict:
    env = petswarm_env.parallel_env(**{"user.scenario": scenario, "swarm.mode": mode, "max_cycles": max_cycles, **overrides})
    obs, _ = env.reset(seed=seed)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    while env.agents:
        obs, *_ = env.step(policy.act_all({a: obs[a] for a in env.active_agents}))
    truth = env.episode.truth
    return {"seed": seed, "state": truth.sessions[0].state, "distance_m": master_user_distance(truth),
            "emergency_s": env.episode.summary()["emergency_s"], "script_s": truth.users[0].script_time_s,
            "driven": drives_its_user(truth)}


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(prog="python -m petswarm.experiments.measure_walks", description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", nargs="+", default=["u_turn", "stop_and_go", "random_walk"])
    parser.add_argument("--mode", choices=["following", "leading"], default="leading")
    parser.add_argument("--seeds", default="0-19")
    parser.add_argument("--max-cycles", type=int, default=600)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--verbose", action="store_true", help="a line per episode too")
    args = parser.parse_args(argv)
    overrides = dict(parse_override(item) for item in args.set)
    for scenario in args.scenarios:
        rows = [run(scenario, seed, args.mode, args.max_cycles, overrides) for seed in parse_seeds(args.seeds)]
        if args.verbose:
            for r in rows:
                print(f"  {scenario} seed {r['seed']}: {'driven' if r['driven'] else 'NOT driven'}, {r['state']}, "
                      f"master {r['distance_m']:.1f} m from its user, emergency {r['emergency_s']:.1f} s, script {r['script_s']:.1f} s")
        em = [r["emergency_s"] for r in rows if r["emergency_s"] > 0]
        print(f"{args.mode} {scenario}: driven to the end in {sum(r['driven'] for r in rows)} of {len(rows)}; "
              f"an emergency in {len(em)} (median {statistics.median(em) if em else 0.0:.1f} s of it); "
              f"the user's script got to {statistics.median(r['script_s'] for r in rows):.1f} s (median)")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_program("python -m petswarm.experiments.measure_walks", main))
