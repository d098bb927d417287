"""The walking user: a kinematic body (robots bump into it, it does not yield) on a script."""

from __future__ import annotations

import math

import pymunk

from petswarm_env.config import UserConfig
from petswarm_env.scenarios import ScenarioScript, Segment
from petswarm_env.sim.body import COLLISION_USER, Body


class User(Body):
    def __init__(self, cfg: UserConfig, space: pymunk.Space, script: ScenarioScript, position, heading_rad: float):
        super().__init__(space, position, heading_rad, cfg.radius_m, COLLISION_USER)  # kinematic: does not yield
        space.add(self.body, self.shape)
        self._heading = self.heading_reader()
        self.cfg = cfg
        self.script = script
        self.index = 0  # user number (several users share a world)
        self.segment: Segment = script.segments[0]
        self.script_time_s = 0.0
        self.walking = False  # the script starts when the swarm is organized
        self.pending_commands: list[str] = []  # commands the user issued (wearables pick them up)

    @property
    def activity(self) -> str:
        return self.segment.activity if self.walking else "stop"

    def apply(self, dt: float) -> None:
        """Set this substep's velocity from the script (the body integrates it). A kinematic body
        keeps the velocity it was given, so only a changed value is written."""
        if not self.walking:
            self.set_velocity((0.0, 0.0), 0.0)
            return
        seg = self.script.at(self.script_time_s)
        if seg is not self.segment and seg.command:
            self.pending_commands.append(seg.command)
        self.segment = seg
        self.script_time_s += dt
        th = self._heading()
        self.set_velocity((seg.speed_mps * math.cos(th), seg.speed_mps * math.sin(th)), math.radians(seg.turn_rate_dps))
