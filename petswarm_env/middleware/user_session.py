"""The user in the loop (seed 002): one user's wearables and the robot connected to them.

A :class:`UserSession` runs, on the shared clock, everything between one walking user and the
master of their swarm:

* **pairing** (seed 002 §3.2, Fig. 5): the user's robot, while waiting for its user, bursts LF with
  its wake-up pattern every ``lf.wake_period_s``; a belt within ``lf.wake_range_m`` whose stored
  pattern matches wakes up and connects over BLE (``ble.connect_s``); the robot enters
  *command-waiting*. A wrong pattern is ignored;
* **commands** (seed 002 §2, Table 1): what the user tells the robot through the watch (driving
  mode, organize / disperse the swarm, return from an exception, remote-control gestures),
  recognised by the watch and delivered over BLE;
* **localisation** (seed 002 §3.3): in leading / following the robot bursts LF every
  ``lf.burst_period_s``; the belt measures both antennas' RSSI and reports over BLE; the robot runs
  Eqs. 1–3 and tracks the user between fixes. A leading master is farthest from the user (seed 000
  Fig. 10) yet must stay inside its own LF range (2 m, seed 002 §3.3): it keeps the standard
  distance beyond the whole formation, capped ``LEADING_LF_MARGIN_M`` inside the LF range, so a deep
  formation takes the user between its rear members (chosen; the papers do not say how a leading
  master beyond 2 m would keep its user);
* **user motion** (seed 002 §3.4): the belt's activity and rotation reports over BLE;
* the **robot states** of seed 002 Fig. 4: waiting-user → command-waiting → following / leading /
  remote; Circle → command-waiting; leading with an obstacle in the travel direction → *exception*
  (remote control by gestures until the user's return command, then the previous mode); no fix
  for ``master.lost_user_s`` → *emergency* (alert to the belt, every robot of the swarm stops;
  chosen: it clears by itself when the user is back inside the reliable range);
* the **master-role controller** (:mod:`petswarm_env.control.master`) that drives the master.

The session reads the truth only where a sensor does (the LF physics needs the true user position
relative to the transmitting robot; the belt needs the user's true motion), like every sensor model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from petswarm_env.config import Config
from petswarm_env.control.master import BeltView, MasterController, UserTracker
from petswarm_env.middleware.formation import formation_for_mode, user_position_in_formation
from petswarm_env.middleware.knowledge import FRESH_IR_S
from petswarm_env.middleware.modes import measured_geometry
from petswarm_env.middleware.swarm import Swarm
from petswarm_env.sim.geometry import wrap_angle
from petswarm_env.sim.user import User
from petswarm_env.sim.world import World
from petswarm_env.wearables import lf
from petswarm_env.wearables.belt import SmartBelt
from petswarm_env.wearables.watch import Command, RemoteDriver, Watch

DRIVING_STATES = ("following", "leading", "remote")
MODE_SETTLE_S = 5.0  # chosen: after a mode change the re-forming swarm raises no obstacle exception
LEADING_LF_MARGIN_M = 0.3  # chosen: a leading master stays this far inside its LF range


def master_distance_m(cfg: Config, formation, mode: str) -> float:
    """The master's distance to its user: ``master.distance_m`` in following; in leading beyond the
    formation's depth (the planned one while not organized), capped inside the LF range."""
    d = cfg.master.distance_m
    if mode != "leading":
        return d
    if formation is None:
        formation = formation_for_mode(cfg.swarm, cfg.swarm.num_slaves + 1, "leading")
    return min(user_position_in_formation(formation, d)[0], cfg.lf.reliable_range_m - LEADING_LF_MARGIN_M)


@dataclass
class UserView:
    """The master's current knowledge of its user, as it broadcasts it to the slaves."""

    activity: str
    user_turn_rate_rps: float
    user_rotating: bool
    user_position_m: tuple[float, float]


class UserSession:
    def __init__(self, cfg: Config, world: World, swarm: Swarm, user: User, rng: np.random.Generator,
                 user_pattern: int, robot_pattern: int):
        self.cfg = cfg
        self.world = world
        self.clock = world.clock
        self.swarm = swarm
        self.user = user
        rngs = rng.spawn(4)
        self.rng_lf, rng_belt, rng_watch, self.rng_misc = rngs
        self.belt = SmartBelt(cfg.belt, rng_belt, t0_s=world.now)
        self._belt_fed = (world.now, user.heading)  # the user's heading when the belt was last advanced
        self.watch = Watch(cfg.watch, rng_watch)
        self.remote = RemoteDriver(cfg.watch)
        self.ctrl = MasterController(cfg.master, math.radians(cfg.lf.reliable_half_angle_deg))
        self.tracker = UserTracker(cfg.master.tracker_alpha, cfg.master.tracker_beta)
        self.user_pattern = user_pattern  # stored in the belt's LF receiver register
        self.robot_pattern = robot_pattern  # what the user's robot bursts
        self.state = "waiting_user"
        self.previous_mode = cfg.swarm.mode
        self.belt_view = BeltView()
        self.connected_robot: int | None = None  # node id the belt is connected to over BLE
        self.paired_at_s: float | None = None
        self.link_since_s = math.inf  # the current BLE connection carries data from this time
        self.events = {"emergencies": 0, "exceptions": 0, "alerts_to_belt": 0, "masters_lost": 0}
        self.commands_received: list[tuple[float, str]] = []
        self.startup: list[str] = []  # commands the user gives right after pairing (set by the env)
        self._emergency_since = 0.0
        self._gestures: list[str] = []  # gestures the user is about to perform, one stroke at a time
        self._watch_free_s = -math.inf
        self.paused = False  # the user stopped after losing their master, until a swarm is organized again
        swarm.on_master_change = self._on_master_change
        self.clock.process(self._wakeup_bursts())
        self.clock.process(self._lf_bursts())
        self.clock.process(self._belt_reports())

    # -- pairing (seed 002 §3.2) ------------------------------------------------------------------
    def _wakeup_bursts(self):
        cfg = self.cfg
        yield self.clock.timeout(float(self.rng_misc.uniform(0.0, cfg.lf.wake_period_s)))  # own clock phase
        robot = self.swarm.master
        while self.connected_robot is None:
            d = math.dist(self.world.robots[robot.node_id].position, self.user.position)
            if lf.wakes_up(cfg.lf, d, self.robot_pattern, self.user_pattern):
                yield self.clock.timeout(cfg.ble.connect_s)
                self.connected_robot = robot.node_id
                self.paired_at_s = self.clock.now
                self.link_since_s = self.clock.now
                robot.connected_user = self.swarm.user_id
                robot.state = "command_waiting"
                self.state = "command_waiting"
                return
            yield self.clock.timeout(cfg.lf.wake_period_s)

    # -- master loss (docs/faults.md) --------------------------------------------------------------
    def _master_lost(self) -> None:
        """The robot the wearables are connected to is off (a ``dead`` or ``battery`` fault): the
        BLE link drops, the belt alerts the user, who stops and waits (chosen); the session goes
        back to waiting-user (seed 002 Fig. 4) and pairs again with a robot of the pool in the
        waiting state whose LF wake-up burst the belt hears (:meth:`_repair`), then the user's
        start-up commands organize a swarm again. Its former slaves stop by their status timeout
        and wait (middleware/sequence.py). Chosen: every waiting robot of a user's pool carries
        the user's wake-up pattern; the papers pair the user with one robot."""
        self.state = "waiting_user"
        self.connected_robot = None
        self.events["masters_lost"] += 1
        self.events["alerts_to_belt"] += 1
        self.user.walking = False  # the user stops at the alert
        self.paused = True
        self.ctrl.reset()
        self.clock.process(self._repair())

    def _repair(self):
        """Wake-up bursts of the pool's waiting robots until the belt pairs with one (seed 002 §3.2)."""
        cfg = self.cfg
        swarm = self.swarm
        fleet = swarm.fleet
        while self.connected_robot is None:
            yield self.clock.timeout(cfg.lf.wake_period_s)
            for idx in sorted(swarm.nodes):
                node = swarm.nodes[idx]
                if node.state != "waiting" or not node.health.powered or fleet.swarm_of(idx) is not swarm:
                    continue
                body = self.world.robots[idx].spec
                if body is not None and not body.can_be_master:
                    continue  # no LF antennas (robot_types): it bursts no wake-up pattern, the belt cannot pair with it
                d = math.dist(self.world.robots[idx].position, self.user.position)
                if lf.wakes_up(cfg.lf, d, self.robot_pattern, self.user_pattern):
                    yield self.clock.timeout(cfg.ble.connect_s)
                    if node.state != "waiting":
                        break
                    swarm.master = node
                    self.connected_robot = idx
                    self.paired_at_s = self.link_since_s = self.clock.now
                    node.connected_user = swarm.user_id
                    node.state = self.state = "command_waiting"
                    self.tracker.reset(node.ahrs_yaw())
                    self.startup = [f"mode:{swarm.mode}", "organize"]
                    return

    # -- localisation (seed 002 §3.3) -------------------------------------------------------------
    def _lf_bursts(self):
        cfg = self.cfg
        period = cfg.lf.burst_period_s
        yield self.clock.timeout(float(self.rng_misc.uniform(0.0, period)))
        while True:
            if self.connected_robot is not None and self.state in ("following", "leading", "emergency") \
                    and self.clock.now >= self.link_since_s:
                tx = self.swarm.master.node_id
                robot = self.world.robots[tx]
                (ux, uy), (rx, ry) = self.user.position, robot.position
                dx, dy = ux - rx, uy - ry
                c, s = math.cos(robot.heading), math.sin(robot.heading)
                fix = lf.locate(cfg.lf, c * dx + s * dy, -s * dx + c * dy, self.rng_lf)
                if fix.valid:  # the belt heard both antennas; RSSIs go back over BLE
                    t_burst = self.clock.now
                    ev = self.clock.timeout(cfg.ble.latency_s)
                    ev.callbacks.append(lambda _e, tx=tx, fix=fix, t=t_burst: self._on_fix(tx, fix, t))
            yield self.clock.timeout(period)

    def _on_fix(self, tx: int, fix: lf.LFFix, t_burst: float) -> None:
        if self.connected_robot != tx or self.swarm.master.node_id != tx:
            return  # the link moved to another robot meanwhile (master change)
        self.tracker.fix((fix.x_fwd, fix.y_left), t_burst)

    # -- belt reports (seed 002 §3.4) -------------------------------------------------------------
    def _belt_reports(self):
        cfg = self.cfg
        while True:
            yield self.clock.timeout(cfg.ble.report_period_s)
            if self.connected_robot is None or self.clock.now < self.link_since_s:
                continue
            r = self.belt.reading()
            view = BeltView(r.activity, r.rotating, r.angular_speed_rps, r.accumulated_angle_rad, self.clock.now)
            ev = self.clock.timeout(cfg.ble.latency_s)
            ev.callbacks.append(lambda _e, v=view: setattr(self, "belt_view", v))

    # -- commands (seed 002 §2, Table 1, Fig. 4) ----------------------------------------------------
    def _deliver(self, handler, item, delay_s: float) -> None:
        """Something the watch recognised travels over BLE to the connected robot."""
        ev = self.clock.timeout(delay_s + self.cfg.ble.latency_s)
        ev.callbacks.append(lambda _e: handler(item))

    def handle_command(self, command: str) -> None:
        """A menu command from the watch: driving mode, organize, disperse, return."""
        if self.connected_robot is None:
            return
        self.commands_received.append((self.clock.now, command))
        swarm = self.swarm
        if command.startswith("mode:"):
            mode = command.split(":", 1)[1]
            if self.state in ("exception", "emergency", "waiting_user"):
                return
            if mode != "remote" and swarm.organized:
                est = self.tracker.user_body(self.clock.now)
                swarm.change_mode(mode, self.cfg.swarm.master_change, est[0] if est is not None else None)
            elif swarm.mode != mode:
                swarm.mode = mode
                if swarm.organized:
                    swarm.events["mode_changes"] += 1
            self.state = mode
            if swarm.master.state not in ("master", "organizing"):
                swarm.master.state = mode  # the robot's own driving state (seed 000 Fig. 4)
            if mode != "remote":
                self.previous_mode = mode
            self.ctrl.reset()
        elif command == "organize":
            if not swarm.organized and swarm.master.state != "organizing" and self.state in DRIVING_STATES:
                swarm.start_organize()
        elif command == "disperse":
            if swarm.organized:
                swarm.start_disperse()
        elif command == "return" and self.state == "exception":
            self.state = self.previous_mode
            self._remote_stop()

    def handle_gesture(self, cmd: Command) -> None:
        """A recognised gesture (seed 002 Table 1) reaches the robot."""
        if self.connected_robot is None:
            return
        self.commands_received.append((self.clock.now, "gesture:" + "+".join(cmd.gestures)))
        if cmd.kind == "cancel":  # Circle: back to command-waiting
            self._remote_stop()
            if self.state not in ("emergency", "waiting_user"):
                self.state = "command_waiting"
        elif self.state in ("remote", "exception"):
            self.remote.push(cmd)

    def _remote_stop(self) -> None:
        self.remote = RemoteDriver(self.cfg.watch)

    def _pick_up_user_commands(self) -> None:
        user = self.user
        now = self.clock.now
        if self.connected_robot is not None and self.startup and self._ready_for(self.startup[0]):
            user.pending_commands.insert(0, self.startup.pop(0))
        delay = self.cfg.watch.recognition_delay_s
        while user.pending_commands:
            cmd = user.pending_commands.pop(0)
            if cmd.startswith("gesture:"):
                self._gestures.append(cmd.split(":", 1)[1])
            else:  # a menu selection on the watch (chosen: recognised after the same delay)
                self._deliver(self.handle_command, cmd, delay)
        while self._gestures and now >= self._watch_free_s:
            self.watch.perform(self._gestures.pop(0), now)
            self._watch_free_s = now + self.cfg.watch.gesture_duration_s
        for cmd in self.watch.poll(now):
            self._deliver(self.handle_gesture, cmd, 0.0)

    def _ready_for(self, command: str) -> bool:
        """The user gives the next start-up command once the robot did the previous one."""
        if command.startswith("mode:"):
            return self.state == "command_waiting"
        if command == "organize":  # leading: the master shifts to its place first (seed 000 §3.5)
            if self.state not in ("following", "leading"):
                return False
            est = self.tracker.user_body(self.clock.now)
            return est is not None and abs(math.hypot(*est[0]) - self.target_distance_m()) < 0.15
        return True

    # -- per control step -------------------------------------------------------------------------
    def target_distance_m(self) -> float:
        """Standard distance (following), or beyond the whole formation (leading master), inside the
        LF range (seed 000 §3.5: the leading master shifts there before the formation is built)."""
        return master_distance_m(self.cfg, self.swarm.formation if self.swarm.organized else None,
                                 "leading" if "leading" in (self.state, self.swarm.mode) else "following")

    def step(self, odometry: tuple[float, float, float], ranges: np.ndarray):
        """Before a control period: advance the belt, take the user's commands, check the exception
        and emergency rules, and return ``(policy_cmd, user_cmd, emergency_stop)`` for the master."""
        cfg = self.cfg
        now = self.clock.now
        user = self.user
        if self.connected_robot is not None and not self.world.robots[self.connected_robot].health.powered:
            self._master_lost()
        elif self.paused and self.swarm.organized:
            self.paused = False
            user.walking = True  # organized again: the user walks on
        seg = user.segment
        moving = user.walking
        t_fed, heading_fed = self._belt_fed  # the waist's mean yaw rate over the period (the gyro integrates
        turn = (user.heading - heading_fed) / (now - t_fed) if now > t_fed else 0.0  # the true rotation)
        self._belt_fed = (now, user.heading)
        self.belt.advance(now, seg.speed_mps if moving else 0.0, turn, seg.activity if moving else "stop")
        self._pick_up_user_commands()
        master = self.swarm.master
        yaw = master.ahrs_yaw()
        self.tracker.move(odometry, yaw, cfg.control_period_s)
        est = self.tracker.user_body(now)
        # emergency: the user is out of the reliable range (no fix) for too long
        if self.state in ("following", "leading") and now - max(self.tracker.last_fix_s, self.link_since_s) > cfg.master.lost_user_s:
            self.state = "emergency"
            self._emergency_since = now
            self.events["emergencies"] += 1
            self.events["alerts_to_belt"] += 1
        elif self.state == "emergency" and self.tracker.last_fix_s > self._emergency_since:
            self.state = self.previous_mode
        self.swarm.emergency = self.state == "emergency"
        # exception: an obstacle in the leading robot's travel direction (behind it: it faces the user)
        if self.state == "leading" and ranges is not None and len(ranges) and self._obstacle_behind(ranges):
            self.state = "exception"
            self.events["exceptions"] += 1
            self.events["alerts_to_belt"] += 1
            self._remote_stop()
        self.swarm.user_view = UserView(
            self.belt_view.activity,
            self.belt_view.angular_speed_rps,
            self.belt_view.rotating,
            tuple(est[0]) if est is not None else (cfg.master.distance_m, 0.0),
        )
        zero = (0.0, 0.0, 0.0)
        if self.state in ("following", "leading"):
            if est is None:
                return zero, None, False
            return self.ctrl.command(est[0], est[1], self.belt_view, odometry, self.state, self.target_distance_m(),
                                     cfg.control_period_s), None, False
        if self.state in ("remote", "exception"):
            return zero, self.remote.command(now, yaw), False
        return zero, None, self.state == "emergency"

    def _obstacle_behind(self, ranges: np.ndarray) -> bool:
        """Something closer than ``master.exception_range_m`` in the leading master's travel
        direction (its back, ±45°) that is not one of its own swarm's robots — those the master
        knows from its IR measurements (fresh within ``FRESH_IR_S``; an older one: where its slot is,
        :func:`~.modes.measured_geometry`)."""
        swarm = self.swarm
        n = len(ranges)
        members = []
        if swarm.organized:
            if self.clock.now - swarm.mode_changed_s < MODE_SETTLE_S:
                return False  # the swarm is re-forming around the master: its echoes are members
            if swarm.formation is not None:
                master = swarm.master
                geometry = measured_geometry(swarm.formation, master.know, master.ahrs_yaw(), self.clock.now, None,
                                             self.cfg.master.distance_m)
                members = [(math.hypot(x, y), math.atan2(y, x)) for m, (x, y) in geometry.positions.items() if m]
        rim = self.cfg.robot.radius_m
        for k in range(n):
            a = 2 * math.pi * k / n
            if abs(wrap_angle(a - math.pi)) > math.pi / 4 + 1e-9 or ranges[k] >= self.cfg.master.exception_range_m:
                continue
            echo_from_member = any(abs(wrap_angle(b - a)) < math.radians(35) and d - 2 * rim < ranges[k] + 0.35 for d, b in members)
            if not echo_from_member:
                return True
        return False

    # -- master change (seed 000 Table 3) ---------------------------------------------------------
    def _on_master_change(self, old, new) -> None:
        """The new master takes over the user: the wearables reconnect to it over BLE, and the old
        master hands over where it last saw the user, placed through its own IR view of the new
        master (headings taken as aligned unless a heading exchange says otherwise)."""
        now = self.clock.now
        est = self.tracker.user_body(now)
        seen = old.know.ir.get(new.node_id)
        self.connected_robot = new.node_id
        self.link_since_s = now + self.cfg.ble.connect_s
        self.tracker.reset(new.ahrs_yaw())  # the new master's own odometry frame
        self.ctrl.reset()
        if est is None:
            return
        yaw = old.ahrs_yaw()
        if seen is not None and now - seen.time_s <= FRESH_IR_S:
            px, py = seen.position_now(yaw)
        else:  # not seen lately (occluded by another member): its slot in the old neighbour table
            formation, members = self.swarm.previous_formation, self.swarm.previous_members
            member = next((m for m, n in members.items() if n == new.node_id), None)
            if formation is None or member is None:
                return
            px, py = (float(v) for v in formation.slot_positions()[member])
        head = old.know.heading.get(new.node_id)
        phi = head.relative_rad - wrap_angle(yaw - head.own_yaw_rad) if head is not None else 0.0
        c, s = math.cos(-phi), math.sin(-phi)
        dx, dy = est[0][0] - px, est[0][1] - py
        self.tracker.fix((c * dx - s * dy, s * dx + c * dy), now)
        vx, vy = est[1]
        self.tracker.vel = [c * vx - s * vy, s * vx + c * vy]
