"""One user's swarm (:class:`Swarm`): the user session's and the experimenter's handle on it.

A swarm is a PAN, the robot connected to the user (its master), the member and neighbour tables,
the driving mode and the events counted. It starts the processes of seed 000 on the clock by asking
its master's managers: organize (the join protocol, §3.4), the IR token ring with heading exchange
(§3.3, §3.5), the master's status broadcast (Fig. 9), driving-mode changes with master change
(Table 3) and disperse. It learns what happened on the robots from their signals, which the fleet
(:mod:`.fleet`, the robots' wiring to the shared media) forwards to the swarm each robot is in; no
robot's middleware sees the swarm.
"""

from __future__ import annotations

from typing import Protocol


from petswarm_env.config import Config
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation, leading_user
from petswarm_env.middleware.join import OrganizeResult
from petswarm_env.middleware.knowledge import MasterStatus
from petswarm_env.middleware.modes import (ModeChangePlan, SwarmGeometry, measured_geometry, plan_master_handover,
                                          plan_mode_change)
from petswarm_env.middleware.node import Node
from petswarm_env.sim.clock import Clock
from petswarm_env.sim.world import World
from petswarm_env.step_kernel import slaves_of


class FleetView(Protocol):
    """What a swarm needs of the robots' wiring, :class:`~.fleet.Fleet` (which only the env imports)."""

    cfg: Config
    world: World
    clock: Clock
    nodes: dict[int, Node]  # every robot's middleware, by node id
    swarms: dict[int, Swarm]  # every user's swarm, by PAN ID

    def add_node(self, index: int, swarm: Swarm) -> Node: ...

    def swarm_of(self, node_id: int) -> Swarm: ...

    def foreign_pan_frames_processed(self) -> int: ...


class Swarm:
    """One user's swarm: its PAN, its master (the user-connected robot), formation and mode."""

    def __init__(self, fleet: FleetView, user_id: int, pan: int, master_index: int, pool: list[int]):
        cfg = fleet.cfg
        self.fleet = fleet
        self.cfg = cfg
        # plain copies of the config's values that the status broadcast reads (the config is frozen)
        self._broadcast_period_s, self._distance_m = cfg.protocol.broadcast_period_s, cfg.master.distance_m
        self.world = fleet.world
        self.clock = fleet.clock
        self.user_id = user_id
        self.pan = pan
        fleet.swarms[pan] = self
        self.nodes = fleet.nodes  # shared: a robot of this pool may join another user's swarm
        for idx in [master_index, *pool]:
            fleet.add_node(idx, self)
        self.master = self.nodes[master_index]
        self.mode = cfg.swarm.mode
        self.organize_result = OrganizeResult()
        self.formation: Formation | None = None
        self.previous_formation: Formation | None = None  # the tables before the last mode change
        self.previous_members: dict[int, int] = {}
        self.mode_changed_s = -float("inf")
        self.last_geometry: SwarmGeometry | None = None  # what the master knew at the last Table 3 choice
        self.user_view: MasterStatus | None = None  # the master's view of its user (set by the session)
        self.events = {"master_changes": 0, "mode_changes": 0, "successions": 0}
        self.emergency = False  # the user is lost (seed 002 Fig. 4); set by the user session
        self.handing_over = False  # the master hands its user over for a broken part (hand_over_for_fault)
        self.fault_handovers: list[tuple[float, int, int, str]] = []  # (time, old master, new master, part)
        self.on_master_change = None  # callback(old_node, new_node), set by the user session
        self._session_on: Node | None = self.master  # the master the user's session follows (_master_changed)
        self.on_succession = None  # callback(new_node): a slave took a lost master's place; set by the user session
        # members lost and recruited while organized (middleware/recovery.py): (time, "lost" | "joined", node ids)
        self.member_log: list[tuple[float, str, list[int]]] = []

    # -- organize (seed 000 §3.4) --------------------------------------------------------------
    def start_organize(self) -> None:
        master = self.master
        self.organize_result = OrganizeResult()
        master.previous_driving_state = master.state
        master.state = "organizing"
        self.clock.process(self._organize())

    def _organize(self):
        master = self.master
        yield from master.join.organize(self.cfg.swarm.num_slaves, self.pan, self.organize_result, lambda: self.mode,
                                        spares=self.cfg.swarm.spares)
        self.formation = master.formation  # laid out for the driving mode by the master's join manager
        master.recovery.pool_heard = len(self.organize_result.candidates)  # the robots its scans heard (spare places)
        self._start_master_processes(master)

    def _start_master_processes(self, master: Node) -> None:
        master.ring.start_as_master()
        self.clock.start(self._broadcast_status, master)
        self.clock.process(master.recovery.maintain(self.pan))  # the periodic scan while a slot is open

    def members_changed(self, node: Node, event: str, node_ids: list[int]) -> None:
        """The master removed (``lost``), recruited (``joined``) or renumbered (``renumbered``, on the mirror image of
        its table while building: recovery.RecoveryManager.replan_building) members (middleware/recovery.py)."""
        if node is self.master:
            self.formation = node.formation
            self.member_log.append((self.clock.now, event, list(node_ids)))

    @property
    def organized(self) -> bool:
        return self.master.state == "master"

    def slave_ids(self) -> list[int]:
        """Node ids of the robots in slave-role driving in this swarm."""
        return slaves_of(self.nodes, self.pan)

    def slaves_missing(self) -> int:
        """The user-required number of slaves minus the robots in slave-role driving (a swarm that
        organized short: the join protocol's budget ran out, see :mod:`.join`)."""
        return max(0, self.cfg.swarm.num_slaves - len(self.slave_ids()))

    def member_ids(self) -> list[int]:
        return [self.master.node_id, *self.slave_ids()] if self.organized else []

    # -- master broadcast (seed 000 §3.5, Fig. 9) ------------------------------------------------
    def _broadcast_status(self, master: Node) -> None:
        """The master's status, every ``protocol.broadcast_period_s`` while it is this swarm's master."""
        if master.state != "master" or self.master is not master:
            return
        view = self.user_view
        if view is not None:
            activity, turn_rate, rotating, user = view.activity, view.user_turn_rate_rps, view.user_rotating, view.user_position_m
        else:
            activity, turn_rate, rotating, user = "stop", 0.0, False, (self._distance_m, 0.0)
        master.send(
            msg.STATUS,
            velocity=master.driving_speed(),  # (vx, vy, ω): its own command's (vx, vy), its wheels' ω (noise and all)
            activity=activity,
            mode="emergency" if self.emergency else self.mode,  # (broadcast_mode)
            turn_rate=turn_rate,
            rotating=rotating,
            user=user,
        )
        # the master's own clock (seed 000 §3.3: independent clocks)
        master.clock.later(self._broadcast_period_s, self._broadcast_status, master)

    def broadcast_mode(self) -> str:
        """The mode the slaves hear: the driving mode, or ``emergency`` while the user is lost."""
        return "emergency" if self.emergency else self.mode

    # -- driving-mode change (seed 000 §3.5, Table 3) --------------------------------------------
    def change_mode(self, new_mode: str, master_change: bool, user_xy: tuple[float, float] | None) -> ModeChangePlan | None:
        """The user asked for ``new_mode``: plan by Table 3 from what the master knows (its IR
        measurements of the members; ``user_xy``: its LF track of the user, body frame, None
        without one) and run the mode-change protocol."""
        if new_mode == self.mode:
            return None
        master = self.master
        if not self.organized or self.formation is None:
            self.mode = new_mode
            self.events["mode_changes"] += 1
            return None
        geometry = measured_geometry(self.formation, master.know, master.ahrs_yaw(), master.clock.now, user_xy,
                                     self.cfg.master.distance_m)
        plan = plan_mode_change(self.cfg.swarm, self.formation, master.know.members, self.mode, new_mode,
                                master_change, geometry, master.know.lf_members, leading_user(self.cfg))
        self.last_geometry = geometry
        self.mode_change_result: dict = {}
        self.clock.process(master.modes.change(plan, self.mode_change_result))
        return plan

    def hand_over_for_fault(self, master: Node, part: str) -> ModeChangePlan | None:
        """The master found its ``part`` broken and its job needs it (``Station.cannot_lead``): it hands
        its user over by Table 3 (:func:`~.modes.plan_master_handover`, from what it knows: its IR
        measurements, stale now, and its LF track of the user) through the mode-change protocol with a
        master change, the mode unchanged. Once a slave, it asks to leave its slot (the node's
        ``handed_over``, seed 003 Algorithm 2 step 5). Nothing when no other robot may be master."""
        if master is not self.master or master.state != "master" or not self.organized or self.formation is None \
                or self.handing_over:
            return None
        view = self.user_view
        user_xy = view.user_position_m if view is not None else None
        geometry = measured_geometry(self.formation, master.know, master.ahrs_yaw(), master.clock.now, user_xy,
                                     self.cfg.master.distance_m)
        plan = plan_master_handover(self.formation, master.know.members, self.mode, geometry, master.know.lf_members)
        if plan is None:
            return None
        self.handing_over = True
        self.last_geometry = geometry
        self.mode_change_result = {"reason": part}
        self.fault_handovers.append((self.clock.now, master.node_id, plan.members[0], part))
        walk = view.walk_direction_rad if view is not None else None  # the way its user walks, as it knows it
        self.clock.process(master.modes.change(plan, self.mode_change_result, walk))
        return plan

    # -- what the robots signal (forwarded by the fleet to the swarm the robot is in) ---------------
    def apply_plan(self, plan: ModeChangePlan, previous_members: dict[int, int]) -> None:
        """The (old) master committed the plan once every member acknowledged it."""
        self.mode = plan.mode
        self.events["mode_changes"] += 1
        self.mode_changed_s = self.clock.now
        self.previous_formation, self.previous_members = self.formation, dict(previous_members)
        self.formation = plan.formation

    def hand_over(self, old: Node, new: Node) -> None:
        """The old master handed the user over and is a slave now (its handover acknowledged, or its
        retries spent)."""
        self.handing_over = False
        self._master_changed(old, new)

    def _master_changed(self, old: Node, new: Node) -> None:
        """The user's session follows the new master once (:meth:`take_over` or :meth:`hand_over`, whichever
        comes first)."""
        self.master = new
        if self._session_on is new:
            return
        self._session_on = new
        self.events["master_changes"] += 1
        if self.on_master_change is not None:
            self.on_master_change(old, new)

    def take_over(self, node: Node) -> None:
        """The new master took the user connection (its wearables reconnect over BLE), or — when
        no handover preceded it — a slave took its lost master's place (middleware/succession.py):
        the user session then pairs the belt with it."""
        succession = node.connected_user is None  # a handover brought the user's id (modes.py); a succession none
        if not succession and self.master is not node:
            # the new master drives its user from now on (the session commands swarm.master): its session starts
            # from its own estimate here, not after the old master's wait for the handover's acknowledgement
            # (chosen: in between, the new master was driven on the old master's user track, in the old
            # master's frame: a turn of up to 40° away from its user, the formation turning with it; IR on
            # the master, 1 + 8, seed 5006)
            self._master_changed(self.master, node)
        self.master = node
        self.formation = node.formation
        self._start_master_processes(node)
        if succession:
            self._session_on = node  # the session pairs the belt with it (on_succession)
            self.events["successions"] += 1
            if self.on_succession is not None:
                self.on_succession(node)

    # -- disperse --------------------------------------------------------------------------------
    def start_disperse(self) -> dict:
        result: dict = {}
        self.clock.process(self.master.seq.disperse(result))
        return result

    def foreign_pan_frames_processed(self) -> int:
        """Frames of a PAN a robot was not in that it processed anyway, over every robot (must be 0)."""
        return self.fleet.foreign_pan_frames_processed()

    def token_recoveries(self) -> int:
        return sum(n.ring.recoveries for i, n in self.nodes.items() if self.fleet.swarm_of(i) is self)
