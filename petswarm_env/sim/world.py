"""Physical truth: the pymunk space, the robots, the user, walls and boxes, and the one clock.

The clock (:mod:`petswarm_env.sim.clock`) carries radio frames, IR slots, token passes and master
broadcasts. :meth:`World.advance` runs it in physics substeps: at each substep boundary the
pending events up to that instant run, then pymunk integrates one substep. Substep instants are
computed from integer counters, so long runs do not accumulate float drift.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pymunk

from petswarm_env.config import Config
from petswarm_env.robot_types import DEFAULT_TYPE
from petswarm_env.robot_types import resolve as resolve_type
from petswarm_env.scenarios import ScenarioScript
from petswarm_env.sim.body import COLLISION_ROBOT, COLLISION_USER, COLLISION_WALL, Substeps
from petswarm_env.sim.clock import Clock
from petswarm_env.sim.robot import Robot
from petswarm_env.sim.user import User
from petswarm_env.step_kernel import read_truth, read_truth_lists


@dataclass
class CollisionCounts:
    robot_robot: int = 0
    robot_user: int = 0
    robot_wall: int = 0
    per_robot: dict = field(default_factory=dict)  # robot index -> contacts it began (any kind)

    def hit(self, index: int) -> None:
        self.per_robot[index] = self.per_robot.get(index, 0) + 1

    def total(self) -> int:
        return self.robot_robot + self.robot_user + self.robot_wall


class World:
    """Bodies, geometry and time. Knows nothing about messages or policies."""

    def __init__(self, cfg: Config, script: ScenarioScript):
        self.cfg = cfg
        self._user_radius_m = cfg.user.radius_m  # read by every truth read (the config is frozen)
        self.clock = Clock()
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)  # top view
        self.space.collision_slop = cfg.world.collision_slop_m
        self.dt_sub = cfg.control_period_s / cfg.physics_substeps
        self._truth_at = -1  # substeps.steps when the truth arrays were read (-1: stale)
        self._truth: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._lists_at = -1  # the same for the truth as lists (truth_lists)
        self._lists: tuple[list, list, list] | None = None
        self.robots: list[Robot] = []
        # each robot's type, by index in the order add_robot is called (the env sets it before the
        # scenario places the robots); beyond it, and by default, the petbot (robot_types.py)
        self.body_plan: list = []
        self.default_body = resolve_type(cfg, DEFAULT_TYPE)
        self.users: list[User] = []
        self.substeps = Substeps(self.space, self.clock, self.robots, self.users, self.dt_sub)  # advance()
        self.user = self.add_user(script, (0.0, 0.0), 0.0)  # the first user (user 0)
        self.collisions = CollisionCounts()
        self.wall_a, self.wall_b = self._build_static()
        self.space.on_collision(COLLISION_ROBOT, COLLISION_ROBOT, begin=self._on_robot_robot)
        self.space.on_collision(COLLISION_ROBOT, COLLISION_USER, begin=self._on_robot_user)
        self.space.on_collision(COLLISION_ROBOT, COLLISION_WALL, begin=self._on_robot_wall)

    # -- construction -------------------------------------------------------------------------
    def _build_static(self) -> tuple[np.ndarray, np.ndarray]:
        segs: list[tuple[tuple[float, float], tuple[float, float]]] = []
        w, h = self.cfg.world.arena_m
        if w > 0 and h > 0:
            x, y = w / 2, h / 2
            corners = [(-x, -y), (x, -y), (x, y), (-x, y)]
            segs += [(corners[i], corners[(i + 1) % 4]) for i in range(4)]
        for box in self.cfg.world.obstacles:
            (cx, cy), (bw, bh) = box.center_m, box.size_m
            c = [(cx - bw / 2, cy - bh / 2), (cx + bw / 2, cy - bh / 2), (cx + bw / 2, cy + bh / 2), (cx - bw / 2, cy + bh / 2)]
            segs += [(c[i], c[(i + 1) % 4]) for i in range(4)]
        for a, b in segs:
            shape = pymunk.Segment(self.space.static_body, a, b, 0.02)
            shape.collision_type = COLLISION_WALL
            self.space.add(shape)
        self.wall_segments = segs
        if not segs:
            return np.zeros((0, 2)), np.zeros((0, 2))
        return np.array([s[0] for s in segs], float), np.array([s[1] for s in segs], float)

    def add_user(self, script: ScenarioScript, position, heading_rad: float) -> User:
        """Another walking user (several users share the world and the radio medium)."""
        user = User(self.cfg.user, self.space, script, position, heading_rad)
        user.index = len(self.users)
        self.users.append(user)
        self._truth_at = self._lists_at = -1
        return user

    def add_robot(self, position, heading_rad: float) -> Robot:
        i = len(self.robots)
        body = self.body_plan[i] if i < len(self.body_plan) else self.default_body
        robot = Robot(i, self.cfg.robot, self.space, position, heading_rad, body)
        self.robots.append(robot)
        self._truth_at = self._lists_at = -1
        return robot

    # -- collisions (experimenter's view) ------------------------------------------------------
    def _on_robot_robot(self, arbiter, space, data):
        a, b = arbiter.shapes
        self.collisions.robot_robot += 1
        self.collisions.hit(a.robot_index)
        self.collisions.hit(b.robot_index)

    def _on_robot_user(self, arbiter, space, data):
        self.collisions.robot_user += 1
        self.collisions.hit(arbiter.shapes[0].robot_index)

    def _on_robot_wall(self, arbiter, space, data):
        self.collisions.robot_wall += 1
        self.collisions.hit(arbiter.shapes[0].robot_index)

    # -- time -----------------------------------------------------------------------------------
    @property
    def now(self) -> float:
        return self.clock.now  # (a plain attribute of the clock)

    def advance(self, substeps: int) -> None:
        """Run the clock for ``substeps`` physics substeps (events first, then physics:
        :class:`~.body.Substeps`, compiled)."""
        self.substeps.run(substeps)

    # -- truth arrays (for sensor models, metrics, rendering) ------------------------------------
    def invalidate_truth(self) -> None:
        """Forget the truth arrays: call after moving a body by hand (outside :meth:`advance`)."""
        self._truth_at = self._lists_at = -1

    def truth_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centres of every round body (robots, then the users), their radii and the robots'
        headings, read from Chipmunk once per physics step (read-only arrays, shared by every
        caller until the next ``Space.step``)."""
        steps = self.substeps.steps  # Space.step calls so far: the truth arrays are valid for one value
        if self._truth_at == steps and self._truth is not None:
            return self._truth
        truth = self._truth
        self._truth = read_truth(self.robots, self.users, self._user_radius_m, None if truth is None else truth[1])
        self._truth_at = steps
        return self._truth

    def truth_lists(self) -> tuple[list, list, list]:
        """:meth:`truth_arrays`' values as lists of Python floats (a centre as an ``(x, y)`` pair):
        what an IR slot reads. From the arrays when they are current, else read straight from
        Chipmunk without making them (a slot falls between physics steps, where nothing else reads
        the truth)."""
        steps = self.substeps.steps
        if self._lists_at != steps or self._lists is None:
            if self._truth_at == steps and self._truth is not None:
                centers, radii, headings = self._truth
                self._lists = (centers.tolist(), radii.tolist(), headings.tolist())
            else:
                self._lists = read_truth_lists(self.robots, self.users, self._user_radius_m)
            self._lists_at = steps
        return self._lists

    def robot_positions(self) -> np.ndarray:
        """(N, 2) true robot positions (read-only)."""
        return self.truth_arrays()[0][: len(self.robots)]

    def robot_headings(self) -> np.ndarray:
        """(N,) true robot headings, rad (read-only)."""
        return self.truth_arrays()[2]

    def body_circles(self) -> tuple[np.ndarray, np.ndarray]:
        """Centres and radii of every round body (robots, then the users); read-only arrays."""
        centers, radii, _ = self.truth_arrays()
        return centers, radii
