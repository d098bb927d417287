"""What one robot knows (seed 000 Fig. 5: the relative-location identification manager's table, the
heading exchange, the master's broadcast). Filled only by frames and the robot's own sensors; a
policy sees a robot through :class:`Knowledge` and nothing else of the middleware."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

FRESH_IR_S = 2.0  # chosen: an IR measurement this fresh still places the robot (the ring visits a member every ~0.5 s)


@dataclass
class IRMeasurement:
    distance_m: float
    bearing_rad: float  # bearing of the other robot in this robot's body frame
    time_s: float
    own_yaw_rad: float  # own AHRS yaw when measured (to carry the bearing over own rotation)

    def position_now(self, yaw_rad: float) -> tuple[float, float]:
        """The other robot in this robot's body frame now, at its AHRS reading ``yaw_rad``: the
        measured bearing carried over this robot's own rotation since (its translation is not)."""
        b = self.bearing_rad - (yaw_rad - self.own_yaw_rad)
        return self.distance_m * math.cos(b), self.distance_m * math.sin(b)


@dataclass
class HeadingEstimate:
    relative_rad: float  # θ_other − θ_self, from the heading exchange
    time_s: float
    own_yaw_rad: float  # own AHRS yaw when estimated


@dataclass
class MasterStatus:
    """The master's periodic broadcast (seed 000 §3.5, Fig. 9)."""

    velocity: tuple[float, float, float]  # master's (vx, vy, ω) in its body frame
    activity: str  # user activity: stop | rest | walk | run (the belt's recognition)
    mode: str  # following | leading | remote | emergency
    user_turn_rate_rps: float
    user_position_m: tuple[float, float]  # user relative to the master, master's frame
    time_s: float  # when this robot received it
    user_rotating: bool = False  # the belt's rotation flag (seed 002 §3.4)


@dataclass
class Knowledge:
    """What one robot knows. Filled only by frames and its own sensors."""

    member: int = -1  # member number in the swarm (0 = master), -1 = none
    total_members: int = 0
    members: dict[int, int] = field(default_factory=dict)  # member number -> node id
    mode: str = ""  # the swarm's driving mode, from the joining notification / the last mode change
    ir: dict[int, IRMeasurement] = field(default_factory=dict)  # node id -> latest measurement
    heading: dict[int, HeadingEstimate] = field(default_factory=dict)  # node id -> relative heading
    status: MasterStatus | None = None
    lf_members: frozenset[int] = frozenset()  # node ids whose bodies carry LF antennas (may be master), from the tables
