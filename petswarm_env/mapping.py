"""Seed 001's middle layer between a policy (the *virtual robot*) and a body (the *physical robot*).

Seed 001 (Kim, Choi, Kim, IEEE SMC 2006) puts a *middle layer* between a software robot (Sobot,
"a virtual robot") and a mobile robot (Mobot, the body): a **sensor mapper** that hands the body's
physical sensor values to the virtual sensors the software expects, and a **behaviour mapper** that
hands the software's behaviour commands to the body's behaviour modules (seed 001 §II, Fig. 1, 3).
For petswarm the virtual robot is the observation layout and action a policy was trained on; the
physical robot is a robot type's body. This module is the pure logic: registrations, the two
mapping tables, the lookups, the differential-drive MOVE module and seed 001's own experiment
(Tables III–V, VII) as data. It imports nothing from the rest of the project.

Sensor mapper (seed 001 §III):

* Registration (§III.A, Fig. 2): each sensor has an ID, a type (``DISTANCE``, ``VISION``, ...) and
  a location; we register the location as radius (m) and angle (degrees, in the registrant's own
  body frame; both sides must use the same frame). Values are MKS (§III.A.4).
* Mapping (§III.B, Fig. 3): "The sensor mapper has two comparators. One is a type comparator, and
  the other is a location comparator." The location comparator runs only on a type match. The table
  (Table I) has one row per physical sensor: mapped virtual sensor ID (or None), valid type, valid
  location. Seed 001 §VI.A: "sensor mapper uses only angles for location comparison" — that is our
  default :class:`LocationRule`; the radius can be compared too.
* Transfer (§III.C): "After sensor mapper creates the mapping table, the mapping table is not
  updated anymore ... [it] just looks up the mapping table". Valid type and location: value and the
  physical location are delivered. Valid type, invalid location: "it transfers only the measured
  value ... Instead it transfers 'NULL' as the location information". No mapped virtual sensor:
  "Sobot can not get physical information from that physical sensor"; a virtual sensor nothing maps
  onto delivers nothing (presence 0).

Behaviour mapper (seed 001 §IV): behaviours are named modules with *information* (Fig. 5: ``GO
FORWARD``: direction, distance, speed); "If two behaviors are the same, behavior mapper maps the
virtual Behavior onto the physical Behavior" (§IV.B); the module then runs "its own kinematics and
control methods" (§IV.C). Ours is ``MOVE`` with (Vx, Vy, ω); a differential body's ``MOVE`` module
takes (Vx, ω) only and converts with :func:`differential_move`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

# --------------------------------------------------------------------------------------------
# Registrations
# --------------------------------------------------------------------------------------------

DISTANCE = "DISTANCE"  # seed 001 §III.A.2: measures the distance between the robot and an obstacle
VISION = "VISION"  # seed 001 §III.A.2: facial recognition (the robot recognises its master)


def _finite(name: str, x: float) -> float:
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be a finite number, got {x!r}")
    return x


@dataclass(frozen=True)
class SensorLocation:
    """Where a sensor is mounted: ``radius_m`` from the body centre (m), ``angle_deg`` (degrees)."""

    radius_m: float
    angle_deg: float

    def __post_init__(self) -> None:
        if _finite("sensor radius_m", self.radius_m) < 0:
            raise ValueError(f"sensor radius_m must be >= 0, got {self.radius_m}")
        _finite("sensor angle_deg", self.angle_deg)


@dataclass(frozen=True)
class Sensor:
    """A registered sensor (seed 001 Fig. 2): ID, type and location."""

    id: int
    type: str
    location: SensorLocation

    def __post_init__(self) -> None:
        if not isinstance(self.type, str) or not self.type:
            raise ValueError(f"sensor {self.id}: type must be a non-empty string such as 'DISTANCE'")


@dataclass(frozen=True)
class Behaviour:
    """A registered behaviour (seed 001 Fig. 5): the module's ``name`` and its information fields."""

    name: str
    fields: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError("behaviour name must be a non-empty string such as 'MOVE'")
        if len(set(self.fields)) != len(self.fields):
            raise ValueError(f"behaviour '{self.name}' lists a field twice: {self.fields}")


@dataclass(frozen=True)
class Registration:
    """What one side registers with the middle layer: its sensors and its behaviours."""

    name: str
    sensors: tuple[Sensor, ...]
    behaviours: tuple[Behaviour, ...] = ()


def distance_sensors(angles_deg: Sequence[float], radius_m: float, first_id: int = 1) -> tuple[Sensor, ...]:
    """``DISTANCE`` sensors at ``radius_m`` and the given angles, IDs counted from ``first_id``."""
    return tuple(Sensor(first_id + k, DISTANCE, SensorLocation(radius_m, a)) for k, a in enumerate(angles_deg))


# --------------------------------------------------------------------------------------------
# Sensor mapper
# --------------------------------------------------------------------------------------------


def angle_difference_deg(a_deg: float, b_deg: float) -> float:
    """Smallest absolute difference of two angles (degrees, in [0, 180]); 0° and 360° are equal."""
    d = (a_deg - b_deg) % 360.0
    return min(d, 360.0 - d)


@dataclass(frozen=True)
class LocationRule:
    """The location comparator (seed 001 Fig. 3).

    Seed 001 §VI.A: "sensor mapper uses only angles for location comparison" (Rity cares about the
    direction of a sensor, not where on the body it sits): ``compare_radius=False``, the default.
    Two locations match when their angles differ by at most ``angle_tol_deg`` (the paper's matches
    are exact: tolerance 0) and, with ``compare_radius``, their radii by at most ``radius_tol_m``.
    """

    angle_tol_deg: float = 0.0
    compare_radius: bool = False
    radius_tol_m: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= _finite("angle_tol_deg", self.angle_tol_deg) < 180.0:
            raise ValueError(f"angle_tol_deg must be in [0, 180), got {self.angle_tol_deg}")
        if _finite("radius_tol_m", self.radius_tol_m) < 0:
            raise ValueError(f"radius_tol_m must be >= 0, got {self.radius_tol_m}")

    def matches(self, virtual: SensorLocation, physical: SensorLocation) -> bool:
        """True when the location comparator outputs 'True' for this pair."""
        eps = 1e-9  # float noise only: 45.0 and 45.0000000001 are the same registered angle
        if angle_difference_deg(virtual.angle_deg, physical.angle_deg) > self.angle_tol_deg + eps:
            return False
        return not self.compare_radius or abs(virtual.radius_m - physical.radius_m) <= self.radius_tol_m + eps


@dataclass(frozen=True)
class SensorRow:
    """One row of the sensor mapping table (seed 001 Table I): keyed by the physical sensor."""

    physical: int
    virtual: int | None
    valid_type: bool
    valid_location: bool

    def as_dict(self) -> dict[str, int | bool | None]:
        """``{physical, virtual, valid_type, valid_location}`` (the key names reproduce's JSON uses)."""
        return {"physical": self.physical, "virtual": self.virtual,
                "valid_type": self.valid_type, "valid_location": self.valid_location}


@dataclass(frozen=True)
class Delivery:
    """What one virtual sensor receives: ``present`` (the presence flag, 0/1), the value (MKS) and
    the physical sensor's location, or ``None`` for seed 001's NULL location."""

    virtual: int
    present: bool
    value: float | None = None
    location: SensorLocation | None = None

    @property
    def location_known(self) -> bool:
        return self.location is not None


def _unique_ids(side: str, sensors: Sequence[Sensor]) -> None:
    seen: set[int] = set()
    for s in sensors:
        if s.id in seen:
            raise ValueError(f"{side} sensor id {s.id} is registered twice")
        seen.add(s.id)


def build_sensor_table(virtual: Sequence[Sensor], physical: Sequence[Sensor],
                       rule: LocationRule = LocationRule()) -> tuple[SensorRow, ...]:
    """The sensor mapping table (seed 001 Table I), one row per physical sensor in registration order.

    Matching rule. The paper runs the type comparator on each (virtual, physical) pair and the
    location comparator on the type matches, "in sequence", and builds the table once "the sensor
    mapper completes the all possible comparisons" (§III.B). It does not say how one physical sensor
    chooses between several matching virtual sensors; we choose, deterministically:

    1. *Type and location.* Each physical sensor, in registration order, takes the unassigned
       virtual sensor of its type whose location matches (``rule``) — the closest angle if several
       do, the first registered on a tie: valid type True, valid location True.
    2. *Type only.* Each physical sensor still unmapped then takes the first unassigned virtual
       sensor of its type: valid type True, valid location False (its value is delivered with a
       NULL location). Pass 1 runs over all sensors first, so a type-only pairing never takes a
       virtual sensor that another physical sensor matches in type and location.
    3. Otherwise the row reads None / False / False.

    The assignment is one-to-one: Table I gives each physical sensor one mapped virtual ID, and we
    let each virtual sensor receive from at most one physical sensor (two sources for one virtual
    value would be ambiguous). Unmapped virtual sensors get nothing (presence 0).
    """
    _unique_ids("virtual", virtual)
    _unique_ids("physical", physical)
    taken: set[int] = set()
    chosen: dict[int, tuple[int, bool]] = {}  # physical id -> (virtual id, valid location)
    for p in physical:  # pass 1: type and location
        cands = [v for v in virtual if v.id not in taken and v.type == p.type and rule.matches(v.location, p.location)]
        if cands:
            best = min(cands, key=lambda v: angle_difference_deg(v.location.angle_deg, p.location.angle_deg))
            chosen[p.id] = (best.id, True)
            taken.add(best.id)
    for p in physical:  # pass 2: type only, location NULL
        if p.id in chosen:
            continue
        v = next((v for v in virtual if v.id not in taken and v.type == p.type), None)
        if v is not None:
            chosen[p.id] = (v.id, False)
            taken.add(v.id)
    rows = []
    for p in physical:
        if p.id in chosen:
            vid, loc_ok = chosen[p.id]
            rows.append(SensorRow(p.id, vid, True, loc_ok))
        else:
            rows.append(SensorRow(p.id, None, False, False))
    return tuple(rows)


class SensorMapper:
    """Builds the mapping table once (at construction) and afterwards only looks it up (§III.C)."""

    def __init__(self, virtual: Sequence[Sensor], physical: Sequence[Sensor], rule: LocationRule = LocationRule()):
        self.virtual: tuple[Sensor, ...] = tuple(virtual)
        self.physical: tuple[Sensor, ...] = tuple(physical)
        self.table: tuple[SensorRow, ...] = build_sensor_table(self.virtual, self.physical, rule)
        loc = {p.id: p.location for p in self.physical}
        source = {r.virtual: (r.physical, loc[r.physical] if r.valid_location else None)
                  for r in self.table if r.virtual is not None and r.valid_type}
        # the lookup: per virtual sensor, in registration order, (physical id, location to deliver) or None
        self._route: tuple[tuple[int, int | None, SensorLocation | None], ...] = tuple(
            (v.id, *source.get(v.id, (None, None))) for v in self.virtual)

    def table_dicts(self) -> list[dict[str, int | bool | None]]:
        """The table as ``[{physical, virtual, valid_type, valid_location}, ...]``."""
        return [r.as_dict() for r in self.table]

    def source_of(self, virtual_id: int) -> int | None:
        """The physical sensor that feeds ``virtual_id``, or None."""
        for vid, pid, _loc in self._route:
            if vid == virtual_id:
                return pid
        raise KeyError(f"virtual sensor {virtual_id} is not registered")

    def deliver(self, readings: Mapping[int, float]) -> dict[int, Delivery]:
        """Per virtual sensor (registration order), what it receives from ``readings``
        (physical sensor id -> measured value, MKS). A mapped physical sensor without a reading
        (switched off or faulty) delivers nothing either: presence 0."""
        out: dict[int, Delivery] = {}
        for vid, pid, loc in self._route:
            if pid is None or pid not in readings:
                out[vid] = Delivery(vid, False)
            else:
                out[vid] = Delivery(vid, True, float(readings[pid]), loc)
        return out


# --------------------------------------------------------------------------------------------
# Behaviour mapper
# --------------------------------------------------------------------------------------------


class BehaviourRefused(ValueError):
    """A behaviour the policy requires has no module on this body (named in the message)."""


@dataclass(frozen=True)
class BehaviourRow:
    """One row of the behaviour mapping table (seed 001 Table II): the virtual behaviour, the
    physical module of the same name (or None) and the virtual information fields that module does
    not take (for a differential ``MOVE``: ``("vy",)``)."""

    virtual: str
    physical: str | None
    missing_fields: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, object]:
        return {"virtual": self.virtual, "physical": self.physical, "missing_fields": list(self.missing_fields)}


class BehaviourMapper:
    """Maps each virtual behaviour onto the physical module of the same name, or onto none.

    The table is built once (seed 001 §IV.B: the behaviour comparator compares names; "If two
    behaviors are the same, behavior mapper maps the virtual Behavior onto the physical Behavior").
    ``required`` names the virtual behaviours the policy cannot run without (default: all of them);
    one of them without a module raises :class:`BehaviourRefused` here, when the policy is attached,
    naming it and the body. An optional behaviour without a module maps to None.
    """

    def __init__(self, virtual: Sequence[Behaviour], physical: Sequence[Behaviour], *,
                 body: str = "the body", required: Iterable[str] | None = None):
        names = [b.name for b in virtual]
        for side, bs in (("virtual", names), ("physical", [b.name for b in physical])):
            dup = {n for n in bs if bs.count(n) > 1}
            if dup:
                raise ValueError(f"{side} behaviour '{sorted(dup)[0]}' is registered twice")
        need = set(names) if required is None else set(required)
        unknown = need - set(names)
        if unknown:
            raise ValueError(f"required behaviour '{sorted(unknown)[0]}' is not among the virtual behaviours")
        modules = {b.name: b for b in physical}
        rows, refused = [], []
        for b in virtual:
            m = modules.get(b.name)
            if m is None:
                rows.append(BehaviourRow(b.name, None, b.fields))
                if b.name in need:
                    refused.append(b.name)
            else:
                rows.append(BehaviourRow(b.name, m.name, tuple(f for f in b.fields if f not in m.fields)))
        if refused:
            raise BehaviourRefused(f"behaviour {', '.join(repr(n) for n in refused)} has no module on {body}")
        self.body = body
        self.table: tuple[BehaviourRow, ...] = tuple(rows)
        self._rows = {r.virtual: r for r in rows}

    def table_dicts(self) -> list[dict[str, object]]:
        return [r.as_dict() for r in self.table]

    def lookup(self, name: str) -> BehaviourRow:
        """The table row of virtual behaviour ``name`` (KeyError naming it if unregistered)."""
        try:
            return self._rows[name]
        except KeyError:
            raise KeyError(f"behaviour '{name}' is not registered by the policy") from None


# --------------------------------------------------------------------------------------------
# MOVE and the differential-drive module
# --------------------------------------------------------------------------------------------

MOVE_FIELDS = ("vx", "vy", "omega")  # body frame: vx forward (m/s), vy left (m/s), omega CCW (rad/s)
MOVE_HOLONOMIC = Behaviour("MOVE", MOVE_FIELDS)  # the policy's move; a mecanum body takes it whole
MOVE_DIFFERENTIAL = Behaviour("MOVE", ("vx", "omega"))  # a differential body: no lateral velocity


@dataclass(frozen=True)
class DifferentialLimits:
    """A differential body's MOVE module: ``max_speed_mps`` (|v|), ``max_omega_rad_s`` (|ω|) and
    ``lookahead_m``, the distance ahead of the wheel axle of the point that follows (Vx, Vy);
    ``heading_yield_mps`` > 0: the policy's own ω yields to a sideways request, scaled by
    max(0, 1 − |Vy| / heading_yield_mps) (0: always added whole)."""

    max_speed_mps: float
    max_omega_rad_s: float
    lookahead_m: float
    heading_yield_mps: float = 0.0

    def __post_init__(self) -> None:
        for name in ("max_speed_mps", "max_omega_rad_s", "lookahead_m"):
            if _finite(name, getattr(self, name)) <= 0:
                raise ValueError(f"differential {name} must be > 0, got {getattr(self, name)}")
        if _finite("heading_yield_mps", self.heading_yield_mps) < 0:
            raise ValueError(f"differential heading_yield_mps must be >= 0, got {self.heading_yield_mps}")


def differential_move(vx_mps: float, vy_mps: float, omega_rad_s: float,
                      limits: DifferentialLimits) -> tuple[float, float]:
    """The differential body's MOVE module: (Vx, Vy, ω) -> (v, ω_body), units m/s and rad/s CCW.

    A differential drive cannot move sideways, so Vy is not available (its behaviour table row
    lists ``vy`` as a missing field). What the body does instead — our choice, seed 001 leaves the
    module's kinematics to the body's developer (§IV: "the internal mechanism of behavior module of
    Mobot is abstracted"): **it turns toward the commanded direction**, by the standard off-axis
    point rule. A point P at ``lookahead_m`` = L ahead of the axle moves, in the body frame, at
    (v, ω·L); asking it to move at (Vx, Vy) gives

        v = Vx,        ω_body = ω + Vy / L,

    i.e. a leftward Vy turns the front to the left (toward +y), forward or reversing, and P moves
    exactly at (Vx, Vy) when the commanded ω is 0. The policy's own ω (its heading intent) is added.
    With Vy = 0 the move passes unchanged (v = Vx, ω_body = ω): what a mecanum body would do. While
    reversing (Vx < 0) with Vy ≠ 0 it is P, not the centre, that moves toward +y; the centre first
    swings the other way, as any differential robot backing and turning does.

    The policy's ω and the turn toward (Vx, Vy) may cancel (a policy holding its heading while it
    asks to move sideways): with ``limits.heading_yield_mps`` > 0 the policy's ω is scaled by
    max(0, 1 − |Vy| / heading_yield_mps), so a body asked to move sideways turns toward where it
    is asked to go first and turns to the asked heading once nothing sideways is asked (it stands,
    or it drives straight on). Chosen: the sideways speed, not the whole speed: scaled by the whole
    speed the policy's ω was gone while the body drove on with its swarm, the swarm's turn with it
    (heterogeneous pools from their slots, seeds 2000-2014: hold RMSE 0.16 m against 0.13).

    Limits: when |v| or |ω_body| exceeds its limit, both are scaled by the same factor, so the body
    keeps the commanded path curvature ω_body / v and slows down along it.
    """
    vx = _finite("vx", vx_mps)
    vy = _finite("vy", vy_mps)
    w_cmd = _finite("omega", omega_rad_s)
    if limits.heading_yield_mps > 0.0:
        w_cmd *= max(0.0, 1.0 - abs(vy) / limits.heading_yield_mps)
    v = vx
    w = w_cmd + vy / limits.lookahead_m
    scale = 1.0
    if abs(v) > limits.max_speed_mps:
        scale = limits.max_speed_mps / abs(v)
    if abs(w) * scale > limits.max_omega_rad_s:
        scale = limits.max_omega_rad_s / abs(w)
    return v * scale, w * scale


# --------------------------------------------------------------------------------------------
# Seed 001's experiment (§VI): Rity (Sobot) onto Mybot (Mobot)
# --------------------------------------------------------------------------------------------

# Seed 001 Table IV: Rity's 8 DISTANCE sensors, radius 0.15, ids 1-8. (Fig. 8, which would show the
# angle frame, is lost in the text; from Mybot's layout — five sensors 180..0 and one at 270 — 90°
# reads as the front and 270° as the rear. The mapper only needs both sides to use one frame.)
RITY_ANGLES_DEG = (180.0, 135.0, 90.0, 45.0, 0.0, 315.0, 270.0, 225.0)
# Seed 001 Table III: Mybot's DISTANCE sensors (ultrasonic), radius 0.15, ids 1-6. The text says Mybot
# also has 1 vision sensor (§VI), but Table III and Table V list only these six; we follow the tables.
MYBOT_ANGLES_DEG = (180.0, 135.0, 90.0, 45.0, 0.0, 270.0)
SEED001_RADIUS_M = 0.15

# Seed 001 Table VI: Rity's EMOTION behaviour (information: Neutral, Happy, Sad, ...); Mybot has
# behaviour modules for its 5 emotions (§VI) and a differential drive (§VI: "It is driven on a
# differential drive platform"); its MOVE module is our model, not in the paper's tables.
EMOTION = Behaviour("EMOTION", ("emotion",))

RITY = Registration("Rity", distance_sensors(RITY_ANGLES_DEG, SEED001_RADIUS_M), (EMOTION,))
MYBOT = Registration("Mybot", distance_sensors(MYBOT_ANGLES_DEG, SEED001_RADIUS_M), (EMOTION, MOVE_DIFFERENTIAL))

# Seed 001 Table V: physical 1-5 -> virtual 1-5, physical 6 -> virtual 7; all valid type and location.
TABLE_V = tuple(SensorRow(p, v, True, True) for p, v in ((1, 1), (2, 2), (3, 3), (4, 4), (5, 5), (6, 7)))
# Seed 001 Table VII: EMOTION -> EMOTION.
TABLE_VII = (BehaviourRow("EMOTION", "EMOTION"),)


def seed001_sensor_mapper() -> SensorMapper:
    """Seed 001 §VI.A's sensor mapper: Rity (virtual, Table IV) onto Mybot (physical, Table III),
    angles only (§VI.A: "sensor mapper uses only angles for location comparison")."""
    return SensorMapper(RITY.sensors, MYBOT.sensors, LocationRule())


def seed001_sensor_table() -> list[dict[str, int | bool | None]]:
    """Seed 001 §VI.A's mapping table, ``[{physical, virtual, valid_type, valid_location}, ...]``;
    the paper's answer is :data:`TABLE_V`."""
    return seed001_sensor_mapper().table_dicts()


def seed001_behaviour_table() -> list[dict[str, object]]:
    """Seed 001 §VI.B through the behaviour mapper: Rity's EMOTION onto Mybot (Table VII)."""
    return BehaviourMapper(RITY.behaviours, MYBOT.behaviours, body=MYBOT.name).table_dicts()
