"""The walking user: a kinematic body (robots bump into it, it does not yield) on a script."""

from __future__ import annotations

import math

import pymunk

from petswarm_env.config import UserConfig
from petswarm_env.sim.robot import COLLISION_USER
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
        self.index = 0  # user number (several users share a world)
        self.segment: Segment = script.segments[0]
        self.script_time_s = 0.0
        self.walking = False  # the script starts when the swarm is organized
        self.pending_commands: list[str] = []  # commands the user issued (wearables pick them up)

    @property
    def position(self) -> tuple[float, float]:
        p = self.body.position
        return (p.x, p.y)

    @property
    def heading(self) -> float:
        return self.body.angle

    @property
    def turn_rate_rps(self) -> float:
        return self.body.angular_velocity

    @property
    def activity(self) -> str:
        return self.segment.activity if self.walking else "stop"

    def apply(self, dt: float) -> None:
        """Set this substep's velocity from the script (the body integrates it)."""
        if not self.walking:
            self.body.velocity = (0.0, 0.0)
            self.body.angular_velocity = 0.0
            return
        seg = self.script.at(self.script_time_s)
        if seg is not self.segment and seg.command:
            self.pending_commands.append(seg.command)
        self.segment = seg
        self.script_time_s += dt
        th = self.body.angle
        self.body.velocity = (seg.speed_mps * math.cos(th), seg.speed_mps * math.sin(th))
        self.body.angular_velocity = math.radians(seg.turn_rate_dps)
