"""Seed 001's middle layer wired between the env's virtual robot and each robot's body.

The virtual robot (seed 001's Sobot side) is the env's observation layout: its ``DISTANCE``
sensors are the ring of ``robot.ultrasonic`` (:func:`~.robot_types.virtual_ring`, sensor k at
360·k/count degrees, radius ``robot.radius_m``) and its behaviour is ``MOVE`` (Vx, Vy, ω). Each
body registers its own sensors and behaviours (its robot type, :mod:`petswarm_env.robot_types`).
:class:`BodyMap` builds a body type's sensor mapping table once (seed 001 §III.B: type comparator,
then location comparator; :class:`~.mapping.SensorMapper`) and afterwards only looks it up
(§III.C): a virtual sensor fed by a physical one of the same type and location gets the value and
a known location; of the same type only, the value with a NULL location (location-known 0); none,
nothing (presence 0: the ring's slot reads the sensor's maximum range, "no echo", chosen, so a
policy trained without the flags reads an absent sensor as free space). :func:`attach_check` is
the behaviour mapper's refusal when a policy is attached (§IV.B).

Location rule (chosen): angles only, exact (seed 001 §VI.A: "sensor mapper uses only angles for
location comparison").
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from petswarm_env.mapping import (MOVE_HOLONOMIC, Behaviour, BehaviourMapper, LocationRule, Sensor,
                                  SensorMapper)
from petswarm_env.robot_types import BodySpec, virtual_ring

LOCATION_RULE = LocationRule()  # seed 001 §VI.A: angles only, exact
VIRTUAL_BEHAVIOURS = (MOVE_HOLONOMIC,)  # the env's action: MOVE (Vx, Vy, ω)


@dataclass(frozen=True)
class BodyMap:
    """One body type's mapping onto the virtual ring: ``table`` (seed 001 Table I rows),
    ``route[k]`` the column of the body's own DISTANCE readings that feeds virtual sensor k (or
    None), ``present[k]`` and ``location_known[k]`` (1.0 / 0.0), and the body's DISTANCE sensors
    (``physical``, registration order: the columns of its readings)."""

    body: str
    physical: tuple[Sensor, ...]
    table: tuple
    route: tuple[int | None, ...]
    present: tuple[float, ...]
    location_known: tuple[float, ...]

    @property
    def identity(self) -> bool:
        """The body carries the virtual ring itself: column k feeds sensor k at its location."""
        n = len(self.route)
        return len(self.physical) == n and self.route == tuple(range(n)) and all(self.location_known)

    def flags(self, off: Iterable[int] = ()) -> list[float]:
        """presence … then location-known … of the virtual ring (2·count floats); sensors of
        physical ids ``off`` (a sensor fault) deliver nothing."""
        dead = {k for k, j in enumerate(self.route) if j is not None and self.physical[j].id in set(off)}
        pres = [0.0 if k in dead else p for k, p in enumerate(self.present)]
        loc = [0.0 if k in dead else q for k, q in enumerate(self.location_known)]
        return pres + loc


def build_body_map(body: BodySpec, virtual: Sequence[Sensor]) -> BodyMap:
    """The table of ``body``'s DISTANCE sensors onto the ``virtual`` ring, built once."""
    physical = body.distance_sensors
    mapper = SensorMapper(virtual, physical, LOCATION_RULE)
    column = {p.id: j for j, p in enumerate(physical)}
    feeds = {r.virtual: r for r in mapper.table if r.virtual is not None and r.valid_type}
    route = tuple(column[feeds[v.id].physical] if v.id in feeds else None for v in virtual)
    present = tuple(1.0 if v.id in feeds else 0.0 for v in virtual)
    known = tuple(1.0 if v.id in feeds and feeds[v.id].valid_location else 0.0 for v in virtual)
    return BodyMap(body.name, physical, mapper.table, route, present, known)


class MiddleLayer:
    """Every robot's :class:`BodyMap` (one per body type, built once) for the virtual ring of
    ``robot_cfg`` (``robot:``): ``maps[index]``."""

    def __init__(self, bodies: Sequence[BodySpec], robot_cfg):
        self.virtual = virtual_ring(robot_cfg.ultrasonic.count, robot_cfg.radius_m)
        by_type: dict[str, BodyMap] = {}
        for b in bodies:
            if b.name not in by_type:
                by_type[b.name] = build_body_map(b, self.virtual)
        self.by_type = by_type
        self.maps = [by_type[b.name] for b in bodies]
        self.identity = all(m.identity for m in by_type.values())


def attach_check(policy_behaviours: Sequence[Behaviour], bodies: Iterable[BodySpec], policy: str = "the policy") -> None:
    """The behaviour mapper at attach time (seed 001 §IV.B): every behaviour the policy needs must
    have a module of the same name on every body it may drive, or :class:`~.mapping.BehaviourRefused`
    names the behaviour and the body. (A differential MOVE serves MOVE without Vy: its table row
    lists ``vy`` as a missing field, and the body turns toward the commanded direction.)"""
    seen = set()
    for b in bodies:
        if b.name in seen:
            continue
        seen.add(b.name)
        BehaviourMapper(policy_behaviours, b.behaviours, body=f"robot type '{b.name}' ({policy})")


def behaviour_table(body: BodySpec) -> list[dict[str, object]]:
    """The env's MOVE onto ``body`` (seed 001 Table II rows)."""
    return BehaviourMapper(VIRTUAL_BEHAVIOURS, body.behaviours, body=body.name).table_dicts()

