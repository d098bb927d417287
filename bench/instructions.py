"""Instructions per ``env.step`` counted by valgrind's callgrind (:func:`bench_instructions`): a
count that other processes' load does not change, for comparing two versions of the code.

The scripted policy's actions for one episode (1 master + ``num_slaves``, seed ``seed``) are
recorded first, in this process, into an ``.npz`` file; a child process then replays the first
``n`` of them with ``env.step`` alone (no policy), under callgrind, for two values of ``n``: the
difference of the two totals over the difference of the steps is what a step costs (the imports,
the reset and the organize phase cancel out). The episodes are bit for bit the recorded one, so
the replayed actions are the policy's.

    python -m petswarm.bench.instructions replay ACTIONS.npz N     # the child (what callgrind runs)
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def _make_env(num_slaves: int):
    import petswarm_env

    return petswarm_env.parallel_env(**{"swarm.num_slaves": num_slaves})


def record_actions(num_slaves: int, seed: int, steps: int, path: Path) -> int:
    """The scripted policy's actions for the first ``steps`` steps of the episode (fewer if it
    ends), into ``path``: ``actions (steps, agents, 3)`` and ``acting (steps, agents)``."""
    from petswarm.baselines.policy import PolicySpec
    from petswarm.baselines.registry import make_policy

    env = _make_env(num_slaves)
    policy = make_policy("scripted", PolicySpec.from_env(env), seed=seed)
    policy.reset(seed)
    obs, _ = env.reset(seed=seed)
    agents = list(env.possible_agents)
    actions = np.zeros((steps, len(agents), 3), np.float32)
    acting = np.zeros((steps, len(agents)), bool)
    done = 0
    while done < steps and env.agents:
        acts = policy.act_all(obs)
        live = {a: acts[a] for a in env.agents if a in acts}
        for a, act in live.items():
            actions[done, agents.index(a)] = act
            acting[done, agents.index(a)] = True
        obs, *_ = env.step(live)
        done += 1
    np.savez(path, actions=actions[:done], acting=acting[:done], num_slaves=num_slaves, seed=seed)
    return done


def replay(path: Path, n: int) -> None:
    """The child: reset with the recorded seed and step the first ``n`` recorded actions."""
    data = np.load(path, allow_pickle=False)
    env = _make_env(int(data["num_slaves"]))
    env.reset(seed=int(data["seed"]))
    agents = list(env.possible_agents)
    actions, acting = data["actions"], data["acting"]
    for k in range(n):
        env.step({agents[i]: actions[k, i] for i in np.flatnonzero(acting[k])})


# the child's settings that make its count repeat to the instruction: OpenBLAS's idle worker threads spin
# (blas_thread_server) for as long as the scheduler lets them under valgrind, which moved the count of
# the same replay by up to ~35 k instructions per step from run to run; and one hash seed
REPEATABLE = {"OPENBLAS_NUM_THREADS": "1", "PYTHONHASHSEED": "0"}


def _callgrind_total(path: Path, n: int, out_dir: Path) -> int:
    out = subprocess.run(
        ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out_dir / f'cg.{n}'}", sys.executable, "-m",
         "petswarm.bench.instructions", "replay", str(path), str(n)],
        cwd=ROOT, capture_output=True, text=True, check=False, env=dict(os.environ, PYTHONPATH=str(ROOT), **REPEATABLE))
    found = re.search(r"Collected : (\d+)", out.stderr)
    if out.returncode != 0 or not found:
        raise RuntimeError(f"callgrind of the replay failed:\n{out.stderr[-2000:]}")
    return int(found.group(1))


def valgrind_available() -> tuple[bool, str]:
    if shutil.which("valgrind") is None:
        return False, "valgrind is not installed (apt-get install valgrind)"
    return True, ""


def bench_instructions(num_slaves: int, seed: int, steps: tuple[int, int]) -> dict:
    """Instructions per step of 1 master + ``num_slaves``: callgrind totals of replays of
    ``steps[0]`` and ``steps[1]`` recorded steps, their difference per step."""
    lo, hi = steps
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "actions.npz"
        recorded = record_actions(num_slaves, seed, hi, path)
        if recorded < hi:
            raise RuntimeError(f"the episode ended after {recorded} steps, before the {hi} to replay")
        totals = [_callgrind_total(path, n, Path(tmp)) for n in (lo, hi)]
    return {
        "slaves": num_slaves,
        "seed": seed,
        "steps": [lo, hi],
        "totals": totals,
        "instructions_per_step": (totals[1] - totals[0]) / (hi - lo),
    }


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "replay":
        replay(Path(sys.argv[2]), int(sys.argv[3]))
    else:
        sys.exit(__doc__.splitlines()[-1].strip())
