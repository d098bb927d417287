"""A mecanum-wheeled Pet-Bot: body-frame commands, wheel kinematics, limits, own sensors.

Control factors (seed 000 §3.6.1, Fig. 11; seed 002 §3.4): ``Vx`` front/rear speed, ``Vy``
left/right speed, ``ω`` angular speed, all in the robot's body frame (x forward, y left, ω CCW).
"""

from __future__ import annotations

import numpy as np
import pymunk

from petswarm_env.config import RobotConfig
from petswarm_env.sim.body import COLLISION_ROBOT, DrivenBody
from petswarm_env.sim.body import _get_position  # noqa: F401  read here by middleware/node.py until it binds Body.read_position
from petswarm_env.sim.faults import FaultState
from petswarm_env.sim.sensors import AHRS

# Wheel order: front-left, front-right, rear-left, rear-right. Linear wheel-rim speeds (m/s).
_INV = np.array(  # body (vx, vy, L*ω) -> wheels
    [
        [1.0, -1.0, -1.0],
        [1.0, 1.0, 1.0],
        [1.0, 1.0, -1.0],
        [1.0, -1.0, 1.0],
    ]
)
_FWD = _INV.T / 4.0  # wheels -> body (vx, vy, L*ω); the pseudo-inverse of _INV


def wheel_speeds(vx: float, vy: float, omega: float, lever_m: float) -> np.ndarray:
    """Standard mecanum inverse kinematics: body velocity -> four wheel rim speeds (m/s)."""
    return _INV @ np.array([vx, vy, lever_m * omega])


def body_velocity(wheels: np.ndarray, lever_m: float) -> tuple[float, float, float]:
    """Mecanum forward kinematics: four wheel rim speeds -> body (vx, vy, ω)."""
    vx, vy, l_omega = _FWD @ wheels
    return float(vx), float(vy), float(l_omega / lever_m)


def saturate_command(vx: float, vy: float, omega: float, cfg: RobotConfig) -> tuple[float, float, float]:
    """Clip ω to its limit, then scale all wheels together so none exceeds the wheel limit.

    Scaling the four wheels by one factor keeps the commanded direction (SPEC §1: a saturated
    command keeps its direction).
    """
    omega = max(-cfg.max_omega_rps, min(cfg.max_omega_rps, omega))
    lever = cfg.wheel_lever_m
    # max |wheel| of _INV @ (vx, vy, Lω) without building arrays (hot path)
    a, b = vx + vy, vx - vy
    lw = lever * omega
    peak = max(abs(b - lw), abs(a + lw), abs(a - lw), abs(b + lw))
    if peak > cfg.max_speed_mps:
        k = cfg.max_speed_mps / peak
        return vx * k, vy * k, omega * k
    return vx, vy, omega


class Robot(DrivenBody):
    """Physical truth of one robot: a pymunk body driven by velocity commands (its motors:
    :meth:`~.body.DrivenBody.apply`), with its own sensors' models attached (the AHRS here; the
    ultrasonic ring and the odometry in :class:`~.sensors.Sensors`)."""

    def __init__(self, index: int, cfg: RobotConfig, space: pymunk.Space, position, heading_rad: float):
        super().__init__(space, position, heading_rad, cfg.radius_m, COLLISION_ROBOT, cfg.mass_kg,
                         cfg.max_accel_mps2, cfg.max_alpha_rps2, friction=0.3, elasticity=0.0)
        self.index = index
        self.cfg = cfg
        self.shape.robot_index = index  # read by collision callbacks
        space.add(self.body, self.shape)
        self.health = FaultState()  # the parts that work (petswarm_env/sim/faults.py)
        self.ahrs = AHRS(self, cfg)  # own sensor: yaw with white noise and a drifting bias
        self.ahrs_yaw = self.ahrs.yaw  # ahrs_yaw(now_s): the reading (bound once: read every frame)

    def set_command(self, vx: float, vy: float, omega: float) -> None:
        """Body-frame command (m/s, m/s, rad/s); wheel saturation applies here. Stored as Python
        floats: a float32 action would otherwise carry numpy-scalar arithmetic (slow, and rounded
        to float32) into every substep of the drive."""
        self.command = saturate_command(float(vx), float(vy), float(omega), self.cfg)
