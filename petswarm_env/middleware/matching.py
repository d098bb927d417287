"""The least-total assignment of robots to places (the Hungarian method): the removal's re-plan
(:meth:`~.recovery.RecoveryManager.nearest_slots`) puts the remaining members on the slots by it."""

from __future__ import annotations

import math


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
