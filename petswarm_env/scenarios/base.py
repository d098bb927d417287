"""What a scenario is: the user's walking script (segments) and where reset puts the robots.

A segment is ``(duration_s, speed_mps, turn_rate_dps, activity, command)``; the user walks at
``speed`` along their heading while the heading turns at ``turn_rate``; ``command`` (optional) is
what the user tells the robots through the watch when the segment starts (see
:data:`USER_COMMANDS`). The last segment repeats until the episode ends.

This module and the scenario modules import nothing of ``petswarm_env`` (the config validates
scenario names against the registry, so the registry sits below it): a scenario gets what it
needs — the user's config section, the world to place robots in, the formation's slots — as
arguments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

ACTIVITIES = ("stop", "rest", "walk", "run")  # seed 002 Table 2
# What a user can tell the robots through the smart watch (seed 002 §2, Fig. 4; seed 000 Fig. 4):
# the driving mode, organize / disperse the swarm, return from an exception, and the seven
# remote-control gestures of seed 002 Table 1 ("gesture:forward", ...).
USER_COMMANDS = ("mode:following", "mode:leading", "mode:remote", "organize", "disperse", "return")

SPAWN_REACH = 0.85  # chosen: waiting robots start within 85 % of the master's available region (Table 1)
PAIRING_DISTANCE_M = 0.8  # chosen: each user starts this close to their robot (LF wake-up range 1 m)


@dataclass(frozen=True)
class Segment:
    duration_s: float
    speed_mps: float
    turn_rate_dps: float
    activity: str
    command: str = ""


def turn(angle_deg: float, rate_dps: float, speed: float) -> Segment:
    """A turn of ``angle_deg`` (positive = left / CCW) while walking at ``speed``."""
    return Segment(abs(angle_deg) / rate_dps, speed, rate_dps if angle_deg > 0 else -rate_dps, "walk")


class ScenarioScript:
    """Evaluates a segment list at a time: speed, turn rate and activity of the user."""

    def __init__(self, segments: list[Segment]):
        self.segments = segments
        self.ends = np.cumsum([s.duration_s for s in segments]).tolist()  # floats: read every substep
        self._last = len(self.ends) - 1
        self._i = 0

    def at(self, t_s: float) -> Segment:
        i = self._i
        while i < self._last and t_s >= self.ends[i]:
            i += 1
        self._i = i
        return self.segments[i]


@dataclass(frozen=True)
class Placement:
    """Where reset put the robots: per user, its own robot (the future master) and its pool of
    waiting robots (world indices); and the robots already connected to another user."""

    pools: list[tuple[int, list[int]]]
    other_user_robots: list[int]


class Scenario:
    """A named scenario (VMAS's make_world / reset_world_at are the model): the user's walking
    script, :meth:`segments`, and the robots' start, :meth:`place`.

    The default script stands for ``user.start_delay_s``, walks :meth:`walk`, then walks straight
    on; the default placement is :meth:`place`'s. A scenario whose script changes the driving mode
    while the swarm is organized sets ``changes_master``: with ``swarm.master_change`` the master
    role may move to another robot (seed 000 Table 3), so the user's own robot is an agent too.
    """

    name: str = ""
    changes_master: bool = False

    def walk(self, user: Any, rng: np.random.Generator) -> list[Segment]:
        """The segments between the start-up stand and the final straight walk (``user``: the
        ``user`` config section; ``rng``: the script's own stream)."""
        return []

    def segments(self, user: Any, rng: np.random.Generator) -> list[Segment]:
        """The whole script: stand, :meth:`walk`, walk straight on."""
        stand = Segment(user.start_delay_s, 0.0, 0.0, "stop")
        straight = Segment(1e9, user.walk_speed_mps, 0.0, "walk")
        return [stand, *self.walk(user, rng), straight]

    def script(self, user: Any, rng: np.random.Generator) -> ScenarioScript:
        return ScenarioScript(self.segments(user, rng))

    def place(self, world: Any, cfg: Any, slots: np.ndarray, user_ahead_m: float, rng: np.random.Generator) -> Placement:
        """Add the robots to ``world`` (``world.add_robot(position, heading)``) for the config
        ``cfg``, given the planned formation for the configured driving mode: ``slots`` (members,
        2), the slot positions in the master's frame, and ``user_ahead_m``, where the user stands
        ahead of the master in that frame.

        Per user: the user's own robot close to the user (to pair), facing them — behind the user
        in following, ahead in leading; waiting robots around their formation slots (jittered; in
        leading off the master's shifting path); extra candidates farther out; then robots of
        another user to the side. Draws from ``rng`` in that order."""
        n = cfg.swarm.num_slaves
        leading = cfg.swarm.mode == "leading"
        heading = math.pi if leading else 0.0  # every robot faces its user
        c, s = math.cos(heading), math.sin(heading)
        world_slots = np.stack([c * slots[:, 0] - s * slots[:, 1], s * slots[:, 0] + c * slots[:, 1]], axis=1)
        final = np.array([user_ahead_m, 0.0]) * (1 if leading else -1)
        depth = float(np.abs(world_slots[:, 0]).max())
        jitter = cfg.swarm.spawn_jitter_m
        pools = []
        for u in range(cfg.world.num_users):
            base = np.array([0.0, u * cfg.world.user_spacing_m])
            start = base + np.array([PAIRING_DISTANCE_M if leading else -PAIRING_DISTANCE_M, 0.0])
            master = world.add_robot(start, heading)
            pool = []
            reach = SPAWN_REACH * cfg.protocol.join_radius_m
            for m in range(1, n + 1):
                rel = world_slots[m] + rng.uniform(-jitter, jitter, 2)
                if np.hypot(*rel) > reach:  # a far slot (e.g. the 5th of a wedge, 3 m): start inside the region
                    rel = rel * (reach / np.hypot(*rel))
                p = base + final + rel
                if leading and abs(world_slots[m][1]) < 0.9:  # keep the master's shifting path clear
                    side = np.sign(world_slots[m][1]) or (1.0 if m % 2 else -1.0)
                    p[1] = base[1] + side * 0.9 + rng.uniform(-jitter, jitter) * 0.3
                pool.append(world.add_robot(p, heading + float(rng.uniform(-0.3, 0.3))).index)
            for k in range(cfg.swarm.extra_robots):
                side = 1.0 if k % 2 == 0 else -1.0
                far = -1.0 if not leading else 1.0
                p = base + final + np.array([far * (depth + 0.8 + 0.6 * (k // 2)), side * 1.6])
                pool.append(world.add_robot(p, heading).index)
            pools.append((master.index, pool))
        others = []
        base = np.array([0.0, 0.0]) + final
        for k in range(cfg.swarm.other_user_robots):
            r = world.add_robot(base + np.array([-0.6 * k, -1.8 - 0.2 * (k % 2)]), heading)
            others.append(r.index)
        return Placement(pools, others)


SCENARIOS: dict[str, Scenario] = {}  # name -> scenario, in registration order


def register(scenario: Scenario) -> Scenario:
    """Add a scenario to the registry under its ``name`` (unique)."""
    if not scenario.name or scenario.name in SCENARIOS:
        raise ValueError(f"a scenario needs a new name, got {scenario.name!r} (taken: {', '.join(SCENARIOS)})")
    SCENARIOS[scenario.name] = scenario
    return scenario
