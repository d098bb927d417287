"""The least-total assignment of robots to places (the Hungarian method) and what a move costs in it: the
removal's re-plan (:meth:`~.recovery.RecoveryManager.nearest_slots`) and a successor's tables
(:func:`~.succession.succession_plan`) put the members on the slots by it."""

from __future__ import annotations

import math

# chosen: what a move of d metres costs in the slots' assignment of a formation that stands (a removal's re-plan,
# :meth:`~.recovery.RecoveryManager.removal_plan`; a successor's tables, :func:`~.succession.least_move`): d + d²·1/m.
# By metres alone one robot sent across the formation costs no more than a chain of robots each moving up one slot
# (the triangle inequality), and the plans took it: a new master that leaves its slot for the old master's place
# gave that slot to the rear robot of the other arm, 3 m through its neighbours and out of their IR reach (1 + 8,
# the master's IR fault, seed 101: 3.2 m off its slot 10 s later). The square makes long moves dear: the least
# total of squared moves gives paths that do not cross (concurrent assignment of straight-line moves), and the
# linear term keeps the fewest metres among plans of equal squares (on a line every assignment of the robots behind
# a lost member moves the same total: the order with no robot passing another). Re-formed within 10 s of the
# fault, by metres alone -> this, seeds 100-119 / 200-219 / 1300-1319 (`sensor_faults --kinds ir [--target master]`):
# the master's IR fault, 1 + 8 11/17/15 -> 15/17/12 of 20, 1 + 6 16/17/16 -> 16/17/18, leading 17/18/16 -> 18/18/16;
# a slave's, 1 + 8 18/17/19 -> 18/20/19, 1 + 6 18/19/18 -> 19/20/20; the default 1 + 4 unchanged (docs/faults.md).
MOVE_SQUARE_PER_M = 1.0
# chosen: the same while a formation builds (the organize's re-plan by the master's fixes, a leading swarm's
# renumbering while it stands): the robots come from anywhere and every metre is traffic, so metres count, the square
# only breaking ties (1 mm per m², below the IR's and the RSSI's resolution). With MOVE_SQUARE_PER_M there, 1 + 16 at
# loss 0 built its formation in 109 of 120 resets against 113, with 1,275 robot-robot contacts against 1,199
# (`measure_scale --slaves 16 --loss 0`, seeds 100-119, 200-219, 300-339, 400-439).
TIE_SQUARE_PER_M = 1e-3


# chosen: in a handover's plan (the new master goes to where the old one stood, :meth:`~.recovery.RecoveryManager._remove`)
# a member's straight move that passes closer than two robot radii and a lane gap (leaving.CLEAR_LANE_GAP_M) to that
# place counts this many metres more: the new master drives there and on with its user, and a member that meets it on
# the way is held by its keep-out, both keep-outs crossing. In a grid that lost its front robot a plan sent the member
# behind the new master's place diagonally across to the new master's old slot while the new master drove across its
# way, and the two held each other 6-8 s (the tie with the member behind that slot moving straight up: the square
# breaks neither); the master's IR fault, grid, seeds 4500-4549: re-formed 33 of 50 (docs/faults.md)
PAST_MASTER_M = 1.0


def move_cost(distance_m: float, building: bool = False) -> float:
    """What moving a robot ``distance_m`` metres costs in an assignment: :data:`MOVE_SQUARE_PER_M` for a
    formation that stands, :data:`TIE_SQUARE_PER_M` while it builds (``building``)."""
    square = TIE_SQUARE_PER_M if building else MOVE_SQUARE_PER_M
    return distance_m + square * distance_m * distance_m


def least_total(cost: list[list[float]]) -> list[int]:
    """The assignment of rows to columns of the square ``cost`` matrix with the least total (the
    Hungarian method, O(n³); row i -> column ``out[i]``). Among equal totals, the one the method
    reaches first from the diagonal (a robot keeps the column of its own index when nothing is gained)."""
    n = len(cost)
    if n == 0:
        return []
    inf = math.inf
    u, v = [0.0] * (n + 1), [0.0] * (n + 1)
    p, way = [0] * (n + 1), [0] * (n + 1)  # p[j]: the row on column j (1-based, 0 = none)
    for i in range(1, n + 1):
        p[0] = i
        j0 = 0
        minv = [inf] * (n + 1)
        used = [False] * (n + 1)
        while True:
            used[j0] = True
            i0, delta, j1 = p[j0], inf, 0
            for j in range(1, n + 1):
                if not used[j]:
                    cur = cost[i0 - 1][j - 1] - u[i0] - v[j]
                    if cur < minv[j] - 1e-12:
                        minv[j], way[j] = cur, j0
                    if minv[j] < delta:
                        delta, j1 = minv[j], j
            for j in range(n + 1):
                if used[j]:
                    u[p[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if p[j0] == 0:
                break
        while j0:
            j1 = way[j0]
            p[j0] = p[j1]
            j0 = j1
    out = [0] * n
    for j in range(1, n + 1):
        out[p[j] - 1] = j - 1
    return out
