"""2-D geometry helpers (numpy only, no physics engine): the angle wrap and the ray casts.

All lengths are in metres, all points are world-frame ``(x, y)`` pairs, all angles radians. The
ray casts work on whole batches at once (no Python loop over rays or segments) and accept empty
batches (zero rays, circles or segments) without special-casing by the caller.

Used for the ultrasonic ring (:mod:`petswarm_env.sim.sensors`) and, for the wrap, by every module
that subtracts headings or bearings. (The IR line of sight through bodies is a plain-Python loop in
:mod:`petswarm_env.comms.ir_channel`: an IR slot has a handful of segments; through walls and boxes
it takes :meth:`SegmentSet.near_box` and :func:`segment_crosses`.)
"""

from __future__ import annotations

import math

import cython
import numpy as np
from cython.cimports.libc.math import cos as _c_cos
from cython.cimports.libc.math import fabs as _c_fabs
from cython.cimports.libc.math import sin as _c_sin
from cython.cimports.libc.math import sqrt as _c_sqrt

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_INF = math.inf
_PI = math.pi
_TWO_PI = 2.0 * math.pi
_C_PI = cython.declare(cython.double, _PI)  # the same two as C doubles (wrap_float)
_C_TWO_PI = cython.declare(cython.double, _TWO_PI)


def wrap_angle(angle_rad):
    """An angle wrapped to [−π, π): ``(a + π) mod 2π − π``, the one angle wrap of the project.

    Works on a Python float and on a numpy array alike (Python's ``%`` and numpy's ``remainder``
    round the same way). Rounding of ``a + π`` can put a value within an ulp of −π at +π. Where a
    bearing belongs to (−π, π] (the IR estimator), ``−wrap_angle(−a)`` is ``π − (π − a) mod 2π``
    to the bit. :func:`wrap_float` is the same for one float, a C call for the compiled modules."""
    return (angle_rad + _PI) % _TWO_PI - _PI


@cython.ccall
def wrap_float(angle_rad: cython.double) -> cython.double:
    """:func:`wrap_angle` of one float: a C call from the compiled modules (``geometry.pxd``), on C doubles
    with Python's ``%`` (the remainder takes the divisor's sign; Cython's ``%`` of doubles is Python's), so
    the same number to the bit."""
    return (angle_rad + _C_PI) % _C_TWO_PI - _C_PI

# Denominators smaller than this (in m for cross products of a unit vector with a segment) are
# treated as "ray parallel to segment": such a segment is never hit.
_PARALLEL_EPS = 1e-12
# A circle whose centre lies farther than the reach plus its radius plus this from a ray's origin is left out of
# the ray's cast (:func:`ring_cast`): its hits lie at t >= |m| - r, beyond the reach, so the answer is the same to
# the bit (the margin, 1 µm, dwarfs the rounding of t); the cast of a large swarm is mostly such pairs.
_CULL_M = 1e-6


def _as_points(a: np.ndarray) -> np.ndarray:
    """Return ``a`` as a float array of shape (N, 2) (an empty input becomes shape (0, 2))."""
    return np.asarray(a, dtype=float).reshape(-1, 2)


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """z component of the 2-D cross product ``u × v``, broadcast over leading axes."""
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def ray_segment_distances(
    origins: np.ndarray,
    dirs: np.ndarray,
    seg_a: np.ndarray,
    seg_b: np.ndarray,
    max_range: float,
) -> np.ndarray:
    """Distance along each ray to its intersection with each line segment (walls, box edges).

    Args:
        origins: (R, 2) ray start points, m.
        dirs: (R, 2) unit direction vectors.
        seg_a: (S, 2) first end point of each segment, m.
        seg_b: (S, 2) second end point of each segment, m.
        max_range: hits farther than this (m) are reported as ``inf``.

    Returns:
        (R, S) distances in m; ``inf`` where the ray misses the segment, is parallel to it
        (collinear overlaps included), or the hit is beyond ``max_range``. End points count as hits.
    """
    o = _as_points(origins)
    d = _as_points(dirs)
    a = _as_points(seg_a)
    e = _as_points(seg_b) - a  # (S, 2) segment vectors
    denom = _cross(d[:, None, :], e[None, :, :])  # (R, S)
    ao = a[None, :, :] - o[:, None, :]  # (R, S, 2) origin -> segment start
    parallel = np.abs(denom) < _PARALLEL_EPS
    safe = np.where(parallel, 1.0, denom)
    t = _cross(ao, e[None, :, :]) / safe  # distance along the ray
    u = _cross(ao, d[:, None, :]) / safe  # position along the segment, 0..1
    hit = ~parallel & (t >= 0.0) & (t <= max_range) & (u >= 0.0) & (u <= 1.0)
    return np.where(hit, t, np.inf)


class SegmentSet:
    """Fixed line segments (walls, box edges) prepared for :func:`ring_first_hits`: end points and
    bounding boxes, so that a cast can leave out every segment out of reach of all its rays."""

    def __init__(self, seg_a: np.ndarray, seg_b: np.ndarray, max_range: float):
        self.a = _as_points(seg_a)
        self.b = _as_points(seg_b)
        # bounding boxes grown by the reach of a ray: a ray from outside cannot hit the segment
        lo = np.minimum(self.a, self.b) - max_range
        hi = np.maximum(self.a, self.b) + max_range
        self._boxes = [(i, *lo[i].tolist(), *hi[i].tolist()) for i in range(len(self.a))]
        e = self.b - self.a  # each segment's vector, as ray_segment_distances computes it
        self._ends = [(*self.a[i].tolist(), *e[i].tolist()) for i in range(len(self.a))]
        # per segment its grown box then its start and vector, flat: what ring_cast reads
        self.table = np.array([[*box[1:], *end] for box, end in zip(self._boxes, self._ends)], float).reshape(-1)
        self.max_range = max_range

    def __len__(self) -> int:
        return len(self.a)

    def ends_near(self, points: list) -> list[tuple[float, float, float, float]]:
        """``(ax, ay, ex, ey)`` (a segment's start and its vector ``b − a``) of the segments that
        some ray of length ``max_range`` from ``points`` (a list of ``[x, y]``) may hit
        (:meth:`near_box` of the points' bounding box)."""
        if not self._boxes or not points:
            return []
        xs = [p[0] for p in points]
        ys = [p[1] for p in points]
        ends = self._ends
        return [ends[i] for i in self.near_box(min(xs), min(ys), max(xs), max(ys))]

    def near(self, points: np.ndarray) -> list[int]:
        """Indices of the segments that some ray of length ``max_range`` from ``points`` may hit:
        those whose grown bounding box overlaps the bounding box of the points."""
        if not self._boxes or not len(points):
            return []
        xs, ys = np.asarray(points).T.tolist()  # the bounding box in Python (a handful of points)
        return self.near_box(min(xs), min(ys), max(xs), max(ys))

    def near_box(self, x0: float, y0: float, x1: float, y1: float) -> list[int]:
        """Indices of the segments whose grown bounding box overlaps the box [x0, x1] × [y0, y1]."""
        return [i for i, lx, ly, hx, hy in self._boxes if lx <= x1 and ly <= y1 and hx >= x0 and hy >= y0]


def segment_crosses(px: float, py: float, vx: float, vy: float, ax: float, ay: float, bx: float, by: float) -> bool:
    """Does the segment ``p → p + v`` cross the segment ``a → b``? Strictly: each segment's end
    points lie strictly on opposite sides of the other's line (touching an end point, grazing and
    collinear overlap are clear, as a grazed circle is for the bodies' line of sight). Plain Python
    floats: called for a handful of segments per IR slot."""
    ex, ey = bx - ax, by - ay
    d1 = vx * (ay - py) - vy * (ax - px)  # side of a, of b, relative to the line p → p + v
    d2 = vx * (by - py) - vy * (bx - px)
    if (d1 > 0.0) == (d2 > 0.0) or d1 == 0.0 or d2 == 0.0:
        return False
    d3 = ex * (py - ay) - ey * (px - ax)  # side of p, of p + v, relative to the line a → b
    d4 = ex * (py + vy - ay) - ey * (px + vx - ax)
    return (d3 > 0.0) != (d4 > 0.0) and d3 != 0.0 and d4 != 0.0


def ring_first_hits(
    origins: np.ndarray,
    headings: np.ndarray,
    angles: np.ndarray,
    centers: np.ndarray,
    radii: np.ndarray,
    walls: SegmentSet | None,
    max_range: float,
) -> np.ndarray:
    """A ring of rays from each origin: distance to the first circle or wall each ray meets.

    Ray ``k`` of origin ``i`` points at ``headings[i] + angles[k]``. The result is the distance to
    the nearest circle (the nearer root of the ray–circle quadratic; a ray never sees a circle its
    origin is inside or on) or segment (the arithmetic of :func:`ray_segment_distances`, ray by
    ray), hits beyond ``max_range`` are ``inf``. (``tests/oracles.py`` keeps the per-circle ray
    cast and the numpy formulation it equals.) The cast itself is :func:`ring_cast`.

    Args:
        origins: (N, 2) ray start points, m.
        headings: (N,) heading of each origin, rad.
        angles: (K,) ray directions relative to the heading, rad.
        centers: (C, 2) circle centres, m; radii: (C,) m.
        walls: the segments (or None); ``walls.max_range`` must be at least ``max_range``.
        max_range: m.

    Returns:
        (N, K) distances, m; ``inf`` where the ray meets nothing within ``max_range``.
    """
    o = np.ascontiguousarray(_as_points(origins))
    th = np.ascontiguousarray(np.asarray(headings, dtype=float).reshape(-1))
    ang = np.ascontiguousarray(np.asarray(angles, dtype=float).reshape(-1))
    out = np.empty((len(o), len(ang)))
    table = walls.table if walls is not None else np.empty(0)
    ring_cast(o, len(o), th, ang, np.ascontiguousarray(_as_points(centers)),
              np.ascontiguousarray(np.asarray(radii, dtype=float).reshape(-1)), table, max_range, out, np.empty((len(ang), 2)))
    return out


def ring_cast(origins: cython.const[cython.double][:, ::1], n: cython.Py_ssize_t,
              headings: cython.const[cython.double][::1], angles: cython.const[cython.double][::1],
              centers: cython.const[cython.double][:, ::1], radii: cython.const[cython.double][::1],
              walls: cython.const[cython.double][::1], max_range: cython.double,
              out: cython.double[:, ::1], dirs: cython.double[:, ::1]) -> None:
    """:func:`ring_first_hits` on float64 arrays, into ``out`` (n, K): the rays of the first ``n``
    origins (rows of ``origins``), ``walls`` a :attr:`SegmentSet.table` (segments whose grown box
    misses every origin are left out: none of their hits is within reach); ``dirs`` (K, 2) is
    scratch for one origin's ray directions. The env's ring calls it on the world's truth arrays as
    they are (no conversion).

    A loop over (origin, circle, ray) in C doubles in the compiled core (a handful of robots: the
    arithmetic is a few hundred operations, less than the numpy calls it replaced cost), the same
    IEEE operations in the same order as the numpy formulation: ``cc = |m|² − r²`` (the origin
    inside or on a circle: never seen), ``b = d·m``, ``disc = b² − cc`` (a miss when negative),
    the root ``t = −b − √disc`` kept negated, ``tn = b + √disc`` (rounding to nearest is symmetric,
    so ``−tn`` is ``t`` to the bit, up to the sign of a zero), and ``tn > 0``: behind the origin.
    Each ray's nearest root is kept in its ``out`` cell while the circles go by in their order, so
    a circle out of reach of the origin (or around it) is left out once for all its rays, not once
    per ray: in a large swarm most pairs of robots are out of each other's reach.
    One function on purpose: its loop runs for every ray of every robot at every step, on C locals."""
    nk: cython.Py_ssize_t = angles.shape[0]
    nc: cython.Py_ssize_t = centers.shape[0]
    nw: cython.Py_ssize_t = walls.shape[0] // 8
    i: cython.Py_ssize_t
    j: cython.Py_ssize_t
    k: cython.Py_ssize_t
    x0: cython.double = _INF  # the origins' bounding box
    y0: cython.double = _INF
    x1: cython.double = -_INF
    y1: cython.double = -_INF
    for i in range(n):
        x0 = min(x0, origins[i, 0])
        y0 = min(y0, origins[i, 1])
        x1 = max(x1, origins[i, 0])
        y1 = max(y1, origins[i, 1])
    reach: cython.double = max_range
    ox: cython.double
    oy: cython.double
    a: cython.double
    dx: cython.double
    dy: cython.double
    mx: cython.double
    my: cython.double
    cc: cython.double
    rj: cython.double
    b: cython.double
    disc: cython.double
    tn: cython.double
    denom: cython.double
    aox: cython.double
    aoy: cython.double
    ex: cython.double
    ey: cython.double
    t: cython.double
    u: cython.double
    near: cython.double
    lim: cython.double
    ang_k: cython.double
    w: cython.Py_ssize_t
    inf: cython.double = _INF
    eps: cython.double = _PARALLEL_EPS
    far: cython.double = reach + _CULL_M  # a circle centred beyond far + its radius is out of reach
    for i in range(n):
        ox = origins[i, 0]
        oy = origins[i, 1]
        a = headings[i]
        for k in range(nk):
            ang_k = angles[k]
            ang_k = a + ang_k
            dirs[k, 0] = _c_cos(ang_k)
            dirs[k, 1] = _c_sin(ang_k)
            out[i, k] = -inf  # the largest tn: the nearest hit in front
        for j in range(nc):
            mx = ox - centers[j, 0]
            my = oy - centers[j, 1]
            rj = radii[j]
            cc = mx * mx + my * my
            lim = far + rj
            if cc > lim * lim:
                continue  # every hit of it lies beyond reach (t >= |m| - r): it cannot be the answer
            cc = cc - rj * rj
            if cc <= 0.0:
                continue  # the origin inside or on it: every ray's tn would be b + √inf, behind (-inf), never kept
            for k in range(nk):
                b = dirs[k, 0] * mx + dirs[k, 1] * my
                if b > 0.0:
                    continue  # the circle behind the ray (tn = b + √disc > 0, or b + √inf): never kept
                disc = b * b - cc
                if disc < 0.0:
                    disc = inf
                tn = b + _c_sqrt(disc)
                if tn > 0.0:
                    tn = -inf
                if tn > out[i, k]:
                    out[i, k] = tn
        for k in range(nk):
            dx = dirs[k, 0]
            dy = dirs[k, 1]
            near = -out[i, k]
            for j in range(nw):
                w = 8 * j
                if not (walls[w] <= x1 and walls[w + 1] <= y1 and walls[w + 2] >= x0 and walls[w + 3] >= y0):
                    continue  # out of reach of every origin (its grown box misses their box)
                w += 4
                ex = walls[w + 2]
                ey = walls[w + 3]
                denom = dx * ey - dy * ex
                if _c_fabs(denom) < eps:
                    continue
                aox = walls[w] - ox
                aoy = walls[w + 1] - oy
                t = (aox * ey - aoy * ex) / denom
                u = (aox * dy - aoy * dx) / denom
                if t >= 0.0 and t <= reach and u >= 0.0 and u <= 1.0 and t < near:
                    near = t
            out[i, k] = inf if near > reach else near
