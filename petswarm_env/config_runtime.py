"""Config types of the runtime changes (docs/faults.md): ``faults``, ``faults_random``,
``arrivals`` (petswarm_env/runtime.py, petswarm_env/sim/faults.py), and ``succession`` (a slave
takes a lost master's place, petswarm_env/middleware/succession.py). Their defaults live in
``default.yaml`` like every other value; :class:`~petswarm_env.config.Config` holds them."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from petswarm_env.config_base import COUNT, EPISODE_S, LONG_S, NEAR_M, SHORT_M, TICK_S, Section

# runtime changes (petswarm_env/sim/faults.py, docs/faults.md): the fault kinds; an arrival's type is one
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


class SuccessionConfig(Section):
    """A slave takes a lost master's place (Table 3's rules among the slaves, seed 002's wake-up)."""

    election_window_s: float = Field(ge=TICK_S, le=LONG_S, description="a slave collects the others' candidacies this long after it lost its master")
    takeover_timeout_s: float = Field(ge=TICK_S, le=LONG_S, description="the elected slave announces its tables this long at most for a first acknowledgement")
    approach_m: float = Field(ge=SHORT_M, le=NEAR_M, description="the new master drives this close to where it puts the user before its wake-up bursts")
