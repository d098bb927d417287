"""Master-role controller of seed 002 §3.4 (Fig. 13): the user-connected robot keeps its user.

Inputs are the robot's own view only: the user's position from the LF localisation (tracked
between the 350 ms fixes by :class:`UserTracker`), the belt's activity and rotation reports over
BLE, and its own odometry. The control system of Fig. 13, in order:

1. **distance and speed** — adaptive-cruise-control style (seed 002 ref. [19]): the robot keeps
   pace with the user's velocity; far from the standard distance (outside ``acc_band_m``) it is a
   distance controller, near it only a gentle distance correction remains. The user's velocity is
   the tracked speed along a walking direction ψ that turns with the belt's accumulated rotation
   angle (the LF track alone lags a turn by a second) and is pulled slowly toward the track's
   direction while the user walks straight (:meth:`MasterController.user_velocity`);
2. **per mode** — where around the user the robot belongs. *Following*: behind the walking user;
   the robot keeps its place relative to the user (pace) and drifts in behind them at
   ``trail_rps`` (a bounded swing the formation can follow), and rotates toward the user once they
   leave a small deadband, keeping them well inside the reliable ±25° region. *Leading*: straight
   ahead of the user. While the belt reports a rotation, a robot ahead of its user moves along the
   arc about the user at the user's angular speed (seed 002 §3.4, Table 4); for a user turning on
   the spot, the arc it has made is closed on the belt's accumulated angle at ``arc_sync_gain``
   (:meth:`MasterController._arc_in_place`); otherwise a remaining angle between its place and
   straight ahead is closed at ``arc_gain``; when the user leaves ±25° and
   is not rotating, the robot corrects sideways (Vy). The leading robot drives backwards along the
   user's walking direction (its heading follows ψ, never turning the user out of the reliable
   region), so keeping pace costs one wheel axis only;
3. **safety** — last, in the control arbiter (:mod:`petswarm_env.control.arbiter`).

Every robot faces its user in both modes (the LF antennas must see the belt inside ±25°); a leading
robot drives backwards, which a mecanum robot does as easily as forwards.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from petswarm_env.config import MasterConfig
from petswarm_env.sim.geometry import wrap_angle


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

    def reset(self, yaw_rad: float = 0.0) -> None:
        """Forget the user; the odometry frame starts here, at the robot's AHRS reading ``yaw_rad``
        (the AHRS counts from its own power-on heading: a fix taken before the next :meth:`move`
        must be placed with the robot's current reading, not with 0)."""
        self.pose = [0.0, 0.0, yaw_rad]  # own x, y (odometry frame) and AHRS yaw
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
    """Seed 002 Fig. 13 for one robot: ``command`` maps the tracked user and the belt's report to
    (Vx, Vy, ω) in the body frame. State: the walking direction ψ (body frame) and the belt's
    accumulated angle at the last step."""

    def __init__(self, cfg: MasterConfig, reliable_half_angle_rad: float):
        self.cfg = cfg
        self.half_angle = reliable_half_angle_rad
        self.reset()

    def reset(self) -> None:
        self._walk_dir: float | None = None  # ψ: the user's walking direction, body frame
        self._trusted = False  # ψ steers: tracked, or guessed while the user stood still (not mid-turn)
        self._belt_angle = 0.0  # the belt's accumulated angle at the last step (current rotation)
        self._was_rotating = False
        self._sync: list[float] | None = None  # leading arc of the current rotation: [share, arc done]
        self._was_rotating_arc = False

    @property
    def walk_direction_rad(self) -> float | None:
        """ψ, the user's walking direction in the body frame (None before the first command)."""
        return self._walk_dir

    def user_velocity(self, user_vel: tuple[float, float], belt: BeltView, own_omega: float, mode: str,
                      bearing: float, dt: float) -> tuple[tuple[float, float], bool]:
        """The user's velocity (body frame) and whether they walk.

        While the belt says Walk / Run: the tracked speed along ψ, a complementary filter — ψ turns
        with the increments of the belt's accumulated rotation angle (fast, seed 002 §3.4) and,
        while the user walks straight, is pulled toward the track's direction at
        ``heading_blend_rps`` (slow, noisy); the first track replaces the initial guess (the user
        faces the robot in leading, away from it in following). While the belt says Stop / Rest the
        user stands — unless the track's component along the line of sight (the accurate LF range)
        is already walking speed: the belt's activity window lags the start of a walk by about a
        second."""
        cfg = self.cfg
        speed = math.hypot(*user_vel)
        if self._walk_dir is None:
            self._walk_dir = wrap_angle(bearing + math.pi) if mode == "leading" else bearing
            self._trusted = belt.activity in ("stop", "rest") and not belt.rotating
        turn = 0.0
        if belt.rotating:  # the belt's accumulated angle restarts at 0 with every rotation
            turn = belt.accumulated_angle_rad - (self._belt_angle if self._was_rotating else 0.0)
            self._belt_angle = belt.accumulated_angle_rad
        self._was_rotating = belt.rotating
        self._walk_dir = wrap_angle(self._walk_dir + turn - own_omega * dt)
        if belt.activity in ("stop", "rest"):
            c, s = math.cos(bearing), math.sin(bearing)
            radial = user_vel[0] * c + user_vel[1] * s
            if abs(radial) < cfg.walk_speed_mps:
                return (0.0, 0.0), False
            return (radial * c, radial * s), True
        if speed > cfg.walk_speed_mps and not belt.rotating:
            track = math.atan2(user_vel[1], user_vel[0])
            k = min(1.0, cfg.heading_blend_rps * dt) if self._trusted else 1.0
            self._walk_dir = wrap_angle(self._walk_dir + k * wrap_angle(track - self._walk_dir))
            self._trusted = True
        return (speed * math.cos(self._walk_dir), speed * math.sin(self._walk_dir)), True

    def _arc_in_place(self, belt: BeltView, off: float, user_pos: tuple[float, float],
                      own_velocity: tuple[float, float, float], dt: float) -> float | None:
        """Leading, the user turning on the spot: the moving arc that synchronises the robot with the
        rotation (seed 002 §3.4: "the robot must know the rotation state, angular speed, and
        accumulated angle of the human to synchronize with their rotation"; §4.3, Table 4). While the
        belt reports a rotation the robot's place about the user turns at the user's angular speed,
        and the arc it has made so far (dead-reckoned from its odometry about the tracked user) is
        closed on the belt's accumulated angle at ``arc_sync_gain``; once the rotation ends, the rest
        of the accumulated angle is closed the same way, until the arc comes to rest. A robot ahead of
        its user turns with them; one beside or behind is met by the turn (its share ``max(0, cos
        off)`` is fixed when the rotation starts). None when there is no such rotation, and as soon as
        the belt says the user walks: the arc about a walking user cannot be dead-reckoned from the
        robot's own motion, and the LF track and the walking direction take over."""
        cfg = self.cfg
        if belt.activity in ("walk", "run"):
            self._sync, self._was_rotating_arc = None, belt.rotating
            return None
        if belt.rotating and not (self._sync is not None and self._was_rotating_arc):
            # a new rotation (the belt's angle restarts at 0): the robot's place before it (ψ has turned already)
            self._sync = [max(0.0, math.cos(off + belt.accumulated_angle_rad)), 0.0]
        self._was_rotating_arc = belt.rotating
        if self._sync is None:
            return None
        share, done = self._sync
        ux, uy = user_pos
        rate = (uy * own_velocity[0] - ux * own_velocity[1]) / (ux * ux + uy * uy)  # place −user_pos: p × v / |p|²
        done += rate * dt
        self._sync[1] = done
        gap = share * belt.accumulated_angle_rad - done
        settle = math.radians(cfg.arc_sync_done_deg)
        if not belt.rotating and abs(gap) < settle and abs(rate) < cfg.arc_sync_gain * settle:
            self._sync = None  # synchronised: at the accumulated angle, and the arc has come to rest
            return None
        return share * (belt.angular_speed_rps if belt.rotating else 0.0) + cfg.arc_sync_gain * gap

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
        """(Vx, Vy, ω) body-frame command. ``user_pos``/``user_vel`` in the body frame (tracker),
        ``own_velocity`` the robot's odometry (Vx, Vy, ω)."""
        cfg = self.cfg
        ux, uy = user_pos
        r = math.hypot(ux, uy)
        if r < 1e-6:
            return 0.0, 0.0, 0.0
        nx, ny = ux / r, uy / r  # unit vector toward the user
        bearing = math.atan2(uy, ux)
        (wx, wy), walking = self.user_velocity(user_vel, belt, own_velocity[2], mode, bearing, dt)
        psi = self._walk_dir
        band = math.radians(cfg.rotate_deadband_deg)

        def beyond(a: float) -> float:  # an angle beyond the deadband
            return a - max(-band, min(band, a))

        # 1. ACC: keep pace with the user; distance control far from the target, gentle near it
        err = r - target_distance_m
        gain = cfg.distance_gain if abs(err) > cfg.acc_band_m else cfg.speed_gain
        vx, vy = wx + gain * err * nx, wy + gain * err * ny
        # 2. per mode: the robot's place about the user turns at ``swing`` (rad/s, CCW)
        arc = swing = 0.0
        if mode == "leading":  # straight ahead of the user
            off = wrap_angle(bearing + math.pi - psi)  # the robot's place about the user from straight ahead
            sync = self._arc_in_place(belt, off, (ux, uy), own_velocity, dt) if self._trusted else None
            if sync is not None:  # the user turns on the spot: the arc closes on the accumulated angle
                arc = swing = sync
            elif self._trusted:
                if belt.rotating:  # the arc: a robot ahead of its user turns with the user; one beside
                    arc = belt.angular_speed_rps * max(0.0, math.cos(off))  # or behind is met by the turn
                swing = arc - cfg.arc_gain * math.sin(beyond(off))  # and closes on straight ahead
        elif walking:  # following: drift in behind the walking user
            swing = -cfg.trail_rps * math.sin(wrap_angle(bearing - psi))
        vx += swing * uy  # the robot's place relative to the user, −user_pos, turns at ``swing``
        vy += -swing * ux
        if mode == "leading" and not belt.rotating and abs(bearing) > self.half_angle:
            vy += cfg.sideways_gain * uy  # move sideways until the user is back inside ±25°
        # 3. heading: face the user
        if mode == "leading":  # drive backwards along the user's walk, the user kept inside the region
            lim = self.half_angle - band
            w = arc + cfg.rotate_gain * min(bearing + lim, max(bearing - lim, beyond(wrap_angle(psi - math.pi))))
        else:  # turn with the line of sight (from the odometry) and correct beyond the deadband
            w = (ux * (wy - own_velocity[1]) - uy * (wx - own_velocity[0])) / (r * r)
            w += cfg.rotate_gain * beyond(bearing)
        return vx, vy, w
