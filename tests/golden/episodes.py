"""Golden episodes: whole episodes hashed, so a change that alters behaviour cannot pass unseen.

Each case runs one seeded episode and hashes, step by step, every agent's observation (float32
bytes), reward (float64 bytes), termination and truncation, the true centre of every body and the
true heading of every robot (float64 bytes), and at the end the episode summary (canonical JSON).
The values recorded in ``episodes.json`` come from the code before a restructure; the test in
``tests/env/test_golden_episodes.py`` holds the current code to them.

A change that alters behaviour on purpose regenerates the file in the same commit and says why in
its message::

    python -m tests.golden.episodes --regenerate
"""

from __future__ import annotations

import argparse
import hashlib
import json
import struct
import sys
from pathlib import Path
from typing import Any

import numpy as np

GOLDEN_PATH = Path(__file__).with_name("episodes.json")

# name -> (config overrides, policy, seed, steps)
CASES: dict[str, tuple[dict[str, Any], str, int, int]] = {
    "default_seed0": ({}, "scripted", 0, 600),
    "default_seed1": ({}, "scripted", 1, 600),
    "default_seed2": ({}, "scripted", 2, 600),
    "random_1p4": ({}, "random", 3, 300),
    "leading_zigzag": ({"swarm.mode": "leading"}, "scripted", 0, 400),
    "mode_change": ({"user.scenario": "mode_change"}, "scripted", 0, 400),
    "nine_slaves_u_turn": ({"swarm.num_slaves": 9, "user.scenario": "u_turn"}, "scripted", 0, 300),
    "two_users": ({"world.num_users": 2}, "scripted", 0, 300),
}


def _policy(name: str, env, seed: int):
    from baselines.policy import PolicySpec
    from baselines.registry import make_policy

    return make_policy(name, PolicySpec.from_env(env), seed=seed)


def _truth(env) -> tuple[np.ndarray, np.ndarray]:
    centers, _, headings = env.world.truth_arrays()
    return np.ascontiguousarray(centers, dtype=np.float64), np.ascontiguousarray(headings, dtype=np.float64)


def run_case(name: str) -> dict[str, Any]:
    """Run one case; returns its hash and a few figures for the eye."""
    import petswarm_env

    overrides, policy_name, seed, steps = CASES[name]
    env = petswarm_env.parallel_env(**{**overrides, "max_cycles": steps})
    policy = _policy(policy_name, env, seed)
    h = hashlib.sha256()

    def add_obs(obs: dict[str, np.ndarray]) -> None:
        for agent in sorted(obs):
            h.update(agent.encode())
            h.update(np.ascontiguousarray(obs[agent], dtype=np.float32).tobytes())

    def add_truth() -> None:
        centers, headings = _truth(env)
        h.update(centers.tobytes())
        h.update(headings.tobytes())

    obs, _ = env.reset(seed=seed)
    policy.reset(seed)
    add_obs(obs)
    add_truth()
    n = 0
    while env.agents:
        actions = policy.act_all({a: obs[a] for a in env.agents})
        obs, rewards, terms, truncs, _ = env.step(actions)
        add_obs(obs)
        for agent in sorted(rewards):
            h.update(agent.encode())
            h.update(struct.pack("<d??", float(rewards[agent]), bool(terms[agent]), bool(truncs[agent])))
        add_truth()
        n += 1
    summary = env.episode_summary()
    h.update(json.dumps(summary, sort_keys=True, default=float).encode())
    return {"sha256": h.hexdigest(), "steps": n, "formation_rmse_m": summary["formation_rmse_m"]}


def run_all() -> dict[str, dict[str, Any]]:
    return {name: run_case(name) for name in CASES}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--regenerate", action="store_true", help=f"rewrite {GOLDEN_PATH.name} from the current code")
    args = ap.parse_args(argv)
    results = run_all()
    if args.regenerate:
        tmp = GOLDEN_PATH.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(results, indent=2, sort_keys=True) + "\n")
        tmp.replace(GOLDEN_PATH)
        print(f"wrote {GOLDEN_PATH}")
        return 0
    golden = json.loads(GOLDEN_PATH.read_text())
    bad = [n for n in CASES if golden.get(n, {}).get("sha256") != results[n]["sha256"]]
    for n in CASES:
        print(f"{n:20s} {'ok' if n not in bad else 'DIFFERS'}  rmse {results[n]['formation_rmse_m']:.4f}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
