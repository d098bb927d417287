"""Master-role controller of seed 002 §3.4 (Fig. 13): the user-connected robot keeps its user.

Inputs are the robot's own view only: the user's position from the LF localisation (tracked
between the 350 ms fixes by :class:`UserTracker`), the belt's rotation report over BLE, and its own
odometry. The control system of Fig. 13, in order:

1. **distance and speed** — adaptive-cruise-control style (seed 002 ref. [19]): the robot keeps
   pace with the user's tracked velocity; far from the standard distance (outside ``acc_band_m``)
   it is a distance controller, near it only a gentle distance correction remains;
2. **per mode** — *following*: rotate (ω) toward the user once it leaves a small deadband, so the
   user stays well inside the reliable ±25° region (the belt's Stop / Rest zeroes the speed to match); *leading*: while the belt reports a rotation, move along the arc around the user
   (the robot's position turns about the user with the user's angular speed, until the arc has
   covered the accumulated angle the belt reports); otherwise, when the user leaves ±25°, correct
   sideways (Vy);
3. **safety** — last, in the control arbiter (:mod:`petswarm_env.control.arbiter`).

Every robot faces its user in both modes (the LF antennas must see the belt inside ±25°); a leading
robot drives backwards, which a mecanum robot does as easily as forwards.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from petswarm_env.config import MasterConfig


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


@dataclass
class BeltView:
    """What the master last heard from the belt over BLE (seed 002 §3.4)."""

    activity: str = "stop"
    rotating: bool = False
    angular_speed_rps: float = 0.0
    accumulated_angle_rad: float = 0.0
    time_s: float = 0.0


class UserTracker:
    """Alpha–beta tracker of the user in the robot's odometry frame.

    The robot dead-reckons its own pose from wheel odometry and its AHRS yaw; each LF fix (user
    position in the body frame) becomes a point in that frame, and the tracker smooths position and
    velocity between fixes. Queries return the user's predicted position and velocity in the body
    frame now.
    """

    def __init__(self, alpha: float, beta: float):
        self.alpha, self.beta = alpha, beta
        self.reset()

    def reset(self) -> None:
        self.pose = [0.0, 0.0, 0.0]  # own x, y (odometry frame) and AHRS yaw
        self.pos: list[float] | None = None
        self.vel = [0.0, 0.0]
        self.t_fix = 0.0
        self.last_fix_s = -math.inf

    def move(self, odometry: tuple[float, float, float], yaw: float, dt: float) -> None:
        """Dead-reckon own pose over one control period (odometry in the body frame)."""
        c, s = math.cos(self.pose[2]), math.sin(self.pose[2])
        vx, vy, _ = odometry
        self.pose[0] += (c * vx - s * vy) * dt
        self.pose[1] += (s * vx + c * vy) * dt
        self.pose[2] = yaw

    def fix(self, body_xy: tuple[float, float], t: float, weight: float = 1.0) -> None:
        """Take an LF fix (body frame) made at ``t``; ``weight`` < 1 trusts a noisier fix less."""
        c, s = math.cos(self.pose[2]), math.sin(self.pose[2])
        z = (self.pose[0] + c * body_xy[0] - s * body_xy[1], self.pose[1] + s * body_xy[0] + c * body_xy[1])
        if self.pos is None:
            self.pos = list(z)
        else:
            dt = max(t - self.t_fix, 1e-3)
            px, py = self.pos[0] + self.vel[0] * dt, self.pos[1] + self.vel[1] * dt
            rx, ry = z[0] - px, z[1] - py
            a, b = self.alpha * weight, self.beta * weight
            self.pos = [px + a * rx, py + a * ry]
            self.vel = [self.vel[0] + b * rx / dt, self.vel[1] + b * ry / dt]
        self.t_fix = t
        self.last_fix_s = t

    def user_body(self, t: float) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """(position, velocity) of the user in the body frame now, or None before the first fix."""
        if self.pos is None:
            return None
        dt = t - self.t_fix
        wx, wy = self.pos[0] + self.vel[0] * dt - self.pose[0], self.pos[1] + self.vel[1] * dt - self.pose[1]
        c, s = math.cos(self.pose[2]), math.sin(self.pose[2])
        pos = (c * wx + s * wy, -s * wx + c * wy)
        vel = (c * self.vel[0] + s * self.vel[1], -s * self.vel[0] + c * self.vel[1])
        return pos, vel


class MasterController:
    def __init__(self, cfg: MasterConfig, reliable_half_angle_rad: float):
        self.cfg = cfg
        self.half_angle = reliable_half_angle_rad
        self.reset()

    def reset(self) -> None:
        self.arc_done_rad = 0.0  # leading: arc covered during the current user rotation
        self._was_rotating = False

    def command(
        self,
        user_pos: tuple[float, float],
        user_vel: tuple[float, float],
        belt: BeltView,
        own_velocity: tuple[float, float, float],
        mode: str,
        target_distance_m: float,
        dt: float,
    ) -> tuple[float, float, float]:
        """(Vx, Vy, ω) body-frame command. ``user_pos``/``user_vel`` in the body frame."""
        cfg = self.cfg
        ux, uy = user_pos
        r = math.hypot(ux, uy)
        if r < 1e-6:
            return 0.0, 0.0, 0.0
        nx, ny = ux / r, uy / r  # unit vector toward the user
        bearing = math.atan2(uy, ux)
        # 1. ACC: distance control far from the target, speed matching near it
        err = r - target_distance_m
        gain = cfg.distance_gain if abs(err) > cfg.acc_band_m else cfg.speed_gain
        if belt.activity in ("stop", "rest"):  # the belt says the user stands: no speed to match
            user_vel = (0.0, 0.0)
        # keep pace with the user (their whole velocity) and close the distance error along the line
        vx, vy, w = user_vel[0] + gain * err * nx, user_vel[1] + gain * err * ny, 0.0
        # 2. mode
        if mode == "leading":
            if belt.rotating:
                if not self._was_rotating:
                    self.arc_done_rad = 0.0
                # arc about the user: the robot's position relative to the user, −user_pos, turns
                # at the user's rate; correct toward the accumulated angle the belt reports
                rate = belt.angular_speed_rps + cfg.arc_gain * (belt.accumulated_angle_rad - self.arc_done_rad)
                vx += rate * uy
                vy += -rate * ux
                w = rate
                self.arc_done_rad += rate * dt
            elif abs(bearing) > self.half_angle:
                vy += cfg.sideways_gain * uy  # move sideways until the user is back inside ±25°
            self._was_rotating = belt.rotating
        else:  # following (and remote/solo driving toward the user)
            band = math.radians(cfg.rotate_deadband_deg)
            w = cfg.rotate_gain * (bearing - max(-band, min(band, bearing)))
            self._was_rotating = False
        return vx, vy, w
