"""The robots' middleware (:class:`Fleet`) and one user's swarm (:class:`Swarm`), wired together.

The world, the radio medium and the IR optical channel are shared by all swarms (several users
share one medium). The :class:`Fleet` owns every robot's :class:`~.node.Node`; a robot belongs to
the swarm whose PAN it joined. A :class:`Swarm` runs the processes of seed 000 on the clock for one
user: organize (join protocol), the IR token ring with heading exchange, the master's status
broadcast, driving-mode changes with master change (Table 3) and disperse.
"""

from __future__ import annotations

import numpy as np

from petswarm_env.comms.ir_channel import IRChannel
from petswarm_env.comms.radio import RadioMedium
from petswarm_env.config import Config
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation, formation_for_mode
from petswarm_env.middleware.join import JoinManager, OrganizeResult
from petswarm_env.middleware.modes import ModeChangePlan, ModeManager, plan_mode_change
from petswarm_env.middleware.node import MasterStatus, Node
from petswarm_env.middleware.sequence import SequenceManager
from petswarm_env.middleware.token_ring import TokenRing
from petswarm_env.sim.world import World


class Fleet:
    """Every robot's middleware on the shared medium, and the swarms by PAN ID."""

    def __init__(self, cfg: Config, world: World, radio: RadioMedium, ir_channel: IRChannel, rng: np.random.Generator):
        self.cfg = cfg
        self.world = world
        self.clock = world.clock
        self.radio = radio
        self.ir_channel = ir_channel
        self.nodes: dict[int, Node] = {}
        self.swarms: dict[int, Swarm] = {}
        self._rng = rng

    def add_node(self, index: int, swarm: Swarm) -> Node:
        node = Node(swarm, index, np.random.default_rng(self._rng.integers(2**63)))
        node.join = JoinManager(node)
        node.ring = TokenRing(node)
        node.seq = SequenceManager(node)
        node.modes = ModeManager(node)
        node.on(msg.STATUS, lambda frame, node=node: node.swarm.on_status(node, frame))
        self.nodes[index] = node
        return node

    def foreign_pan_frames_processed(self) -> int:
        return sum(n.counters["foreign_pan_frames_processed"] for n in self.nodes.values())


class Swarm:
    """One user's swarm: its PAN, its master (the user-connected robot), formation and mode."""

    def __init__(self, fleet: Fleet, user_id: int, pan: int, master_index: int, pool: list[int]):
        cfg = fleet.cfg
        self.fleet = fleet
        self.cfg = cfg
        self.world = fleet.world
        self.clock = fleet.clock
        self.radio = fleet.radio
        self.ir_channel = fleet.ir_channel
        self.user_id = user_id
        self.pan = pan
        fleet.swarms[pan] = self
        self.nodes = fleet.nodes  # shared: a robot of this pool may join another user's swarm
        for idx in [master_index, *pool]:
            fleet.add_node(idx, self)
        self.master = self.nodes[master_index]
        self.mode = cfg.swarm.mode
        self.master_previous_state = cfg.swarm.mode
        self.organize_result = OrganizeResult()
        self.formation: Formation | None = None
        self.previous_formation: Formation | None = None  # the tables before the last mode change
        self.previous_members: dict[int, int] = {}
        self.mode_changed_s = -float("inf")
        self.user_view: MasterStatus | None = None  # the master's view of its user (set by the session)
        self.events = {"master_changes": 0, "mode_changes": 0}
        self.emergency = False  # the user is lost (seed 002 Fig. 4); set by the user session
        self._mode_seq = 0
        self.on_master_change = None  # callback(old_node, new_node), set by the user session

    # -- organize (seed 000 §3.4) --------------------------------------------------------------
    def start_organize(self) -> None:
        master = self.master
        self.organize_result = OrganizeResult()
        self.master_previous_state = master.state
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
        self.formation = formation_for_mode(self.cfg.swarm, len(result.members), self.mode)
        master.formation = self.formation
        self._start_master_processes(master)

    def _start_master_processes(self, master: Node) -> None:
        if master.know.total_members > 1:
            master.ring.token_seq += 1000  # supersede any token still in flight
            self.clock.process(master.ring.hold(master.ring.token_seq))
            self.clock.process(master.ring.watchdog())
        self.clock.process(self._broadcast_status(master))

    def become_slave(self, node: Node, pan: int, member: int, members: dict, shape: str) -> None:
        """A waiting robot accepts the joining notification: new PAN, member number, neighbours."""
        swarm = self.fleet.swarms[pan]
        node.swarm = swarm
        node.state = "slave"
        node.swarm_pan = pan
        node.pans = frozenset({pan})
        node.know.member = member
        node.know.members = {int(m): n for m, n in members.items()}
        node.know.total_members = len(members)
        node.formation = formation_for_mode(self.cfg.swarm, len(members), swarm.mode)

    @property
    def organized(self) -> bool:
        return self.master.state == "master"

    def slave_ids(self) -> list[int]:
        """Node ids of the robots in slave-role driving in this swarm."""
        return sorted(n for n, node in self.nodes.items() if node.state == "slave" and node.swarm_pan == self.pan)

    def member_ids(self) -> list[int]:
        return [self.master.node_id, *self.slave_ids()] if self.organized else []

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
                self.nodes[rid].store_ir(holder.node_id, d, b)
        formation = holder.formation
        neighbours = formation.neighbours(holder.know.member) if formation is not None else set()
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
    def _broadcast_status(self, master: Node):
        period = self.cfg.protocol.broadcast_period_s
        robot = self.world.robots[master.node_id]
        while master.state == "master" and self.master is master:
            view = self.user_view
            master.send(
                msg.STATUS,
                velocity=robot.velocity_body,  # (vx, vy, ω), an immutable tuple
                activity=view.activity if view else "stop",
                mode=self.broadcast_mode(),
                turn_rate=view.user_turn_rate_rps if view else 0.0,
                rotating=view.user_rotating if view else False,
                user=view.user_position_m if view else (self.cfg.master.distance_m, 0.0),
            )
            yield self.clock.timeout(period)

    def broadcast_mode(self) -> str:
        """The mode the slaves hear: the driving mode, or ``emergency`` while the user is lost."""
        return "emergency" if self.emergency else self.mode

    def on_status(self, node: Node, frame) -> None:
        p = frame.payload
        node.know.status = MasterStatus(p["velocity"], p["activity"], p["mode"], p["turn_rate"], p["user"],
                                        self.clock._now, p["rotating"])  # (clock.now, per frame)

    # -- driving-mode change (seed 000 §3.5, Table 3) --------------------------------------------
    def change_mode(self, new_mode: str, master_change: bool, user_distance_m: float) -> ModeChangePlan | None:
        """The user asked for ``new_mode``: plan by Table 3 and run the mode-change protocol."""
        if new_mode == self.mode:
            return None
        master = self.master
        if not self.organized or self.formation is None:
            self.mode = new_mode
            self.events["mode_changes"] += 1
            return None
        plan = plan_mode_change(self.cfg.swarm, self.formation, master.know.members, self.mode, new_mode,
                                master_change, user_distance_m)
        self._mode_seq += 1
        self.mode_change_result: dict = {}
        self.clock.process(master.modes.change(plan, self._mode_seq, self.mode_change_result))
        return plan

    def apply_plan(self, master: Node, plan: ModeChangePlan) -> None:
        """The (old) master commits the plan once every member acknowledged it."""
        self.mode = plan.mode
        self.events["mode_changes"] += 1
        self.mode_changed_s = self.clock.now
        self.previous_formation, self.previous_members = self.formation, dict(master.know.members)
        self.formation = plan.formation
        master.know.members = dict(plan.members)
        master.know.total_members = len(plan.members)
        master.know.member = next(m for m, n in plan.members.items() if n == master.node_id)
        master.formation = plan.formation

    def hand_over(self, old: Node, new: Node) -> None:
        """The old master hands the user over and becomes a slave."""
        old.state = "slave"
        old.connected_user = None
        self.master = new  # takes effect for the swarm once the new master took over
        self.events["master_changes"] += 1
        if self.on_master_change is not None:
            self.on_master_change(old, new)

    def take_over(self, node: Node, user_id: int, previous_state: str) -> None:
        """The new master takes the user connection (its wearables reconnect over BLE)."""
        node.state = "master"
        self.master = node
        node.connected_user = user_id
        node.seq.previous_driving_state = previous_state
        node.pans = frozenset({self.pan})
        self._start_master_processes(node)

    # -- disperse --------------------------------------------------------------------------------
    def start_disperse(self) -> dict:
        result: dict = {}
        self.clock.process(self.master.seq.disperse(result))
        return result

    def foreign_pan_frames_processed(self) -> int:
        """Frames of a PAN a robot was not in that it processed anyway, over every robot (must be 0)."""
        return self.fleet.foreign_pan_frames_processed()

    def token_recoveries(self) -> int:
        return sum(n.ring.recoveries for n in self.nodes.values() if n.swarm is self)
