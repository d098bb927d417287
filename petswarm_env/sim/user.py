"""The walking user: a kinematic body (robots bump into it, it does not yield) on a script."""

from __future__ import annotations

import math

import pymunk

from petswarm_env.config import UserConfig
from petswarm_env.sim.robot import (
    COLLISION_USER,
    _get_angle,
    _get_angular_velocity,
    _get_position,
    _get_velocity,
    _set_angular_velocity,
    _set_velocity,
)
from petswarm_env.sim.scenarios import ScenarioScript, Segment


class User:
    def __init__(self, cfg: UserConfig, space: pymunk.Space, script: ScenarioScript, position, heading_rad: float):
        self.cfg = cfg
        self.script = script
        self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.body.position = tuple(position)
        self.body.angle = heading_rad
        self.shape = pymunk.Circle(self.body, cfg.radius_m)
        self.shape.collision_type = COLLISION_USER
        space.add(self.body, self.shape)
        self._cbody = self.body._body  # the Chipmunk body (its accessors are called directly, as in Robot)
        self.index = 0  # user number (several users share a world)
        self.segment: Segment = script.segments[0]
        self.script_time_s = 0.0
        self.walking = False  # the script starts when the swarm is organized
        self.pending_commands: list[str] = []  # commands the user issued (wearables pick them up)

    @property
    def position(self) -> tuple[float, float]:
        p = _get_position(self._cbody)
        return (p.x, p.y)

    @property
    def heading(self) -> float:
        return _get_angle(self._cbody)

    @property
    def turn_rate_rps(self) -> float:
        return _get_angular_velocity(self._cbody)

    @property
    def activity(self) -> str:
        return self.segment.activity if self.walking else "stop"

    def apply(self, dt: float) -> None:
        """Set this substep's velocity from the script (the body integrates it). A kinematic body
        keeps the velocity it was given, so only a changed value is written."""
        if not self.walking:
            self._write((0.0, 0.0), 0.0)
            return
        seg = self.script.at(self.script_time_s)
        if seg is not self.segment and seg.command:
            self.pending_commands.append(seg.command)
        self.segment = seg
        self.script_time_s += dt
        th = _get_angle(self._cbody)
        self._write((seg.speed_mps * math.cos(th), seg.speed_mps * math.sin(th)), math.radians(seg.turn_rate_dps))

    def _write(self, velocity: tuple[float, float], omega: float) -> None:
        cb = self._cbody
        v = _get_velocity(cb)
        if velocity[0] != v.x or velocity[1] != v.y:
            _set_velocity(cb, velocity)
        if omega != _get_angular_velocity(cb):
            _set_angular_velocity(cb, omega)
