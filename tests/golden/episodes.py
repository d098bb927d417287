"""Golden episodes: whole episodes hashed, so a change that alters behaviour cannot pass unseen.

Each case runs one seeded episode and hashes, step by step, every agent's observation (float32
bytes), reward (float64 bytes), termination and truncation, the true centre of every body and the
true heading of every robot (float64 bytes), and at the end the episode summary (canonical JSON).
The values recorded in ``episodes.json`` come from the code before a restructure; the test in
``tests/env/test_golden_episodes.py`` holds the current code to them.

The cases run in a child process whose NumPy dispatches no AVX-512 kernels
(:func:`portable_environ`): NumPy picks its SIMD kernels for the machine it runs on, and the
AVX-512 forms of some ufuncs round the last bit differently from the AVX2 ones, so the same seed
gives the same episode bit for bit on one machine, but an AVX-512 machine and an AVX2 machine
differ in the last digits (seen on 2026-12-02: 6 of the 8 cases). Capped at AVX2 (x86-64-v3),
every x86-64 machine with AVX2 computes the recorded episodes.

A change that alters behaviour on purpose regenerates the file in the same commit and says why in
its message::

    python -m tests.golden.episodes --regenerate
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

GOLDEN_PATH = Path(__file__).with_name("episodes.json")

# Robot types, faults and RUTA added 16 observation fields after layout 2's 67 (the ring's presence and location-known
# flags, layout 3) and 7 summary keys (faults, reassignments, arrivals). ``layout2_sha256`` hashes a
# case as it was hashed before: each observation cut to its first 67 values, the summary without
# those keys; it equals the hash recorded at 64567ef, before robot types, faults and RUTA — so a petbot-only pool gives
# the same episodes as before the heterogeneous swarm, bit for bit.
LAYOUT2_SIZE = 67
RUNTIME_SUMMARY_KEYS = frozenset({"faults_injected", "faults_detected", "detection_time_s", "reassignments",
                                  "reassignment_time_s", "slots_unfilled_s", "arrivals_joined"})
# Summary keys added later without any change of behaviour (building and holding measured apart,
# petswarm_env/metrics.py): left out of ``layout2_sha256`` like the keys above.
FIGURE_SUMMARY_KEYS = frozenset({"formation_hold_rmse_m", "formation_hold_steps", "refill_settle_rmse_m", "lost_robot_s"})

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
    # differential bodies (their MOVE module, their relayed heading exchange: middleware/token_ring.py)
    "heterogeneous": ({"user.scenario": "heterogeneous"}, "scripted", 0, 400),
}


def _policy(name: str, env, seed: int):
    from petswarm.baselines.policy import PolicySpec
    from petswarm.baselines.registry import make_policy

    return make_policy(name, PolicySpec.from_env(env), seed=seed)


def _truth(env) -> tuple[np.ndarray, np.ndarray]:
    centers, _, headings = env.truth.truth_arrays()
    return np.ascontiguousarray(centers, dtype=np.float64), np.ascontiguousarray(headings, dtype=np.float64)


def run_case(name: str) -> dict[str, Any]:
    """Run one case; returns its hash and a few figures for the eye."""
    import petswarm_env

    overrides, policy_name, seed, steps = CASES[name]
    env = petswarm_env.parallel_env(**{**overrides, "max_cycles": steps})
    policy = _policy(policy_name, env, seed)
    h, h2 = hashlib.sha256(), hashlib.sha256()  # the whole case; as layout 2 hashed it (LAYOUT2_SIZE)

    def add_obs(obs: dict[str, np.ndarray]) -> None:
        for agent in sorted(obs):
            o = np.ascontiguousarray(obs[agent], dtype=np.float32)
            for x in (h, h2):
                x.update(agent.encode())
            h.update(o.tobytes())
            h2.update(o[:LAYOUT2_SIZE].tobytes())

    def add_truth() -> None:
        centers, headings = _truth(env)
        for x in (h, h2):
            x.update(centers.tobytes())
            x.update(headings.tobytes())

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
            for x in (h, h2):
                x.update(agent.encode())
                x.update(struct.pack("<d??", float(rewards[agent]), bool(terms[agent]), bool(truncs[agent])))
        add_truth()
        n += 1
    summary = env.episode_summary()
    h.update(json.dumps(summary, sort_keys=True, default=float).encode())
    before = {k: v for k, v in summary.items() if k not in RUNTIME_SUMMARY_KEYS | FIGURE_SUMMARY_KEYS}
    h2.update(json.dumps(before, sort_keys=True, default=float).encode())
    return {"sha256": h.hexdigest(), "layout2_sha256": h2.hexdigest(), "steps": n,
            "formation_rmse_m": summary["formation_rmse_m"]}


def run_all() -> dict[str, dict[str, Any]]:
    return {name: run_case(name) for name in CASES}


PROFILE_FLAG = "PETSWARM_GOLDEN_PROFILE"  # set in the child process that runs the cases


def portable_environ() -> dict[str, str]:
    """This process's environment with NumPy's AVX-512 kernels switched off
    (``NPY_DISABLE_CPU_FEATURES``: every AVX-512 feature this machine has; none elsewhere), for
    the child process that runs the cases."""
    from numpy._core._multiarray_umath import __cpu_features__  # NumPy's own table of this CPU

    found = [k for k, v in __cpu_features__.items() if v and (k.startswith("AVX512") or k == "X86_V4")]
    env = dict(os.environ, **{PROFILE_FLAG: "1"})
    if found:
        env["NPY_DISABLE_CPU_FEATURES"] = " ".join(found)
    return env


def run_all_portable() -> dict[str, dict[str, Any]]:
    """Every case, run in a child process with :func:`portable_environ` (this process's NumPy has
    already chosen its kernels)."""
    if os.environ.get(PROFILE_FLAG):
        return run_all()
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-m", "tests.golden.episodes", "--json"], cwd=root, env=portable_environ(),
                         capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"the golden cases failed in their child process:\n{out.stderr[-4000:]}")
    return json.loads(out.stdout)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--regenerate", action="store_true", help=f"rewrite {GOLDEN_PATH.name} from the current code")
    ap.add_argument("--json", action="store_true", help="print every case's figures as JSON (in the child process)")
    args = ap.parse_args(argv)
    if args.json:
        print(json.dumps(run_all()))
        return 0
    results = run_all_portable()
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
