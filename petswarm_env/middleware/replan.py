"""A master renumbering its members while it stands (seed 000 Fig. 10: the formation builds from a scattered start):
when its IR fixes place them so that other numbers would save at least :data:`REPLAN_GAIN_M` of their total move. A
mixin of :class:`~.recovery.RecoveryManager`, whose least-move plans (``removal_plan``, ``_least_move``,
``_move_costs``) and member update (``reassign``) it uses."""

from __future__ import annotations

import math

from petswarm_env.middleware.formation import formation_for_mode, leading_user
from petswarm_env.middleware.knowledge import FRESH_IR_S
from petswarm_env.middleware.matching import least_total, move_cost

# chosen: a master whose own odometry reads less than this stands (a refill may recruit from beyond the organize's
# region: RecoveryManager.refill_region_m); a master holding its distance to a standing user creeps below it
STANDING_MPS = 0.1
# chosen: a master renumbers its members while building only when that saves at least this much of their total move
# (its IR fixes' errors and the robots' own motion toward their slots stay well below it)
REPLAN_GAIN_M = 1.0


class Replanning:
    """The renumbering while building, on a :class:`~.recovery.RecoveryManager`."""

    def replan_building(self) -> None:
        """Master, while it stands for the building (seed 000 Fig. 10): when its IR fixes of every member place them
        so that the standard table or its mirror image, slots given by the least total move (:meth:`removal_plan`),
        would save at least :data:`REPLAN_GAIN_M` over their numbers, it renumbers them on that table (an
        acknowledged member update, :meth:`reassign`; a table re-rooted by a master change is kept, Table 3).
        Table 2 numbers the joining robots by their RSSI distances, blind to the side each stands on (chosen): in
        leading the user stands among the rear slots, and a slave given a slot on the other side had to pass its
        user and the robots beside them, and stalled there (leading straight, seeds 1200-1239: 4 formations never
        built, 2 after 20 s); in following two slaves each on the other's side met head-on behind the master, their
        keep-outs holding them apart, 0.8-1.0 m off for 40 s (1 + 4, seed 86). Without a fresh fix of every member
        (a wedge's rear robots stand in the IR shadow of the front ones) the members it sees swap the slots they
        hold among themselves (:meth:`_swap_seen`)."""
        node = self.node
        know = node.know
        if self.busy or node.formation is None or node.cfg.swarm.formation == "custom":
            return
        now = node.clock.now
        slaves = [n for m, n in know.members.items() if m != 0]
        seen = {n for n in slaves if n in know.ir and now - know.ir[n].time_s <= FRESH_IR_S}
        if not slaves or len(seen) < len(slaves) and not self._seen_would_swap(seen):
            return
        members = dict(know.members)
        standard = formation_for_mode(node.cfg.swarm, len(members), know.mode, leading_user(node.cfg))
        if node.formation != standard and node.formation != standard.mirrored():
            return  # a table re-rooted by a master change keeps its references (Table 3)
        held, cost = self._move_costs(members, node.formation)
        if any(not 0 < m <= len(row) for m, row in zip(held, cost)):
            return  # numbers with a gap (a removal under way)
        if len(seen) < len(slaves):
            self._swap_seen(members, slaves, seen, held, cost)
            return
        now_total = sum(row[m - 1] for m, row in zip(held, cost))
        table, formation, mirrored = self.removal_plan(members, standard, building=True)
        if self._least_move(table, formation, None, True)[0] >= now_total - REPLAN_GAIN_M:
            return
        self._renumber(table, formation, mirrored)

    def _seen_would_swap(self, seen: set[int]) -> bool:
        """Whether the members of ``seen`` on the slots they hold, by their IR fixes as each was taken (no sensor
        read: the master stands), would save :data:`REPLAN_GAIN_M` (:meth:`_swap_seen` then plans it on the fixes
        carried to now)."""
        know = self.node.know
        slots = self.node.formation.slot_positions()
        holds = sorted((m, n) for m, n in know.members.items() if n in seen and 0 < m < len(slots))
        if len(holds) < 2:
            return False
        fixes = [(know.ir[n].distance_m * math.cos(know.ir[n].bearing_rad),
                  know.ir[n].distance_m * math.sin(know.ir[n].bearing_rad)) for _, n in holds]
        cost = [[math.hypot(x - float(slots[m][0]), y - float(slots[m][1])) for m, _ in holds] for x, y in fixes]
        return _least_swap(cost)[1] > REPLAN_GAIN_M

    def _swap_seen(self, members: dict[int, int], slaves: list[int], seen: set[int], held: list[int],
                   cost: list[list[float]]) -> None:
        """The members this master has fresh IR fixes of (``seen``) on the slots they hold, by the least total move
        (``cost``, :meth:`_move_costs`: the rows of ``slaves`` in member order, each the slot it holds in ``held``),
        the others keeping theirs, when that saves at least :data:`REPLAN_GAIN_M` (chosen: the two front slaves of a
        1 + 4 wedge started on each other's sides and held each other head-on behind the master, 0.8 m off their
        slots for 54 s; the rear ones, in their IR shadow, were never all seen at once: seed 4531)."""
        rows = [i for i, n in enumerate(slaves) if n in seen]
        if len(rows) < 2:
            return
        slots = [held[i] - 1 for i in rows]
        order, saving = _least_swap([[cost[i][c] for c in slots] for i in rows])
        if saving <= REPLAN_GAIN_M:
            return
        table = dict(members)
        for a, i in enumerate(rows):
            table[slots[order[a]] + 1] = slaves[i]
        self._renumber(dict(sorted(table.items())), self.node.formation, self.mirrored)

    def _renumber(self, table: dict[int, int], formation, mirrored: bool) -> None:
        """Renumber on ``table`` and ``formation`` if this master stands (its own odometry, read last: each read
        draws the sensor's noise)."""
        node = self.node
        vx, vy, _ = node.odometry.read()
        if math.hypot(vx, vy) < STANDING_MPS:
            self.mirrored = mirrored
            self.replans.append((node.clock.now, mirrored))
            self.reassign(table, formation)
            node.members_changed.emit("renumbered", [])  # the swarm's tables (and the experimenter's references) follow


def _least_swap(cost: list[list[float]]) -> tuple[list[int], float]:
    """Robots on the places they hold (row i holds column i of ``cost``, metres) reassigned among those places by the
    least total move while building (:func:`~.matching.move_cost`): the assignment (row -> column) and the metres it
    saves over keeping them."""
    order = least_total([[move_cost(d, True) for d in row] for row in cost])
    return order, sum(row[i] for i, row in enumerate(cost)) - sum(row[order[i]] for i, row in enumerate(cost))
