"""The timed step loops: a petswarm env driven by a policy (:class:`EnvLoop`) and MPE
``simple_spread`` driven by random actions (:class:`MPELoop`), each accumulating ``env.step`` wall
and CPU time, the time of choosing the actions and the resets' time apart (:class:`TimedLoop`)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

import petswarm_env
from petswarm.baselines.policy import PolicySpec
from petswarm.baselines.registry import make_policy


class TimedLoop:
    """Steps ``self.env``, resetting (seed ``next_seed``, then + 1, ...) as episodes end. Only
    ``env.step`` is in ``step_s`` (wall) and ``step_cpu_s`` (process CPU time); choosing the actions
    is in ``policy_s`` and the resets in ``reset_s``. Subclasses say how an episode starts, how the
    actions are chosen and how a step is taken."""

    env: Any
    next_seed: int

    def clear(self) -> None:
        self.step_s = self.step_cpu_s = self.policy_s = self.reset_s = 0.0
        self.steps = self.agent_steps = self.resets = 0

    def _over(self) -> bool:
        return not self.env.agents

    def _start_episode(self, seed: int) -> None:
        raise NotImplementedError

    def _actions(self) -> dict:
        raise NotImplementedError

    def _step(self, actions: dict) -> None:
        raise NotImplementedError

    def _reset(self) -> None:
        t0 = time.perf_counter()
        self._start_episode(self.next_seed)
        self.reset_s += time.perf_counter() - t0
        self.next_seed += 1
        self.resets += 1

    def run(self, steps: int | None = None, seconds: float | None = None, min_steps: int = 0,
            step_hook: Callable[[], None] | None = None, on_step: Callable[[int], None] | None = None) -> None:
        """Run ``steps`` steps, or until ``seconds`` of env.step time and ``min_steps`` steps.
        ``step_hook`` is called right before and right after each env.step (inside the timing);
        ``on_step(steps)`` after each step."""
        perf, cpu, step = time.perf_counter, time.process_time, self._step
        while True:
            if steps is not None and self.steps >= steps:
                return
            if seconds is not None and self.step_s >= seconds and self.steps >= min_steps:
                return
            if self._over():
                self._reset()
            t0 = perf()
            actions = self._actions()
            t1, c1 = perf(), cpu()
            if step_hook is None:
                step(actions)
            else:
                step_hook()
                step(actions)
                step_hook()
            t2, c2 = perf(), cpu()
            self.policy_s += t1 - t0
            self.step_s += t2 - t1
            self.step_cpu_s += c2 - c1
            self.steps += 1
            self.agent_steps += len(actions)
            if on_step is not None:
                on_step(self.steps)


class EnvLoop(TimedLoop):
    """A petswarm env of 1 master + ``num_slaves`` slaves driven by a policy (``policy_name``)."""

    def __init__(self, num_slaves: int, policy_name: str, seed: int, **overrides: Any):
        self.env = petswarm_env.parallel_env(**{"swarm.num_slaves": num_slaves, **overrides})
        self.policy = make_policy(policy_name, PolicySpec.from_env(self.env), seed=seed)
        self.next_seed = seed
        self.obs: dict | None = None
        self.clear()

    def _over(self) -> bool:
        return self.obs is None or not self.env.agents

    def _start_episode(self, seed: int) -> None:
        self.obs, _ = self.env.reset(seed=seed)

    def _reset(self) -> None:
        seed = self.next_seed
        super()._reset()
        self.policy.reset(seed)

    def _actions(self) -> dict:
        return self.policy.act_all(self.obs)

    def _step(self, actions: dict) -> None:
        self.obs, *_ = self.env.step(actions)

    def finish_episode(self) -> None:
        """Step until the current episode ends (the next step would reset)."""
        while self.obs is not None and self.env.agents:
            self.run(steps=self.steps + 1)

    def run_episode(self) -> None:
        """Reset (if the episode is over) and run one whole episode."""
        self.run(steps=self.steps + 1)
        self.finish_episode()


class MPELoop(TimedLoop):
    """MPE simple_spread (parallel API, continuous actions) with ``n_agents`` agents and uniform
    random actions (drawn outside the timed call)."""

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

    def _start_episode(self, seed: int) -> None:
        self.env.reset(seed=seed)

    def _actions(self) -> dict:
        acts = self.rng.uniform(self.low, self.high, (len(self.env.agents), len(self.low))).astype(np.float32)
        return dict(zip(self.env.agents, acts))

    def _step(self, actions: dict) -> None:
        self.env.step(actions)
