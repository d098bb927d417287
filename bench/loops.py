"""The timed step loops: a petswarm env driven by a policy and MPE ``simple_spread`` driven by
random actions, each accumulating ``env.step`` wall and CPU time, the actions' time and the
resets' time apart."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

import petswarm_env
from baselines.policy import PolicySpec
from baselines.registry import make_policy


class EnvLoop:
    """Steps a petswarm env with a policy, resetting (seed, seed + 1, ...) as episodes end, and
    accumulates env.step, policy and reset wall times separately."""

    def __init__(self, num_slaves: int, policy_name: str, seed: int, **overrides: Any):
        self.env = petswarm_env.parallel_env(**{"swarm.num_slaves": num_slaves, **overrides})
        self.policy = make_policy(policy_name, PolicySpec.from_env(self.env), seed=seed)
        self.next_seed = seed
        self.obs: dict | None = None
        self.clear()

    def clear(self) -> None:
        self.step_s = self.step_cpu_s = self.policy_s = self.reset_s = 0.0
        self.steps = self.agent_steps = self.resets = 0

    def _reset(self) -> None:
        t0 = time.perf_counter()
        self.obs, _ = self.env.reset(seed=self.next_seed)
        self.reset_s += time.perf_counter() - t0
        self.policy.reset(self.next_seed)
        self.next_seed += 1
        self.resets += 1

    def finish_episode(self) -> None:
        """Step until the current episode ends (the next step would reset)."""
        while self.obs is not None and self.env.agents:
            self.run(steps=self.steps + 1)

    def run_episode(self) -> None:
        """Reset (if the episode is over) and run one whole episode."""
        self.run(steps=self.steps + 1)
        self.finish_episode()

    def run(self, steps: int | None = None, seconds: float | None = None, min_steps: int = 0,
            step_hook: Callable[[], None] | None = None, on_step: Callable[[int], None] | None = None) -> None:
        """Run ``steps`` steps, or until ``seconds`` of env.step time and ``min_steps`` steps."""
        env, policy = self.env, self.policy
        perf, cpu = time.perf_counter, time.process_time
        while True:
            if steps is not None and self.steps >= steps:
                return
            if seconds is not None and self.step_s >= seconds and self.steps >= min_steps:
                return
            if self.obs is None or not env.agents:
                self._reset()
            t0 = perf()
            actions = policy.act_all(self.obs)
            t1, c1 = perf(), cpu()
            if step_hook is None:
                self.obs, *_ = env.step(actions)
            else:
                step_hook()
                self.obs, *_ = env.step(actions)
                step_hook()
            t2, c2 = perf(), cpu()
            self.policy_s += t1 - t0
            self.step_s += t2 - t1
            self.step_cpu_s += c2 - c1
            self.steps += 1
            self.agent_steps += len(actions)
            if on_step is not None:
                on_step(self.steps)


class MPELoop:
    """Steps MPE simple_spread (parallel API, continuous actions) with uniform random actions drawn
    outside the timed call, resetting (seed, seed + 1, ...) as episodes end; accumulates env.step
    wall and CPU time, the actions' time and the resets' time apart."""

    def __init__(self, n_agents: int, seed: int, max_cycles: int):
        from mpe2 import simple_spread_v3

        self.env = simple_spread_v3.parallel_env(N=n_agents, continuous_actions=True, max_cycles=max_cycles)
        self.rng = np.random.default_rng(seed)
        space = self.env.action_space(self.env.possible_agents[0])
        self.low, self.high = space.low, space.high
        self.next_seed = seed
        self.env.reset(seed=self.next_seed)
        self.next_seed += 1
        self.clear()

    def clear(self) -> None:
        self.step_s = self.step_cpu_s = self.policy_s = self.reset_s = 0.0
        self.steps = self.agent_steps = self.resets = 0

    def run(self, steps: int | None = None, seconds: float | None = None, min_steps: int = 0) -> None:
        env, perf = self.env, time.perf_counter
        while True:
            if steps is not None and self.steps >= steps:
                return
            if seconds is not None and self.step_s >= seconds and self.steps >= min_steps:
                return
            if not env.agents:
                t0 = perf()
                env.reset(seed=self.next_seed)
                self.reset_s += perf() - t0
                self.resets += 1
                self.next_seed += 1
            t0 = perf()
            acts = self.rng.uniform(self.low, self.high, (len(env.agents), len(self.low))).astype(np.float32)
            actions = dict(zip(env.agents, acts))
            t1, c1 = perf(), time.process_time()
            env.step(actions)
            t2, c2 = perf(), time.process_time()
            self.policy_s += t1 - t0
            self.step_s += t2 - t1
            self.step_cpu_s += c2 - c1
            self.steps += 1
            self.agent_steps += len(actions)
