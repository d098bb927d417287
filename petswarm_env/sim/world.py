"""Physical truth: the pymunk space, the robots, the user, walls and boxes, and the one clock.

The clock is a SimPy environment: radio frames, IR slots, token passes and master broadcasts are
events on it. :meth:`World.advance` runs it in physics substeps: at each substep boundary the
pending events up to that instant run, then pymunk integrates one substep. Substep instants are
computed from integer counters, so long runs do not accumulate float drift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from heapq import heappop

import numpy as np
import pymunk
import simpy

from petswarm_env.config import Config
from petswarm_env.sim import geometry
from petswarm_env.sim.robot import COLLISION_ROBOT, COLLISION_USER, COLLISION_WALL, Robot
from petswarm_env.sim.scenarios import ScenarioScript
from petswarm_env.sim.user import User


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


class Clock(simpy.Environment):
    """The one discrete-event clock (SimPy)."""

    def run_until(self, t: float) -> None:
        """Process every event before ``t``, then stand at ``t`` — what ``run(until=t)`` does,
        without scheduling a stop event and raising to leave the loop on every call. The body of
        ``simpy.Environment.step`` is inlined (no peek/step call per event)."""
        queue = self._queue
        while queue and queue[0][0] < t:
            self._now, _, _, event = heappop(queue)
            callbacks, event.callbacks = event.callbacks, None
            for callback in callbacks:
                callback(event)
            if not event._ok and not hasattr(event, "_defused"):  # a failed event nobody handled
                exc = type(event._value)(*event._value.args)
                exc.__cause__ = event._value
                raise exc
        self._now = t


class World:
    """Bodies, geometry and time. Knows nothing about messages or policies."""

    def __init__(self, cfg: Config, script: ScenarioScript):
        self.cfg = cfg
        self.clock = Clock()
        self.space = pymunk.Space()
        self.space.gravity = (0.0, 0.0)  # top view
        self.dt_sub = cfg.control_period_s / cfg.physics_substeps
        self._substeps_done = 0
        self.robots: list[Robot] = []
        self.users: list[User] = []
        self.user = self.add_user(script, (0.0, 0.0), 0.0)  # the first user (user 0)
        self.collisions = CollisionCounts()
        self.wall_a, self.wall_b = self._build_static()
        self.space.on_collision(COLLISION_ROBOT, COLLISION_ROBOT, begin=self._on_robot_robot)
        self.space.on_collision(COLLISION_ROBOT, COLLISION_USER, begin=self._on_robot_user)
        self.space.on_collision(COLLISION_ROBOT, COLLISION_WALL, begin=self._on_robot_wall)
        n_us = cfg.robot.ultrasonic.count
        self._us_angles = np.arange(n_us) * (2 * math.pi / max(n_us, 1))

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
        return user

    def add_robot(self, position, heading_rad: float) -> Robot:
        robot = Robot(len(self.robots), self.cfg.robot, self.space, position, heading_rad)
        self.robots.append(robot)
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
        return self.clock.now

    def advance(self, substeps: int) -> None:
        """Run the clock for ``substeps`` physics substeps (events first, then physics)."""
        dt = self.dt_sub
        robots = self.robots
        users = self.users
        for _ in range(substeps):
            self._substeps_done += 1
            t_next = self._substeps_done * dt
            self.clock.run_until(t_next)
            for r in robots:
                r.apply(dt)
            for user in users:
                user.apply(dt)
            self.space.step(dt)

    # -- truth arrays (for sensor models, metrics, rendering) ------------------------------------
    def robot_positions(self) -> np.ndarray:
        return np.array([r.body.position for r in self.robots], dtype=float).reshape(-1, 2)

    def robot_headings(self) -> np.ndarray:
        return np.array([r.body.angle for r in self.robots], dtype=float)

    def body_circles(self) -> tuple[np.ndarray, np.ndarray]:
        """Centres and radii of every round body (robots, then the users)."""
        pos = self.robot_positions()
        centers = np.vstack([pos, np.array([u.position for u in self.users], float).reshape(-1, 2)])
        radii = np.full(len(centers), self.cfg.robot.radius_m)
        radii[len(pos):] = self.cfg.user.radius_m
        return centers, radii

    def ultrasonic_ranges(self, indices: list[int], rng: np.random.Generator) -> np.ndarray:
        """Ultrasonic ring readings (m) of the given robots: (len(indices), count), ray casts
        against bodies and walls from the robot's rim, clipped to [min_range, max_range]."""
        us = self.cfg.robot.ultrasonic
        n = us.count
        if n == 0 or not indices:
            return np.zeros((len(indices), n))
        centers, radii = self.body_circles()
        pos = centers[indices]
        th = self.robot_headings()[indices]
        ang = th[:, None] + self._us_angles[None, :]
        dirs = np.stack([np.cos(ang), np.sin(ang)], axis=-1).reshape(-1, 2)
        origins = np.repeat(pos, n, axis=0)
        reach = us.max_range_m + self.cfg.robot.radius_m
        d = geometry.ray_circle_distances(origins, dirs, centers, radii, reach).min(axis=1)
        if len(self.wall_a):
            d = np.minimum(d, geometry.ray_segment_distances(origins, dirs, self.wall_a, self.wall_b, reach).min(axis=1))
        d = d - self.cfg.robot.radius_m  # from the sensor on the rim
        d = d + rng.normal(0.0, us.noise_m, d.shape) if us.noise_m > 0 else d
        return np.clip(d, us.min_range_m, us.max_range_m).reshape(len(indices), n)
