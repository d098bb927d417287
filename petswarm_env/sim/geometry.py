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

import numpy as np

_PI = math.pi
_TWO_PI = 2.0 * math.pi


def wrap_angle(angle_rad):
    """An angle wrapped to [−π, π): ``(a + π) mod 2π − π``, the one angle wrap of the project.

    Works on a Python float and on a numpy array alike (Python's ``%`` and numpy's ``remainder``
    round the same way). Rounding of ``a + π`` can put a value within an ulp of −π at +π. Where a
    bearing belongs to (−π, π] (the IR estimator), ``−wrap_angle(−a)`` is ``π − (π − a) mod 2π``
    to the bit."""
    return (angle_rad + _PI) % _TWO_PI - _PI

# Denominators smaller than this (in m for cross products of a unit vector with a segment) are
# treated as "ray parallel to segment": such a segment is never hit.
_PARALLEL_EPS = 1e-12


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
        self.max_range = max_range

    def __len__(self) -> int:
        return len(self.a)

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
    origin is inside or on) or segment (:func:`ray_segment_distances`), hits beyond ``max_range``
    are ``inf``, computed in one pass: the origin-to-centre vectors are shared by the rays of one
    origin, and segments out of reach of every origin are left out. (``tests/oracles.py`` keeps the
    per-circle ray cast it equals.)

    Written for few numpy calls on small arrays (a handful of robots, where a call costs more than
    its arithmetic): the (circle, origin, ray) arrays have the circles first, so the nearest hit is
    a reduction over the leading axis; misses are marked by overwriting in place rather than by
    boolean masks combined with ``&``; the ``max_range`` cut is applied once, to the nearest hit of
    each ray (it is within range iff some hit is). The root ``t = −b − √disc`` is kept negated,
    ``tn = b + √disc``: rounding to nearest is symmetric, so ``−tn`` is ``t`` to the bit (up to the
    sign of a zero).

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
    o = _as_points(origins)
    c = _as_points(centers)
    ang = np.asarray(headings, dtype=float).reshape(-1, 1) + np.asarray(angles, dtype=float).reshape(1, -1)
    dx, dy = np.cos(ang), np.sin(ang)  # (N, K)
    if c.shape[0]:
        r = np.asarray(radii, dtype=float).reshape(-1, 1, 1)
        mx = (o[:, 0] - c[:, 0:1])[:, :, None]  # (C, N, 1) centre -> origin
        my = (o[:, 1] - c[:, 1:2])[:, :, None]
        cc = mx * mx + my * my - r * r  # |m|² − r², ≤ 0 when the origin is inside: never seen
        cc[cc <= 0.0] = np.inf
        b = dx * mx + dy * my  # (C, N, K) d·m
        disc = b * b - cc  # −inf when inside
        disc[disc < 0.0] = np.inf  # a miss: its root below becomes +inf, i.e. not in front
        tn = b + np.sqrt(disc)  # −t, t = −b − √disc the nearer root of t² + 2bt + cc = 0
        tn[tn > 0.0] = -np.inf  # behind the origin (t < 0), or a miss
        d = -tn.max(axis=0)  # (N, K) the nearest hit in front; inf for none
    else:
        d = np.full(ang.shape, np.inf)
    if walls is not None and len(walls):
        near = walls.near(o)
        if len(near):
            dirs = np.stack([dx, dy], axis=-1).reshape(-1, 2)
            seg = ray_segment_distances(np.repeat(o, ang.shape[1], axis=0), dirs, walls.a[near], walls.b[near], max_range)
            d = np.minimum(d, seg.min(axis=1).reshape(ang.shape))
    d[d > max_range] = np.inf
    return d
