"""The walking user: a kinematic body (robots bump into it, it does not yield) on a script."""

from __future__ import annotations

import pymunk

from petswarm_env.config import UserConfig
from petswarm_env.scenarios import ScenarioScript
from petswarm_env.sim.body import COLLISION_USER, WalkingBody


class User(WalkingBody):
    """A user walking the script (:class:`~.body.WalkingBody`: every substep's velocity from the
    script's segment, ``segment``, at ``script_time_s``, while ``walking``; a segment's command goes
    to ``pending_commands``, where the wearables pick it up)."""

    def __init__(self, cfg: UserConfig, space: pymunk.Space, script: ScenarioScript, position, heading_rad: float):
        super().__init__(space, position, heading_rad, cfg.radius_m, COLLISION_USER, script)
        space.add(self.body, self.shape)
        self.cfg = cfg
        self.index = 0  # user number (several users share a world)

    @property
    def activity(self) -> str:
        return self.segment.activity if self.walking else "stop"
