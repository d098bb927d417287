"""The belt's pairing with a robot (seed 002 §3.2, Fig. 5), the user session's side: the first pairing by
the user's robot's LF wake-up bursts, a lost link (the belt's BLE supervision timeout, or the robot's
release), and, with no slave to take a lost master's place, the pool's waiting robots' bursts until one
pairs. A mixin of :class:`~.user_session.UserSession`, whose state (the belt's link, the tracker, the
swarm) it reads; interpreted (it runs at pairings and at a lost link, not every control period)."""

from __future__ import annotations

import math

from petswarm_env.control.master import BeltView
from petswarm_env.middleware.master_role import can_be_master
from petswarm_env.wearables import lf


class PairingSide:
    """The pairing of a :class:`~.user_session.UserSession`'s belt with a robot."""

    # -- pairing (seed 002 §3.2) ------------------------------------------------------------------
    def _wakeup_bursts(self):
        cfg = self.cfg
        robot = self.swarm.master
        yield robot.clock.timeout(float(self.rng_misc.uniform(0.0, cfg.lf.wake_period_s)))  # own clock phase
        while self.connected_robot is None:
            d = math.dist(self.world.robots[robot.node_id].position, self.user.position)
            if lf.wakes_up(cfg.lf, d, self.robot_pattern, self.user_pattern):
                yield self.clock.timeout(cfg.ble.connect_s)
                self.connected_robot = robot.node_id
                self.paired_at_s = self.link_since_s = self.clock.now
                self.link_ack_s = self.belt_clock.now
                robot.connected_user = self.swarm.user_id
                robot.state = "command_waiting"
                self.state = "command_waiting"
                return
            yield robot.clock.timeout(cfg.lf.wake_period_s)

    # -- losing the master, pairing with the next (seed 002 §3.2; middleware/succession.py) --------
    def _link_lost(self, reason: str) -> None:
        """The belt lost its robot: its BLE supervision timeout passed (the robot is off), or the
        robot released it (cut off from its swarm: :meth:`~.sequence.SequenceManager.cut_off`).
        The belt alerts the user, who stops and waits (chosen); the session goes back to
        waiting-user (seed 002 Fig. 4) until a robot's wake-up burst pairs it again: the slave that
        takes the lost master's place (:meth:`_on_succession`), or, with none, a robot of the pool
        in the waiting state (:meth:`_repair`)."""
        self.state = "waiting_user"
        self.released_by.add(self.connected_robot)
        self.connected_robot = None
        self.events["masters_lost"] += 1
        self.events["alerts_to_belt"] += 1
        self.link_losses.append((self.clock.now, reason))
        self.user.walking = False  # the user stops at the alert
        self.user.returning = self._returning = False
        self.paused = True
        self.ctrl.reset()
        self.belt_view = BeltView()  # nothing more from the belt until a link carries it
        self.clock.process(self._repair())

    def _wake_up(self, node) -> bool:
        """One LF wake-up burst of ``node`` (seed 002 §3.2): a belt within ``lf.wake_range_m`` whose
        pattern matches pairs over BLE (``ble.connect_s``). Whether it did."""
        d = math.dist(self.world.robots[node.node_id].position, self.user.position)  # the LF field's reach
        if not lf.wakes_up(self.cfg.lf, d, self.robot_pattern, self.user_pattern):
            return False
        self.clock.later(self.cfg.ble.connect_s, self._paired, node, [f"mode:{self.swarm.mode}"])
        self._wake_next_s = math.inf
        return True

    def _paired(self, node, startup: list[str]) -> None:
        """The belt connected over BLE to ``node`` (seed 002 §3.2): command-waiting; the user gives
        ``startup`` (the driving mode of the swarm it masters, or the mode and organize)."""
        if self.connected_robot is not None or not self.world.robots[node.node_id].health.powered:
            return
        self.connected_robot = node.node_id
        self.paired_at_s = self.link_since_s = self.clock.now
        self.link_ack_s = self.belt_clock.now
        node.connected_user = self.swarm.user_id
        node.previous_driving_state = self.swarm.mode
        if node.state != "master":
            node.state = "command_waiting"
        self.state = "command_waiting"
        self.pairings.append((self.clock.now, node.node_id))
        self.startup = list(startup)

    def _repair(self):
        """With no slave to take the lost master's place: wake-up bursts of the pool's waiting robots
        until the belt pairs with one (seed 002 §3.2; chosen: every waiting robot of a user's pool
        carries the user's wake-up pattern), then the user's start-up commands organize a swarm."""
        cfg = self.cfg
        swarm = self.swarm
        fleet = swarm.fleet
        while self.connected_robot is None:
            yield swarm.master.clock.timeout(cfg.lf.wake_period_s)  # the waiting robots' burst period (chosen: the old master's clock)
            if swarm.master.state == "master" or any(n.succession.electing for n in swarm.nodes.values()
                                                      if fleet.swarm_of(n.node_id) is swarm):
                continue  # a slave takes or took the master's place: it calls the belt (_successor_command)
            for idx in sorted(swarm.nodes):
                node = swarm.nodes[idx]
                if node.state != "waiting" or idx in self.released_by or fleet.swarm_of(idx) is not swarm:
                    continue
                if not can_be_master(self.world.robots[idx]):
                    continue  # no LF antennas (robot_types): it bursts no wake-up pattern, the belt cannot pair with it
                d = math.dist(self.world.robots[idx].position, self.user.position)
                if lf.wakes_up(cfg.lf, d, self.robot_pattern, self.user_pattern):
                    yield self.clock.timeout(cfg.ble.connect_s)
                    if node.state != "waiting" or self.connected_robot is not None:
                        break
                    swarm.master = node
                    self.tracker.reset(node.ahrs_yaw())
                    self.tracker_node = node
                    self._paired(node, [f"mode:{swarm.mode}", "organize"])
                    return
