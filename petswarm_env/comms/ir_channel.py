"""The optical path of the IR module: from true geometry to ring readings to the paper's estimate.

This is the only place where IR measurements touch the physical truth: it takes the true
positions and headings, decides what lies in the line of sight, simulates the receiver ring
(:func:`petswarm_env.comms.ir.received_strengths`) and runs the paper's estimator
(:func:`petswarm_env.comms.ir.estimate`). What a robot gets back is only the estimate.

IR needs a line of sight (SPEC §3.2: "bodies in the line of sight block the signal"):

* a wall or a box edge (the world's static segments) crossing the line between the two centres
  is opaque: no light reaches the receiver, which then reads its noise alone, as from a source
  beyond range (the reading is invalid but for a noise peak over the detection threshold, ≈ 5.7 σ);
* a round body (another robot, a user) cutting the line attenuates the signal by
  ``ir.occlusion_attenuation`` (0.05: below the detection threshold beyond 0.61 m, and no body fits
  between two robots closer than 0.8 m, so a body blocks too).

A module of the compiled core (``petswarm_env/_core.py``): Cython's pure-Python mode, so this file
runs as it is under the interpreter and is compiled to C at install; the geometry of a slot (one
line of sight per receiver, tested against every round body) runs on typed locals.
"""

from __future__ import annotations

import math

import cython
import numpy as np
from cython.cimports.libc.math import atan2 as _c_atan2
from cython.cimports.libc.math import hypot as _c_hypot

from petswarm_env.comms import ir
from petswarm_env.sim.geometry import SegmentSet, segment_crosses
from petswarm_env.sim.world import World

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)


@cython.cfunc
@cython.inline
def _hypot(a: cython.double, b: cython.double) -> cython.double:
    """The C library's hypot (numpy's), not Python's ``math.hypot``: the two differ in the last bit
    now and then."""
    if cython.compiled:
        return _c_hypot(a, b)
    return float(np.hypot(a, b))


@cython.cfunc
@cython.inline
def _atan2(y: cython.double, x: cython.double) -> cython.double:
    """The C library's atan2 (what ``math.atan2`` calls)."""
    if cython.compiled:
        return _c_atan2(y, x)
    return math.atan2(y, x)


_NOISE_BLOCK = 2048  # receiver noise drawn at once (standard normals): about 30 slots of 1 + 4


class IRChannel:
    """The IR optical path of every slot (module docstring). ``rng`` is the channel's own stream: the
    receivers' noise is drawn from it in blocks (:meth:`_slot_noise`), so nothing else may draw from it."""

    def __init__(self, world: World, cfg: ir.IRConfig, rng: np.random.Generator):
        self.world = world
        self.cfg = cfg
        self.rng = rng
        self._noise = np.empty(0)  # the normals of rng drawn so far, ``_noise_used`` of them handed out
        self._noise_used = 0
        self.walls = SegmentSet(world.wall_a, world.wall_b, 0.0)  # walls and box edges, with their bounding boxes
        self._wall_ends = [(*a, *b) for a, b in zip(world.wall_a.tolist(), world.wall_b.tolist())]
        self._optics = None  # ir.Optics of cfg, made at the first slot

    def measure(self, tx_index: int, rx_indices: list[int]) -> tuple[list[float], list[float], list[bool]]:
        """Receivers ``rx_indices`` measure the IR of robot ``tx_index``.

        Returns estimated distance (m), bearing of the transmitter in each receiver's body frame
        (rad), and validity, one entry per receiver (nan where not valid).
        """
        cl, rl, hl = self.world.truth_lists()  # the true centres, radii and headings as Python floats
        tx: cython.Py_ssize_t = tx_index
        r: cython.Py_ssize_t
        tx_x: cython.double = cl[tx][0]
        tx_y: cython.double = cl[tx][1]
        px: cython.double
        py: cython.double
        dx: cython.double
        dy: cython.double
        walls = self._walls_near(cl, tx_index, rx_indices)
        distance, bearing, occluded, opaque = [], [], [], []
        for r in rx_indices:
            px, py = cl[r][0], cl[r][1]
            dx, dy = tx_x - px, tx_y - py  # receiver -> transmitter
            distance.append(_hypot(dx, dy))  # libm's hypot (numpy's): math.hypot differs in the last bit now and then
            bearing.append(_atan2(dy, dx) - cython.cast(cython.double, hl[r]))  # in the receiver's frame (its heading only)
            occluded.append(line_of_sight_blocked(px, py, dx, dy, cl, rl, r, tx))
            if walls:
                opaque.append(any(segment_crosses(px, py, dx, dy, *w) for w in walls))
        if any(opaque):  # no light reaches these receivers: as from a source beyond range
            distance = [math.inf if o else d for d, o in zip(distance, opaque)]
        # ir.estimate(cfg, ir.received_strengths(cfg, distance, bearing, occluded, rng)), on arrays
        optics = self._optics
        if optics is None or optics.cfg is not self.cfg:  # the configuration's constants (sections are frozen)
            optics = self._optics = ir.Optics(self.cfg)
        z = self._slot_noise(len(distance), optics.k)  # the slot's receiver noise
        return ir.measure_rows(optics, distance, bearing, occluded, z)

    def _slot_noise(self, m: cython.Py_ssize_t, k: cython.Py_ssize_t):
        """The next ``2·m·k`` standard normals of ``rng`` as a (2, m, k) array: the numbers
        ``rng.standard_normal((2, m, k))`` gives (numpy fills an array from the generator in order),
        taken from a block drawn at once (a numpy call per slot costs more than its draws)."""
        need: cython.Py_ssize_t = 2 * m * k
        used: cython.Py_ssize_t = self._noise_used
        left: cython.Py_ssize_t = len(self._noise) - used
        if need > left:  # the block's rest first, then the generator's next draws
            block = np.empty(max(_NOISE_BLOCK, need))
            block[:left] = self._noise[used:]
            self.rng.standard_normal(out=block[left:])
            self._noise, used = block, 0
        self._noise_used = used + need
        return self._noise[used:used + need].reshape(2, m, k)

    def _walls_near(self, cl: list, tx_index: int, rx_indices: list[int]) -> list[tuple[float, float, float, float]]:
        """The wall and box segments whose bounding box overlaps the slot's (the transmitter's and
        the receivers' centres): the only ones that can cross a line of sight of this slot. Inside
        the arena and away from boxes, none (a few comparisons per slot)."""
        if not self._wall_ends or not rx_indices:
            return []
        # the box of the centres: min(min(xs), tx_x) ... as the builtins take them (a later value
        # replaces only a smaller, or a greater, one), on typed locals
        x0: cython.double = 0.0
        y0: cython.double = 0.0
        x1: cython.double = 0.0
        y1: cython.double = 0.0
        x: cython.double
        y: cython.double
        k: cython.Py_ssize_t
        j: cython.Py_ssize_t
        n: cython.Py_ssize_t = len(rx_indices)
        for k in range(n + 1):  # the receivers, then the transmitter
            j = rx_indices[k] if k < n else tx_index
            x, y = cl[j][0], cl[j][1]
            if k == 0:
                x0, y0, x1, y1 = x, y, x, y
                continue
            if x < x0:
                x0 = x
            if y < y0:
                y0 = y
            if x > x1:
                x1 = x
            if y > y1:
                y1 = y
        near = self.walls.near_box(x0, y0, x1, y1)
        return [self._wall_ends[i] for i in near]


@cython.ccall
def line_of_sight_blocked(px: cython.double, py: cython.double, vx: cython.double, vy: cython.double, centers: list,
                          radii: list, rx: cython.Py_ssize_t, tx: cython.Py_ssize_t) -> cython.bint:
    """Does a body other than the receiver ``rx`` and the transmitter ``tx`` cut the line of sight
    ``p → p + v``? A circle (``centers``, ``radii``: every round body, as lists) blocks it when its
    centre is strictly closer than its radius to some point of the segment (grazing is clear).
    One segment on typed locals: an IR slot has a handful of segments (``tests/oracles.py`` keeps
    the numpy form for many segments, ``segments_blocked``)."""
    vv: cython.double = vx * vx + vy * vy
    den: cython.double = vv if vv > 0.0 else 1.0
    j: cython.Py_ssize_t
    cx: cython.double
    cy: cython.double
    r: cython.double
    u: cython.double
    ex: cython.double
    ey: cython.double
    n: cython.Py_ssize_t = min(len(centers), len(radii))
    for j in range(n):
        if j == rx or j == tx:
            continue
        cx, cy = centers[j][0], centers[j][1]
        r = radii[j]
        u = ((cx - px) * vx + (cy - py) * vy) / den  # the closest point's parameter on the segment
        if u < 0.0:  # clamped to the segment, as max(u, 0.0) then min(u, 1.0)
            u = 0.0
        elif u > 1.0:
            u = 1.0
        ex, ey = cx - (px + u * vx), cy - (py + u * vy)
        if ex * ex + ey * ey < r * r:
            return True
    return False

