"""The experimenter's reference points on C doubles: every slave's reference point, formation
error and heading error from the world's truth arrays (the figures of :mod:`petswarm_env.metrics`).

A slave's *reference point* is the mean over its reference links of its neighbour's true position
plus the link's offset rotated by the formation heading, the true heading of the master whose
neighbour table defines it; its *formation error* is its true distance from that point and its
*heading error* its true heading minus that master's. A :class:`ReferenceTable` holds every
organized swarm's links as flat C arrays — (slave, master) robot indices, and per link the
neighbour's robot index and the offset — rebuilt only when a swarm's formation, master, members
or organized state changed since the last step; each step reads the truth arrays as lists (one
conversion for all robots).

The sums run in the order of the links, as ``sum(neighbour + R(θ)·offset) / n`` in Python floats
(``nx + c·ox − s·oy`` per link), so the interpreted form and the compiled form give the same
values to the bit (the C build has no fused multiply-add: setup.py).

A module of the compiled core (``petswarm_env/_core.py``, Cython's pure-Python mode).
"""

from __future__ import annotations

import math

import cython
import numpy as np
from cython.cimports.libc.math import cos as _c_cos
from cython.cimports.libc.math import sin as _c_sin

if cython.compiled:  # the angle wrap of one float as a C call (sim/geometry.pxd)
    from cython.cimports.petswarm_env.sim.geometry import wrap_float
else:
    from petswarm_env.sim.geometry import wrap_float


COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

_hypot = math.hypot  # Python's own (CPython's hypot is not the C library's)


def _held_link(formation, members: dict, link) -> tuple | None:
    """A link as (neighbour's robot index, offset x, offset y). A neighbour whose member number the swarm leaves open (a
    custom table keeps its size at a loss, and a master change's re-rooted table the lost master's slot) is referred
    through (:meth:`~petswarm_env.middleware.formation.Formation.through`); None when no member held is on the way."""
    held = formation.through(link, members)
    return None if held is None else (members[held.neighbour], held.offset_m[0], held.offset_m[1])


@cython.cclass
class ReferenceTable:
    """The reference links of every organized swarm (module docstring). :meth:`update` with the
    swarms before reading; :meth:`errors` and :meth:`references` read the world's truth arrays
    as lists (``xy``: every body's centre, ``th``: every robot's heading)."""

    _keys = cython.declare(list)  # per swarm: what its links were built from (formation, master, members)
    _slave = cython.declare(cython.long[:])  # per entry: the slave's robot index
    _master = cython.declare(cython.long[:])  # per entry: the robot index of the master whose table defines it
    _first = cython.declare(cython.long[:])  # per entry: its first link
    _count = cython.declare(cython.long[:])  # per entry: its number of links
    _nb = cython.declare(cython.long[:])  # per link: the neighbour's robot index
    _ox = cython.declare(cython.double[:])  # per link: the offset, formation frame (m)
    _oy = cython.declare(cython.double[:])
    _entries = cython.declare(cython.Py_ssize_t)
    _entry_of = cython.declare(dict)  # robot index -> its entry (the last swarm's, as a dict assignment keeps it)
    _px = cython.declare(cython.double)  # the last _point's reference point and formation heading
    _py = cython.declare(cython.double)
    _pt = cython.declare(cython.double)

    def __init__(self):
        self._keys = []
        self._entries = 0
        self._entry_of = {}
        self._build([])

    def update(self, swarms: list) -> None:
        """Rebuild the links if a swarm's formation (the same plan object), master, members or
        organized state changed."""
        keys = self._keys
        if len(keys) == len(swarms):
            for swarm, key in zip(swarms, keys):
                if not _same_links(swarm, key):
                    break
            else:
                return
        self._build(swarms)
        self._keys = [_swarm_key(sw) for sw in swarms]

    def _build(self, swarms: list) -> None:
        """The flat links of ``swarms`` (in the order of the swarms and of each formation's links)."""
        slave, master, first, count, nb, ox, oy = [], [], [], [], [], [], []
        entry_of = {}
        for swarm in swarms:
            if swarm.formation is None or not swarm.organized:
                continue
            members = swarm.master.know.members
            for m, links in swarm.formation.links.items():
                idx = members.get(m)
                if idx is None or not links:
                    continue
                held = [ref for ref in (_held_link(swarm.formation, members, link) for link in links) if ref is not None]
                if not held:
                    continue
                entry_of[idx] = len(slave)
                slave.append(idx)
                master.append(swarm.master.node_id)
                first.append(len(nb))
                count.append(len(held))
                for j, x, y in held:
                    nb.append(j)
                    ox.append(x)
                    oy.append(y)
        self._slave, self._master = np.array(slave, np.int_), np.array(master, np.int_)
        self._first, self._count = np.array(first, np.int_), np.array(count, np.int_)
        self._nb, self._ox, self._oy = np.array(nb, np.int_), np.array(ox, float), np.array(oy, float)
        self._entries = len(slave)
        self._entry_of = entry_of

    @cython.cfunc
    def _point(self, e: cython.Py_ssize_t, xy: list, th: list) -> cython.void:
        """Entry ``e``'s reference point and formation heading, into ``_px``, ``_py``, ``_pt``."""
        t: cython.double = th[self._master[e]]
        c: cython.double = _c_cos(t)  # the C library's, as math.cos
        s: cython.double = _c_sin(t)
        sx: cython.double = 0.0
        sy: cython.double = 0.0
        k: cython.Py_ssize_t
        j: cython.Py_ssize_t
        ox: cython.double
        oy: cython.double
        nx: cython.double
        ny: cython.double
        for k in range(self._first[e], self._first[e] + self._count[e]):
            j = self._nb[k]
            ox, oy = float(self._ox[k]), float(self._oy[k])  # (float: Python floats in the interpreted form too)
            nx, ny = xy[j]
            sx += nx + c * ox - s * oy
            sy += ny + s * ox + c * oy
        n: cython.double = self._count[e]
        self._px, self._py, self._pt = sx / n, sy / n, t

    def references(self, xy: list, th: list) -> dict:
        """Every slave's reference point and formation heading: robot index -> (x, y, θ_master)."""
        out = {}
        e: cython.Py_ssize_t
        for e in range(self._entries):  # a robot in two swarms' tables: the last one's point
            self._point(e, xy, th)
            out[int(self._slave[e])] = (self._px, self._py, self._pt)
        return out

    def errors(self, xy: list, th: list, robots: list) -> tuple:
        """For the robots ``robots`` (indices): their formation errors (m) and heading errors (rad),
        0.0 for a robot without a reference point, and whether each has one."""
        errs, heads, has = [], [], []
        entry_of = self._entry_of
        px: cython.double
        py: cython.double
        for idx in robots:
            e = entry_of.get(idx)
            if e is None:
                errs.append(0.0)
                heads.append(0.0)
                has.append(False)
                continue
            self._point(e, xy, th)
            px, py = xy[idx]
            errs.append(_hypot(px - self._px, py - self._py))
            heads.append(wrap_float(th[idx] - self._pt))
            has.append(True)
        return errs, heads, has


def _same_links(swarm, key: tuple) -> bool:
    """Whether ``swarm``'s links are still those built from ``key`` (:func:`_swarm_key`)."""
    if swarm.formation is None or not swarm.organized:
        return key[0] is None
    master = swarm.master
    return key[0] is swarm.formation and key[1] == master.node_id and key[2] == master.know.members


def _swarm_key(swarm) -> tuple:
    """What a swarm's reference links depend on: its formation (an immutable plan), its master
    and the master's member table (a copy), while it is organized."""
    if swarm.formation is None or not swarm.organized:
        return (None,)
    master = swarm.master
    return (swarm.formation, master.node_id, dict(master.know.members))
