"""The one interface every slave policy implements: scripted, random or learned.

A policy maps one slave's observation (the documented vector of :mod:`petswarm_env.observe`) to
its action ``(Vx, Vy, ω)`` in [-1, 1]³. It never sees ground truth. Policies are built for an
environment's observation layout and action limits (:class:`PolicySpec`), so a scripted and a
learned slave can be swapped robot by robot. Policies are built by name in
:mod:`petswarm.baselines.registry` (``make_policy``), which imports this module, never the other way.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from petswarm_env.mapping import Behaviour
from petswarm_env.middle_layer import VIRTUAL_BEHAVIOURS, attach_check
from petswarm_env.observe import ObservationLayout


@dataclass(frozen=True)
class PolicySpec:
    """What a policy needs to know about the robots it drives."""

    layout: ObservationLayout
    max_speed_mps: float
    max_omega_rps: float
    us_max_range_m: float
    bodies: tuple = ()  # the robot types it may drive (robot_types.BodySpec): the behaviour mapper checks them

    @classmethod
    def from_env(cls, env) -> PolicySpec:
        r = env.cfg.robot
        return cls(env.layout, r.max_speed_mps, r.max_omega_rps, r.ultrasonic.max_range_m, getattr(env, "body_types", ()))


class Policy(ABC):
    """Slave policy. ``act`` is called once per agent per step."""

    name: str = "policy"
    behaviours: tuple[Behaviour, ...] = VIRTUAL_BEHAVIOURS  # what it commands: MOVE (Vx, Vy, ω)

    def __init__(self, spec: PolicySpec):
        self.spec = spec
        # seed 001 §IV.B: a behaviour no module of a body serves is refused here, naming it and the body
        attach_check(self.behaviours, spec.bodies, f"policy '{self.name}'")

    def reset(self, seed: int | None = None) -> None:
        """Start of an episode (clear any per-episode state, reseed)."""

    @abstractmethod
    def act(self, agent: str, observation: np.ndarray) -> np.ndarray:
        """Action (3,) float32 in [-1, 1] for ``agent`` given its observation."""

    def act_all(self, observations: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {agent: self.act(agent, obs) for agent, obs in observations.items()}


class RandomPolicy(Policy):
    """Uniform random actions (a floor to compare against), seeded."""

    name = "random"

    def __init__(self, spec: PolicySpec, seed: int = 0):
        super().__init__(spec)
        self.rng = np.random.default_rng(seed)

    def reset(self, seed: int | None = None) -> None:
        if seed is not None:
            self.rng = np.random.default_rng(seed)

    def act(self, agent: str, observation: np.ndarray) -> np.ndarray:
        return self.rng.uniform(-1.0, 1.0, 3).astype(np.float32)


class MixedPolicy(Policy):
    """A mixed team: ``per_agent`` policies for some robots, ``default`` for the others."""

    name = "mixed"

    def __init__(self, spec: PolicySpec, default: Policy, per_agent: dict[str, Policy]):
        super().__init__(spec)
        self.default = default
        self.per_agent = per_agent

    def reset(self, seed: int | None = None) -> None:
        self.default.reset(seed)
        for p in self.per_agent.values():
            p.reset(seed)

    def act(self, agent: str, observation: np.ndarray) -> np.ndarray:
        return self.per_agent.get(agent, self.default).act(agent, observation)
