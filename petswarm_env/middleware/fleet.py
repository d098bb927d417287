"""Every robot's middleware wired to the shared media, and to the swarm each robot is in.

The world, the radio medium and the IR optical channel are shared by all robots and all swarms
(several users share one medium). The :class:`Fleet` builds each robot's :class:`~.node.Node`
(which builds its own managers), plugs the node's IR port into the IR medium (:meth:`Fleet.ir_slot`)
and subscribes to the node's signals, which it forwards to the user's :class:`~.swarm.Swarm` the
robot is in: first the swarm whose pool it starts in, then the one whose PAN it joined. Only the
env imports this module.

A module of the compiled core (``petswarm_env/_core.py``): the IR medium (:meth:`Fleet.ir_slot`)
runs for every slot of every token ring; the same file runs under the interpreter.
"""

from __future__ import annotations

import functools

import cython
import numpy as np

from petswarm_env.comms.ir_channel import IRChannel
from petswarm_env.comms.radio import RadioMedium
from petswarm_env.config import Config
from petswarm_env.middleware.node import Node
from petswarm_env.middleware.swarm import Swarm
from petswarm_env.sim.world import World

if cython.compiled:  # a station's PAN, health and member number as C reads (middleware/station.pxd): every IR slot
    from cython.cimports.petswarm_env.middleware.knowledge import Knowledge
    from cython.cimports.petswarm_env.middleware.station import Station
else:
    from petswarm_env.middleware.knowledge import Knowledge
    from petswarm_env.middleware.station import Station

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)


class Fleet:
    """Every robot's middleware on the shared media, and the swarms by PAN ID."""

    def __init__(self, cfg: Config, world: World, radio: RadioMedium, ir_channel: IRChannel, rng: np.random.Generator):
        self.cfg = cfg
        self.world = world
        self.clock = world.clock
        self.radio = radio
        self.ir_channel = ir_channel
        self.nodes: dict[int, Node] = {}
        self.swarms: dict[int, Swarm] = {}
        self._swarm_of: dict[int, Swarm] = {}  # node id -> the swarm the robot is in
        self._rng = rng

    def add_node(self, index: int, swarm: Swarm) -> Node:
        """Robot ``index``'s middleware, starting in ``swarm``'s pool."""
        node = Node(index, self.cfg, self.clock, self.radio, self.world.robots[index],
                    np.random.default_rng(self._rng.integers(2**63)))
        node.transmit_ir = functools.partial(self.ir_slot, node)
        self.nodes[index] = node
        self._swarm_of[index] = swarm
        swarm_of = self._swarm_of.__getitem__
        node.became_slave.connect(lambda pan: self._swarm_of.__setitem__(index, self.swarms[pan]))
        node.plan_applied.connect(lambda plan, previous: swarm_of(index).apply_plan(plan, previous))
        node.handed_over.connect(lambda new_master: swarm_of(index).hand_over(node, self.nodes[new_master]))
        node.took_over.connect(lambda: swarm_of(index).take_over(node))
        node.cannot_lead.connect(lambda part: swarm_of(index).hand_over_for_fault(node, part))
        node.members_changed.connect(lambda event, ids: swarm_of(index).members_changed(node, event, ids))
        return node

    def swarm_of(self, node_id: int) -> Swarm:
        """The swarm robot ``node_id`` is in (or, while it never joined one, whose pool it is in)."""
        return self._swarm_of[node_id]

    # -- the IR medium (seed 000 §3.3 Fig. 7, §3.5 Fig. 9) --------------------------------------------
    def ir_slot(self, holder: Node, neighbours: list[int | None]) -> list[int]:
        """The token holder's IR transmission (its IR port): every other robot of its swarm (on its
        PAN, by the robots' own state, not the holder's table) whose IR module works measures it now
        and credits the reading to the robot its own ring frames announced as the holder
        (``TokenRing.announced_holder``: a robot that missed the announcement drops it, one that heard
        another holder named credits it there, as a real one would); each of the holder's
        ``neighbours`` (node ids, in the holder's order) that measured it in this slot reports the
        bearing it saw it at (heading exchange). Returns the reporters' ids, for which the holder waits."""
        nodes = self.nodes
        tx: Station = holder
        own, pan = tx.node_id, tx.swarm_pan
        if not tx.health.ir_ok:  # the IR module is off (a fault): no transmission, nothing measured
            return []
        # in the order of the member number each receiver holds (its own table's; the order of the draws)
        order: list = []
        st: Station
        know: Knowledge
        for n, node in nodes.items():
            st = node
            if n != own and st.swarm_pan == pan and st.health.ir_ok:
                know = st.know
                order.append((know.member, n))
        if not order:
            return []
        order.sort()
        receivers: list = [n for _, n in order]
        dist, bearing, valid = self.ir_channel.measure(own, receivers)
        for rid, d, b, ok in zip(receivers, dist, bearing, valid):
            if ok:
                heard = nodes[rid].ring.announced_holder()
                if heard is not None and heard != rid:
                    nodes[rid].store_ir(heard, d, b)
        return [rid for rid in neighbours if rid in receivers and nodes[rid].ring.report_heading(own)]

    def foreign_pan_frames_processed(self) -> int:
        return sum(n.counters["foreign_pan_frames_processed"] for n in self.nodes.values())
