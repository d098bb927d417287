"""Driving-mode change with and without master change (seed 000 §3.5, Fig. 10, Table 3).

Table 3 — criteria for changing the master when the driving mode is changed:

=====================  ==========================================  ==========================================
driving-mode change    master-change request: Change               master-change request: No change
=====================  ==========================================  ==========================================
leading → following    select the closest robot as the master, but  do not change the master, but change the
                       do not change the neighbour robots'          neighbour robots' relative-location
                       relative-location reference                  reference
following → leading    select the robot with the highest            do not change the master, but change the
                       hierarchical level as master, and the        neighbour robots' relative-location
                       neighbour robots' relative-location          reference
                       reference
=====================  ==========================================  ==========================================

Hierarchy levels are numbered from the robot farthest from the user (level 1, seed 000 §3.5);
"the highest hierarchical level" is read as the top of that hierarchy, level 1 — the robot
farthest from the user, where the leading-mode master belongs (Fig. 10). "The closest robot" is
the one closest to the user.

:func:`plan_mode_change` is the pure rule; :class:`ModeManager` runs it on the radio: the master
broadcasts the *mode-change* frame (new mode, member table, neighbour table) until every member
acknowledged, then hands the user connection over to the new master (*handover* frame,
acknowledged), which takes the user's wearables over BLE.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from petswarm_env.comms.radio import Frame
from petswarm_env.config import SwarmConfig
from petswarm_env.middleware import messages as msg
from petswarm_env.middleware.formation import Formation, Link, formation_for_mode, user_position_in_formation
from petswarm_env.middleware.node import Node

TABLE3_MODES = ("following", "leading")


@dataclass(frozen=True)
class ModeChangePlan:
    mode: str
    members: dict[int, int]  # new member number -> node id (member 0 = the master)
    formation: Formation
    master_changed: bool
    references_changed: bool


def plan_mode_change(
    cfg: SwarmConfig,
    formation: Formation,
    members: dict[int, int],
    old_mode: str,
    new_mode: str,
    master_change: bool,
    user_distance_m: float,
    positions: dict[int, tuple[float, float]] | None = None,
) -> ModeChangePlan:
    """Apply Table 3 to the current swarm.

    ``positions`` maps member number -> its estimated position in the master's frame (the
    master's IR measurements); it is used only to give each robot the nearest slot when the
    neighbour references are re-selected around a new master. Changes between a Table 3 mode and
    remote control keep master and references (the table has no row for them).
    """
    if old_mode == new_mode or old_mode not in TABLE3_MODES or new_mode not in TABLE3_MODES:
        return ModeChangePlan(new_mode, dict(members), formation, False, False)
    n = formation.size
    levels = formation.hierarchy_levels(user_position_in_formation(formation, user_distance_m))
    if not master_change:  # keep the master, change the references: the standard layout of the new mode
        return ModeChangePlan(new_mode, dict(members), formation_for_mode(cfg, n, new_mode), False, True)
    if new_mode == "following":  # leading → following: the closest robot, references unchanged
        new_root = max(range(n), key=lambda m: (levels[m], -m))
        new_formation, renumber = formation.rerooted(new_root)
        new_members = {renumber[m]: node for m, node in members.items()}
        return ModeChangePlan(new_mode, new_members, new_formation, new_root != 0, False)
    # following → leading: the top of the hierarchy (farthest from the user) and new references
    new_root = min(range(n), key=lambda m: (levels[m], m))
    new_formation = formation_for_mode(cfg, n, new_mode)
    slots = new_formation.slot_positions()
    pos = formation.slot_positions() if positions is None else np.array(
        [positions.get(m, tuple(formation.slot_positions()[m])) for m in range(n)], float)
    rel = pos - pos[new_root]  # where each robot stands, seen from the new master
    new_members = {0: members[new_root]}
    free = [m for m in range(n) if m != new_root]
    pairs = sorted((float(np.hypot(*(rel[m] - slots[k]))), k, m) for k in range(1, n) for m in free)
    taken_slots: set[int] = set()
    for _d, k, m in pairs:  # nearest robot to each slot, greedily
        if k in taken_slots or m not in free:
            continue
        new_members[k] = members[m]
        taken_slots.add(k)
        free.remove(m)
    return ModeChangePlan(new_mode, dict(sorted(new_members.items())), new_formation, new_root != 0, True)


def _links_payload(formation: Formation) -> dict:
    return {m: [(lk.neighbour, lk.offset_m) for lk in lks] for m, lks in formation.links.items()}


def _links_from_payload(shape: str, payload: dict) -> Formation:
    return Formation(shape, {int(m): tuple(Link(int(nb), tuple(off)) for nb, off in lks) for m, lks in payload.items()})


class ModeManager:
    """Both ends of a mode change on one robot."""

    def __init__(self, node: Node):
        self.node = node
        self.last_seq = -1
        self._acks: set[int] = set()
        self.handover_acked = False
        node.on(msg.MODE_CHANGE, self._on_mode_change)
        node.on(msg.MODE_CHANGE_ACK, self._on_ack)
        node.on(msg.HANDOVER, self._on_handover)
        node.on(msg.HANDOVER_ACK, self._on_handover_ack)

    # -- master side ------------------------------------------------------------------------------
    def change(self, plan: ModeChangePlan, seq: int, result: dict):
        """Master process: announce the plan until acknowledged, then hand the user over."""
        node = self.node
        clock = node.clock
        cfg = node.cfg.protocol
        old_members = dict(node.know.members)
        others = {n for n in old_members.values() if n != node.node_id}
        self._acks = set()
        retries = 0
        payload = dict(seq=seq, mode=plan.mode, members=dict(plan.members), shape=plan.formation.shape,
                       links=_links_payload(plan.formation))
        while True:
            node.send(msg.MODE_CHANGE, **payload)
            yield clock.timeout(cfg.response_timeout_s)
            if others <= self._acks or retries >= cfg.max_retries:
                break
            retries += 1
        result["retries"] = retries
        new_master = plan.members[0]
        swarm = node.swarm
        swarm.apply_plan(node, plan)
        if new_master != node.node_id:
            retries = 0
            self.handover_acked = False
            while True:
                node.send(msg.HANDOVER, dst=new_master, seq=seq, user=node.connected_user,
                          previous=swarm.master_previous_state)
                yield clock.timeout(cfg.response_timeout_s)
                if self.handover_acked or retries >= cfg.max_retries:
                    break
                retries += 1
            result["handover_retries"] = retries
            swarm.hand_over(node, node.swarm.nodes[new_master])
        result["done_s"] = clock.now

    def _on_ack(self, frame: Frame) -> None:
        if frame.dst == self.node.node_id:
            self._acks.add(frame.src)

    def _on_handover_ack(self, frame: Frame) -> None:
        if frame.dst == self.node.node_id:
            self.handover_acked = True

    # -- members ----------------------------------------------------------------------------------
    def _on_mode_change(self, frame: Frame) -> None:
        node = self.node
        p = frame.payload
        node.send(msg.MODE_CHANGE_ACK, dst=frame.src)
        if p["seq"] <= self.last_seq or node.state != "slave":
            return
        self.last_seq = p["seq"]
        members = {int(m): n for m, n in p["members"].items()}
        node.know.members = members
        node.know.total_members = len(members)
        node.know.member = next(m for m, n in members.items() if n == node.node_id)
        node.formation = _links_from_payload(p["shape"], p["links"])
        node.swarm.mode = p["mode"]

    def _on_handover(self, frame: Frame) -> None:
        node = self.node
        node.send(msg.HANDOVER_ACK, dst=frame.src)
        if node.state == "slave" and node.know.member == 0:
            node.swarm.take_over(node, frame.payload["user"], frame.payload["previous"])
