"""A mecanum-wheeled Pet-Bot: body-frame commands, wheel kinematics, limits, own sensors.

Control factors (seed 000 §3.6.1, Fig. 11; seed 002 §3.4): ``Vx`` front/rear speed, ``Vy``
left/right speed, ``ω`` angular speed, all in the robot's body frame (x forward, y left, ω CCW).

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode): the wheel
saturation runs on C doubles (every robot's command, every step).
"""

from __future__ import annotations

import math

import cython
import numpy as np
import pymunk

from petswarm_env.config import RobotConfig
from petswarm_env.mapping import differential_move
from petswarm_env.robot_types import Battery as BatterySpec
from petswarm_env.sim.battery import Battery
from petswarm_env.sim.body import COLLISION_ROBOT, DrivenBody
from petswarm_env.sim.body import _get_position  # noqa: F401  read here by middleware/node.py until it binds Body.read_position
from petswarm_env.sim.faults import FaultState
from petswarm_env.sim.sensors import AHRS

if cython.compiled:  # a driven body's command and battery as C reads and writes (sim/body.pxd)
    from cython.cimports.petswarm_env.sim.body import DrivenBody as _Driven
else:
    _Driven = DrivenBody

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

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


@cython.ccall
def saturate_command(vx: cython.double, vy: cython.double, omega: cython.double, cfg) -> tuple:
    """Clip ω to its limit, then scale all wheels together so none exceeds the wheel limit.

    Scaling the four wheels by one factor keeps the commanded direction (SPEC §1: a saturated
    command keeps its direction). ``min`` and ``max`` written out as Python's builtins give them
    (the first of equals; a NaN ω clips to the limit).
    """
    return _saturate(vx, vy, omega, cfg.max_omega_rps, cfg.wheel_lever_m, cfg.max_speed_mps)


@cython.cfunc
def _saturate(vx: cython.double, vy: cython.double, omega: cython.double, limit: cython.double, lever: cython.double,
              max_speed: cython.double) -> tuple:
    """:func:`saturate_command` with the config's limits given (ω limit, wheel lever, wheel speed
    limit): a robot reads them from its config once, not at every command."""
    omega = omega if omega < limit else limit  # max(-limit, min(limit, ω))
    omega = omega if omega > -limit else -limit
    # max |wheel| of _INV @ (vx, vy, Lω) without building arrays (hot path)
    a: cython.double = vx + vy
    b: cython.double = vx - vy
    lw: cython.double = lever * omega
    peak: cython.double = abs(b - lw)  # max(|b − Lω|, |a + Lω|, |a − Lω|, |b + Lω|)
    wheel: cython.double = abs(a + lw)
    if wheel > peak:
        peak = wheel
    wheel = abs(a - lw)
    if wheel > peak:
        peak = wheel
    wheel = abs(b + lw)
    if wheel > peak:
        peak = wheel
    k: cython.double
    if peak > max_speed:
        k = max_speed / peak
        return vx * k, vy * k, omega * k
    return vx, vy, omega


@cython.cfunc
def drive_command(body: _Driven, vx: cython.double, vy: cython.double, omega: cython.double) -> cython.void:
    """A robot's body-frame command (m/s, m/s, rad/s) through its MOVE module (:meth:`Robot.set_command`; the
    per-step command loops, step_kernel.py, call it directly): a differential body turns toward the commanded
    direction (:func:`~petswarm_env.mapping.differential_move`), a mecanum body saturates its wheels
    (:func:`saturate_command`); the body moves (1 − slip) of it. An empty battery stops it."""
    if not cython.compiled:  # Python floats, as the compiled form's C doubles take them
        vx, vy, omega = float(vx), float(vy), float(omega)
    if body.battery.empty:
        body._cx, body._cy, body._cw = 0.0, 0.0, 0.0
        return
    cmd: tuple
    if body._differential is not None:
        v, w = differential_move(vx, vy, omega, body._differential)
        cmd = (v, 0.0, w)
    else:
        cmd = _saturate(vx, vy, omega, body._limit, body._lever, body._max_speed)
    keep: cython.double = body._keep
    if keep == 1.0:
        body._cx, body._cy, body._cw = cmd[0], cmd[1], cmd[2]
    else:
        body._cx, body._cy, body._cw = cmd[0] * keep, cmd[1] * keep, cmd[2] * keep


# a bare Robot without a type (tests; the world always gives one): a battery that never empties
_PETBOT_BATTERY = BatterySpec(math.inf, 0.0, 0.0, 0.0)


class Robot(DrivenBody):
    """Physical truth of one robot: a pymunk body driven by velocity commands (its motors, every
    substep: :meth:`~.body.DrivenBody.apply`, the drive, the wheels and the battery's drain), with
    its own sensors' models attached (the AHRS here; the ultrasonic ring and the odometry in
    :class:`~.sensors.Sensors`) and its battery.

    ``body`` is its robot type (:class:`~petswarm_env.robot_types.BodySpec`; None: ``cfg``, the
    petbot, as before robot types). A mecanum body saturates its wheels (:func:`saturate_command`);
    a differential body runs the move through its own MOVE module (seed 001 §IV.C,
    :func:`~petswarm_env.mapping.differential_move`: no Vy, it turns toward the commanded
    direction). Wheel slip (seed 003's w): the body moves (1 − w) of what its wheels turn
    (:attr:`wheel_gain` = 1 / (1 − w) gives the wheels' view, what the odometry counts). A robot
    whose battery is empty ignores its commands and stops (:attr:`battery` ``.empty``)."""

    def __init__(self, index: int, cfg: RobotConfig, space: pymunk.Space, position, heading_rad: float, body=None):
        rc = cfg if body is None else body.robot
        super().__init__(space, position, heading_rad, rc.radius_m, COLLISION_ROBOT, rc.mass_kg,
                         rc.max_accel_mps2, rc.max_alpha_rps2, friction=0.3, elasticity=0.0)
        self.index = index
        self.cfg = rc
        self.spec = body
        self.type_name = "petbot" if body is None else body.name
        self.radius_m = rc.radius_m
        self.shape.robot_index = index  # read by collision callbacks
        space.add(self.body, self.shape)
        self.health = FaultState()  # the parts that work (petswarm_env/sim/faults.py)
        self.ahrs = AHRS(self, rc)  # own sensor: yaw with white noise and a drifting bias
        self.ahrs_yaw = self.ahrs.yaw  # ahrs_yaw(now_s): the reading (bound once: read every frame)
        battery = body.battery if body is not None else _PETBOT_BATTERY
        self.battery = Battery(battery, rc.max_speed_mps, rc.max_omega_rps)  # DrivenBody.apply drains it every substep
        self.sensors_off: set[int] = set()  # ids of its sensors that are faulty (Sensors.sensor_off sets it)
        slip = body.slip if body is not None else 0.0
        me: _Driven = self  # (its MOVE module's values: typed attributes of the body, sim/body.pxd; drive_command reads them)
        me._keep = 1.0 - slip  # the body's share of the wheels' motion
        self.wheel_gain = 1.0 / me._keep
        me._differential = body.differential_limits() if body is not None and body.drive == "differential" else None

    def set_command(self, vx: float, vy: float, omega: float) -> None:
        """Body-frame command (m/s, m/s, rad/s) through the body's MOVE module; wheel saturation
        applies here. Stored as Python floats: a float32 action would otherwise carry numpy-scalar
        arithmetic (slow, and rounded to float32) into every substep of the drive. An empty
        battery ignores it (the robot stops). (:func:`drive_command`, which the per-step command
        loops call directly.)"""
        drive_command(self, float(vx), float(vy), float(omega))

    @property
    def motor_command(self) -> tuple[float, float, float]:
        """What its MOVE module last told the motors (own frame: vx m/s, vy m/s, ω rad/s; after its saturation, a
        differential body's (v, 0, ω)): the robot's software knows it, its MCU sent it. The motors reach it under
        their acceleration limits, and the body moves (1 − slip) of it."""
        me: _Driven = self
        k: cython.double = me._keep
        return (me._cx / k, me._cy / k, me._cw / k)

    @property
    def wheel_velocity(self) -> tuple[float, float, float]:
        """What the wheels turn (the odometry's view, the wheel encoders'): the motors' speed, which
        follows the command under the acceleration limits whatever the body does (contacts, shoves),
        over (1 − slip) of the body's share."""
        v = self._wheels
        g = self.wheel_gain
        return v if g == 1.0 else (v[0] * g, v[1] * g, v[2] * g)

    @property
    def cfg(self) -> RobotConfig:
        """The robot's config (its type's); setting it sets the wheel limits :meth:`set_command` reads."""
        return self._cfg

    @cfg.setter
    def cfg(self, cfg: RobotConfig) -> None:
        self._cfg = cfg
        me: _Driven = self  # the wheel limits drive_command reads (a config is frozen)
        me._limit, me._lever, me._max_speed = cfg.max_omega_rps, cfg.wheel_lever_m, cfg.max_speed_mps

    def own_status(self) -> dict:
        """This robot's own status from its own body only (seed 003's β_i = <id, w_i, P_rem_i> and
        the rates of §4.1.2), what its middleware may report (RUTA): type, drive, battery, slip,
        consumption rates and the registered sensors. No other robot's truth."""
        spec, b = self.spec, self.battery
        me: _Driven = self
        keep: cython.double = me._keep
        sensors = spec.sensors if spec is not None else ()
        rates = spec.battery if spec is not None else _PETBOT_BATTERY
        return {"id": self.index, "type": self.type_name, "drive": spec.drive if spec is not None else "mecanum",
                "battery_mah": b.remaining_mah, "battery_capacity_mah": b.capacity_mah, "battery_fraction": b.fraction,
                "battery_empty": b.empty, "wheel_slip_pct": 100.0 * (1.0 - keep),
                "servo_ma": rates.servo_ma, "actuator_ma": rates.actuator_ma, "sensing_ma": rates.sensing_ma,
                "sensors": [{"id": s.id, "type": s.type, "radius_m": s.location.radius_m, "angle_deg": s.location.angle_deg,
                             "working": s.id not in self.sensors_off} for s in sensors]}
