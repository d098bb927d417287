"""Robot types (seed 003's heterogeneous robots, seed 001's Mobot): the ``robot_types:`` config
section, ``swarm.pool``, and each type resolved into a :class:`BodySpec` the simulation builds.

How a type relates to ``robot:``: the ``robot:`` section is the petbot's body (kinematics, mass,
AHRS, odometry, the ultrasonic model), and ``robot_types.petbot`` adds what ``robot:`` does not
hold (drive, wheel slip, the registered sensors, the battery, extra behaviour modules) and must
give all of it. Every other type lists only what differs from the petbot: a key it leaves out
(or gives as null) takes the petbot's value. The ultrasonic model (range, noise) is shared; which
``DISTANCE`` sensors a body carries, and where, is its ``sensors`` list.

Sensors are registered as seed 001 §III.A does (Fig. 2): an id, a type (``DISTANCE`` for an
ultrasonic sensor, ``IR`` for the IR relative-location ring, ``LF`` for an LF antenna: the master
carries two; VISION, seed 001's camera, is registered but not read; any other name is refused) and a location, radius (m) and
angle (degrees, counter-clockwise, 0 = the body's forward axis: the env's ring frame).

This module imports nothing of the package but the sections' base and the pure mapper.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from pydantic import Field

from petswarm_env.config_base import ACCEL_MPS2, COUNT, FAST_MPS, MASS_KG, SPIN_RPS, Section
from petswarm_env.mapping import (DISTANCE, VISION, MOVE_DIFFERENTIAL, MOVE_HOLONOMIC, Behaviour, DifferentialLimits, Sensor,
                                  SensorLocation)

DEFAULT_TYPE = "petbot"  # today's robot: every robot of a config without a pool, and every master
DRIVES = ("mecanum", "differential")
IR, LF = "IR", "LF"  # sensor types of the IR relative-location ring and of an LF antenna (seed 002)
# the sensor types a registration may name: seed 001 §III.A.2's DISTANCE and VISION, the IR ring and an LF
# antenna; any other name is refused (a typo, LASER for DISTANCE, would silently drop a sensor)
SENSOR_TYPES = (DISTANCE, VISION, IR, LF)
# keys of robot: a type may override (the rest of robot: is shared by every type)
BODY_KEYS = ("radius_m", "mass_kg", "max_speed_mps", "max_omega_rps", "max_accel_mps2", "max_alpha_rps2")


class SensorEntry(Section):
    id: int = Field(ge=1, le=COUNT, description="the sensor's id on its body (seed 001 Fig. 2)")
    type: Literal[SENSOR_TYPES] = Field(description="DISTANCE (ultrasonic), IR (the IR ring), LF (an LF antenna), VISION")  # type: ignore[valid-type]
    radius_m: float = Field(ge=0, le=5.0, description="distance of the sensor from the body's centre, m")
    angle_deg: float = Field(ge=-360, le=360, description="direction, degrees CCW from the body's forward axis")


class RobotTypeConfig(Section):
    """One body; null = the petbot's value (``robot:`` for the BODY_KEYS)."""

    drive: Literal[DRIVES] | None = None  # type: ignore[valid-type]
    radius_m: float | None = Field(None, ge=0.01, le=5.0)
    mass_kg: float | None = Field(None, gt=0, le=MASS_KG)
    max_speed_mps: float | None = Field(None, gt=0, le=FAST_MPS, description="speed limit (m/s)")
    max_omega_rps: float | None = Field(None, gt=0, le=SPIN_RPS, description="turn-rate limit (rad/s)")
    max_accel_mps2: float | None = Field(None, gt=0, le=ACCEL_MPS2)
    max_alpha_rps2: float | None = Field(None, gt=0, le=10 * ACCEL_MPS2)
    lookahead_m: float | None = Field(None, gt=0, le=10.0, description="differential MOVE: the point ahead of the axle that follows (Vx, Vy)")
    heading_yield_mps: float | None = Field(None, ge=0, le=FAST_MPS, description="differential MOVE: the policy's ω fades out as the asked sideways speed reaches this (0: never)")
    wheel_slip_pct: float | None = Field(None, ge=0, lt=100, description="seed 003's w, % of the wheels' motion lost")
    sensors: list[SensorEntry] | None = Field(None, max_length=64)
    behaviours: list[str] | None = Field(None, max_length=64, description="behaviour modules besides MOVE (seed 001 §IV)")
    battery_mah: float | None = Field(None, ge=1, le=1e6, description="battery capacity, mAh (1 mAh runs a petbot some 5 s)")
    servo_ma: float | None = Field(None, ge=0, le=1e5, description="drive servos' current at full load, mA (seed 003 rate_servo)")
    actuator_ma: float | None = Field(None, ge=0, le=1e5, description="manipulator current while in use, mA (seed 003 rate_act)")
    sensing_ma: float | None = Field(None, ge=0, le=1e5, description="sensors' and electronics' current, always on, mA (seed 003 rate_sens)")


class PoolEntry(Section):
    type: str = Field(min_length=1, description="a name of robot_types")
    count: int = Field(ge=1, le=16)


_OWN_KEYS = ("drive", "lookahead_m", "heading_yield_mps", "wheel_slip_pct", "sensors", "behaviours", "battery_mah", "servo_ma", "actuator_ma",
             "sensing_ma")


@dataclass(frozen=True)
class Battery:
    """A body's battery (seed 003 §4.1.2: P_rem in mAh; rates in mA)."""

    capacity_mah: float
    servo_ma: float
    actuator_ma: float
    sensing_ma: float


@dataclass(frozen=True)
class BodySpec:
    """One robot type resolved: ``robot`` is a full ``RobotConfig`` (the petbot's is ``robot:``
    itself), the rest is what ``robot:`` does not hold."""

    name: str
    drive: str
    robot: Any  # config.RobotConfig
    lookahead_m: float
    heading_yield_mps: float
    slip: float  # fraction (seed 003's w / 100)
    sensors: tuple[Sensor, ...]
    behaviours: tuple[Behaviour, ...]
    battery: Battery

    @property
    def distance_sensors(self) -> tuple[Sensor, ...]:
        return tuple(s for s in self.sensors if s.type == DISTANCE)

    # A master locates its user with two LF antennas (seed 002 §3.2): whether this body carries them (set once
    # from ``sensors``; the master's LF burst reads it every 350 ms)
    can_be_master: bool = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "can_be_master", sum(s.type == LF for s in self.sensors) >= 2)

    def differential_limits(self) -> DifferentialLimits:
        return DifferentialLimits(self.robot.max_speed_mps, self.robot.max_omega_rps, self.lookahead_m, self.heading_yield_mps)


def robot_types_problem(cfg: Any) -> str | None:
    """Why ``robot_types`` / ``swarm.pool`` of a whole config cannot be used (None if they can)."""
    types = cfg.robot_types
    names = ", ".join(sorted(types))
    pet = types.get(DEFAULT_TYPE)
    if pet is None:
        return f"robot_types must define '{DEFAULT_TYPE}' (today's robot, the default and every master); defined: {names}"
    missing = [k for k in _OWN_KEYS if getattr(pet, k) is None]
    if missing:
        return f"robot_types.{DEFAULT_TYPE} must give every key the other types inherit; missing: {', '.join(missing)}"
    given = [k for k in BODY_KEYS if getattr(pet, k) is not None]
    if given:
        return f"robot_types.{DEFAULT_TYPE}.{given[0]} is set in robot: (robot.{given[0]}); remove it here"
    for name, t in types.items():
        ids = [s.id for s in (t.sensors if t.sensors is not None else pet.sensors)]
        if len(set(ids)) != len(ids):
            return f"robot_types.{name}.sensors registers a sensor id twice ({sorted(ids)}); give each sensor its own id"
        if (t.behaviours or []).count("MOVE"):
            return f"robot_types.{name}.behaviours: MOVE comes with the drive; list only other modules"
    if not resolve(cfg, DEFAULT_TYPE).can_be_master:
        return f"robot_types.{DEFAULT_TYPE}.sensors must carry two LF antennas (type LF): the master locates its user with them"
    if cfg.swarm.pool and cfg.swarm.extra_robots:
        return ("swarm.extra_robots must be 0 with a swarm.pool: the pool lists every waiting robot "
                f"(its robots beyond swarm.num_slaves={cfg.swarm.num_slaves} are the extra ones)")
    return pool_problem(cfg, [(e.type, e.count) for e in cfg.swarm.pool], "swarm.pool")


def pool_problem(cfg: Any, entries: list[tuple[str, int]], where: str) -> str | None:
    """Why a pool of ``(type, count)`` entries (``where``: its key, for the message) cannot be used."""
    names = ", ".join(sorted(cfg.robot_types))
    for k, (name, _count) in enumerate(entries):
        if name not in cfg.robot_types:
            return f"{where}[{k}].type '{name}' is not a robot type; robot_types defines: {names}"
    if entries:
        total = sum(c for _, c in entries)
        if not cfg.swarm.num_slaves <= total <= 32:
            return (f"{where} holds {total} robots; it needs at least swarm.num_slaves={cfg.swarm.num_slaves} "
                    "and at most 32: change the counts")
    return None


def resolve(cfg: Any, name: str) -> BodySpec:
    """Robot type ``name`` of ``cfg`` as a :class:`BodySpec` (a missing key: the petbot's)."""
    types = cfg.robot_types
    if name not in types:
        raise KeyError(f"'{name}' is not a robot type; robot_types defines: {', '.join(sorted(types))}")
    pet, t = types[DEFAULT_TYPE], types[name]

    def pick(key: str) -> Any:
        own = getattr(t, key)
        return own if own is not None else getattr(pet, key)

    update = {k: getattr(t, k) for k in BODY_KEYS if getattr(t, k) is not None}
    robot = cfg.robot.model_copy(update=update) if update else cfg.robot
    sensors = tuple(Sensor(s.id, s.type, SensorLocation(s.radius_m, s.angle_deg)) for s in pick("sensors"))
    drive = pick("drive")
    move = MOVE_HOLONOMIC if drive == "mecanum" else MOVE_DIFFERENTIAL
    behaviours = (move, *(Behaviour(b) for b in pick("behaviours")))
    battery = Battery(pick("battery_mah"), pick("servo_ma"), pick("actuator_ma"), pick("sensing_ma"))
    return BodySpec(name, drive, robot, pick("lookahead_m"), pick("heading_yield_mps"), pick("wheel_slip_pct") / 100.0, sensors, behaviours, battery)


def pool_types(cfg: Any, scenario: Any = None) -> list[str]:
    """The type of each waiting robot of one user's pool, in placement order: ``swarm.pool``
    expanded, else the scenario's ``robot_pool``, else ``num_slaves + extra_robots`` petbots."""
    entries = [(e.type, e.count) for e in cfg.swarm.pool] or list(getattr(scenario, "robot_pool", ()) or ())
    if entries:
        return [name for name, count in entries for _ in range(count)]
    return [DEFAULT_TYPE] * (cfg.swarm.num_slaves + cfg.swarm.extra_robots)


def virtual_ring(count: int, radius_m: float) -> tuple[Sensor, ...]:
    """The virtual robot's DISTANCE sensors (seed 001's Sobot side): the env's observation ring,
    sensor k at 360·k/count degrees CCW from forward, ids 1 … count, at ``radius_m``."""
    return tuple(Sensor(k + 1, DISTANCE, SensorLocation(radius_m, 360.0 * k / count)) for k in range(count))


def episode_scenarios(cfg: Any) -> list[str]:
    """The scenarios an episode of ``cfg`` may run (``user.scenario_pool``, else ``user.scenario``)."""
    return list(dict.fromkeys(cfg.user.scenario_pool or [cfg.user.scenario]))


def max_pool_size(cfg: Any) -> int:
    """The most waiting robots one user's pool can hold over the episode's scenarios."""
    from petswarm_env.scenarios import SCENARIOS

    return max(len(pool_types(cfg, SCENARIOS[name])) for name in episode_scenarios(cfg))


def body_plan(cfg: Any, scenario: Any, specs: dict[str, BodySpec]) -> list[BodySpec]:
    """Every user's robots' types in the order the scenario places them: the master (a petbot),
    then its pool (:func:`pool_types`); the robots of another user after them are petbots."""
    pool = [specs[name] for name in pool_types(cfg, scenario)]
    return [b for _ in range(cfg.world.num_users) for b in (specs[DEFAULT_TYPE], *pool)]


def placement_config(cfg: Any, scenario: Any) -> Any:
    """The config the scenario places a pool with: ``swarm.extra_robots`` = the pool's robots
    beyond ``num_slaves`` (they start where the extra robots do); ``cfg`` itself without a pool."""
    n = len(pool_types(cfg, scenario))
    extra = n - cfg.swarm.num_slaves
    if extra == cfg.swarm.extra_robots:
        return cfg
    return cfg.model_copy(update={"swarm": cfg.swarm.model_copy(update={"extra_robots": extra})})
