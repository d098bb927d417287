"""A robot's own sensors: wheel odometry, the ultrasonic ring and the AHRS.

Each model reads the physical truth (a sensor model must) and gives only what the hardware would:
noisy, within its range. Nothing else in the package turns truth into a robot's own readings. The
noise comes from fixed streams in a fixed order: the ring and the odometry from the env's sensor
stream (:class:`Sensors`), each AHRS from its own stream (:class:`AHRS`, one per robot, which also
gives its power-on heading).
"""

from __future__ import annotations

import math
from typing import Protocol

import cython
import numpy as np
from cython.cimports.libc.math import sqrt as _c_sqrt

from petswarm_env.config import RobotConfig
from petswarm_env.middle_layer import BodyMap, MiddleLayer
from petswarm_env.sim import geometry
from petswarm_env.sim.body import Body

if cython.compiled:  # the body's heading and wheels as C reads (sim/body.pxd): the AHRS and the odometry, every reading
    from cython.cimports.petswarm_env.sim.body import Body as _CBody
    from cython.cimports.petswarm_env.sim.body import DrivenBody as _CDriven
    from cython.cimports.petswarm_env.sim.health import FaultState  # its flags as C reads (sim/health.pxd)
else:
    from petswarm_env.sim.body import DrivenBody as _CDriven
    from petswarm_env.sim.health import FaultState

    _CBody = Body
from petswarm_env.sim.draws import Draws

if cython.compiled:  # the ring's ray cast as a C call (sim/geometry.pxd): every robot's ring at every step
    from cython.cimports.petswarm_env.sim.geometry import ring_cast as _ring_cast
else:
    _ring_cast = geometry.ring_cast


COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)


class Truth(Protocol):
    """What the sensor models read of the world (:class:`~.world.World`, which imports this module
    through the robot: named here, not imported)."""

    robots: list
    wall_a: np.ndarray
    wall_b: np.ndarray

    def truth_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


@cython.cclass
class NormalStream:
    """One generator's standard normals z, drawn ``block`` at a time (``standard_normal``) and
    handed out in order: numpy's ``normal(0.0, σ, size)`` is ``0.0 + σ·z`` of the next ``size``
    of them, so ``0.0 + σ·z`` taken here is the number that call gives, and the stream's draws are
    the generator's draws in the order they were asked for. Every draw of the generator must come
    through the stream (the env's sensor stream in :class:`Sensors`; a smart belt's). Read per
    reading in C. ``last_first``: each block is handed out from its last z to its first (the order
    of :class:`~.draws.Draws`' normals, an AHRS's)."""

    rng = cython.declare(object, visibility="readonly")
    block = cython.declare(cython.Py_ssize_t, visibility="readonly")
    _block = cython.declare(object)  # the block (float64 array), refilled in place
    _z = cython.declare(cython.double[::1])  # the same, as C doubles
    _i = cython.declare(cython.Py_ssize_t)  # how many z's of the block are used (``block``: all)
    _last_first = cython.declare(cython.bint)

    def __init__(self, rng: np.random.Generator, block: int = 256, last_first: bool = False):
        self.rng = rng
        self.block = max(int(block), 1)
        self._block = np.empty(self.block)
        self._z = self._block
        self._i = self.block
        self._last_first = last_first

    @cython.cfunc
    def next(self) -> cython.double:
        """The next z."""
        if self._i == self.block:
            self.rng.standard_normal(out=self._block)
            self._i = 0
        at: cython.Py_ssize_t = self.block - 1 - self._i if self._last_first else self._i
        z: cython.double = float(self._z[at])  # (a Python float in the interpreted form too)
        self._i += 1
        return z

    @cython.ccall
    def normal(self, scale: cython.double, size: cython.Py_ssize_t) -> list:
        """``size`` draws of N(0, ``scale``): ``rng.normal(0.0, scale, size).tolist()``'s numbers."""
        k: cython.Py_ssize_t
        return [0.0 + scale * self.next() for k in range(size)]

    @cython.ccall
    def standard_normal(self, size: cython.Py_ssize_t) -> list:
        """The next ``size`` z's: ``rng.standard_normal(size).tolist()``'s numbers."""
        k: cython.Py_ssize_t
        return [self.next() for k in range(size)]


@cython.cclass
class Readings:
    """What a robot's software gets of its own sensors (its MCU's clock stamp, which feeds its self-diagnosis:
    middleware/station.py ``OwnClock``): the ultrasonic ring's reading and self-test after every reading
    (:meth:`Sensors.read_rings`) and every AHRS reading (:meth:`AHRS.yaw`), by C calls in the compiled form
    (sim/sensors.pxd). This base ignores them."""

    @cython.ccall
    def ring(self, ranges, present, now_s: cython.double, rang: cython.bint):
        """The ring's reading (a list of floats), which slots the body has, the true time, whether its bursts rang down."""

    @cython.ccall
    def ahrs(self, now_s: cython.double, yaw: cython.double):
        """One AHRS reading at true time ``now_s``."""


@cython.cclass
class AHRS:
    """Yaw (rad) of one body relative to its own power-on heading: truth − the heading at power-on
    + a slowly drifting bias (a random walk in time) + white noise.

    An AHRS without a magnetometer (seed 000 §3.5: "no magnetic compass is used") knows no
    absolute direction: it integrates its gyro from wherever the robot faced when it was switched
    on. :meth:`power_on` switches it on: the robot was switched on somewhere before the episode
    and moved since, so its power-on heading is its current heading plus a uniform random angle,
    drawn per robot and episode — no two robots share a frame, and a robot's readings are in no
    frame of the world; only differences of its own readings (its own rotation) mean something.
    Before :meth:`power_on` it reads the body's heading (offset 0: a bare sensor, for tests).

    A typed class of the compiled core: read for every frame a robot's middleware stamps and every
    observation."""

    # its typed attributes are declared in ``sensors.pxd`` (the station and the observation read it by C calls of
    # :meth:`yaw`): the body, the noise and drift σ, the bias, the power-on heading, the last bias step's time, the
    # last reading (a frozen AHRS repeats it), ``readings`` (the robot's software sees every reading: its
    # self-diagnosis), the body's heading reader and the body when it is a Body (its heading a C call), the body's
    # health (its ahrs_ok a C read) and its noise stream's normals, in blocks

    def __init__(self, body: Body, cfg: RobotConfig, rng: np.random.Generator | None = None):
        self.body = body
        self._heading = body.heading_reader()
        self._body = body if isinstance(body, Body) else None
        self.noise_rad = math.radians(cfg.ahrs_noise_deg)
        self.drift_rad = math.radians(cfg.ahrs_drift_dps)
        self.bias_rad = 0.0
        self.power_on_heading_rad = 0.0
        self.time_s = 0.0
        self.rng = np.random.default_rng(0) if rng is None else rng  # (the env gives every robot its own stream)
        self._health = getattr(body, "health", None)  # an AHRS fault freezes the output (sim/faults.py)
        self._last_yaw = 0.0
        self.readings = None

    def power_on(self, rng: np.random.Generator, now_s: float = 0.0) -> None:
        """Switch on at clock time ``now_s`` with the noise stream ``rng`` (its first draw is the
        power-on heading's offset from the current heading, uniform in [−π, π); then the noise)."""
        self.power_on_heading_rad = self._heading() + float(rng.uniform(-math.pi, math.pi))
        self.bias_rad = 0.0
        self.time_s = now_s
        self.rng = rng

    @property
    def rng(self) -> np.random.Generator:
        """The noise stream; its normals are drawn in blocks of 256, each handed out from its last
        to its first (:class:`NormalStream`, as :class:`~.draws.Draws` hands them out)."""
        return self._normals.rng

    @rng.setter
    def rng(self, rng: np.random.Generator) -> None:
        self._normals = NormalStream(rng, 256, True)

    @cython.ccall
    def yaw(self, now_s: cython.double) -> cython.double:
        """The reading at clock time ``now_s``: the bias walks over the time since the last reading
        (one normal), then one normal of white noise."""
        health = self._health
        readings: Readings = self.readings
        if health is not None and not health.ahrs_ok:
            if readings is not None:
                readings.ahrs(now_s, self._last_yaw)
            return self._last_yaw  # no new yaw: the last reading repeats
        normals: NormalStream = self._normals
        dt: cython.double = now_s - self.time_s
        z: cython.double
        if dt > 0:
            z = normals.next()
            self.bias_rad += self.drift_rad * _c_sqrt(dt) * z
            self.time_s = now_s
        heading: cython.double = self._body._read_heading() if self._body is not None else self._heading()
        z = normals.next()
        yaw: cython.double = heading - self.power_on_heading_rad + self.bias_rad + self.noise_rad * z
        self._last_yaw = yaw
        if readings is not None:
            readings.ahrs(now_s, yaw)
        return yaw


@cython.ccall
def noisy_odometry(velocity_body: tuple[float, float, float], errors) -> tuple[float, float, float]:
    """The wheel-odometry model: the wheels' velocity ``(vx, vy, ω)`` in the body frame, each
    component with its relative error (``errors``: three draws of N(0, ``odometry_noise_rel``))."""
    vx, vy, w = velocity_body
    return _with_errors(vx, vy, w, errors[0], errors[1], errors[2])


@cython.cfunc
@cython.exceptval(check=False)
def _with_errors(vx: cython.double, vy: cython.double, w: cython.double, ex: cython.double, ey: cython.double,
                 ew: cython.double) -> tuple[cython.double, cython.double, cython.double]:
    """The odometry's relative errors on the wheels' ``(vx, vy, ω)`` (one formula for both readers)."""
    return vx * (1 + ex), vy * (1 + ey), w * (1 + ew)


@cython.cfunc
@cython.exceptval(check=False)
def wheel_odometry(robot: _CDriven, ex: cython.double, ey: cython.double, ew: cython.double) -> tuple[cython.double, cython.double, cython.double]:
    """:func:`noisy_odometry` of what a robot's wheels turn (``Robot.wheel_velocity``: the motors'
    speed times ``wheel_gain``) with the errors ``ex``, ``ey``, ``ew``, as C doubles: the same
    arithmetic in the same order (the observation's call, for every slave at every step)."""
    vx: cython.double = robot._wx
    vy: cython.double = robot._wy
    w: cython.double = robot._ww
    g: cython.double = robot.wheel_gain
    if g != 1.0:
        vx, vy, w = vx * g, vy * g, w * g
    return _with_errors(vx, vy, w, ex, ey, ew)


class Odometry:
    """One robot's wheel odometry read on its own, at any clock time, with its own noise stream: the
    model of :meth:`Sensors.odometry` (:func:`noisy_odometry`). The master reads its turn rate for its status
    broadcast (:meth:`~petswarm_env.middleware.station.Station.driving_speed`), a leaving robot its own pace."""

    def __init__(self, body, cfg: RobotConfig, rng: np.random.Generator):
        self.body = body  # a DrivenBody: its achieved velocity_body after the last substep
        self.noise_rel = cfg.odometry_noise_rel
        self._draws = Draws(rng)

    def read(self) -> tuple[float, float, float]:
        k = self.noise_rel
        if k > 0:
            normal = self._draws.normal
            return noisy_odometry(self._velocity(), (k * normal(), k * normal(), k * normal()))
        return self._velocity()

    def _velocity(self) -> tuple[float, float, float]:
        """What the wheels turn (the wheel encoders): the motors' speed, over (1 − slip) on a slipping
        body (``Robot.wheel_velocity``; a bare driven body without motors: its achieved velocity)."""
        body = self.body
        wheels = getattr(body, "wheel_velocity", None)
        return body.velocity_body if wheels is None else wheels


@cython.cclass
class UltrasonicRing:
    """``count`` range sensors on the robot's rim, sensor 0 forward, counter-clockwise: ray casts
    against every round body and every wall (:func:`~.geometry.ring_first_hits`), from the rim,
    with Gaussian noise, clipped to [min_range, max_range].

    A typed class of the compiled core: its directions, rims and walls are held as C arrays, and
    the cast (:func:`~.geometry.ring_cast`) and the readings (:func:`_readings`) are C calls, for
    every robot's ring at every step."""

    count = cython.declare(cython.Py_ssize_t, visibility="readonly")
    min_range_m = cython.declare(cython.double, visibility="readonly")
    max_range_m = cython.declare(cython.double, visibility="readonly")
    noise_m = cython.declare(cython.double, visibility="readonly")
    reach_m = cython.declare(cython.double, visibility="readonly")  # from the centre
    radius_m = cython.declare(object, visibility="readonly")
    angles = cython.declare(object, visibility="readonly")
    walls = cython.declare(object, visibility="readonly")
    _rims = cython.declare(object)  # each sensor's distance from the centre
    _angles_c = cython.declare(cython.double[::1])  # the same three as C doubles (held: no conversion per cast)
    _rims_c = cython.declare(cython.double[::1])
    _walls_c = cython.declare(cython.double[::1])
    _dirs_c = cython.declare(cython.double[:, ::1])  # the cast's scratch: one robot's ray directions

    def __init__(self, cfg: RobotConfig, wall_a: np.ndarray, wall_b: np.ndarray,
                 angles_rad: list[float] | None = None, radii_m: list[float] | None = None):
        us = cfg.ultrasonic
        self.count = us.count if angles_rad is None else len(angles_rad)
        self.min_range_m, self.max_range_m, self.noise_m = us.min_range_m, us.max_range_m, us.noise_m
        self.radius_m = cfg.radius_m if radii_m is None else np.asarray(radii_m, float)
        self.angles = np.arange(us.count) * (2 * math.pi / max(us.count, 1)) if angles_rad is None else np.asarray(angles_rad, float)
        self._rims = np.broadcast_to(self.radius_m, (self.count,)).astype(float)
        rim = cfg.radius_m if radii_m is None else max(radii_m, default=0.0)
        self.reach_m = us.max_range_m + rim
        self.walls = geometry.SegmentSet(wall_a, wall_b, self.reach_m)
        self._angles_c = np.ascontiguousarray(self.angles, dtype=float)
        self._rims_c = self._rims
        self._walls_c = self.walls.table
        self._dirs_c = np.empty((self.count, 2))

    def ranges(self, world: Truth, indices: list[int], rng) -> np.ndarray:
        """Readings (m) of the robots ``indices``: (len(indices), count); the noise is the next
        len(indices)·count draws of ``rng`` (a :class:`NormalStream`, or a generator: one
        ``normal`` call's numbers)."""
        n: cython.Py_ssize_t = len(indices)
        if self.count == 0 or n == 0:
            return np.zeros((n, self.count))
        centers, radii, headings = world.truth_arrays()
        if isinstance(indices, list) and indices == list(range(len(world.robots))):
            return self._read(centers, radii, headings, centers, headings, n, rng)  # every robot, in order: the first rows
        return self._read(centers, radii, headings, centers[indices], headings[indices], n, rng)

    @cython.cfunc
    def _read(self, centers, radii, headings, pos, th, n: cython.Py_ssize_t, rng) -> object:
        """:meth:`ranges` of the first ``n`` rows of ``pos`` (their headings ``th``) among the truth
        arrays (``centers``, ``radii``, ``headings``)."""
        d = np.empty((n, self.count))
        out: cython.double[:, ::1] = d
        c: cython.const[cython.double][:, ::1] = centers
        o: cython.const[cython.double][:, ::1]
        if pos is centers:  # every robot, in order (the env's call): one conversion
            o = c
        else:
            o = pos
        _ring_cast(o, n, th, self._angles_c, c, radii, self._walls_c, self.reach_m, out, self._dirs_c)
        if self.noise_m > 0:
            normals = rng if isinstance(rng, NormalStream) else NormalStream(rng, n * self.count)  # (a generator: exactly d.size draws)
            _readings(out, self._rims_c, normals, self.noise_m, self.min_range_m, self.max_range_m)
        else:
            _readings(out, self._rims_c, None, 0.0, self.min_range_m, self.max_range_m)
        return d

    def read_all(self, world: Truth, rng: NormalStream) -> np.ndarray:
        """:meth:`ranges` of every robot of ``world``, in order (the env's call)."""
        n: cython.Py_ssize_t = len(world.robots)
        if self.count == 0 or n == 0:
            return np.zeros((n, self.count))
        centers, radii, headings = world.truth_arrays()
        return self._read(centers, radii, headings, centers, headings, n, rng)


@cython.cfunc
def _readings(d: cython.double[:, ::1], rims: cython.double[::1], normals: NormalStream | None, sigma: cython.double,
              lo: cython.double, hi: cython.double) -> cython.void:
    """The ring's readings from its ray casts ``d`` (n, K), in place: from the sensor on the rim
    (``rims``: each sensor's radius), plus N(0, ``sigma``) noise (the next n·K draws of ``normals``
    in row order, as ``normal(0.0, sigma, n·K)``; None: none), clipped to [lo, hi] as
    ``np.maximum`` then ``np.minimum`` clip (a NaN stays NaN)."""
    n: cython.Py_ssize_t = d.shape[0]
    nk: cython.Py_ssize_t = d.shape[1]
    i: cython.Py_ssize_t
    k: cython.Py_ssize_t
    x: cython.double
    for i in range(n):
        for k in range(nk):
            x = d[i, k] - rims[k]
            if normals is not None:
                x += 0.0 + sigma * normals.next()
            if x < lo:
                x = lo
            if x > hi:
                x = hi
            d[i, k] = x


@cython.cclass
class Sensors:
    """The sensors of every robot of a world as the env reads them, from the env's sensor stream:
    :meth:`read_rings` after every advance of the world (all robots in one cast, their noise the
    stream's next draws), :meth:`odometry` for one robot (three draws, or ones drawn already by
    :meth:`odometry_noise` for many robots at once); every draw through :class:`NormalStream`.
    The AHRS is per robot (``robot.ahrs``).

    Heterogeneous bodies (seed 001's middle layer, :mod:`petswarm_env.middle_layer`): each robot
    reads its own DISTANCE sensors (its type's angles and radii; one cast and one noise draw per
    type, in the order of each type's first robot), and :attr:`ranges` is every robot's reading
    mapped onto the virtual ring (an absent sensor reads ``max_range``); :attr:`flags` holds, per
    robot, the ring's presence and location-known flags. When every body carries the virtual
    ring itself (the petbot-only default) the one cast of the whole ring is all there is.
    :meth:`sensor_off` is a sensor fault's seam: the sensors it names deliver nothing.

    A typed class of the compiled core: what :meth:`read_rings` and its readers read of it at every step are C reads."""

    world = cython.declare(object, visibility="public")
    ring = cython.declare(UltrasonicRing, visibility="public")
    odometry_noise_rel = cython.declare(cython.double, visibility="public")
    layer = cython.declare(object, visibility="public")  # the middle layer (None: bare bodies)
    flags = cython.declare(list, visibility="public")  # per robot, the ring's presence and location-known flags
    ranges = cython.declare(object, visibility="public")  # every robot's last ring, (robots, count) m
    _normals = cython.declare(NormalStream)
    _cfg = cython.declare(object)
    _off = cython.declare(dict)
    _ring_faulted = cython.declare(set)
    _changed = cython.declare(set)
    _groups = cython.declare(list)
    _present = cython.declare(list)
    _rows = cython.declare(list)
    _rows_of = cython.declare(object)

    def __init__(self, world: Truth, cfg: RobotConfig, rng: np.random.Generator):
        self.world = world
        self._normals = NormalStream(rng)  # every draw of the sensor stream goes through it
        self.ring = UltrasonicRing(cfg, world.wall_a, world.wall_b)
        self.odometry_noise_rel = cfg.odometry_noise_rel
        self._cfg = cfg
        self._off: dict[int, set[int]] = {}
        self._ring_faulted: set[int] = set()  # robots whose whole ring an ultrasonic fault switched off
        self._changed: set[int] = set()  # robots whose health changed since the last reading (fault_changed)
        self.refresh()
        self.ranges = np.zeros((0, self.ring.count))  # every robot's last ring, (robots, count) m
        self._rows, self._rows_of = [], self.ranges  # :meth:`range_rows` and the array they were made of
        self.read_rings()

    @property
    def rng(self) -> np.random.Generator:
        """The env's sensor stream (drawn only through :class:`NormalStream`)."""
        return self._normals.rng

    def refresh(self) -> None:
        """(Re)build the middle layer for the world's robots now: call after adding a robot (an
        arrival) before the next :meth:`read_rings`. Sensor faults set so far stay."""
        world, cfg, count = self.world, self._cfg, self.ring.count
        specs = [getattr(r, "spec", None) for r in world.robots]
        self.layer = MiddleLayer(specs, cfg) if specs and None not in specs else None  # None: bare bodies (tests)
        self.flags = [self.layer.maps[i].flags(self._off.get(i, ())) for i in range(len(world.robots))] if self.layer \
            else [[1.0] * (2 * count) for _ in world.robots]
        self._groups = [] if self.layer is None or self.layer.identity else self._type_groups(cfg, world)
        # which virtual-ring slots each body has (the presence flags of a body with every sensor working)
        self._present = [self.layer.maps[i].flags(())[:count] for i in range(len(world.robots))] if self.layer \
            else [[1.0] * count for _ in world.robots]

    def _type_groups(self, cfg: RobotConfig, world: Truth) -> list:
        """Per body type (first robot's order): its robots, its ring of own sensors, its routes."""
        groups: dict[str, tuple[list[int], BodyMap]] = {}
        for i, m in enumerate(self.layer.maps):
            groups.setdefault(m.body, ([], m))[0].append(i)
        out = []
        for indices, m in groups.values():
            angles = [math.radians(s.location.angle_deg) for s in m.physical]
            radii = [s.location.radius_m for s in m.physical]
            ring = UltrasonicRing(cfg, world.wall_a, world.wall_b, angles, radii)
            pairs = [(k, j) for k, j in enumerate(m.route) if j is not None]
            out.append((indices, ring, [k for k, _ in pairs], [j for _, j in pairs]))
        return out

    def read_rings(self) -> np.ndarray:
        """Read every robot's ultrasonic ring now; also kept as :attr:`ranges`. A ring with an
        ``ultrasonic`` fault reads the maximum range on every sensor and its transducers do not ring
        down after their bursts (the driver's self-test, chosen: a dead ring driver sends no burst);
        each robot's software gets its reading (a list of floats) and the self-test's result (``robot.readings.ring(ranges,
        present, now, rang)``, its self-diagnosis: middleware/diagnosis.py), then the sensors it
        knows to be off (``robot.sensors_off``) read ``max_range`` with presence 0 (:meth:`sensor_off`)."""
        if self._changed:
            self._follow_faults()
        world = self.world
        robots: list = world.robots
        ring: UltrasonicRing = self.ring
        if not self._groups:
            ranges = ring.read_all(world, self._normals)
        else:
            ranges = np.full((len(robots), ring.count), ring.max_range_m)
            for indices, own_ring, virt, cols in self._groups:
                own = own_ring.ranges(world, indices, self._normals)
                if virt:
                    ranges[np.ix_(indices, virt)] = own[:, cols]
        self.ranges = ranges
        faulted: set = self._ring_faulted
        for i in faulted:  # no echo: "nothing in range" on every sensor (sim/faults.py)
            ranges[i, :] = ring.max_range_m
        now = None
        rows: list = ranges.tolist()  # each robot's reading as Python floats, for its software
        present: list = self._present
        known_off: dict = self._off
        k: cython.Py_ssize_t
        body: _CDriven
        for k in range(len(robots)):
            body = robots[k]  # (its readings' listener and its record as C reads: sim/body.pxd)
            listener: Readings = body.readings
            if listener is not None:
                if now is None:
                    now = world.clock.now
                listener.ring(rows[k], present[k], now, k not in faulted)
            off = body.sensors_off  # the robot's own record of its broken sensors
            if (off != known_off[k]) if k in known_off else off:
                self.sensor_off(k, set(off))
        if self._off:
            for i, off in self._off.items():
                for k, f in enumerate(self.flags[i][: self.ring.count]):
                    if f == 0.0:
                        self.ranges[i, k] = self.ring.max_range_m
            rows = self.ranges.tolist()
        self._rows, self._rows_of = rows, self.ranges
        return self.ranges

    def range_rows(self) -> list:
        """:attr:`ranges` as one list of Python floats per robot (``ranges.tolist()``), made once per
        reading (:meth:`read_rings`) for its readers in the step (the commands, the observation); a
        new array put in its place is converted anew. Read-only."""
        if self._rows_of is not self.ranges:
            self._rows, self._rows_of = self.ranges.tolist(), self.ranges
        return self._rows

    def fault_changed(self, robot: int, kind: str, on: bool) -> None:
        """A ``Faults.on_change`` callback (petswarm_env/runtime.py registers it): the robot's
        ring follows its health at the next :meth:`read_rings`."""
        self._changed.add(robot)

    def _follow_faults(self) -> None:
        """An ``ultrasonic`` fault (``robot.health``, petswarm_env/sim/faults.py) makes every sensor
        of its robot's ring read the maximum range (no echo) from the next reading on, and its end
        gives the echoes back: for the robots whose health changed since the last reading. What the
        robot's software makes of it (presence flags, status) is its own diagnosis's."""
        if not self._changed:
            return
        for i in sorted(self._changed):
            if not self.world.robots[i].health.ultrasonic_ok:
                self._ring_faulted.add(i)
            else:
                self._ring_faulted.discard(i)
        self._changed.clear()

    def sensor_off(self, index: int, physical_ids: set[int]) -> None:
        """Robot ``index``'s DISTANCE sensors of ids ``physical_ids`` deliver nothing from now on
        (presence 0, the slot reads max_range); an empty set switches them back on. The fault's
        state lives on the robot (``robot.sensors_off``, which its own status reports)."""
        off = set(physical_ids)
        self.world.robots[index].sensors_off = off
        if off:
            self._off[index] = off
        else:
            self._off.pop(index, None)
        body_map = self.layer.maps[index] if self.layer else None
        self.flags[index] = body_map.flags(off) if body_map else \
            [0.0 if (k % self.ring.count) + 1 in off else 1.0 for k in range(2 * self.ring.count)]

    def odometry_noise(self, n: int) -> list[list[float]] | None:
        """The relative odometry errors of ``n`` readings, (n, 3): the stream's next 3·n draws (the
        same numbers as ``n`` draws of 3); None when the odometry is noiseless."""
        k = self.odometry_noise_rel
        if k <= 0:
            return None
        normals: NormalStream = self._normals  # (its draws as C calls)
        i: cython.Py_ssize_t
        return [normals.normal(k, 3) for i in range(n)]

    def odometry(self, index: int, noise: list[float] | None = None) -> tuple[float, float, float]:
        """Wheel odometry of robot ``index``: what its wheels turn ``(vx, vy, ω)`` (``Robot.wheel_velocity``) with relative
        noise (``noise``: the three N(0, odometry_noise_rel) errors when drawn already, else drawn here)."""
        robot = self.world.robots[index]  # the wheel encoders: the motors' speed, not the body's (a shove turns no wheel)
        k = self.odometry_noise_rel
        if k > 0:
            e = self._normals.normal(k, 3) if noise is None else noise
            return wheel_odometry(robot, e[0], e[1], e[2])
        return robot.wheel_velocity
