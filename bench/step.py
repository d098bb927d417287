"""Per-step wall and CPU time of the default environment (the full benchmark: ``petswarm bench``).

    python -m petswarm.bench.step [--steps N] [--vector NUM_ENVS] [--set KEY=VALUE ...]

Prints the mean wall time of ``env.step`` (policy time excluded) with the scripted policy's
actions, its CPU time (``time.process_time``: less sensitive to other processes on a busy machine,
good for comparing two versions), and the wall time of ``reset`` (which runs the organize phase on
the clock).

``--vector NUM_ENVS``: the same for ``vector_env(NUM_ENVS)`` (``--steps`` env-steps in all), the
scripted policy acting on each copy's active slots: CPU time per env-step of ``step``, and apart
the share of it that is the auto-resets of finished copies (their organize phase), which the
single env's figure leaves out (its resets are timed apart).

To compare two checkouts, run each from its own directory: ``python -m`` puts the current
directory first on ``sys.path``, so a checkout's interpreter started in another checkout imports
that one's ``petswarm_env``.
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
    ap.add_argument("--vector", type=int, default=0, metavar="NUM_ENVS")
    args = ap.parse_args()
    overrides = dict(parse_override(s) for s in args.set)
    if args.vector:
        return vector(args.vector, args.steps, overrides)
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
            acts = policy.act_all(obs)
            actions = {a: acts[a] for a in env.agents if a in acts}  # never for an agent that has left
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


def vector(num_envs: int, env_steps: int, overrides: dict) -> None:
    """``vector_env(num_envs)`` driven by the scripted policy (module docstring)."""
    import numpy as np

    venv = petswarm_env.vector_env(num_envs, **overrides)
    policy = make_policy("scripted", PolicySpec.from_env(venv.env))
    agents = venv.possible_agents
    reset_cpu = [0.0]
    start = venv._start

    def timed_start(n, obs):  # the auto-resets, timed apart inside step
        c0 = time.process_time()
        out = start(n, obs)
        reset_cpu[0] += time.process_time() - c0
        return out

    venv._start = timed_start
    obs, _ = venv.reset(seed=0)
    reset_cpu[0] = 0.0  # (the first episodes: not in a step)
    actions = np.zeros((num_envs, len(agents), 3), np.float32)
    step_cpu, calls = 0.0, 0
    while calls * num_envs < env_steps:
        for n in range(num_envs):
            slots = np.flatnonzero(venv.active[n])
            acts = policy.act_all({agents[j]: obs[n, j] for j in slots})
            actions[n] = 0.0
            for j in slots:
                actions[n, j] = acts[agents[j]]
        c0 = time.process_time()
        obs, *_ = venv.step(actions)
        step_cpu += time.process_time() - c0
        calls += 1
    per = 1e6 / (calls * num_envs)
    print(f"vector_env({num_envs}): 1 master + {venv.cfg.swarm.num_slaves} slaves, {calls} steps of {num_envs} copies")
    print(f"step CPU time per env-step: {step_cpu * per:.0f} us, of which auto-resets {reset_cpu[0] * per:.0f} us; "
          f"without them {(step_cpu - reset_cpu[0]) * per:.0f} us")


if __name__ == "__main__":
    main()
