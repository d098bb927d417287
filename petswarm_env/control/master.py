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
   arc about the user at the user's angular speed (seed 002 §3.4, Table 4; a walking user's, at most
   :data:`LEADING_ARC_MAX_RPS`, the rate its formation can follow); for a user turning on
   the spot, the arc it has made is closed on the belt's accumulated angle at ``arc_sync_gain``,
   never faster than it can stop within the rest of that angle (``arc_brake_mps2``)
   (:meth:`MasterController._arc_in_place`); otherwise a remaining angle between its place and
   straight ahead is closed at ``arc_gain``; when the user leaves ±25° and
   is not rotating, the robot corrects sideways (Vy). The leading robot drives backwards along the
   user's walking direction (its heading follows ψ, never turning the user out of the reliable
   region), so keeping pace costs one wheel axis only;
3. **safety** — last, in the control arbiter (:mod:`petswarm_env.control.arbiter`).

Every robot faces its user in both modes (the LF antennas must see the belt inside ±25°); a leading
robot drives backwards, which a mecanum robot does as easily as forwards.

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): the belt's view,
the tracker and the controller are typed classes whose arithmetic runs on C doubles (the master, every
control period). cos, sin, atan2 and sqrt are the C library's, as ``math``'s are; ``math.hypot`` is
CPython's own algorithm (not the C library's hypot), so it stays a call of ``math.hypot``.
The three classes are declared in ``master.pxd``: the user session (``middleware/user_session.py``) reads
and calls them by C reads and C calls.
"""

from __future__ import annotations

import math

import cython
from cython.cimports.libc.math import atan2 as _c_atan2
from cython.cimports.libc.math import cos as _c_cos
from cython.cimports.libc.math import sin as _c_sin
from cython.cimports.libc.math import sqrt as _c_sqrt

from petswarm_env.config import MasterConfig

if cython.compiled:  # the angle wrap of one float as a C call (sim/geometry.pxd)
    from cython.cimports.petswarm_env.sim.geometry import wrap_float
else:
    from petswarm_env.sim.geometry import wrap_float

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)


@cython.cfunc
def _pose_axes(pose: list) -> tuple[cython.double, cython.double, cython.double, cython.double]:
    """Own dead-reckoned position and the cosine and sine of own heading, from ``pose`` (x, y, yaw)."""
    th: cython.double = pose[2]
    x: cython.double = pose[0]
    y: cython.double = pose[1]
    return x, y, _c_cos(th), _c_sin(th)

_hypot = math.hypot  # CPython's own (not the C library's hypot)
_PI = math.pi

# Chosen: the fastest a leading swarm turns about its WALKING user (rad/s): the master's arc and the
# slaves' arc driving (seed 000 §3.6.3, baselines/leader_follower.py step 4) follow the belt's rate up
# to this, and the rest of the turn is closed afterwards (``arc_gain``). The leading wedge stands up to
# 2 m from its user (the master at 1.7 m, the arms' rear ends 1 m to either side of the user): a user
# walking a turn at 60°/s, 1 m/s (radius 0.95 m) asks 2.0 m/s of the master and of the outer rear
# slave (1.95 m from the turn's centre) and 1.75 m/s of the outer front slave, beyond the 1.5 m/s
# wheels (|Vx| + |Vy| + L·|ω|). Asked anyway, every wheel command is scaled down together: the master
# lost its pace with the user too, who walked into the formation (0.3-0.7 m inside the master's
# distance), and the slaves, arcing at the full rate, outran the master's frame. At 0.3 rad/s the outer
# robots add about 0.6 m/s across the walk. Measured on the zigzag (leading, seeds 200-219 and
# 100-119, docs/faults.md): formation hold RMSE 0.35 and 0.37 m at the belt's full rate.
LEADING_ARC_MAX_RPS = 0.3


@cython.cclass
class BeltView:
    """What the master last heard from the belt over BLE (seed 002 §3.4)."""

    # its typed attributes are declared in ``master.pxd``

    def __init__(self, activity: str = "stop", rotating: bool = False, angular_speed_rps: float = 0.0,
                 accumulated_angle_rad: float = 0.0, time_s: float = 0.0):
        self.activity = activity
        self.rotating = rotating
        self.angular_speed_rps = angular_speed_rps
        self.accumulated_angle_rad = accumulated_angle_rad
        self.time_s = time_s

    def __repr__(self) -> str:
        return (f"BeltView(activity={self.activity!r}, rotating={self.rotating!r}, angular_speed_rps={self.angular_speed_rps!r}, "
                f"accumulated_angle_rad={self.accumulated_angle_rad!r}, time_s={self.time_s!r})")


@cython.cclass
class UserTracker:
    """Alpha–beta tracker of the user in the robot's odometry frame.

    The robot dead-reckons its own pose from wheel odometry and its AHRS yaw; each LF fix (user
    position in the body frame) becomes a point in that frame, and the tracker smooths position and
    velocity between fixes. Queries return the user's predicted position and velocity in the body
    frame now.
    """

    # its typed attributes are declared in ``master.pxd``

    def __init__(self, alpha: float, beta: float):
        self.alpha, self.beta = alpha, beta
        self.reset()

    @cython.ccall
    def reset(self, yaw_rad: cython.double = 0.0):
        """Forget the user; the odometry frame starts here, at the robot's AHRS reading ``yaw_rad``
        (the AHRS counts from its own power-on heading: a fix taken before the next :meth:`move`
        must be placed with the robot's current reading, not with 0)."""
        self.pose = [0.0, 0.0, yaw_rad]  # own x, y (odometry frame) and AHRS yaw
        self.pos = None
        self.vel = [0.0, 0.0]
        self.t_fix = 0.0
        self.last_fix_s = -math.inf

    @cython.ccall
    def move(self, odometry, yaw: cython.double, dt: cython.double):
        """Dead-reckon own pose over one control period (odometry in the body frame)."""
        pose: list = self.pose
        x: cython.double
        y: cython.double
        c: cython.double
        s: cython.double
        x, y, c, s = _pose_axes(pose)
        vx: cython.double = odometry[0]
        vy: cython.double = odometry[1]
        pose[0] = x + (c * vx - s * vy) * dt
        pose[1] = y + (s * vx + c * vy) * dt
        pose[2] = yaw

    @cython.ccall
    def move_without_ahrs(self, odometry, dt: cython.double):
        """:meth:`move` for a robot that found its AHRS broken (middleware/diagnosis.py): its heading
        dead-reckoned from its wheel odometry's ω (seed 001's mecanum odometry; a frozen AHRS would
        leave the odometry frame unturned while the robot turns, and the user's track with it)."""
        w: cython.double = odometry[2]
        th: cython.double = self.pose[2]
        self.move(odometry, th + w * dt, dt)

    @cython.ccall
    def fix(self, body_xy, t: cython.double, weight: cython.double = 1.0):
        """Take an LF fix (body frame) made at ``t``; ``weight`` < 1 trusts a noisier fix less."""
        x: cython.double
        y: cython.double
        c: cython.double
        s: cython.double
        x, y, c, s = _pose_axes(self.pose)
        bx: cython.double = body_xy[0]
        by: cython.double = body_xy[1]
        zx: cython.double = x + c * bx - s * by
        zy: cython.double = y + s * bx + c * by
        if self.pos is None:
            self.pos = [zx, zy]
        else:
            dt: cython.double = max(t - self.t_fix, 1e-3)
            vx: cython.double = self.vel[0]
            vy: cython.double = self.vel[1]
            ux: cython.double = self.pos[0]
            uy: cython.double = self.pos[1]
            px: cython.double = ux + vx * dt
            py: cython.double = uy + vy * dt
            rx: cython.double = zx - px
            ry: cython.double = zy - py
            a: cython.double = self.alpha * weight
            b: cython.double = self.beta * weight
            self.pos = [px + a * rx, py + a * ry]
            self.vel = [vx + b * rx / dt, vy + b * ry / dt]
        self.t_fix = t
        self.last_fix_s = t

    @cython.ccall
    def user_body(self, t: cython.double):
        """(position, velocity) of the user in the body frame now, or None before the first fix."""
        if self.pos is None:
            return None
        x: cython.double
        y: cython.double
        c: cython.double
        s: cython.double
        x, y, c, s = _pose_axes(self.pose)
        ux: cython.double = self.pos[0]
        uy: cython.double = self.pos[1]
        vx: cython.double = self.vel[0]
        vy: cython.double = self.vel[1]
        dt: cython.double = t - self.t_fix
        wx: cython.double = ux + vx * dt - x
        wy: cython.double = uy + vy * dt - y
        return (c * wx + s * wy, -s * wx + c * wy), (c * vx + s * vy, -s * vx + c * vy)


@cython.cfunc
@cython.inline
def _beyond(a: cython.double, band: cython.double) -> cython.double:
    """An angle beyond the deadband ``±band``."""
    return a - max(-band, min(band, a))


@cython.cclass
class MasterController:
    """Seed 002 Fig. 13 for one robot: ``command`` maps the tracked user and the belt's report to
    (Vx, Vy, ω) in the body frame. State: the walking direction ψ (body frame) and the belt's
    accumulated angle at the last step."""

    # its typed attributes are declared in ``master.pxd``

    def __init__(self, cfg: MasterConfig, reliable_half_angle_rad: float):
        self.cfg = cfg
        self.half_angle = reliable_half_angle_rad
        self.reset()

    @property
    def cfg(self) -> MasterConfig:
        return self._cfg

    @cfg.setter
    def cfg(self, cfg: MasterConfig) -> None:
        self._cfg = cfg
        self._walk_speed, self._blend = cfg.walk_speed_mps, cfg.heading_blend_rps
        self._band, self._acc_band = math.radians(cfg.rotate_deadband_deg), cfg.acc_band_m
        self._distance_gain, self._speed_gain = cfg.distance_gain, cfg.speed_gain
        self._arc_gain, self._trail, self._sideways_gain = cfg.arc_gain, cfg.trail_rps, cfg.sideways_gain
        self._rotate_gain = cfg.rotate_gain
        self._settle, self._sync_gain = math.radians(cfg.arc_sync_done_deg), cfg.arc_sync_gain
        self._brake = cfg.arc_brake_mps2

    @cython.ccall
    def reset(self):
        self._walk_dir, self._has_walk_dir = 0.0, False
        self._trusted = False
        self._belt_angle = 0.0
        self._was_rotating = False
        self._syncing, self._share, self._done = False, 0.0, 0.0
        self._was_rotating_arc = False

    @property
    def walk_direction_rad(self) -> float | None:
        """ψ, the user's walking direction in the body frame (None before the first command)."""
        return self._walk_dir if self._has_walk_dir else None

    def know_walk_direction(self, walk_dir_rad: float) -> None:
        """Start from ψ = ``walk_dir_rad`` (body frame), a direction the robot knows itself — a new
        master's own estimate of the way its user walks (seed 002 §3.3-3.4: the old master drove along
        it; :func:`~petswarm_env.middleware.succession.walk_direction`) — instead of the first command's
        guess (that the user faces the robot in leading, walks away from it in following). It steers at
        once (the leading robot closes its place on straight ahead); the LF track then pulls it at
        ``heading_blend_rps``."""
        self._walk_dir, self._has_walk_dir, self._trusted = wrap_float(walk_dir_rad), True, True

    @cython.ccall
    def user_velocity(self, user_vel, belt: BeltView, own_omega: cython.double, mode: str,
                      bearing: cython.double, dt: cython.double) -> tuple:
        """The user's velocity (body frame) and whether they walk.

        While the belt says Walk / Run: the tracked speed along ψ, a complementary filter — ψ turns
        with the increments of the belt's accumulated rotation angle (fast, seed 002 §3.4) and,
        while the user walks straight, is pulled toward the track's direction at
        ``heading_blend_rps`` (slow, noisy); the first track replaces the initial guess (the user
        faces the robot in leading, away from it in following). While the belt says Stop / Rest the
        user stands — unless the track's component along the line of sight (the accurate LF range)
        is already walking speed: the belt's activity window lags the start of a walk by about a
        second."""
        vx: cython.double = user_vel[0]
        vy: cython.double = user_vel[1]
        speed: cython.double = _hypot(vx, vy)
        if not self._has_walk_dir:
            self._walk_dir = wrap_float(bearing + _PI) if mode == "leading" else bearing
            self._has_walk_dir = True
            self._trusted = belt.activity in ("stop", "rest") and not belt.rotating
        turn: cython.double = 0.0
        if belt.rotating:  # the belt's accumulated angle restarts at 0 with every rotation
            turn = belt.accumulated_angle_rad - (self._belt_angle if self._was_rotating else 0.0)
            self._belt_angle = belt.accumulated_angle_rad
        self._was_rotating = belt.rotating
        self._walk_dir = wrap_float(self._walk_dir + turn - own_omega * dt)
        if belt.activity in ("stop", "rest"):
            c: cython.double = _c_cos(bearing)
            s: cython.double = _c_sin(bearing)
            radial: cython.double = vx * c + vy * s
            if abs(radial) < self._walk_speed:
                return (0.0, 0.0), False
            return (radial * c, radial * s), True
        if speed > self._walk_speed and not belt.rotating:
            track: cython.double = _c_atan2(vy, vx)
            k: cython.double = min(1.0, self._blend * dt) if self._trusted else 1.0
            self._walk_dir = wrap_float(self._walk_dir + k * wrap_float(track - self._walk_dir))
            self._trusted = True
        return (speed * _c_cos(self._walk_dir), speed * _c_sin(self._walk_dir)), True

    @cython.cfunc
    def _arc_in_place(self, belt: BeltView, off: cython.double, ux: cython.double, uy: cython.double,
                      own_velocity, dt: cython.double):
        """Leading, the user turning on the spot: the moving arc that synchronises the robot with the
        rotation (seed 002 §3.4: "the robot must know the rotation state, angular speed, and
        accumulated angle of the human to synchronize with their rotation"; §4.3, Table 4). While the
        belt reports a rotation the robot's place about the user (at ``(ux, uy)``) turns at the user's
        angular speed, and the arc it has made so far (dead-reckoned from its odometry about the
        tracked user) is closed on the belt's accumulated angle at ``arc_sync_gain``; once the
        rotation ends, the rest of the accumulated angle is closed the same way, until the arc comes
        to rest. The arc is never faster than the robot can stop within the rest of the angle at
        ``arc_brake_mps2``: the robot arcs at ~1 m/s when the user stops, and the belt's filtered rate
        keeps feeding the arc for half a second, so unplanned it passed the angle by ~6° on a 90° turn
        and came back, ending on the far side (the simulated robot over-rotated where the paper's
        under-rotates). A robot ahead of its user turns with them; one beside or behind is met by the
        turn (its share ``max(0, cos off)`` is fixed when the rotation starts). None when there is no
        such rotation, and as soon as the belt says the user walks: the arc about a walking user
        cannot be dead-reckoned from the robot's own motion, and the LF track and the walking
        direction take over."""
        if belt.activity in ("walk", "run"):
            self._syncing, self._was_rotating_arc = False, belt.rotating
            return None
        if belt.rotating and not (self._syncing and self._was_rotating_arc):
            # a new rotation (the belt's angle restarts at 0): the robot's place before it (ψ has turned already)
            self._syncing = True
            self._share, self._done = max(0.0, _c_cos(off + belt.accumulated_angle_rad)), 0.0
        self._was_rotating_arc = belt.rotating
        if not self._syncing:
            return None
        ox: cython.double = own_velocity[0]
        oy: cython.double = own_velocity[1]
        rate: cython.double = (uy * ox - ux * oy) / (ux * ux + uy * uy)  # place −user_pos: p × v / |p|²
        self._done += rate * dt
        gap: cython.double = self._share * belt.accumulated_angle_rad - self._done
        settle: cython.double = self._settle
        if not belt.rotating and abs(gap) < settle and abs(rate) < self._sync_gain * settle:
            self._syncing = False  # synchronised: at the accumulated angle, and the arc has come to rest
            return None
        rate_cmd: cython.double = self._share * (belt.angular_speed_rps if belt.rotating else 0.0) + self._sync_gain * gap
        # never faster than the arc can still stop within the gap: v² = 2·a·s, s = r·|gap|, rate = v / r
        brake: cython.double = _c_sqrt(2.0 * self._brake * abs(gap) / _hypot(ux, uy))
        return min(rate_cmd, brake) if gap >= 0.0 else max(rate_cmd, -brake)

    @cython.ccall
    def command(
        self,
        user_pos,
        user_vel,
        belt: BeltView,
        own_velocity,
        mode: str,
        target_distance_m: cython.double,
        dt: cython.double,
    ) -> tuple:
        """(Vx, Vy, ω) body-frame command. ``user_pos``/``user_vel`` in the body frame (tracker),
        ``own_velocity`` the robot's odometry (Vx, Vy, ω)."""
        ux: cython.double = user_pos[0]
        uy: cython.double = user_pos[1]
        r: cython.double = _hypot(ux, uy)
        if r < 1e-6:
            return 0.0, 0.0, 0.0
        nx: cython.double = ux / r  # unit vector toward the user
        ny: cython.double = uy / r
        bearing: cython.double = _c_atan2(uy, ux)
        (wx, wy), walking = self.user_velocity(user_vel, belt, own_velocity[2], mode, bearing, dt)
        return self._command(ux, uy, r, nx, ny, bearing, wx, wy, walking, belt, own_velocity, mode == "leading",
                             target_distance_m, dt)

    @cython.cfunc
    def _command(self, ux: cython.double, uy: cython.double, r: cython.double, nx: cython.double, ny: cython.double,
                 bearing: cython.double, wx: cython.double, wy: cython.double, walking: cython.bint, belt: BeltView,
                 own_velocity, leading: cython.bint, target_distance_m: cython.double, dt: cython.double) -> tuple:
        """Fig. 13's three stages on the user's place (``ux, uy``: at ``r``, along ``nx, ny``, at ``bearing``) and
        velocity (``wx, wy``) in the body frame."""
        psi: cython.double = self._walk_dir
        band: cython.double = self._band
        # 1. ACC: keep pace with the user; distance control far from the target, gentle near it
        err: cython.double = r - target_distance_m
        gain: cython.double = self._distance_gain if abs(err) > self._acc_band else self._speed_gain
        vx: cython.double = wx + gain * err * nx
        vy: cython.double = wy + gain * err * ny
        # 2. per mode: the robot's place about the user turns at ``swing`` (rad/s, CCW)
        arc: cython.double = 0.0
        swing: cython.double = 0.0
        if leading:  # straight ahead of the user
            off: cython.double = wrap_float(bearing + _PI - psi)  # the robot's place about the user from straight ahead
            sync = self._arc_in_place(belt, off, ux, uy, own_velocity, dt) if self._trusted else None
            if sync is not None:  # the user turns on the spot: the arc closes on the accumulated angle
                arc = swing = sync
            elif self._trusted:
                if belt.rotating:  # the arc: a robot ahead of its user turns with the user (at most at
                    rate: cython.double = max(-LEADING_ARC_MAX_RPS, min(LEADING_ARC_MAX_RPS, belt.angular_speed_rps))
                    arc = rate * max(0.0, _c_cos(off))  # the rate its formation can follow); one beside or behind is met by the turn
                swing = arc - self._arc_gain * _c_sin(_beyond(off, band))  # and closes on straight ahead
        elif walking:  # following: drift in behind the walking user
            swing = -self._trail * _c_sin(wrap_float(bearing - psi))
        vx += swing * uy  # the robot's place relative to the user, −user_pos, turns at ``swing``
        vy += -swing * ux
        if leading and not belt.rotating and abs(bearing) > self.half_angle:
            vy += self._sideways_gain * uy  # move sideways until the user is back inside ±25°
        # 3. heading: face the user
        w: cython.double
        if leading:  # drive backwards along the user's walk, the user kept inside the region
            lim: cython.double = self.half_angle - band
            w = arc + self._rotate_gain * min(bearing + lim, max(bearing - lim, _beyond(wrap_float(psi - _PI), band)))
        else:  # turn with the line of sight (from the odometry) and correct beyond the deadband
            ox: cython.double = own_velocity[0]
            oy: cython.double = own_velocity[1]
            w = (ux * (wy - oy) - uy * (wx - ox)) / (r * r)
            w += self._rotate_gain * _beyond(bearing, band)
        return vx, vy, w
