"""What one robot knows (seed 000 Fig. 5: the relative-location identification manager's table, the
heading exchange, the master's broadcast). Filled only by frames and the robot's own sensors; a
policy sees a robot through :class:`Knowledge` and nothing else of the middleware."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

# chosen: own odometry is counted at every control step while the robot drives as a slave (0.1 s); a
# longer gap (it was the master, or not yet a member) starts the count again, the velocity of one
# step not standing for the time between
RECKON_GAP_S = 0.5
FRESH_IR_S = 2.0  # chosen: an IR measurement this fresh still places the robot (the ring visits a member every ~0.5 s)


@dataclass
class IRMeasurement:
    distance_m: float
    bearing_rad: float  # bearing of the other robot in this robot's body frame
    time_s: float
    own_yaw_rad: float  # own AHRS yaw when measured (to carry the bearing over own rotation)
    own_x_m: float = 0.0  # own dead-reckoned position when measured (:attr:`Knowledge.odometry_xy`)
    own_y_m: float = 0.0

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
    # own position relative to the swarm, dead-reckoned (:meth:`dead_reckon`), and when it was last advanced (own clock)
    odometry_xy: tuple[float, float] = (0.0, 0.0)
    odometry_s: float = math.nan

    def dead_reckon(self, now_s: float, vx: float, vy: float, yaw_rad: float) -> None:
        """Advance :attr:`odometry_xy`, own position relative to the swarm, to ``now_s`` (own clock):
        own wheel odometry ``(vx, vy)`` (body frame, m/s, over the period since the last call) less
        the master's broadcast driving speed (seed 000 §3.5: the speed that compensates the IR
        ring's update delay; taken in our own frame, the formation's heading being the master's),
        turned into the odometry frame by own AHRS yaw ``yaw_rad`` (the frame where the robot was,
        and its AHRS read zero, when the count began). An IR fix carried over it
        (the observation's ``observe._put_fix``) stays where the swarm carried the measured robot, had it
        kept its place in it: while the swarm stands, where it stood."""
        dt = now_s - self.odometry_s
        self.odometry_s = now_s
        if 0.0 < dt <= RECKON_GAP_S:  # (nan, or a longer gap: the count starts (again) here)
            st = self.status
            if st is not None:
                vx -= st.velocity[0]
                vy -= st.velocity[1]
            c, s = math.cos(yaw_rad), math.sin(yaw_rad)
            x, y = self.odometry_xy
            self.odometry_xy = (x + (c * vx - s * vy) * dt, y + (s * vx + c * vy) * dt)
