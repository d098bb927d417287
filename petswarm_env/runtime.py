"""The episode's runtime changes (docs/faults.md): faults and arrivals, as the experimenter makes
them happen. Nothing here is a robot's knowledge: the env asks this module to break parts of
robots and to switch robots on; the robots' middleware notices only through what its radio, IR
module and sensors stop or start delivering (:mod:`petswarm_env.sim.faults`,
:mod:`petswarm_env.middleware.recovery`).

* **faults** — ``faults: [{at_s, robot, kind, duration_s}]`` (the config's; if it lists none, the
  scenario's :attr:`~.scenarios.base.Scenario.faults`), and ``faults_random`` (Poisson at
  ``rate_per_min`` over the episode, each a permanent fault of a uniformly drawn kind on a random
  slave). ``at_s`` is episode time: seconds after ``reset`` returned (the swarm organized).
  ``robot``: an index; ``master`` — user 0's master at the fault's time; ``random_slave`` — one
  of user 0's slaves at the fault's time, drawn from the episode's fault stream (seeded). A
  fault whose target does not exist then (no slave) is not injected.
* **arrivals** — ``arrivals: [{at_s, type}]`` (the config's, else the scenario's). An arrival
  robot exists from ``reset`` on, switched off and parked far from everything
  (:data:`PARK_M`); at ``at_s`` it is carried next to the path of user 0's master — the first free
  spot of :data:`ARRIVAL_SPOTS_M` in the master's frame around where the master will be
  :data:`ARRIVAL_LEAD_S` later at its current true velocity (a robot left standing beside a
  walking swarm is out of its reach within seconds), at least :data:`ARRIVAL_CLEARANCE_M` (rim to
  rim) from every robot and user and inside the walls — and switched on: it boots into waiting,
  where the master's periodic scan finds it (:mod:`~.middleware.recovery`). Chosen: the papers
  say only that robots are added at random (seed 003); a robot switched on out of the master's
  radio range would never be found, so the experimenter puts it within it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from petswarm_env.config import ArrivalSpec, Config, FaultSpec
from petswarm_env.sim.faults import POWER_KINDS, Faults
from petswarm_env.step_kernel import drained

if TYPE_CHECKING:
    from petswarm_env.middleware.fleet import Fleet
    from petswarm_env.middleware.swarm import Swarm
    from petswarm_env.sim.world import World

PARK_M = (-1000.0, -1000.0)  # chosen: where arrival robots wait switched off (no walls) — 2 m apart along x
PARK_IN_ARENA = 0.45  # with walls: parked this fraction of the half size toward the (-, -) corner
# chosen: where an arrival is put, in user 0's master's frame (x toward its user), tried in order
# (right of the master first: the open slot is the last member's, and the last of a row or wedge is on the right)
ARRIVAL_SPOTS_M = ((0.0, -2.0), (-1.0, -2.0), (0.0, 2.0), (-1.0, 2.0), (1.0, -2.0), (1.0, 2.0), (0.0, -2.5), (0.0, 2.5),
                   (-2.0, -2.0), (-2.0, 2.0))
ARRIVAL_LEAD_S = 3.0  # chosen: the spot is beside where the master will be this much later (recruiting takes ~1-3 s)
ARRIVAL_CLEARANCE_M = 0.4  # chosen: rim-to-rim clearance of an arrival from every body at its switch-on


def arrival_specs(cfg: Config, scenario) -> list[ArrivalSpec]:
    """The episode's arrivals: the config's, or the scenario's when the config lists none."""
    return list(cfg.arrivals) or [ArrivalSpec.model_validate(a) for a in scenario.arrivals]


def fault_specs(cfg: Config, scenario) -> list[FaultSpec]:
    """The episode's scheduled faults: the config's, or the scenario's when the config lists none."""
    return list(cfg.faults) or [FaultSpec.model_validate(f) for f in scenario.faults]


def park_positions(cfg: Config, count: int) -> list[tuple[float, float]]:
    """Where the ``count`` arrival robots wait switched off."""
    w, h = cfg.world.arena_m
    if w > 0 and h > 0:
        x0, y0 = -PARK_IN_ARENA * w, -PARK_IN_ARENA * h
    else:
        x0, y0 = PARK_M
    return [(x0 + 2.0 * k, y0) for k in range(count)]


class Runtime:
    """One episode's faults and arrivals on the world's clock."""

    def __init__(self, cfg: Config, world: World, fleet: Fleet, swarms: list[Swarm], scenario, arrival_robots: list[int],
                 rng: np.random.Generator, on_change: Callable[[int, str, bool], None] | None = None):
        """``on_change``: a further ``Faults.on_change`` callback (the env's sensors follow the faults)."""
        self.cfg, self.world, self.fleet, self.swarms = cfg, world, fleet, swarms
        self.clock = world.clock
        self.rng = rng
        self.faults = Faults([r.health for r in world.robots])
        self.faults.on_change.append(self._apply)
        if on_change is not None:
            self.faults.on_change.append(on_change)
        self.specs = fault_specs(cfg, scenario)
        arrivals = arrival_specs(cfg, scenario)
        self.arrivals = list(zip(arrivals, arrival_robots))  # (spec, robot index), the rest stay parked
        self._spare = arrival_robots[len(arrivals):]  # room for another scenario's arrivals: parked all episode
        self.arrived: list[tuple[float, int]] = []  # (time, robot) switched on
        for idx in arrival_robots:  # off until switched on (not a fault: not in the log)
            self.faults._set(idx, "dead", True)

    def start(self) -> None:
        """Schedule everything, from now (the end of ``reset``) on."""
        later = self.clock.later
        for spec in self.specs:
            later(spec.at_s, self._inject, spec.robot, spec.kind, spec.duration_s)
        for spec, idx in self.arrivals:
            later(spec.at_s, self._arrive, idx)
        fr = self.cfg.faults_random
        if fr.rate_per_min > 0:
            horizon, t = self.cfg.max_cycles * self.cfg.control_period_s, 0.0
            while True:
                t += float(self.rng.exponential(60.0 / fr.rate_per_min))
                if t >= horizon:
                    break
                later(t, self._inject, "random_slave", fr.kinds[int(self.rng.integers(len(fr.kinds)))], None)

    def parked(self) -> list[int]:
        """The arrival robots not switched on yet."""
        on = {idx for _, idx in self.arrived}
        return [idx for _, idx in self.arrivals if idx not in on] + self._spare

    # -- faults -----------------------------------------------------------------------------------
    def _role(self, idx: int) -> str:
        node = self.fleet.nodes.get(idx)
        if node is None:
            return ""
        return "master" if node.state == "master" else node.state

    def _inject(self, robot: int | str, kind: str, duration_s: float | None) -> None:
        swarm = self.swarms[0]
        if robot == "master":
            idx = swarm.master.node_id
        elif robot == "random_slave":
            slaves = swarm.slave_ids()
            if not slaves:
                return
            idx = slaves[int(self.rng.integers(len(slaves)))]
        else:
            idx = int(robot)
        self.faults.inject(idx, kind, self.clock.now, self._role(idx), duration_s)
        if duration_s is not None:
            self.clock.later(duration_s, self.faults.clear, idx, kind)

    def check_batteries(self) -> None:
        """A battery the robot's motion and sensing drained to 0 (sim/battery.py) is the ``battery``
        fault (seed 003 §4.1.2's battery): logged and applied like an injected one. Called after every step."""
        for robot in drained(self.world.robots):  # (a typed loop: step_kernel.py)
            self.faults.inject(robot.index, "battery", self.clock.now, self._role(robot.index))

    def _apply(self, idx: int, kind: str, on: bool) -> None:
        """A part changed: the motors and the middleware follow the robot's power. An injected
        ``battery`` fault drains the battery to 0; its end (a transient fault) is a full battery."""
        if kind not in POWER_KINDS:
            return
        robot, node = self.world.robots[idx], self.fleet.nodes.get(idx)
        if kind == "battery":
            robot.battery.set_remaining(0.0 if on else robot.battery.capacity_mah)
        if not robot.health.powered:
            robot.set_command(0.0, 0.0, 0.0)  # motors off: the body coasts to a stop and stays, an obstacle
            if node is not None and node.state != "off":
                node.seq.power_off()
        elif node is not None and node.state == "off":
            node.seq.power_on()  # reboot: waiting, knowing nothing

    # -- arrivals ---------------------------------------------------------------------------------
    def _arrive(self, idx: int) -> None:
        spot = self._free_spot(idx)
        if spot is None:
            return  # nowhere to put it: it stays parked (documented)
        robot = self.world.robots[idx]
        body = robot.body
        body.position, body.angle = spot  # carried there (as env._stand_members_at_their_slots places robots)
        robot.set_velocity((0.0, 0.0), 0.0)
        self.world.space.reindex_shapes_for_body(body)
        self.world.invalidate_truth()
        self.faults._set(idx, "dead", False)
        self.arrived.append((self.clock.now, idx))

    def _free_spot(self, idx: int) -> tuple[tuple[float, float], float] | None:
        world, cfg = self.world, self.cfg
        master = world.robots[self.swarms[0].master.node_id]
        (mx, my), th = master.position, master.heading
        vx, vy = master.body.velocity  # truth: the experimenter places the robot
        mx, my = mx + ARRIVAL_LEAD_S * vx, my + ARRIVAL_LEAD_S * vy
        c, s = math.cos(th), math.sin(th)
        r = cfg.robot.radius_m
        others = [(rb.position, r) for rb in world.robots if rb.index != idx]
        others += [(u.position, cfg.user.radius_m) for u in world.users]
        w, h = cfg.world.arena_m
        for fx, fy in ARRIVAL_SPOTS_M:
            x, y = mx + c * fx - s * fy, my + s * fx + c * fy
            if w > 0 and (abs(x) + r > w / 2 or abs(y) + r > h / 2):
                continue
            if all(math.dist((x, y), p) >= r + q + ARRIVAL_CLEARANCE_M for p, q in others):
                return (x, y), th
        return None
