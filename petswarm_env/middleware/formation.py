"""Formation shapes as neighbour tables (seed 000 §3.5, Fig. 10).

Leader–follower: each slave (member number ≥ 1) keeps a reference offset relative to one or two
reference neighbours. Offsets are in the *formation frame*: x along the swarm heading (the
master's heading), y to its left. The master is member 0. The user chooses each robot's
neighbours, which defines the shape; ``custom`` takes the table from the config.

Hierarchy levels are numbered from the robot farthest from the user (level 1) (seed 000 §3.5).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from petswarm_env.config import SwarmConfig

MAX_LINKS = 2  # reference neighbours per slave (grid uses front and side)


@dataclass(frozen=True)
class Link:
    neighbour: int  # member number of the reference neighbour
    offset_m: tuple[float, float]  # this robot's reference position relative to the neighbour


@dataclass(frozen=True)
class Formation:
    shape: str
    links: dict[int, tuple[Link, ...]]  # member number -> its reference links

    @property
    def size(self) -> int:
        return len(self.links) + 1

    def mirrored(self) -> Formation:
        """The same table reflected about the formation's x axis (every offset's y negated): the
        shape's mirror image, slot m on the other side (a wedge's arms swap)."""
        return Formation(self.shape, {m: tuple(Link(lk.neighbour, (lk.offset_m[0], -lk.offset_m[1])) for lk in links)
                                      for m, links in self.links.items()})

    def slot_positions(self) -> np.ndarray:
        """Reference position of every member in the formation frame, master at the origin (a new
        array each call, computed once per table: the table is frozen)."""
        return self._solved_slots.copy()

    @cached_property  # (written into the instance's __dict__: a frozen dataclass allows it)
    def _solved_slots(self) -> np.ndarray:
        return self._solve_slots()

    def _solve_slots(self) -> np.ndarray:
        pos = _place(self.links)
        return np.array([pos[m] for m in range(self.size)])

    def links_payload(self) -> dict[int, list[tuple[int, tuple[float, float]]]]:
        """The neighbour table as a frame carries it (joining notification, mode change): member ->
        [(reference neighbour, offset), ...] — plain values, no object shared with the sender."""
        return {m: [(lk.neighbour, tuple(lk.offset_m)) for lk in lks] for m, lks in self.links.items()}

    @classmethod
    def from_links_payload(cls, shape: str, payload: dict) -> Formation:
        """The neighbour table a robot received in a frame (:meth:`links_payload`)."""
        return cls(shape, {int(m): tuple(Link(int(nb), (float(off[0]), float(off[1]))) for nb, off in lks)
                           for m, lks in payload.items()})

    def neighbours(self, member: int) -> set[int]:
        """Symmetric neighbour set: the robots that exchange headings with ``member`` (Fig. 9)."""
        out = {lk.neighbour for lk in self.links.get(member, ())}
        out |= {m for m, links in self.links.items() if any(lk.neighbour == member for lk in links)}
        return out

    def rotated(self, angle_rad: float) -> Formation:
        """The same neighbour table with every reference offset rotated by ``angle_rad``."""
        c, s = math.cos(angle_rad), math.sin(angle_rad)
        links = {
            m: tuple(Link(lk.neighbour, (round(c * lk.offset_m[0] - s * lk.offset_m[1], 12),
                                         round(s * lk.offset_m[0] + c * lk.offset_m[1], 12))) for lk in lks)
            for m, lks in self.links.items()
        }
        return Formation(self.shape, links)

    def rerooted(self, new_root: int) -> tuple[Formation, dict[int, int]]:
        """The same neighbour pairs and geometry with ``new_root`` as the master (member 0).

        Seed 000 Table 3, "select the closest robot as the master, but do not change the neighbour
        robots' relative-location reference": every robot keeps its neighbours and where it stands
        relative to them; only the direction of the references along the way to the new master
        turns around. The new master and the old one swap member numbers; returns the new table
        and the renumbering ``old member -> new member``."""
        pos = self.slot_positions()
        renumber = {m: m for m in range(self.size)}
        renumber[new_root], renumber[0] = 0, new_root
        edges: dict[int, set[int]] = {m: set() for m in range(self.size)}
        for m, lks in self.links.items():
            for lk in lks:
                edges[m].add(lk.neighbour)
                edges[lk.neighbour].add(m)
        order, seen = [new_root], {new_root}
        for m in order:  # breadth-first from the new master: references point back toward it
            for nb in sorted(edges[m]):
                if nb not in seen:
                    seen.add(nb)
                    order.append(nb)
        rank = {m: i for i, m in enumerate(order)}
        links: dict[int, tuple[Link, ...]] = {}
        for m in order[1:]:
            refs = sorted((nb for nb in edges[m] if rank[nb] < rank[m]), key=lambda nb: rank[nb])[:MAX_LINKS]
            links[renumber[m]] = tuple(
                Link(renumber[nb], (round(float(pos[m][0] - pos[nb][0]), 12), round(float(pos[m][1] - pos[nb][1]), 12)))
                for nb in refs
            )
        return Formation(self.shape, links), renumber

    def through(self, link: Link, held) -> Link | None:
        """``link`` referred to a member in ``held`` (a container of member numbers): a neighbour not held stands
        where its own first link puts it, so the link goes on along the first links of the members not held, the
        offsets added up, to the first one held; None when the way reaches none (a loop, or a row without links)."""
        x, y = float(link.offset_m[0]), float(link.offset_m[1])
        m, seen = link.neighbour, set()
        while m not in held:
            if m in seen or not self.links.get(m):
                return None
            seen.add(m)
            step = self.links[m][0]
            x, y, m = x + float(step.offset_m[0]), y + float(step.offset_m[1]), step.neighbour
        return Link(m, (x, y))

    def cut(self, num_members: int) -> Formation:
        """The table of its first ``num_members`` members, every slot where this table puts it: a member keeps
        its links to kept members; one whose links all lead to members cut off refers to the first kept member
        along its first links' way to the master (:meth:`through`; to the master by its slot where that way loops)."""
        kept_members = range(num_members)
        links: dict[int, tuple[Link, ...]] = {}
        for m in range(1, num_members):
            kept = tuple(lk for lk in self.links[m] if lk.neighbour < num_members)
            if not kept:
                way = self.through(self.links[m][0], kept_members)
                if way is None:
                    pos = self.slot_positions()
                    way = Link(0, (float(pos[m][0] - pos[0][0]), float(pos[m][1] - pos[0][1])))
                kept = (way,)
            links[m] = kept
        return Formation(self.shape, links)

    def hierarchy_levels(self, user_position_formation: tuple[float, float]) -> dict[int, int]:
        """Level 1 = farthest from the user, counting up toward the user (seed 000 Fig. 10)."""
        slots = self.slot_positions()
        d = np.hypot(*(slots - np.asarray(user_position_formation)).T)
        order = sorted(range(self.size), key=lambda m: (-round(float(d[m]), 6), m))
        return {m: i + 1 for i, m in enumerate(order)}


def _place(links: dict[int, tuple[Link, ...]], adjust=None) -> dict[int, np.ndarray]:
    """Every member's slot in the master's frame (member 0 at the origin): a member is placed, in the
    table's order, once all its reference neighbours are, at the mean of their slots plus its offsets;
    ``adjust(slot)`` may move a slot before the members that refer to it are placed."""
    pos = {0: np.zeros(2)}
    pending = dict(links)
    while pending:
        progressed = False
        for m, lks in list(pending.items()):
            if all(lk.neighbour in pos for lk in lks):
                p = np.mean([pos[lk.neighbour] + np.asarray(lk.offset_m) for lk in lks], axis=0)
                pos[m] = p if adjust is None else adjust(p)
                del pending[m]
                progressed = True
        if not progressed:
            raise ValueError(f"formation links do not reach the master from members {sorted(pending)}")
    return pos

def user_position_in_formation(formation: Formation, distance_m: float) -> tuple[float, float]:
    """Where the user stands in the master's frame for a formation laid out for its mode: the
    formation lies behind the master (following, x ≤ 0) or between the master and the user
    (leading, x ≥ 0); the user is ``distance_m`` beyond the master or beyond the whole formation."""
    slots = formation.slot_positions()
    return (distance_m + max(0.0, float(slots[:, 0].max())), 0.0)


LEADING_LF_MARGIN_M = 0.3  # chosen: a leading master stays this far inside its LF range
# chosen: no leading slot nearer to where the user stands (body contact is at 0.45 m, robot 0.20 +
# user 0.25; a slave counts as in place within 0.3 m of its slot). Below the 0.97 m of the 4-slave
# wedge's rear arms, whose layout it keeps; the scripted slave holds its target 1.0 m off a leading user.
LEADING_CLEARANCE_M = 0.9


def leading_user(cfg) -> tuple[float, float]:
    """What a leading layout needs to know of where its user stands (``cfg``: a :class:`Config`):
    the standard distance beyond the formation (``master.distance_m``) and the farthest the master
    keeps its user, ``LEADING_LF_MARGIN_M`` inside its LF range (seed 002 §3.3)."""
    return cfg.master.distance_m, cfg.lf.reliable_range_m - LEADING_LF_MARGIN_M


def leading_user_x(depth_m: float, user: tuple[float, float]) -> float:
    """How far ahead of a leading master its user stands: ``user`` (:func:`leading_user`)'s
    distance beyond a formation ``depth_m`` deep, capped at the master's reach."""
    return min(user[0] + max(0.0, depth_m), user[1])


def formation_for_mode(cfg: SwarmConfig, num_members: int, mode: str,
                       user: tuple[float, float] | None = None) -> Formation:
    """The standard neighbour table of the configured shape, laid out for a driving mode.

    Every robot faces its user (the LF antennas must see the belt within ±25°, seed 002 §3.3), so
    the swarm heading is the master's heading toward the user. Following: the formation trails
    behind the master, which is closest to the user. Leading: the master is farthest from the user
    (seed 000 §3.5, Fig. 10) and the formation lies between it and the user as far as the LF range
    allows (``user``: :func:`leading_user`, required in leading) — the same table turned by 180°,
    except that no slot is nearer than ``LEADING_CLEARANCE_M`` to where the user stands: the wedge
    leaves such a place free and takes the next (its places' order), every other shape steps such a
    slot sideways, off the user's line, to the clearance (:func:`_aside_of_user`)."""
    if mode != "leading":
        return build_formation(cfg, num_members)
    if user is None:
        raise ValueError("formation_for_mode: a leading layout needs where the user stands: pass user=leading_user(cfg)")
    if cfg.formation == "wedge":
        return Formation("wedge", _wedge_links(cfg.spacing_m, num_members, user)).rotated(math.pi)
    return _aside_of_user(build_formation(cfg, num_members).rotated(math.pi), user)


def table_for_members(cfg: SwarmConfig, members: Iterable[int], mode: str,
                      user: tuple[float, float] | None = None) -> Formation:
    """The neighbour table for the member numbers ``members`` (the master's 0 among them): :func:`formation_for_mode`
    for as many, except for a custom table, which fixes its size. A custom swarm whose numbers leave one open (the
    lost master's slot after a master change, a lost member's) keeps its whole table, the open rows open (a held
    member referring to an open one refers through it: :mod:`petswarm_env.references` measures it so, the robot by its
    own fixes); one numbered 0 … n − 1 but fewer than the table has is cut to them, by :meth:`Formation.cut` where a
    plain cut fails (a member it keeps refers only to members beyond: a table re-rooted by a master change, or
    written so), every slot where the whole table puts it."""
    numbers = sorted(members)
    n = len(numbers)
    size = max((link.robot for link in cfg.custom_links), default=0) + 1
    if cfg.formation == "custom" and numbers != list(range(n)) and numbers[-1] < size:
        return formation_for_mode(cfg, size, mode, user)
    try:
        return formation_for_mode(cfg, n, mode, user)
    except ValueError:
        if cfg.formation != "custom" or n >= size:
            raise
        return formation_for_mode(cfg, size, mode, user).cut(n)


def _aside_of_user(formation: Formation, user: tuple[float, float]) -> Formation:
    """A leading table (x toward the user) whose slots nearer than ``LEADING_CLEARANCE_M`` to the
    user step sideways, away from the user's line, to the clearance; a slot on the line steps away
    from the side the table's slots lie on (left if centred). Slots are placed in the table's order,
    each from its (already stepped) neighbours, so the members beyond a stepped one follow it: a
    column bends round the user and runs on beside; the grid parts round the user's line. The same
    table when no slot is that near."""
    slots = formation.slot_positions()
    ux = leading_user_x(float(slots[:, 0].max()), user)  # stepping sideways keeps every x: the same place
    c = LEADING_CLEARANCE_M
    if float(np.hypot(slots[:, 0] - ux, slots[:, 1]).min()) >= c:
        return formation
    away = -1.0 if float(slots[:, 1].mean()) > 1e-9 else 1.0

    def aside(p: np.ndarray) -> np.ndarray:
        dx = float(p[0]) - ux
        if math.hypot(dx, float(p[1])) >= c:
            return p
        side = math.copysign(1.0, float(p[1])) if abs(float(p[1])) > 1e-9 else away
        return np.array([p[0], side * math.sqrt(c * c - dx * dx)])

    pos = _place(formation.links, aside)
    links = {m: tuple(Link(lk.neighbour, (round(float(pos[m][0] - pos[lk.neighbour][0]), 12),
                                         round(float(pos[m][1] - pos[lk.neighbour][1]), 12))) for lk in lks)
             for m, lks in formation.links.items()}
    return Formation(formation.shape, links)


def _wedge_links(s: float, n: int, user: tuple[float, float] | None = None) -> dict[int, tuple[Link, ...]]:
    """The wedge: a V opening backwards, its two arms 30° off the back axis, filled row by row.

    Row r (r ≥ 1) lies r·s·cos 30° behind the master and holds r + 1 places, s apart across it
    (lateral r·s/2, (r − 2)·s/2, …, −r·s/2): a triangular lattice whose every place is s from the
    one or two places diagonally in front of it, its reference neighbours (seed 000 §3.5: each slave
    keeps its reference to its neighbour robot(s); MAX_LINKS). A place on an edge of the V beyond
    the first two rows has one place in front of it; it references the place beside it, inward, as
    well when a member holds it (chosen: with two references a slave still has a target while one
    of them is occluded or missed its IR slot, and its errors from two robots average; 1 + 9, seeds
    0–9: stale slave-seconds 16 → 11 an episode, building 20.0 → 17.7 s). Members 1–4 take the arms' first two
    rows (left, right, left, right: the V of 1 + 4), the others the free places nearest the master
    first, left before right (chosen: 16 slaves fill 5 rows, 4.3 m deep, each reference
    neighbour 1 m away; two 8-robot arms reach 7 m behind the master, far beyond the IR's 2.4-2.8 m
    reach from every robot but its chain neighbours, with one reference each, and no formation of
    them was built from a scattered start). Leading (``user``: :func:`leading_user`): a place nearer
    than ``LEADING_CLEARANCE_M`` to where the user stands stays free, the next place in this order
    is taken (1 + 5: row 2's centre, 0.03 m from the user, gives way to row 3's left of centre)."""
    back, half = s * math.cos(math.radians(30)), s * math.sin(math.radians(30))
    first = [(1, 1), (1, -1), (2, 2), (2, -2)]
    rows = 1
    while (rows + 1) * (rows + 2) // 2 - 1 < n - 1:  # rows 1..rows hold 2 + 3 + ... places
        rows += 1
    while True:
        rest = [(r, k) for r in range(1, rows + 1) for k in range(r, -r - 1, -2) if (r, k) not in first]
        order = first + sorted(rest, key=lambda rk: (round(0.75 * rk[0] ** 2 + 0.25 * rk[1] ** 2, 9), -rk[1]))
        if user is None:
            places = order[: n - 1]
            break
        places, depth = [], 0.0  # leading: leave free a place too near where the user stands
        for r, k in order:
            if len(places) == n - 1:
                break
            ux = leading_user_x(max(depth, r * back), user)  # the user, in this (following) frame at (-ux, 0)
            held = r == 1 or (r - 1, k - 1) in places or (r - 1, k + 1) in places  # a place in front of it
            if held and math.hypot(r * back - ux, k * half) >= LEADING_CLEARANCE_M:
                places.append((r, k))
                depth = max(depth, r * back)
        if len(places) == n - 1:
            break
        rows += 1
    member = {(0, 0): 0}
    links: dict[int, tuple[Link, ...]] = {}
    for m, (r, k) in enumerate(places, start=1):
        front = [(0, 0)] if r == 1 else [p for p in ((r - 1, k - 1), (r - 1, k + 1)) if p in member]
        if r > 1 and len(front) == 1 and (r, k - 2 if k > 0 else k + 2) in member:
            front.append((r, k - 2 if k > 0 else k + 2))  # the V's edge: the place beside it, inward, as well
        links[m] = tuple(Link(member[(fr, fk)], (-(r - fr) * back, (k - fk) * half)) for fr, fk in front)
        member[(r, k)] = m
    return links


def build_formation(cfg: SwarmConfig, num_members: int) -> Formation:
    """Neighbour table for ``num_members`` robots (master included) in the configured shape."""
    s = cfg.spacing_m
    n = num_members
    links: dict[int, tuple[Link, ...]] = {}
    if cfg.formation == "column":  # each robot behind the previous one
        for m in range(1, n):
            links[m] = (Link(m - 1, (-s, 0.0)),)
    elif cfg.formation == "row":  # alternately left and right, outward from the master
        for m in range(1, n):
            side = 1.0 if m % 2 == 1 else -1.0
            links[m] = (Link(max(m - 2, 0), (0.0, side * s)),)
    elif cfg.formation == "wedge":
        links = _wedge_links(s, n)
    elif cfg.formation == "grid":  # two columns; front neighbour and left neighbour
        for m in range(1, n):
            row, col = divmod(m, 2)
            own: list[Link] = []
            if row > 0:
                own.append(Link(m - 2, (-s, 0.0)))
            if col == 1:
                own.append(Link(m - 1, (0.0, -s)))
            links[m] = tuple(own)
    else:  # custom
        # fewer members than the table names (some robots did not join: radio loss, another swarm
        # took them): the master keeps the rows of the members that joined and their links to members
        # that joined, so a table built outward from the master still places everyone it has (chosen)
        table_size = max((link.robot for link in cfg.custom_links), default=0) + 1
        for link in cfg.custom_links:
            if n < table_size and (link.robot >= n or link.neighbour >= n):
                continue
            links.setdefault(link.robot, ())
            links[link.robot] = links[link.robot] + (Link(link.neighbour, tuple(link.offset_m)),)
        expected = set(range(1, n))
        if set(links) != expected:
            raise ValueError(
                f"swarm.custom_links must give links for members {sorted(expected)}, got {sorted(links)}"
                + (f" (of a table for {table_size - 1} members, {n - 1} joined)" if n < table_size else "")
            )
        for m, lks in links.items():
            if len(lks) > MAX_LINKS:
                raise ValueError(f"swarm.custom_links: member {m} has {len(lks)} links; at most {MAX_LINKS}")
            for lk in lks:
                if not 0 <= lk.neighbour < n or lk.neighbour == m:
                    raise ValueError(f"swarm.custom_links: member {m} refers to invalid neighbour {lk.neighbour}")
    formation = Formation(cfg.formation, links)
    formation.slot_positions()  # validates reachability
    return formation
