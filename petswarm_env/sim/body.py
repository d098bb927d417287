"""Round bodies in the pymunk space: the position/heading base of robots and users.

This is the only module that touches pymunk's Chipmunk objects (``body._body`` and the
``pymunk.cp`` accessors). Every read of a position, heading or velocity and every velocity write of
the simulation goes through :class:`Body` (a robot, :mod:`.robot`, and a user, :mod:`.user`, are
bodies) or :func:`read_poses` (the world's truth arrays). They call Chipmunk's accessors directly
instead of pymunk's Python properties, which build a ``Vec2d`` and go through a typing
``__setattr__`` on every access: the same C calls, a fraction of the cost, which matters for the
per-substep drive and the radio's antenna positions.

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): :class:`Body`
and :class:`DrivenBody` are typed classes (a robot and a user are Python subclasses of them), the
drive's arithmetic per substep runs on C doubles.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial

import cython
import pymunk
from cython.cimports.libc.math import cos as _c_cos
from cython.cimports.libc.math import fabs as _c_fabs
from cython.cimports.libc.math import frexp as _c_frexp
from cython.cimports.libc.math import isinf as _c_isinf
from cython.cimports.libc.math import isnan as _c_isnan
from cython.cimports.libc.math import ldexp as _c_ldexp
from cython.cimports.libc.math import sin as _c_sin
from cython.cimports.libc.math import sqrt as _c_sqrt

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_get_position = pymunk.cp.cpBodyGetPosition
_get_angle = pymunk.cp.cpBodyGetAngle
_get_velocity = pymunk.cp.cpBodyGetVelocity
_get_angular_velocity = pymunk.cp.cpBodyGetAngularVelocity
_set_velocity = pymunk.cp.cpBodySetVelocity
_set_angular_velocity = pymunk.cp.cpBodySetAngularVelocity
_radians = math.radians
_hypot = math.hypot  # Python's own (CPython's hypot is not the C library's): the interpreted form's, _py_hypot's oracle

if cython.compiled:  # the clock's run_until by a C call (sim/clock.pxd)
    from cython.cimports.petswarm_env.sim.clock import Clock
else:
    from petswarm_env.sim.clock import Clock

if cython.compiled:  # Chipmunk's accessors by their C addresses (declared in body.pxd)
    def _address(name: str) -> int:
        return int(pymunk.ffi.cast("uintptr_t", pymunk.ffi.addressof(pymunk.cp, name)))

    _cp_get_position = cython.cast(_GetVec, cython.cast(cython.size_t, _address("cpBodyGetPosition")))
    _cp_get_angle = cython.cast(_GetDbl, cython.cast(cython.size_t, _address("cpBodyGetAngle")))
    _cp_get_velocity = cython.cast(_GetVec, cython.cast(cython.size_t, _address("cpBodyGetVelocity")))
    _cp_get_angular_velocity = cython.cast(_GetDbl, cython.cast(cython.size_t, _address("cpBodyGetAngularVelocity")))
    _cp_set_velocity = cython.cast(_SetVec, cython.cast(cython.size_t, _address("cpBodySetVelocity")))
    _cp_set_angular_velocity = cython.cast(_SetDbl, cython.cast(cython.size_t, _address("cpBodySetAngularVelocity")))
    _cp_space_step = cython.cast(_SpaceStep, cython.cast(cython.size_t, _address("cpSpaceStep")))


# One accessor each for what the drive and the radio read and write of a body: Chipmunk's own
# functions, called directly in the compiled form and through pymunk's cffi module otherwise.
@cython.cfunc
@cython.inline
def _pos(b: Body) -> tuple[cython.double, cython.double]:
    if cython.compiled:
        p = _cp_get_position(cython.cast(cython.p_void, b._cp))
        return (p.x, p.y)
    q = _get_position(b._cbody)
    return (q.x, q.y)


@cython.cfunc
@cython.inline
def _angle(b: Body) -> cython.double:
    if cython.compiled:
        return _cp_get_angle(cython.cast(cython.p_void, b._cp))
    return _get_angle(b._cbody)


@cython.cfunc
@cython.inline
def _vel(b: Body) -> tuple[cython.double, cython.double]:
    if cython.compiled:
        v = _cp_get_velocity(cython.cast(cython.p_void, b._cp))
        return (v.x, v.y)
    w = _get_velocity(b._cbody)
    return (w.x, w.y)


@cython.cfunc
@cython.inline
def _omega(b: Body) -> cython.double:
    if cython.compiled:
        return _cp_get_angular_velocity(cython.cast(cython.p_void, b._cp))
    return _get_angular_velocity(b._cbody)


@cython.cfunc
@cython.inline
def _set_vel(b: Body, x: cython.double, y: cython.double) -> cython.void:
    if cython.compiled:
        v: cpVect
        v.x = x
        v.y = y
        _cp_set_velocity(cython.cast(cython.p_void, b._cp), v)
    else:
        _set_velocity(b._cbody, (x, y))


@cython.cfunc
@cython.inline
def _set_omega(b: Body, w: cython.double) -> cython.void:
    if cython.compiled:
        _cp_set_angular_velocity(cython.cast(cython.p_void, b._cp), w)
    else:
        _set_angular_velocity(b._cbody, w)


@cython.cfunc
@cython.inline
@cython.exceptval(check=False)
def _square_error(v: cython.double, hi: cython.double) -> cython.double:
    """The rounding error of ``hi = v * v``, exactly (Dekker's product with Veltkamp's split, as
    ``fma(v, v, -hi)`` gives it): ``v`` must be below 2^996 (here |v| < 1)."""
    c: cython.double = 134217729.0 * v  # 2^27 + 1
    vh: cython.double = c - (c - v)
    vl: cython.double = v - vh
    return ((vh * vh - hi) + 2.0 * vh * vl) + vl * vl


@cython.cfunc
@cython.inline
@cython.exceptval(check=False)
def _py_hypot(x: cython.double, y: cython.double) -> cython.double:
    """``math.hypot(x, y)`` bit for bit, in C: CPython's ``vector_norm`` (Modules/mathmodule.c,
    3.11) for two coordinates, which is not the C library's ``hypot`` — a lossless scaling by a
    power of two, exact squares, a compensated sum and one differential correction of the square
    root. The interpreted form calls ``math.hypot`` itself (the oracle: tests/unit/test_body.py
    holds the two to each other)."""
    if not cython.compiled:
        return _hypot(x, y)
    ax: cython.double = _c_fabs(x)
    ay: cython.double = _c_fabs(y)
    mx: cython.double = 0.0  # max(|x|, |y|) as CPython finds it (a NaN is never the max)
    if ax > mx:
        mx = ax
    if ay > mx:
        mx = ay
    if _c_isinf(mx):
        return mx
    if _c_isnan(ax) or _c_isnan(ay):
        return math.nan
    if mx == 0.0:
        return mx
    e: cython.int
    _c_frexp(mx, cython.address(e))
    if e < -1023:  # subnormal (ldexp(1.0, -e) would overflow): CPython's own, never met by a body's speed
        return _hypot(x, y)
    scale: cython.double = _c_ldexp(1.0, -e)
    csum: cython.double = 1.0
    frac1: cython.double = 0.0
    frac2: cython.double = 0.0
    v: cython.double
    hi: cython.double
    s: cython.double
    k: cython.int
    for k in range(2):
        v = (ax if k == 0 else ay) * scale  # lossless
        hi = v * v  # lossless squaring: (hi, its error)
        s = csum + hi  # lossless addition (csum >= hi): (s, (csum - s) + hi)
        frac1 += _square_error(v, hi)
        frac2 += (csum - s) + hi
        csum = s
    h: cython.double = _c_sqrt(csum - 1.0 + (frac1 + frac2))
    hi = -h * h  # dl_mul(-h, h): its error is minus that of h * h
    s = csum + hi
    frac1 -= _square_error(h, -hi)
    frac2 += (csum - s) + hi
    csum = s
    h += (csum - 1.0 + (frac1 + frac2)) / (2.0 * h)  # differential correction
    return h / scale


def hypot(x: float, y: float) -> float:
    """:func:`_py_hypot` for Python callers (its test)."""
    return _py_hypot(x, y)


COLLISION_ROBOT = 1
COLLISION_USER = 2
COLLISION_WALL = 3


@cython.cclass
class Body:
    """A circle in the pymunk space: a dynamic body of ``mass_kg`` (a robot), or a kinematic one
    (``mass_kg=None``: a user, who bumps robots and does not yield). ``body`` and ``shape`` are the
    pymunk objects (moving ``body.position`` by hand is allowed; tell the world, see
    :meth:`~.world.World.invalidate_truth`)."""

    def __init__(self, space: pymunk.Space, position, heading_rad: float, radius_m: float, collision_type: int,
                 mass_kg: float | None = None, friction: float | None = None, elasticity: float | None = None):
        if mass_kg is None:
            self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        else:
            self.body = pymunk.Body(mass_kg, pymunk.moment_for_circle(mass_kg, 0, radius_m))
        self.body.position = tuple(position)
        self.body.angle = heading_rad
        self.shape = pymunk.Circle(self.body, radius_m)
        self.shape.collision_type = collision_type
        if friction is not None:
            self.shape.friction = friction
        if elasticity is not None:
            self.shape.elasticity = elasticity
        self._cbody = self.body._body  # the Chipmunk body behind self.body
        if cython.compiled:
            self._cp = int(pymunk.ffi.cast("uintptr_t", self._cbody))  # its address (body.pxd)

    @property
    def position(self) -> tuple[float, float]:
        """True position of the centre (m), world frame."""
        return _pos(self)

    def read_position(self) -> tuple[float, float]:
        """:attr:`position` as a method, for a caller that binds it once (a radio station's
        antenna position, read for every frame it sends or receives)."""
        return _pos(self)

    @property
    def heading(self) -> float:
        """True heading (rad, counter-clockwise from +x; not wrapped)."""
        return _angle(self)

    @cython.cfunc
    def _read_heading(self) -> cython.double:
        """:attr:`heading` as a C call (body.pxd), for a sensor that reads it many times a step (the AHRS)."""
        return _angle(self)

    def heading_reader(self) -> Callable[[], float]:
        """A function of no argument that returns :attr:`heading`: Chipmunk's accessor bound to
        this body (a C-level partial, no Python frame per call), for a sensor that reads the
        heading many times a step (the AHRS)."""
        return partial(_get_angle, self._cbody)

    @property
    def turn_rate_rps(self) -> float:
        """True angular velocity (rad/s, counter-clockwise)."""
        return _omega(self)

    def set_velocity(self, velocity: tuple[float, float], omega: float) -> None:
        """Give the body a world-frame velocity (m/s) and angular velocity (rad/s). Only a changed
        value is written: the same state as writing it again."""
        vx: cython.double
        vy: cython.double
        vx, vy = velocity
        wx: cython.double
        wy: cython.double
        wx, wy = _vel(self)
        if vx != wx or vy != wy:
            _set_vel(self, vx, vy)
        if omega != _omega(self):
            _set_omega(self, omega)


@cython.cclass
class DrivenBody(Body):
    """A dynamic body driven by an own-frame velocity command under acceleration limits (a robot's
    motors): :meth:`apply`, every physics substep, moves the achieved velocity toward
    :attr:`command` by at most ``max_accel_mps2``·dt and ``max_alpha_rps2``·dt and writes it to the
    body (contacts may still change it during the substep). The motors' own speed (``_wheels``)
    follows the command under the same limits from its own previous value, whatever the body does;
    ``battery`` (a robot's :class:`~.battery.Battery`, or None) is drained after every substep,
    and an empty battery stops the body."""

    def __init__(self, space: pymunk.Space, position, heading_rad: float, radius_m: float, collision_type: int,
                 mass_kg: float, max_accel_mps2: float, max_alpha_rps2: float, **shape: float):
        super().__init__(space, position, heading_rad, radius_m, collision_type, mass_kg=mass_kg, **shape)
        self.command = (0.0, 0.0, 0.0)  # own-frame (vx m/s, vy m/s, ω rad/s) to reach
        self.velocity_body = (0.0, 0.0, 0.0)  # the achieved own-frame velocity after the last apply
        self._accel = (max_accel_mps2, max_alpha_rps2)
        self._limits_dt = -1.0  # the substep length the limits below were computed for
        self._max_dv = self._max_dw = 0.0
        self._wheels = (0.0, 0.0, 0.0)  # the motors' own-frame speed (a robot's wheel_velocity)
        self.battery = None  # a robot's Battery (robot.py), drained at every substep
        self.wheel_gain = 1.0  # what the wheel encoders count over the motors' speed (a slipping robot's 1 / (1 − slip), robot.py)
        self.readings = None  # a robot's software's view of its ring's readings (middleware/node.py sets it)

    # The three velocity triples live in C doubles (read and written at every substep); Python sees
    # each as a tuple of floats, and setting one sets its three values.
    @property
    def command(self) -> tuple[float, float, float]:
        """The own-frame command (vx m/s, vy m/s, ω rad/s) the drive moves toward."""
        return (self._cx, self._cy, self._cw)

    @command.setter
    def command(self, value) -> None:
        self._cx, self._cy, self._cw = value

    @property
    def velocity_body(self) -> tuple[float, float, float]:
        """The achieved own-frame velocity (vx, vy, ω) after the last substep's drive."""
        return (self._vx, self._vy, self._vw)

    @velocity_body.setter
    def velocity_body(self, value) -> None:
        self._vx, self._vy, self._vw = value

    @property
    def _wheels(self) -> tuple[float, float, float]:
        """The motors' own-frame speed (vx, vy, ω)."""
        return (self._wx, self._wy, self._ww)

    @_wheels.setter
    def _wheels(self, value) -> None:
        self._wx, self._wy, self._ww = value

    def apply(self, dt: float) -> None:
        """One substep of the drive (:meth:`_apply`), for a Python caller."""
        self._apply(dt)

    @cython.cfunc
    def _apply(self, dt: cython.double):
        """One substep of the drive (:meth:`_drive`), then the motors' own speed follows the command
        under the same limits — a shove or a wall moves the body, not the wheels (they slip) — then
        the battery's drain over the substep (an empty battery stops the body). A C method: the
        substeps call it without looking up a Python override (a robot is a Python subclass)."""
        self._drive(dt)
        wx: cython.double = self._wx
        wy: cython.double = self._wy
        ww: cython.double = self._ww
        cx: cython.double = self._cx
        cy: cython.double = self._cy
        cw: cython.double = self._cw
        dvx: cython.double = cx - wx
        dvy: cython.double = cy - wy
        dv: cython.double
        k: cython.double
        dw: cython.double
        max_dw: cython.double = self._max_dw
        if dvx != 0.0 or dvy != 0.0 or cw != ww:
            dv = _py_hypot(dvx, dvy)
            if dv > self._max_dv:
                k = self._max_dv / dv
                dvx *= k
                dvy *= k
            dw = cw - ww  # max(-max_dw, min(max_dw, cw - ww)) as Python's min and max give it (nan too)
            dw = dw if dw < max_dw else max_dw
            dw = dw if dw > -max_dw else -max_dw
            self._wx = wx + dvx
            self._wy = wy + dvy
            self._ww = ww + dw
        battery = self.battery
        if battery is not None:
            if battery.drain_at(dt, _py_hypot(self._vx, self._vy), self._vw):  # Battery.drain, its speed computed here
                self._cx = self._cy = self._cw = 0.0

    @cython.cfunc
    def _drive(self, dt: cython.double):
        """The drive of one substep (:meth:`_apply`'s first part): the achieved velocity toward the
        command, from the body's actual velocity (after the last step's contacts); sets
        :attr:`velocity_body`. Only a changed value is written to the body."""
        if dt != self._limits_dt:  # the per-substep limits, computed once per substep length
            self._limits_dt = dt
            self._max_dv = self._accel[0] * dt
            self._max_dw = self._accel[1] * dt
        th: cython.double = _angle(self)
        c: cython.double = _c_cos(th)  # the C library's, as math.cos
        s: cython.double = _c_sin(th)
        wx: cython.double
        wy: cython.double
        wx, wy = _vel(self)
        vx: cython.double = c * wx + s * wy
        vy: cython.double = -s * wx + c * wy
        w: cython.double = _omega(self)
        cx: cython.double = self._cx
        cy: cython.double = self._cy
        cw: cython.double = self._cw
        dvx: cython.double = cx - vx
        dvy: cython.double = cy - vy
        dv: cython.double = _py_hypot(dvx, dvy)
        max_dv: cython.double = self._max_dv
        k: cython.double
        if dv > max_dv:
            k = max_dv / dv
            dvx *= k
            dvy *= k
        vx += dvx
        vy += dvy
        max_dw: cython.double = self._max_dw
        dw: cython.double = cw - w  # clipped to [-max_dw, max_dw]
        if dw > max_dw:
            dw = max_dw
        elif dw < -max_dw:
            dw = -max_dw
        w_new: cython.double = w + dw
        self._vx = vx
        self._vy = vy
        self._vw = w_new
        # write only what changed (a body turning at its commanded rate, or driving straight at its
        # commanded speed, keeps its values): the same state as writing it again
        if w_new != w:
            _set_omega(self, w_new)
        vx_w: cython.double = c * vx - s * vy
        vy_w: cython.double = s * vx + c * vy
        if vx_w != wx or vy_w != wy:
            _set_vel(self, vx_w, vy_w)


@cython.cclass
class WalkingBody(Body):
    """A kinematic body walked on a script (a user, :mod:`.user`): :meth:`apply`, every physics
    substep, sets the velocity of the script's segment at the script's time along the body's own
    heading (the body integrates it). ``walking`` False: it stands (the script waits)."""

    def __init__(self, space: pymunk.Space, position, heading_rad: float, radius_m: float, collision_type: int, script):
        super().__init__(space, position, heading_rad, radius_m, collision_type)  # kinematic: does not yield
        self.script = script
        self.segment = script.segments[0]
        self.script_time_s = 0.0
        self.walking = False  # the script starts when the swarm is organized
        # not walking the script: stepping toward a point (toward_x, toward_y) at toward_mps, the heading kept
        # (a user going back to their robot at its alert, middleware/user_session.py)
        self.returning = False
        self.toward_x = self.toward_y = self.toward_mps = 0.0
        self.pending_commands = []  # commands the user issued (wearables pick them up)
        # the segment last taken from the script, until the script time at which it ends (ScenarioScript.segment_end_s),
        # with its speed and turn rate (rad/s): the script is asked again only then (or when script or segment is replaced)
        self._seg_script = None
        self._seg = None
        self._seg_end_s = -math.inf
        self._seg_speed = 0.0
        self._seg_w = 0.0

    def apply(self, dt: float) -> None:
        """One substep of the walk (:meth:`_apply`), for a Python caller."""
        self._apply(dt)

    @cython.cfunc
    def _apply(self, dt: cython.double):
        """Set this substep's velocity from the script; a segment that begins with a command
        issues it (:attr:`pending_commands`). A kinematic body keeps the velocity it was given, so
        only a changed value is written."""
        wx: cython.double
        wy: cython.double
        if not self.walking:
            if self.returning:
                self._step_toward()
                return
            wx, wy = _vel(self)
            if wx != 0.0 or wy != 0.0:
                _set_vel(self, 0.0, 0.0)
            if _omega(self) != 0.0:
                _set_omega(self, 0.0)
            return
        script = self.script
        if self.script_time_s >= self._seg_end_s or script is not self._seg_script or self.segment is not self._seg:
            seg = script.at(self.script_time_s)
            if seg is not self.segment and seg.command:
                self.pending_commands.append(seg.command)
            self.segment = seg
            self._seg_script, self._seg, self._seg_end_s = script, seg, script.segment_end_s()
            self._seg_speed, self._seg_w = seg.speed_mps, _radians(seg.turn_rate_dps)
        self.script_time_s += dt
        th: cython.double = _angle(self)
        speed: cython.double = self._seg_speed
        vx: cython.double = speed * _c_cos(th)  # the C library's, as math.cos
        vy: cython.double = speed * _c_sin(th)
        w: cython.double = self._seg_w
        wx, wy = _vel(self)
        if vx != wx or vy != wy:
            _set_vel(self, vx, vy)
        if w != _omega(self):
            _set_omega(self, w)


    @cython.cfunc
    def _step_toward(self):
        """Not walking the script: this substep's velocity toward ``(toward_x, toward_y)`` at ``toward_mps``,
        the heading kept (no turn)."""
        px, py = _pos(self)
        dx: cython.double = self.toward_x - px
        dy: cython.double = self.toward_y - py
        d: cython.double = _py_hypot(dx, dy)
        vx: cython.double = 0.0
        vy: cython.double = 0.0
        if d > 1e-9:
            vx, vy = self.toward_mps * dx / d, self.toward_mps * dy / d
        _set_vel(self, vx, vy)
        if _omega(self) != 0.0:
            _set_omega(self, 0.0)


@cython.cclass
class Substeps:
    """A world's physics substeps (:meth:`~.world.World.advance`): at each substep boundary the
    clock's pending events up to that instant (``run_until``), then every robot's drive
    (:meth:`DrivenBody._apply`), every user's walk (:meth:`WalkingBody._apply`) and one Chipmunk
    step of ``dt``. ``robots`` and ``users`` are the world's own lists (bodies added later are
    stepped too). Substep instants come from the integer count ``done`` (no float drift);
    ``steps`` counts the space's steps (the world's truth arrays are valid for one value).

    The compiled form calls Chipmunk's ``cpSpaceStep`` directly, doing what pymunk's
    ``Space.step`` does around it (its lock while Chipmunk runs the collision callbacks, then what
    they deferred): the same physics, without the wrapper's per-call Python work."""

    def __init__(self, space: pymunk.Space, clock: Clock, robots: list, users: list, dt: float):
        self.space = space
        self._clock = clock
        # what Space.step reads of the space besides Chipmunk's step: the space's own containers, made once in
        # its __init__ and changed in place (pymunk 7's space.py), and its threading, fixed at its creation
        self._bodies_to_check, self._removed_shapes = space._bodies_to_check, space._removed_shapes
        self._add_later, self._remove_later = space._add_later, space._remove_later
        self._post_step_callbacks, self._threaded = space._post_step_callbacks, space.threaded
        self.robots = robots
        self.users = users
        self.dt = dt
        self.done = 0
        self.steps = 0
        if cython.compiled:
            self._cspace = int(pymunk.ffi.cast("uintptr_t", space._space))  # alive as long as space

    @cython.ccall
    def run(self, n: cython.int) -> None:
        """``n`` substeps (class docstring)."""
        dt: cython.double = self.dt
        k: cython.int
        r: DrivenBody
        u: WalkingBody
        for k in range(n):
            self.done += 1
            self._clock.run_until(self.done * dt)
            for r in self.robots:
                r._apply(dt)
            for u in self.users:
                u._apply(dt)
            self._step(dt)
            self.steps += 1

    @cython.cfunc
    def _step(self, dt: cython.double) -> cython.void:
        """One step of the space: pymunk's ``Space.step`` (see the class docstring)."""
        space = self.space
        if not cython.compiled or self._bodies_to_check or self._threaded:
            space.step(dt)  # pymunk's own (it checks the bodies added since its last step)
            return
        space._locked = True
        try:
            _cp_space_step(cython.cast(cython.p_void, self._cspace), dt)
            if self._removed_shapes:
                self._removed_shapes.clear()
        finally:
            space._locked = False
        if self._add_later or self._remove_later or self._post_step_callbacks:
            _after_step(space)


def _after_step(space: pymunk.Space) -> None:
    """What pymunk's ``Space.step`` (pymunk 7) does after Chipmunk's step: add and remove what the
    collision callbacks deferred, then the post-step callbacks."""
    space.add(*space._add_later)
    space._add_later.clear()
    removed = set()
    while space._remove_later:
        to_remove, _ = space._remove_later.popitem()
        if to_remove not in removed:
            removed.add(to_remove)
            space._remove(to_remove)
    for key in space._post_step_callbacks:
        space._post_step_callbacks[key](space)
    space._post_step_callbacks.clear()


def read_poses(bodies: list, centers: cython.double[:, :], first: cython.Py_ssize_t, headings: cython.double[:] = None) -> None:
    """Write the centres (m) of ``bodies`` into rows ``first, first + 1, ...`` of ``centers`` (n, 2)
    and, unless ``headings`` is None, their headings (rad) into the same entries of ``headings``,
    read from Chipmunk in one pass (the world's truth arrays, once per physics step)."""
    b: Body
    i: cython.Py_ssize_t = first
    x: cython.double
    y: cython.double
    for b in bodies:
        x, y = _pos(b)
        centers[i, 0] = x
        centers[i, 1] = y
        if headings is not None:
            headings[i] = _angle(b)
        i += 1
