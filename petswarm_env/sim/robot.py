"""A mecanum-wheeled Pet-Bot: body-frame commands, wheel kinematics, limits, own sensors.

Control factors (seed 000 §3.6.1, Fig. 11; seed 002 §3.4): ``Vx`` front/rear speed, ``Vy``
left/right speed, ``ω`` angular speed, all in the robot's body frame (x forward, y left, ω CCW).
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from petswarm_env.config import RobotConfig
from petswarm_env.sim.draws import Draws

# Chipmunk's body accessors (``pymunk.cp``, pymunk's low-level handle): the per-substep drive and
# the radio's position reads call them directly instead of through pymunk's Python properties,
# which build a Vec2d and go through a typing ``__setattr__`` on every access. Same C calls.
_get_position = pymunk.cp.cpBodyGetPosition
_get_angle = pymunk.cp.cpBodyGetAngle
_get_velocity = pymunk.cp.cpBodyGetVelocity
_get_angular_velocity = pymunk.cp.cpBodyGetAngularVelocity
_set_velocity = pymunk.cp.cpBodySetVelocity
_set_angular_velocity = pymunk.cp.cpBodySetAngularVelocity
_cos, _sin, _hypot = math.cos, math.sin, math.hypot

COLLISION_ROBOT = 1
COLLISION_USER = 2
COLLISION_WALL = 3

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


class Robot:
    """Physical truth of one robot: a pymunk body driven by velocity commands."""

    def __init__(self, index: int, cfg: RobotConfig, space: pymunk.Space, position, heading_rad: float):
        self.index = index
        self.cfg = cfg
        moment = pymunk.moment_for_circle(cfg.mass_kg, 0, cfg.radius_m)
        self.body = pymunk.Body(cfg.mass_kg, moment)
        self.body.position = tuple(position)
        self.body.angle = heading_rad
        self.shape = pymunk.Circle(self.body, cfg.radius_m)
        self.shape.collision_type = COLLISION_ROBOT
        self.shape.friction = 0.3
        self.shape.elasticity = 0.0
        self.shape.robot_index = index  # read by collision callbacks
        space.add(self.body, self.shape)
        self._cbody = self.body._body  # the Chipmunk body behind self.body
        # commanded (saturated) body-frame velocity, and the achieved one after acceleration limits
        self.command = (0.0, 0.0, 0.0)
        self.velocity_body = (0.0, 0.0, 0.0)
        self._limits_dt = -1.0  # the substep length the acceleration limits below were computed for
        self._max_dv = self._max_dw = 0.0
        # AHRS: yaw with white noise and a slowly drifting bias (random walk in time)
        self.ahrs_rng = np.random.default_rng(0)  # (the env gives every robot its own stream)
        self._ahrs_noise_rad = math.radians(cfg.ahrs_noise_deg)  # σ of the white noise
        self._ahrs_drift_rad = math.radians(cfg.ahrs_drift_dps)  # σ of the bias walk over one second
        self._ahrs_bias = 0.0
        self._ahrs_time = 0.0

    @property
    def ahrs_rng(self) -> np.random.Generator:
        """The AHRS noise stream; its normals are drawn in blocks (:class:`~.draws.Draws`)."""
        return self._ahrs_draws.rng

    @ahrs_rng.setter
    def ahrs_rng(self, rng: np.random.Generator) -> None:
        self._ahrs_draws = Draws(rng)

    def ahrs_yaw(self, now_s: float) -> float:
        """AHRS yaw reading (rad) at clock time ``now_s``: truth + drifting bias + white noise."""
        draws = self._ahrs_draws
        dt = now_s - self._ahrs_time
        if dt > 0:
            self._ahrs_bias += self._ahrs_drift_rad * math.sqrt(dt) * draws.normal()
            self._ahrs_time = now_s
        return _get_angle(self._cbody) + self._ahrs_bias + self._ahrs_noise_rad * draws.normal()

    @property
    def position(self) -> tuple[float, float]:
        p = _get_position(self._cbody)
        return (p.x, p.y)

    @property
    def heading(self) -> float:
        return _get_angle(self._cbody)

    def set_command(self, vx: float, vy: float, omega: float) -> None:
        """Body-frame command (m/s, m/s, rad/s); wheel saturation applies here. Stored as Python
        floats: a float32 action would otherwise carry numpy-scalar arithmetic (slow, and rounded
        to float32) into every substep of the drive."""
        self.command = saturate_command(float(vx), float(vy), float(omega), self.cfg)

    def apply(self, dt: float) -> None:
        """Move the achieved velocity toward the command within the acceleration limits, then
        hand it to the physics body (collisions may still change it during the step)."""
        if dt != self._limits_dt:  # the per-substep limits, computed once per substep length
            self._limits_dt = dt
            self._max_dv = self.cfg.max_accel_mps2 * dt
            self._max_dw = self.cfg.max_alpha_rps2 * dt
        cbody = self._cbody
        th = _get_angle(cbody)
        c, s = _cos(th), _sin(th)
        # the body's actual velocity (after last step's collisions) in its own frame
        wv = _get_velocity(cbody)
        wx, wy = wv.x, wv.y
        vx = c * wx + s * wy
        vy = -s * wx + c * wy
        w = _get_angular_velocity(cbody)
        cx, cy, cw = self.command
        dvx, dvy = cx - vx, cy - vy
        dv = _hypot(dvx, dvy)
        max_dv = self._max_dv
        if dv > max_dv:
            k = max_dv / dv
            dvx *= k
            dvy *= k
        vx += dvx
        vy += dvy
        max_dw = self._max_dw
        dw = cw - w  # clipped to [-max_dw, max_dw]
        if dw > max_dw:
            dw = max_dw
        elif dw < -max_dw:
            dw = -max_dw
        w_new = w + dw
        self.velocity_body = (vx, vy, w_new)
        # write only what changed (a body turning at its commanded rate, or driving straight at its
        # commanded speed, keeps its values): the same state as writing it again
        if w_new != w:
            _set_angular_velocity(cbody, w_new)
        vx_w, vy_w = c * vx - s * vy, s * vx + c * vy
        if vx_w != wx or vy_w != wy:
            _set_velocity(cbody, (vx_w, vy_w))
