"""A recurrent policy's step (``RecurrentPolicy.step_batch``) two ways, side by side in alternating
rounds of one run:

- **members** (what the policy does, baselines/members.py): each student of a mean of students run
  on its own, stacked;
- **whole** (the policy before 2026-12-07): the merged network's matrices multiplied whole, the
  zeros outside each student's blocks included.

    python -m petswarm.bench.members_step [--policy baselines/models/recurrent_eight_students.npz] [--agents 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def whole_step(layers, encoder_layers: int, cell, act, x: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The merged network's step as written in its file: every matrix whole, zeros and all (the form
    ``RecurrentPolicy.step_batch`` had before baselines/members.py; tests/unit/test_members.py's oracle)."""
    for w, b in layers[:encoder_layers]:
        x = act(x @ w.T + b)
    h = cell.step(x, h)
    y = np.concatenate([x, h], axis=-1)
    for w, b in layers[encoder_layers:-1]:
        y = act(y @ w.T + b)
    w, b = layers[-1]
    return y @ w.T + b, h


def time_steps(policy_path: str, agents: int = 5, steps: int = 400, rounds: int = 4, seed: int = 0) -> dict[str, list[float]]:
    """Microseconds per step of ``agents`` agents, each way, per round; and the two ways' largest
    difference of outputs over the run (the same network: float64 sums in another order)."""
    from petswarm.baselines.learned import LearnedPolicy
    from petswarm.baselines.policy import PolicySpec
    from petswarm_env import parallel_env

    env = parallel_env(**{"swarm.num_slaves": agents})
    obs, _ = env.reset(seed=seed)
    policy = LearnedPolicy.load(policy_path, PolicySpec.from_env(env))
    x0 = np.stack([obs[a] for a in env.agents]).astype(np.float64)
    noise = np.random.default_rng(seed).normal(0, 0.2, (steps, *x0.shape))
    layers, k, cell, act = policy.layers, policy.encoder_layers, policy.cell, policy.act_fn

    def whole(x, h):
        return whole_step(layers, k, cell, act, x if policy._identity else x[..., policy.index], h)

    def run(step) -> tuple[float, np.ndarray]:
        h, outs = np.zeros((len(x0), cell.hidden_size)), []
        start = time.perf_counter()
        for i in range(steps):
            y, h = step(x0 + noise[i], h)
            outs.append(y)
        return (time.perf_counter() - start) / steps * 1e6, np.array(outs)

    out: dict[str, list[float]] = {"members": [], "whole": [], "count": [policy._stack.members], "max_diff": [0.0]}
    for r in range(rounds):
        ways = (("members", policy.step_batch), ("whole", whole))
        results = {}
        for name, step in (ways if r % 2 == 0 else ways[::-1]):
            us, ys = run(step)
            out[name].append(us)
            results[name] = ys
        out["max_diff"][0] = max(out["max_diff"][0], float(np.abs(results["members"] - results["whole"]).max()))
    return out


def main() -> None:
    from petswarm.baselines.learned import shipped_policy_path

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--policy", default=None, help="a recurrent policy file (default: the shipped `learned`)")
    ap.add_argument("--agents", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=4)
    a = ap.parse_args()
    path = a.policy or str(shipped_policy_path())
    res = time_steps(path, a.agents, rounds=a.rounds)
    m, w = float(np.median(res["members"])), float(np.median(res["whole"]))
    print(f"{path}: {res['count'][0]} member(s), {a.agents} agents, {a.rounds} rounds: members "
          f"{' / '.join(f'{t:.0f}' for t in res['members'])} µs, whole {' / '.join(f'{t:.0f}' for t in res['whole'])} µs "
          f"per step; whole / members {w / m:.2f}x (medians); largest output difference {res['max_diff'][0]:.1e}")


if __name__ == "__main__":
    main()
