"""Per-step wall and CPU time of the default environment (the full benchmark: ``petswarm bench``).

    python -m petswarm.bench.step [--steps N] [--set KEY=VALUE ...]

Prints the mean wall time of ``env.step`` (policy time excluded) with the scripted policy's
actions, its CPU time (``time.process_time``: less sensitive to other processes on a busy machine,
good for comparing two versions), and the wall time of ``reset`` (which runs the organize phase on
the clock).
"""

from __future__ import annotations

import argparse
import time

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env.config import parse_override


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    overrides = dict(parse_override(s) for s in args.set)
    env = petswarm_env.parallel_env(**overrides)
    policy = make_policy("scripted", PolicySpec.from_env(env))
    step_time = step_cpu = reset_time = 0.0
    steps = resets = 0
    seed = 0
    while steps < args.steps:
        t0 = time.perf_counter()
        obs, _ = env.reset(seed=seed)
        reset_time += time.perf_counter() - t0
        resets += 1
        seed += 1
        while env.agents and steps < args.steps:
            actions = policy.act_all(obs)
            t0, c0 = time.perf_counter(), time.process_time()
            obs, *_ = env.step(actions)
            step_time += time.perf_counter() - t0
            step_cpu += time.process_time() - c0
            steps += 1
    n = len(env.possible_agents)
    print(f"env: 1 master + {n} slaves, scenario {env.cfg.user.scenario}, {env.cfg.physics_substeps} substeps")
    print(f"step: {step_time / steps * 1e3:.3f} ms  ({steps / step_time:.0f} steps/s, {n * steps / step_time:.0f} agent-steps/s) over {steps} steps")
    print(f"step CPU time: {step_cpu / steps * 1e3:.3f} ms  ({steps / step_cpu:.0f} steps/s)")
    print(f"reset (organize on the clock): {reset_time / resets * 1e3:.1f} ms over {resets} resets")


if __name__ == "__main__":
    main()
