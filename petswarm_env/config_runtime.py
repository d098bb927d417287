"""Config types of the runtime changes (issue 15 part 4): ``faults``, ``faults_random``,
``arrivals`` (petswarm_env/runtime.py, petswarm_env/sim/faults.py). Their defaults live in
``default.yaml`` like every other value; :class:`~petswarm_env.config.Config` holds them."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from petswarm_env.config_base import COUNT, EPISODE_S, TICK_S, Section

# runtime changes (issue 15 part 4; petswarm_env/sim/faults.py): the fault kinds; an arrival's type is one
# of the config's robot_types (checked by Config, which holds both)
FAULT_KINDS = ("dead", "radio_silent", "ir", "ultrasonic", "ahrs", "battery")
FAULT_TARGETS = ("master", "random_slave")


class FaultSpec(Section):
    at_s: float = Field(ge=0, le=EPISODE_S, description="episode time of the fault (s after reset ended)")
    robot: Annotated[int, Field(ge=0, le=COUNT)] | str = Field(description="robot index, 'master' or 'random_slave' (a seeded draw at the fault's time)")
    kind: str = Field(description="dead | radio_silent | ir | ultrasonic | ahrs | battery")
    duration_s: float | None = Field(ge=TICK_S, le=EPISODE_S, default=None, description="a transient fault clears after this; null = permanent")

    @model_validator(mode="after")
    def _check(self) -> FaultSpec:
        if self.kind not in FAULT_KINDS:
            raise ValueError(f"faults[].kind {self.kind!r} is not a fault kind; use one of {', '.join(FAULT_KINDS)}")
        if isinstance(self.robot, str) and self.robot not in FAULT_TARGETS:
            raise ValueError(f"faults[].robot {self.robot!r} must be a robot index (an integer >= 0), 'master' or 'random_slave'")
        if isinstance(self.robot, int) and self.robot < 0:
            raise ValueError(f"faults[].robot {self.robot} must be a robot index >= 0, 'master' or 'random_slave'")
        return self


class FaultsRandomConfig(Section):
    rate_per_min: float = Field(ge=0, le=60.0, description="faults drawn per minute of episode (Poisson, seeded); 0 = none")
    kinds: list[str] = Field(description="the kinds drawn from, uniformly; each on a random slave, permanent")

    @model_validator(mode="after")
    def _check(self) -> FaultsRandomConfig:
        bad = [k for k in self.kinds if k not in FAULT_KINDS]
        if bad or (self.rate_per_min > 0 and not self.kinds):
            raise ValueError(f"faults_random.kinds {self.kinds!r} must list fault kinds of {', '.join(FAULT_KINDS)}")
        return self


class ArrivalSpec(Section):
    at_s: float = Field(ge=0, le=EPISODE_S, description="episode time the robot is switched on (s after reset ended)")
    type: str = Field(description="the robot's type, a name of robot_types (checked by Config)")
