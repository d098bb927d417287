"""What one robot knows (seed 000 Fig. 5: the relative-location identification manager's table, the
heading exchange, the master's broadcast). Filled only by frames and the robot's own sensors; a
policy sees a robot through :class:`Knowledge` and nothing else of the middleware.

Compiled (petswarm_env/_core.py): the records are typed classes (``knowledge.pxd`` declares their
attributes), so the observation, the token ring and a station build and read them by C calls and
reads; interpreted they are plain classes with the same attributes and arithmetic."""

from __future__ import annotations

import math

import cython
from cython.cimports.libc.math import cos as _cos
from cython.cimports.libc.math import sin as _sin

if cython.compiled:  # a C call (geometry.pxd)
    from cython.cimports.petswarm_env.sim.geometry import wrap_float as _wrap
else:
    from petswarm_env.sim.geometry import wrap_float as _wrap

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

# chosen: own odometry is counted at every control step while the robot drives as a slave (0.1 s); a
# longer gap (it was the master, or not yet a member) starts the count again, the velocity of one
# step not standing for the time between
RECKON_GAP_S = 0.5
FRESH_IR_S = 2.0  # chosen: an IR measurement this fresh still places the robot (the ring visits a member every ~0.5 s)


@cython.final
@cython.cclass
class IRMeasurement:
    """One IR measurement of another robot (seed 000 §3.2) as this robot holds it."""

    def __init__(self, distance_m: float, bearing_rad: float, time_s: float, own_yaw_rad: float,
                 own_x_m: float = 0.0, own_y_m: float = 0.0):
        self.distance_m = distance_m
        self.bearing_rad = bearing_rad  # bearing of the other robot in this robot's body frame
        self.time_s = time_s
        self.own_yaw_rad = own_yaw_rad  # own AHRS yaw when measured (to carry the bearing over own rotation)
        self.own_x_m = own_x_m  # own dead-reckoned position when measured (:attr:`Knowledge.odometry_xy`)
        self.own_y_m = own_y_m

    def position_now(self, yaw_rad: float) -> tuple[float, float]:
        """The other robot in this robot's body frame now, at its AHRS reading ``yaw_rad``: the
        measured bearing carried over this robot's own rotation since (its translation is not)."""
        b = self.bearing_rad - (yaw_rad - self.own_yaw_rad)
        return self.distance_m * math.cos(b), self.distance_m * math.sin(b)

    def __repr__(self) -> str:
        return (f"IRMeasurement(distance_m={self.distance_m!r}, bearing_rad={self.bearing_rad!r}, time_s={self.time_s!r}, "
                f"own_yaw_rad={self.own_yaw_rad!r}, own_x_m={self.own_x_m!r}, own_y_m={self.own_y_m!r})")


@cython.final
@cython.cclass
class HeadingEstimate:
    """The relative heading of another robot from the heading exchange (seed 000 §3.5)."""

    def __init__(self, relative_rad: float, time_s: float, own_yaw_rad: float):
        self.relative_rad = relative_rad  # θ_other − θ_self, from the heading exchange
        self.time_s = time_s
        self.own_yaw_rad = own_yaw_rad  # own AHRS yaw when estimated

    def __repr__(self) -> str:
        return f"HeadingEstimate(relative_rad={self.relative_rad!r}, time_s={self.time_s!r}, own_yaw_rad={self.own_yaw_rad!r})"


@cython.final
@cython.cclass
class MasterStatus:
    """The master's periodic broadcast (seed 000 §3.5, Fig. 9)."""

    def __init__(self, velocity: tuple[float, float, float], activity: str, mode: str, user_turn_rate_rps: float,
                 user_position_m: tuple[float, float], time_s: float, user_rotating: bool = False):
        self.velocity = velocity  # master's (vx, vy, ω) in its body frame
        self.activity = activity  # user activity: stop | rest | walk | run (the belt's recognition)
        self.mode = mode  # following | leading | remote | emergency
        self.user_turn_rate_rps = user_turn_rate_rps
        self.user_position_m = user_position_m  # user relative to the master, master's frame
        self.time_s = time_s  # when this robot received it
        self.user_rotating = user_rotating  # the belt's rotation flag (seed 002 §3.4)

    def __repr__(self) -> str:
        return (f"MasterStatus(velocity={self.velocity!r}, activity={self.activity!r}, mode={self.mode!r}, "
                f"user_turn_rate_rps={self.user_turn_rate_rps!r}, user_position_m={self.user_position_m!r}, "
                f"time_s={self.time_s!r}, user_rotating={self.user_rotating!r})")


@cython.cfunc
def new_status(velocity, activity, mode, user_turn_rate_rps: cython.double, user_position_m, time_s: cython.double,
               user_rotating: cython.bint) -> MasterStatus:
    """``MasterStatus(...)`` with its fields set directly: a C call for every status broadcast a slave hears
    (middleware/node.py; the constructor's call through Python costs several times the record)."""
    status: MasterStatus = MasterStatus.__new__(MasterStatus)
    status.velocity, status.activity, status.mode = velocity, activity, mode
    status.user_turn_rate_rps, status.user_position_m = user_turn_rate_rps, user_position_m
    status.time_s, status.user_rotating = time_s, user_rotating
    return status


@cython.cclass
class Knowledge:
    """What one robot knows. Filled only by frames and its own sensors."""

    def __init__(self, member: int = -1, total_members: int = 0, members: dict[int, int] | None = None, mode: str = "",
                 ir: dict[int, IRMeasurement] | None = None, heading: dict[int, HeadingEstimate] | None = None,
                 status: MasterStatus | None = None, lf_members: frozenset[int] = frozenset(),
                 odometry_xy: tuple[float, float] = (0.0, 0.0), odometry_s: float = math.nan):
        self.member = member  # member number in the swarm (0 = master), -1 = none
        self.total_members = total_members
        self.members = {} if members is None else members  # member number -> node id
        self.mode = mode  # the swarm's driving mode, from the joining notification / the last mode change
        self.ir = {} if ir is None else ir  # node id -> latest measurement
        self.heading = {} if heading is None else heading  # node id -> relative heading
        self.status = status
        self.lf_members = lf_members  # node ids whose bodies carry LF antennas (may be master), from the tables
        # own position relative to the swarm, dead-reckoned (:meth:`dead_reckon`), and when it was last advanced (own clock)
        self.odometry_xy = odometry_xy
        self.odometry_s = odometry_s

    @cython.ccall
    def dead_reckon(self, now_s: cython.double, vx: cython.double, vy: cython.double, yaw_rad: cython.double) -> cython.void:
        """Advance :attr:`odometry_xy`, own position relative to the swarm, to ``now_s`` (own clock):
        own wheel odometry ``(vx, vy)`` (body frame, m/s, over the period since the last call) less
        the master's broadcast driving speed (seed 000 §3.5: the speed that compensates the IR
        ring's update delay; taken in our own frame, the formation's heading being the master's),
        turned into the odometry frame by own AHRS yaw ``yaw_rad`` (the frame where the robot was,
        and its AHRS read zero, when the count began). An IR fix carried over it
        (the observation's ``observe._put_fix``) stays where the swarm carried the measured robot, had it
        kept its place in it: while the swarm stands, where it stood."""
        gap: cython.double = RECKON_GAP_S
        dt: cython.double = now_s - self.odometry_s
        self.odometry_s = now_s
        if 0.0 < dt <= gap:  # (nan, or a longer gap: the count starts (again) here)
            st: MasterStatus = self.status
            if st is not None:
                vx -= st.velocity[0]
                vy -= st.velocity[1]
            c: cython.double = _cos(yaw_rad)
            s: cython.double = _sin(yaw_rad)
            x: cython.double
            y: cython.double
            x, y = self.odometry_xy
            self.odometry_xy = (x + (c * vx - s * vy) * dt, y + (s * vx + c * vy) * dt)

    @cython.ccall
    def number_of(self, node_id) -> object:
        """The member number of robot ``node_id`` in :attr:`members` (the first; None: not a member)."""
        for m, n in self.members.items():
            if n == node_id:
                return m
        return None

    @cython.ccall
    def formation_offset(self, now_s: cython.double, yaw_rad: cython.double, fresh_s: cython.double) -> cython.double:
        """ψ = θ_master − θ_self on a slave from its heading exchange with the master (member 0), carried over our own
        rotation since (``yaw_rad``, own AHRS) and the formation's turn since (the master's broadcast ω, seed 000 §3.5);
        nan when that exchange is older than ``fresh_s`` (or none). ``now_s``: own clock. Only the master's: a relayed
        estimate passed on again by robots that relay each other has nothing holding it to the master's heading (two r1s
        out of the master's IR sight drove off together, docs/results.md)."""
        h: HeadingEstimate = self.heading.get(self.members.get(0))
        if h is None or now_s - h.time_s >= fresh_s:
            return math.nan
        turn: cython.double = 0.0
        st: MasterStatus = self.status
        if st is not None:
            turn = st.velocity[2]
        return _wrap(h.relative_rad - (yaw_rad - h.own_yaw_rad) + turn * (now_s - h.time_s))

    def __repr__(self) -> str:
        return (f"Knowledge(member={self.member!r}, total_members={self.total_members!r}, members={self.members!r}, "
                f"mode={self.mode!r}, ir={self.ir!r}, heading={self.heading!r}, status={self.status!r}, "
                f"lf_members={self.lf_members!r}, odometry_xy={self.odometry_xy!r}, odometry_s={self.odometry_s!r})")
