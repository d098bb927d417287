"""One user's swarm: the middleware of its master and of the robots around it, wired together.

The world, the radio medium and the IR optical channel are shared by all swarms (several users
share one medium). A :class:`Swarm` owns its robots' :class:`~.node.Node` objects and runs the
processes of seed 000 on the clock: organize (join protocol), the IR token ring with heading
exchange, the master's status broadcast and disperse.
"""

from __future__ import annotations

import math

import numpy as np

from petswarm_env.comms.ir_channel import IRChannel
from petswarm_env.comms.radio import RadioMedium
from petswarm_env.config import Config
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation, build_formation
from petswarm_env.middleware.join import JoinManager, OrganizeResult
from petswarm_env.middleware.node import MasterStatus, Node
from petswarm_env.middleware.sequence import SequenceManager
from petswarm_env.middleware.token_ring import TokenRing
from petswarm_env.sim.world import World


class Swarm:
    def __init__(
        self,
        cfg: Config,
        world: World,
        radio: RadioMedium,
        ir_channel: IRChannel,
        rng: np.random.Generator,
        user_id: int,
        pan: int,
        master_index: int,
        robot_indices: list[int],
    ):
        self.cfg = cfg
        self.world = world
        self.clock = world.clock
        self.radio = radio
        self.ir_channel = ir_channel
        self.rng = rng
        self.user_id = user_id
        self.pan = pan
        self.nodes: dict[int, Node] = {}
        for idx in [master_index, *robot_indices]:
            node = Node(self, idx, np.random.default_rng(rng.integers(2**63)))
            node.join = JoinManager(node)
            node.ring = TokenRing(node)
            node.seq = SequenceManager(node)
            node.on(msg.STATUS, lambda frame, node=node: self.on_status(node, frame))
            self.nodes[idx] = node
        self.master = self.nodes[master_index]
        self.master.connected_user = user_id
        self.master.state = cfg.swarm.mode
        self.mode = cfg.swarm.mode
        self.organize_result = OrganizeResult()
        self.formation: Formation | None = None
        self.user_estimate: tuple[float, float] | None = None  # master's noisy view of the user
        self.user_turn_rate_estimate = 0.0

    # -- organize (seed 000 §3.4) --------------------------------------------------------------
    def start_organize(self) -> None:
        master = self.master
        self.organize_result = OrganizeResult()
        master.seq.previous_driving_state = master.state
        master.state = "organizing"
        self.clock.process(self._organize())

    def _organize(self):
        master = self.master
        result = self.organize_result
        yield from master.join.organize(self.cfg.swarm.num_slaves, self.pan, self.cfg.swarm.formation, result)
        master.state = "master"
        master.swarm_pan = self.pan
        master.know.member = 0
        master.know.members = dict(result.members)
        master.know.total_members = len(result.members)
        self.formation = build_formation(self.cfg.swarm, len(result.members))
        master.formation = self.formation
        if len(result.members) > 1:
            self.clock.process(master.ring.hold(0))
            self.clock.process(master.ring.watchdog())
        self.clock.process(self._broadcast_status())

    def become_slave(self, node: Node, pan: int, member: int, members: dict, shape: str) -> None:
        """A waiting robot accepts the joining notification: new PAN, member number, neighbours."""
        node.state = "slave"
        node.swarm_pan = pan
        node.pans = frozenset({pan})
        node.know.member = member
        node.know.members = {int(m): n for m, n in members.items()}
        node.know.total_members = len(members)
        node.formation = build_formation(self.cfg.swarm, len(members))

    @property
    def organized(self) -> bool:
        return self.master.state == "master"

    def slave_ids(self) -> list[int]:
        """Node ids of the robots in slave-role driving."""
        return sorted(n for n, node in self.nodes.items() if node.state == "slave" and node.swarm_pan == self.pan)

    # -- IR slot and heading exchange (seed 000 §3.3, §3.5) -------------------------------------
    def ir_slot(self, holder: Node) -> list[int]:
        """The holder's IR transmission: every other member measures it; the holder's neighbours
        that saw it report their bearing back (heading exchange). Returns the reporters' ids."""
        receivers = [n for n in holder.know.members.values() if n != holder.node_id and self.nodes[n].swarm_pan == self.pan]
        if not receivers:
            return []
        dist, bearing, valid = self.ir_channel.measure(holder.node_id, receivers)
        for rid, d, b, ok in zip(receivers, dist, bearing, valid):
            if ok:
                self.nodes[rid].store_ir(holder.node_id, float(d), float(b))
        neighbours = self.formation.neighbours(holder.know.member) if self.formation else set()
        reporters = []
        for m in neighbours:
            rid = holder.know.members.get(m)
            node = self.nodes.get(rid)
            if node is None or rid not in receivers:
                continue
            seen = node.know.ir.get(holder.node_id)
            if seen is not None and seen.time_s == self.clock.now:
                node.ring.send_heading(holder.node_id, seen.bearing_rad)
                reporters.append(rid)
        return reporters

    # -- master broadcast (seed 000 §3.5, Fig. 9) ------------------------------------------------
    def _broadcast_status(self):
        master = self.master
        period = self.cfg.protocol.broadcast_period_s
        while master.state == "master":
            vx, vy, w = self.world.robots[master.node_id].velocity_body
            user = self.user_estimate or (self.cfg.master.distance_m, 0.0)
            master.send(
                msg.STATUS,
                velocity=(vx, vy, w),
                activity=self.world.user.activity,
                mode=self.mode,
                turn_rate=self.user_turn_rate_estimate,
                user=user,
            )
            yield self.clock.timeout(period)

    def on_status(self, node: Node, frame) -> None:
        p = frame.payload
        node.know.status = MasterStatus(p["velocity"], p["activity"], p["mode"], p["turn_rate"], p["user"], self.clock.now)

    # -- the master's view of its user (stand-in for the LF/BLE chain of seed 002) ---------------
    def sense_user(self) -> None:
        """Noisy user position relative to the master, in the master's frame.

        Until the wearable chain of seed 002 is built, the master reads the true relative position
        with Gaussian noise ``master.user_pos_noise_m`` and the user's turn rate with 5 % noise.
        """
        robot = self.world.robots[self.master.node_id]
        ux, uy = self.world.user.position
        rx, ry = robot.position
        th = robot.heading
        dx, dy = ux - rx, uy - ry
        c, s = math.cos(th), math.sin(th)
        sigma = self.cfg.master.user_pos_noise_m
        noise = self.rng.normal(0.0, sigma, 2) if sigma > 0 else (0.0, 0.0)
        self.user_estimate = (c * dx + s * dy + noise[0], -s * dx + c * dy + noise[1])
        self.user_turn_rate_estimate = self.world.user.turn_rate_rps * (1.0 + 0.05 * self.rng.standard_normal())

    # -- disperse --------------------------------------------------------------------------------
    def start_disperse(self) -> dict:
        result: dict = {}
        self.clock.process(self.master.seq.disperse(result))
        return result

    def token_recoveries(self) -> int:
        return self.master.ring.recoveries

    def foreign_pan_frames_processed(self) -> int:
        return sum(n.counters["foreign_pan_frames_processed"] for n in self.nodes.values())
