"""What a policy sees: one fixed-size vector per slave, built from its middleware only.

The layout is declared once, in :data:`FIELDS`; the builder, the documentation table
(:func:`markdown_table`) and the policies' accessors (:class:`ObservationLayout`) all read it.
Every value is scaled to about [-1, 1]; ``scale`` says by what (value_in_obs = value / scale).
Nothing here reads ground truth: the inputs, one :class:`Readings` per slave and step, are a
node's :class:`~.middleware.node.Knowledge` and reference links, its own sensors (odometry, AHRS,
ultrasonic ring; :mod:`petswarm_env.sim.sensors`) and its last action. :class:`Observer` gathers
them for the env's agents and builds their observations.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import cython
import numpy as np
from cython.cimports.libc.math import cos as _cos
from cython.cimports.libc.math import sin as _sin
from cython.cimports.libc.math import sqrt as _sqrt

from petswarm_env.middleware.formation import MAX_LINKS, Formation, formation_for_mode, leading_user, user_position_in_formation
from petswarm_env.scenarios import ACTIVITIES

if cython.compiled:  # a robot's wheels, their odometry and its node's knowledge as C reads (the .pxd files)
    from cython.cimports.petswarm_env.middleware.knowledge import HeadingEstimate, IRMeasurement, Knowledge, MasterStatus
    from cython.cimports.petswarm_env.middleware.station import Station
    from cython.cimports.petswarm_env.sim.body import DrivenBody
    from cython.cimports.petswarm_env.sim.sensors import AHRS, wheel_odometry
else:
    from petswarm_env.middleware.knowledge import HeadingEstimate, IRMeasurement, Knowledge, MasterStatus
    from petswarm_env.middleware.station import Station
    from petswarm_env.sim.body import DrivenBody
    from petswarm_env.sim.sensors import AHRS, wheel_odometry

if TYPE_CHECKING:
    from petswarm_env.middleware.node import Node
    from petswarm_env.sim.sensors import Sensors

COMPILED = cython.compiled  # True in the compiled form (petswarm_env/_core.py checks it)

OBS_VERSION = 5  # 5: the same layout, a differential neighbour relays the master's heading in its link's heading (middleware/token_ring.py TokenRing.send_heading); 4: the same layout, the IR fixes (links, master, anchor) carried over the slave's own odometry less the master's broadcast speed (seed 000 §3.5); 3: the ring's presence and location-known flags (seed 001's middle layer: heterogeneous bodies); 2: the master's IR fix (master.ir_*) and an anchor member's (anchor.*): a slave finds its slot from a scattered start
POS_SCALE_M = 3.0
AGE_SCALE_S = 2.0

CLIP = 1.5  # the bound of the fields clipped at the builder (velocities, turn rate), in scaled units
USER_CLIP = 3.0  # the bound of master.user_xy (9 m), clipped at the builder


@dataclass(frozen=True)
class Field:
    """One field of the layout: ``bounds`` is ``(low, high)`` in scaled units, or the name of a
    bound derived from the config (:func:`observation_bounds`: ``"ir"``, ``"link_offset"``,
    ``"slot"``); ``why`` says where the bound comes from (the docs' bounds column)."""

    name: str
    size: int
    scale: str  # human-readable scale, for the docs
    doc: str
    bounds: tuple[float, float] | str = (0.0, 1.0)
    why: str = "a flag / one-hot"


def _link_fields(k: int) -> list[Field]:
    p = f"link{k}."
    return [
        Field(p + "present", 1, "0/1", f"reference link {k} exists (slot 0 = primary neighbour, 1 = second, grid)"),
        Field(p + "ir_valid", 1, "0/1", "an IR measurement of that neighbour has been received"),
        Field(p + "neighbour_xy", 2, f"m / {POS_SCALE_M}", "IR-estimated position of the neighbour in own body frame (x forward, y left) when measured, carried over own rotation (AHRS) and own motion in the swarm (wheel odometry less the master's broadcast driving speed) since; at most the estimator's largest distance",
              "ir", "± the estimator's largest distance: readings in [0, saturation] and the strongest ≥ ir.detect_threshold give "
              "r ≥ threshold·(1 + 2·min(cos Δ, 0)) / (1 + 2·cos²Δ), d = sqrt(strength_at_1m / r)"),
        Field(p + "ir_age", 1, f"s / {AGE_SCALE_S}, clipped to 1", "age of that IR measurement", (0.0, 1.0), "an age ≥ 0, clipped to 1"),
        Field(p + "offset_xy", 2, f"m / {POS_SCALE_M}", "own reference offset from the neighbour, formation frame (x = swarm heading)",
              "link_offset", "± the largest offset of any neighbour table of the configured shape (2 … num_slaves + 1 members, both modes)"),
        Field(p + "heading_sincos", 2, "-", "sin, cos of θ_neighbour − θ_self from the heading exchange, carried over own rotation since (AHRS); a differential neighbour with a fresh exchange with the master reports the master's heading instead of its own (middleware/token_ring.py), giving θ_master − θ_self; (0, 1) if unknown",
              (-1.0, 1.0), "a unit vector"),
        Field(p + "heading_valid", 1, "0/1", "a heading exchange with that neighbour has happened"),
        Field(p + "heading_age", 1, f"s / {AGE_SCALE_S}, clipped to 1", "age of the heading estimate", (0.0, 1.0), "an age ≥ 0, clipped to 1"),
    ]


FIELDS: list[Field] = [
    *[f for k in range(MAX_LINKS) for f in _link_fields(k)],
    Field("master.valid", 1, "0/1", "a master status broadcast has been received"),
    Field("master.age", 1, "s / 1, clipped to 1", "age of the last master broadcast", (0.0, 1.0), "an age ≥ 0, clipped to 1"),
    Field("master.velocity", 3, "/ (v_max, v_max, ω_max)", "master's (Vx, Vy, ω) in its body frame, as broadcast: the (Vx, Vy) of its own last command, the ω its wheel odometry measured (noisy like self.odometry)",
          (-CLIP, CLIP), f"clipped to ±{CLIP} (the master's commanded velocity; its ω: achieved times 1 + Gaussian noise)"),
    Field("master.activity", len(ACTIVITIES), "one-hot", "user activity broadcast by the master: " + ", ".join(ACTIVITIES)),
    Field("master.rotating", 1, "0/1", "user rotation flag of the smart belt, as broadcast (seed 002 §3.4)"),
    Field("master.turn_rate", 1, "/ ω_max", "user angular speed from the belt's filtered gyro, as broadcast (rad/s, CCW +)",
          (-CLIP, CLIP), f"clipped to ±{CLIP} (a filtered gyro with noise and bias)"),
    Field("master.leading", 1, "0/1", "the swarm's driving mode as the joining notification and the last mode-change frame said: 1 = leading, 0 = following"),
    Field("master.user_xy", 2, f"m / {POS_SCALE_M}", "user position relative to the master, master's frame, as broadcast",
          (-USER_CLIP, USER_CLIP), f"clipped to ±{USER_CLIP} ({USER_CLIP * POS_SCALE_M:g} m; the master's track of a user out of LF range drifts)"),
    Field("master.ir_valid", 1, "0/1", "an IR measurement of the master has been received (every member measures every token holder)"),
    Field("master.ir_xy", 2, f"m / {POS_SCALE_M}", "IR-estimated position of the master in own body frame (x forward, y left), carried as link0.neighbour_xy",
          "ir", "± the estimator's largest distance (as link0.neighbour_xy)"),
    Field("master.ir_age", 1, f"s / {AGE_SCALE_S}, clipped to 1", "age of that IR measurement", (0.0, 1.0), "an age ≥ 0, clipped to 1"),
    Field("anchor.ir_valid", 1, "0/1", f"an IR measurement younger than {AGE_SCALE_S} s of another slave of the swarm (the anchor: the lowest member number with one)"),
    Field("anchor.ir_xy", 2, f"m / {POS_SCALE_M}", "IR-estimated position of the anchor in own body frame, carried as link0.neighbour_xy",
          "ir", "± the estimator's largest distance (as link0.neighbour_xy)"),
    Field("anchor.ir_age", 1, f"s / {AGE_SCALE_S}, clipped to 1", "age of that IR measurement", (0.0, 1.0), "an age in [0, 1): only a fix younger than the age scale is an anchor"),
    Field("anchor.slot_xy", 2, f"m / {POS_SCALE_M}", "the anchor's reference position relative to the master, formation frame (from the neighbour table)",
          "slot", "± the largest extent along an axis of any neighbour table of the configured shape (as self.offset_from_master_xy)"),
    Field("self.odometry", 3, "/ (v_max, v_max, ω_max)", "own wheel-odometry (Vx, Vy, ω), body frame",
          (-CLIP, CLIP), f"clipped to ±{CLIP} (the achieved velocity times 1 + Gaussian noise)"),
    Field("self.yaw_sincos", 2, "-", "own AHRS yaw (noisy, drifting), counted from its own power-on heading: a random angle per robot and episode, so only its changes (own rotation) mean something, never a direction in the world", (-1.0, 1.0), "a unit vector"),
    Field("self.last_action", 3, "[-1, 1]", "the action applied last step", (-1.0, 1.0), "actions are clipped to [-1, 1]"),
    Field("self.offset_from_master_xy", 2, f"m / {POS_SCALE_M}", "own reference position relative to the master, formation frame (from the neighbour table)",
          "slot", "± the largest extent along an axis of any neighbour table of the configured shape (2 … num_slaves + 1 members, "
          "both modes; a mode change re-roots it at any member)"),
    Field("self.ultrasonic", -1, "m / max_range", "ultrasonic ring ranges, sensor 0 forward, counter-clockwise",
          (0.0, 1.0), "a range in [0, max_range]"),
    Field("self.hierarchy", 1, "level / members", "hierarchy level (1 = farthest from the user) over the number of members",
          (0.0, 1.0), "a level in 0 … members"),
    Field("self.members", 1, "/ 16", "number of swarm members (master included)", (0.0, 17 / 16), "at most 16 slaves + the master"),
    Field("self.member", 1, "/ 16", "own member number", (-1 / 16, 1.0), "-1 (none) … 16"),
    Field("self.ultrasonic_present", -1, "0/1", "seed 001's presence flag of each virtual ring sensor: 1 = a sensor of the body's type "
          "DISTANCE feeds it (its mapping table, built once); 0 = none does, or it is faulty: its self.ultrasonic value then reads max_range"),
    Field("self.ultrasonic_location_known", -1, "0/1", "1 = the feeding sensor sits at the virtual sensor's angle (seed 001's location comparator); "
          "0 = type match only, the value comes with a NULL location (or nothing is delivered)"),
]


# the fields after the links, in the order build_observation unpacks their start offsets
_BUILDER_FIELDS = ("master.valid", "master.activity", "master.rotating", "master.turn_rate", "master.leading", "master.user_xy",
                   "master.ir_valid", "anchor.ir_valid", "self.odometry", "self.yaw_sincos", "self.last_action", "self.offset_from_master_xy", "self.ultrasonic",
                   "self.hierarchy", "self.members", "self.member", "self.ultrasonic_present")
_ACTIVITY_INDEX = {a: i for i, a in enumerate(ACTIVITIES)}


class ObservationLayout:
    """Offsets of every named field; the same object documents, builds and reads observations.

    The builder also needs the scales of the robot's own values: ``limits`` (v_max, v_max, ω_max)
    for velocities and odometry, ``us_max_range_m`` for the ultrasonic ring (the env gives both;
    a layout made only to read observations needs neither)."""

    def __init__(self, num_ultrasonic: int, limits: tuple[float, float, float] | None = None,
                 us_max_range_m: float | None = None, ir_max_m: float = math.inf):
        self.limits = limits
        self.us_max_range_m = us_max_range_m
        self.ir_max_m = ir_max_m  # the IR estimator's largest distance (ir_distance_bound): a carried fix's bound
        self.slices: dict[str, slice] = {}
        self.fields: list[Field] = []
        i = 0
        for f in FIELDS:
            size = num_ultrasonic if f.size == -1 else f.size
            self.fields.append(Field(f.name, size, f.scale, f.doc, f.bounds, f.why))
            self.slices[f.name] = slice(i, i + size)
            i += size
        self.size = i
        # start offsets the builder writes at (resolved once, not per observation)
        st = {name: sl.start for name, sl in self.slices.items()}
        self._link_starts = tuple(st[f"link{k}.present"] for k in range(MAX_LINKS))
        self._starts = tuple(st[name] for name in _BUILDER_FIELDS)
        self._scratch = np.zeros(self.size)  # the builder's float64 values (build_observation)

    def get(self, obs: np.ndarray, name: str) -> np.ndarray:
        return obs[self.slices[name]]

    def signature(self) -> list[tuple[str, int]]:
        """(name, size) of every field: what a saved policy records and is matched against."""
        return [(f.name, f.size) for f in self.fields]


def markdown_table(layout: ObservationLayout, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> str:
    """The layout as a markdown table; with ``bounds`` (:func:`observation_bounds`) a column of
    each field's bounds (the default config's values for the derived ones) and where they come from."""
    head = "| index | field | size | scale | meaning |" + (" bounds |" if bounds is not None else "")
    rows = [head, "|---|---|---|---|---|" + ("---|" if bounds is not None else "")]
    for f in layout.fields:
        s = layout.slices[f.name]
        idx = f"{s.start}" if f.size == 1 else f"{s.start}–{s.stop - 1}"
        row = f"| {idx} | `{f.name}` | {f.size} | {f.scale} | {f.doc} |"
        if bounds is not None:
            lo, hi = float(bounds[0][s.start]), float(bounds[1][s.start])
            row += f" [{lo:.4g}, {hi:.4g}]: {f.why} |"
        rows.append(row)
    return "\n".join(rows)


def ir_distance_bound(ir) -> float:
    """The largest distance the IR estimator returns (:func:`petswarm_env.comms.ir.estimate`):
    the readings are clipped to [0, saturation] and the strongest S0 is ≥ the threshold, so
    a = (S0 + (S+ + S−)·cos Δ) / (1 + 2·cos²Δ) ≥ S0·(1 + 2·min(cos Δ, 0)) / (1 + 2·cos²Δ) and
    r = hypot(a, b) ≥ a; d = sqrt(strength_at_1m / r). (config.IRConfig keeps cos Δ > 0.)"""
    cos_d = math.cos(2.0 * math.pi / ir.num_receivers)
    r_min = ir.detect_threshold * (1.0 + 2.0 * min(cos_d, 0.0)) / (1.0 + 2.0 * cos_d**2)
    if r_min <= 0.0:
        raise ValueError(f"ir.num_receivers={ir.num_receivers} leaves the IR distance estimate unbounded")
    return math.sqrt(ir.strength_at_1m / r_min)


def formation_extents(swarm_cfg, user: tuple[float, float]) -> tuple[float, float]:
    """The largest |component| of a link offset and of a slot position (m) over every neighbour
    table of the configured shape a swarm can hold: 2 … num_slaves + spares + 1 members (the join and
    the mode change build them so, :func:`~.middleware.formation.formation_for_mode`), both modes,
    rooted at any member (a mode change with master change re-roots the table at the new master,
    so a slot is bounded by the table's extent along each axis, not by its distance from member 0).
    A custom formation has one table: ``swarm.custom_links`` name exactly num_slaves + 1 members.
    ``user``: where a leading layout's user stands (:func:`~.middleware.formation.leading_user`)."""
    link = slot = 0.0
    full = swarm_cfg.num_slaves + swarm_cfg.spares + 1
    for n in [full] if swarm_cfg.formation == "custom" else range(2, full + 1):
        for mode in ("following", "leading"):
            formation = formation_for_mode(swarm_cfg, n, mode, user)
            offsets = [abs(c) for links in formation.links.values() for lk in links for c in lk.offset_m]
            link = max(link, *offsets, 0.0)
            pos = formation.slot_positions()  # a mode change re-roots the table at any member (modes.py)
            slot = max(slot, float((pos.max(axis=0) - pos.min(axis=0)).max()))
    return link, slot


def observation_bounds(layout: ObservationLayout, cfg) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of every observation value, float32, from each field's declared bounds; the
    derived ones from ``cfg`` (a :class:`~.config.Config`): the IR estimator's largest distance
    and the configured formation's extents, over :data:`POS_SCALE_M`."""
    link, slot = formation_extents(cfg.swarm, leading_user(cfg))
    derived = {"ir": ir_distance_bound(cfg.ir) / POS_SCALE_M, "link_offset": link / POS_SCALE_M, "slot": slot / POS_SCALE_M}
    low, high = np.zeros(layout.size, np.float64), np.zeros(layout.size, np.float64)
    for f in layout.fields:
        s = layout.slices[f.name]
        lo, hi = (-derived[f.bounds], derived[f.bounds]) if isinstance(f.bounds, str) else f.bounds
        low[s], high[s] = lo, hi
    return low.astype(np.float32), high.astype(np.float32)


@dataclass(slots=True)
class Readings:
    """What one slave's own sensors and middleware give at one instant: all its observation is
    built from."""

    know: Knowledge  # its middleware's knowledge (IR, headings, master status, members)
    links: Sequence[Any]  # its reference links in the neighbour table (formation.Link)
    now_s: float  # the robot's own clock (its MCU's: the times in ``know`` are on it)
    odometry: tuple[float, float, float]  # wheel odometry (Vx, Vy, ω), body frame
    yaw_rad: float  # AHRS yaw
    last_action: np.ndarray  # the action applied last step, (3,)
    ultrasonic_m: Sequence[float]  # the ring, sensor 0 forward (a list of floats or an array)
    hierarchy_level: int  # its level in the neighbour table (0 if none)
    offset_from_master_m: tuple[float, float]  # its slot relative to the master, formation frame
    member_slots: Sequence[tuple[float, float]] = ()  # every member's slot relative to the master, formation frame
    ultrasonic_flags: Sequence[float] = ()  # the ring's presence then location-known flags (middle_layer.py); () = a full ring


def build_observation(layout: ObservationLayout, readings: Readings, out: np.ndarray | None = None) -> np.ndarray:
    """The observation of one slave, written into ``out`` (layout.size,) or, with ``out=None``, a
    new float32 array. The values are computed in float64 (:func:`_fill`, into the layout's scratch
    array) and converted once (float64 -> float32 rounding, as ``np.array(v, dtype=np.float32)``).
    The ring may be a list of Python floats (the env converts the rings of all robots at once) or
    an array."""
    if layout.limits is None or layout.us_max_range_m is None:
        raise ValueError("build_observation needs a layout with limits and us_max_range_m (the robot's scales)")
    r = readings
    buf = layout._scratch
    ovx, ovy, ow = r.odometry
    _fill(_Plan(layout), buf, r.know, r.links, r.now_s, ovx, ovy, ow, r.yaw_rad, r.last_action, r.ultrasonic_m,
          r.hierarchy_level, r.offset_from_master_m, r.member_slots, r.ultrasonic_flags)
    if out is None:
        return buf.astype(np.float32)
    out[:] = buf
    return out


@cython.cclass
class _Plan:
    """Where :func:`_fill` writes each field and by what it scales the robot's own values: the
    layout's start offsets and scales as C values (typed in observe.pxd), read from the layout once
    (per :class:`Observer`), not per observation."""

    def __init__(self, layout: ObservationLayout):
        lim = layout.limits
        self.vmax, self.wmax, self.us_max, self.ir_max = lim[0], lim[2], layout.us_max_range_m, layout.ir_max_m
        starts = layout._link_starts
        self.link0, self.max_links = starts[0], len(starts)
        self.link_size = starts[1] - starts[0] if len(starts) > 1 else 0
        if any(starts[k] != self.link0 + k * self.link_size for k in range(len(starts))):
            raise ValueError("the links' fields must be equal blocks one after the other (observe.FIELDS)")
        (self.master, self.activity, self.rotating, self.turn_rate, self.leading, self.user_xy, self.master_ir,
         self.anchor, self.odo, self.yaw, self.last, self.offset, self.us, self.hierarchy, self.members, self.member,
         self.flags) = layout._starts


@cython.cfunc
@cython.inline
def _clip(x: cython.double, c: cython.double) -> cython.double:
    """``x`` clipped to [-c, c] (a bound of the layout; nan passes through)."""
    return -c if x < -c else c if x > c else x


@cython.cfunc
@cython.inline
def _age(age: cython.double) -> cython.double:
    """An age in scaled units clipped to 1 as ``min(age, 1.0)`` would (nan passes through)."""
    return 1.0 if age > 1.0 else age


@cython.cfunc
def _put_fix(v: cython.double[::1], at: cython.Py_ssize_t, m: IRMeasurement, yaw: cython.double, x0: cython.double, y0: cython.double,
             reach: cython.double, pos_scale: cython.double) -> cython.void:
    """Fix ``m`` into ``v[at:at + 2]``, scaled, carried to ``know.odometry_xy`` = ``(x0, y0)`` (oracle: ``carried_fix``), at most ``reach`` away."""
    a: cython.double = m.own_yaw_rad + m.bearing_rad  # the bearing in the odometry frame
    d: cython.double = m.distance_m
    px: cython.double = m.own_x_m + d * _cos(a) - x0
    py: cython.double = m.own_y_m + d * _sin(a) - y0
    x: cython.double = _cos(yaw) * px + _sin(yaw) * py
    y: cython.double = _cos(yaw) * py - _sin(yaw) * px
    d = reach / _sqrt(x * x + y * y) if x * x + y * y > reach * reach else 1.0
    v[at], v[at + 1] = x * d / pos_scale, y * d / pos_scale


@cython.cfunc
def _fill(plan: _Plan, v: cython.double[::1], know: Knowledge, links, now: cython.double, ovx: cython.double, ovy: cython.double,
          ow: cython.double, yaw_rad: cython.double, last_action, ultrasonic_m, hierarchy_level: cython.double,
          offset_from_master, member_slots, flags) -> cython.void:
    """The observation of one slave (:class:`Readings`' fields; the odometry as ``ovx, ovy, ow``) in
    float64 into ``v`` (layout.size,), the fields written in the layout's order at ``plan``'s
    offsets. One function on purpose: it runs for every slave at every step (typed: C doubles in
    the compiled core, Python floats interpreted; the same IEEE operations in the same order, so
    the same bits)."""
    k: cython.Py_ssize_t
    n: cython.Py_ssize_t = v.shape[0]
    for k in range(n):
        v[k] = 0.0
    pos_scale: cython.double = POS_SCALE_M  # the scales as C doubles (a module constant is a Python float)
    age_scale: cython.double = AGE_SCALE_S
    clip: cython.double = CLIP
    user_clip: cython.double = USER_CLIP
    vmax: cython.double = plan.vmax
    wmax: cython.double = plan.wmax
    age: cython.double
    rel: cython.double
    base: cython.Py_ssize_t
    cython.declare(mb=cython.double, my=cython.double, mt=cython.double)  # a measurement's bearing (or relative heading), own yaw and time
    # unpacked pairs and triples as C doubles (Python floats: their division is the same IEEE one)
    ox: cython.double
    oy: cython.double
    svx: cython.double
    svy: cython.double
    sw: cython.double
    ux: cython.double
    uy: cython.double
    sx: cython.double
    sy: cython.double
    cython.declare(a0=cython.double, a1=cython.double, a2=cython.double)
    cython.declare(m=IRMeasurement, fix=IRMeasurement, h=HeadingEstimate, st=MasterStatus)  # fixes (or None), typed records
    members: dict = know.members
    irs: dict = know.ir
    ox0: cython.double = know.odometry_xy[0]  # own motion in the swarm (dead-reckoned): every fix is carried over it
    oy0: cython.double = know.odometry_xy[1]
    nl: cython.Py_ssize_t = len(links)
    if nl > plan.max_links:
        nl = plan.max_links
    if nl > 0:
        heads: dict = know.heading
        for k in range(nl):
            base = plan.link0 + k * plan.link_size
            link = links[k]
            v[base] = 1.0
            nb = members.get(link.neighbour)
            m = irs.get(nb)
            if m is not None:  # carried over own rotation (AHRS) and translation (odometry) since the measurement
                mt = m.time_s
                v[base + 1] = 1.0
                _put_fix(v, base + 2, m, yaw_rad, ox0, oy0, plan.ir_max, pos_scale)
                v[base + 4] = _age((now - mt) / age_scale)
            else:
                v[base + 4] = 1.0
            ox, oy = link.offset_m
            v[base + 5] = ox / pos_scale
            v[base + 6] = oy / pos_scale
            h = heads.get(nb)
            if h is not None:  # θ_nb − θ_self falls as we turn: carry it over own rotation (AHRS)
                mb, my, mt = h.relative_rad, h.own_yaw_rad, h.time_s
                rel = mb - (yaw_rad - my)
                v[base + 7] = _sin(rel)
                v[base + 8] = _cos(rel)
                v[base + 9] = 1.0
                v[base + 10] = _age((now - mt) / age_scale)
            else:
                v[base + 8] = 1.0
                v[base + 10] = 1.0
    cython.declare(i=cython.Py_ssize_t, activity=cython.Py_ssize_t, rotating=cython.Py_ssize_t, turn_rate=cython.Py_ssize_t,
                   leading=cython.Py_ssize_t, user_xy=cython.Py_ssize_t, master_ir=cython.Py_ssize_t, anchor=cython.Py_ssize_t,
                   odo=cython.Py_ssize_t, yaw=cython.Py_ssize_t, last=cython.Py_ssize_t, offset=cython.Py_ssize_t, us=cython.Py_ssize_t,
                   hierarchy=cython.Py_ssize_t, members_at=cython.Py_ssize_t, member_at=cython.Py_ssize_t, flags_at=cython.Py_ssize_t)
    i = plan.master
    activity, rotating, turn_rate, leading, user_xy = plan.activity, plan.rotating, plan.turn_rate, plan.leading, plan.user_xy
    master_ir, anchor, odo, yaw, last, offset, us = plan.master_ir, plan.anchor, plan.odo, plan.yaw, plan.last, plan.offset, plan.us
    hierarchy, members_at, member_at, flags_at = plan.hierarchy, plan.members, plan.member, plan.flags
    v[leading] = 1.0 if know.mode == "leading" else 0.0  # from the joining / mode-change frames
    st = know.status
    if st is not None:
        mt = st.time_s
        age = now - mt  # / 1.0
        svx, svy, sw = st.velocity
        ux, uy = st.user_position_m
        v[i] = 1.0
        v[i + 1] = _age(age)
        v[i + 2] = _clip(svx / vmax, clip)
        v[i + 3] = _clip(svy / vmax, clip)
        v[i + 4] = _clip(sw / wmax, clip)
        ai: cython.Py_ssize_t = _ACTIVITY_INDEX[st.activity]
        v[activity + ai] = 1.0
        v[rotating] = 1.0 if st.user_rotating else 0.0
        turn: cython.double = st.user_turn_rate_rps
        v[turn_rate] = _clip(turn / wmax, clip)
        v[user_xy] = _clip(ux / pos_scale, user_clip)
        v[user_xy + 1] = _clip(uy / pos_scale, user_clip)
    else:
        v[i + 1] = 1.0
    m = irs.get(members.get(0))  # the master's IR fix (member 0), carried over own rotation and translation
    if m is not None:
        mt = m.time_s
        v[master_ir] = 1.0
        _put_fix(v, master_ir + 1, m, yaw_rad, ox0, oy0, plan.ir_max, pos_scale)
        v[master_ir + 3] = _age((now - mt) / age_scale)
    else:
        v[master_ir + 3] = 1.0
    v[anchor + 3] = 1.0
    own: cython.Py_ssize_t = know.member
    nslots: cython.Py_ssize_t = len(member_slots)
    # the anchor: the lowest other slave's member number with a fresh fix, below the formation's slot count. Member
    # numbers are formation slots (0 the master, 1.. the slaves: Knowledge.members), so they are tried upwards from 1
    # and the first with a fresh fix is the lowest (most slaves find one among the first few, not after all members)
    fix = None
    member: cython.Py_ssize_t
    first: cython.Py_ssize_t = nslots
    for member in range(1, nslots):
        if member == own:
            continue
        m = irs.get(members.get(member))
        if m is not None:
            mt = m.time_s
            if now - mt < age_scale:
                first, fix = member, m
                break
    if fix is not None:
        m = fix
        mt = m.time_s
        sx, sy = member_slots[first]
        v[anchor] = 1.0
        _put_fix(v, anchor + 1, m, yaw_rad, ox0, oy0, plan.ir_max, pos_scale)
        v[anchor + 3] = (now - mt) / age_scale
        v[anchor + 4] = sx / pos_scale
        v[anchor + 5] = sy / pos_scale
    v[odo] = _clip(ovx / vmax, clip)
    v[odo + 1] = _clip(ovy / vmax, clip)
    v[odo + 2] = _clip(ow / wmax, clip)
    v[yaw] = _sin(yaw_rad)
    v[yaw + 1] = _cos(yaw_rad)
    a0, a1, a2 = last_action.tolist()  # float32 values, exactly as doubles
    v[last] = a0
    v[last + 1] = a1
    v[last + 2] = a2
    ox, oy = offset_from_master
    v[offset] = ox / pos_scale
    v[offset + 1] = oy / pos_scale
    us_max: cython.double = plan.us_max
    ring = ultrasonic_m if type(ultrasonic_m) is list else (  # a ring's row of Python floats (range_rows): as it is
        ultrasonic_m.tolist() if isinstance(ultrasonic_m, np.ndarray) else ultrasonic_m)
    r: cython.double
    k = us
    for r in ring:  # Python's division rounds as numpy's float64 one
        v[k] = r / us_max
        k += 1
    total: cython.double = max(know.total_members, 1)
    v[hierarchy] = hierarchy_level / total
    v[members_at] = total / 16.0
    v[member_at] = own / 16.0
    f: cython.double
    if flags:
        k = flags_at
        for f in flags:
            v[k] = f
            k += 1
    else:
        for k in range(flags_at, n):
            v[k] = 1.0


@cython.cfunc
def _as_dict(mapping) -> dict:
    return mapping if isinstance(mapping, dict) else dict(mapping)  # ``mapping`` itself when it is a dict, else a dict of it


_NO_ACTION = np.zeros(3, np.float32)  # the last action of an agent that has not acted yet (read only)
_NO_ACTION.flags.writeable = False


@cython.cclass
class Observer:
    """Every agent's observation, from its own robot's sensors and its node's middleware: the readings gathered per agent,
    then :func:`build_observation`. Agents are ``robot_<index>`` (``agent_index``: name -> robot index). Typed (observe.pxd)."""

    def __init__(self, layout: ObservationLayout, nodes: dict[int, Node], sensors: Sensors,
                 ahrs: list[AHRS], agent_index: dict[str, int], master_distance_m: float):
        self.layout = layout
        self.nodes = nodes
        self.sensors = sensors
        self.ahrs = ahrs  # each robot's AHRS (sim/sensors.py): its reading ahrs[index].yaw(now_s), a C call
        self.agent_index = agent_index
        self.master_distance_m = master_distance_m
        self._formation_cache: dict[int, tuple[Formation, list[tuple[float, float]], dict[int, int]]] = {}
        scaled = layout.limits is not None and layout.us_max_range_m is not None
        self._plan = _Plan(layout) if scaled else None  # the builder's offsets and scales, read once

    def formation_geometry(self, formation: Formation) -> tuple[list[tuple[float, float]], dict[int, int]]:
        """Slot positions and hierarchy levels of a neighbour table (cached per table)."""
        hit = self._formation_cache.get(id(formation))
        if hit is None or hit[0] is not formation:
            slots = [tuple(p) for p in formation.slot_positions().tolist()]  # Python floats
            levels = formation.hierarchy_levels(user_position_in_formation(formation, self.master_distance_m))
            hit = (formation, slots, levels)
            self._formation_cache[id(formation)] = hit
        return hit[1], hit[2]

    def observe(self, agents: list[str], last_actions: dict[str, np.ndarray], now_s: float) -> dict[str, np.ndarray]:
        """A new observation array for each of ``agents`` at true time ``now_s`` (the ages of what a
        robot knows are counted on its own clock, ``node.clock``) (``last_actions``:
        agent -> the action applied last step; none yet reads as zeros). The odometry noise of all
        agents is one draw, in the agents' order. Each agent's readings go to the builder as they
        are gathered (:func:`build_observation`'s body, without a :class:`Readings` per agent)."""
        sensors, ahrs, layout = self.sensors, self.ahrs, self.layout
        nodes: dict = _as_dict(self.nodes)  # (dicts, looked up in C)
        agent_index: dict = _as_dict(self.agent_index)
        last_by: dict = _as_dict(last_actions)
        levels: dict
        plan: _Plan = self._plan
        if plan is None:
            raise ValueError("Observer needs a layout with limits and us_max_range_m (the robot's scales)")
        noise = sensors.odometry_noise(len(agents))
        robots = sensors.world.robots
        robot: DrivenBody
        node: Station
        ovx: cython.double
        ovy: cython.double
        ow: cython.double
        ranges = sensors.range_rows()  # every robot's ring as Python floats, converted once per reading
        flags = sensors.flags  # every robot's ring flags (the middle layer's presence and location-known)
        cache: dict = self._formation_cache
        v: cython.double[::1] = layout._scratch  # the builder's float64 values, one agent at a time
        size: cython.Py_ssize_t = v.shape[0]
        block = np.empty((len(agents), size), np.float32)  # one row per agent, each its own memory
        rows: cython.float[:, ::1] = block
        k: cython.Py_ssize_t
        i: cython.Py_ssize_t
        obs = {}
        for i, agent in enumerate(agents):
            idx = agent_index[agent]
            node = nodes[idx]
            know: Knowledge = node.know
            member = know.member
            level, offset, slots = 0, (0.0, 0.0), ()
            formation = node.formation
            if formation is not None and member >= 0:
                hit = cache.get(id(formation))  # formation_geometry's cache, read here
                if hit is None or hit[0] is not formation:
                    table_slots, levels = self.formation_geometry(formation)
                else:
                    table_slots, levels = hit[1], hit[2]
                if member < len(table_slots):  # one slot per member of the table (its size)
                    level, offset, slots = levels.get(member, 0), table_slots[member], table_slots
            last = last_by.get(agent)
            robot = robots[idx]  # its wheel odometry (Sensors.odometry's model, sim/sensors.py)
            if noise is not None:
                e = noise[i]
                ovx, ovy, ow = wheel_odometry(robot, e[0], e[1], e[2])
            else:
                ovx, ovy, ow = wheel_odometry(robot, 0.0, 0.0, 0.0)  # noiseless: the wheels' own values, exactly
            sensor: AHRS = ahrs[idx]
            yaw = sensor.yaw(now_s)  # the sensor's physics at true time
            know.dead_reckon(node._mcu.local_now(), ovx, ovy, yaw)  # own position from own odometry, on its own clock
            table = node.formation  # its reference links (Station.reference_links, read here)
            own = node.know.member
            table_links: dict = table.links if table is not None and own > 0 else None
            links = table_links.get(own, ()) if table_links is not None else ()
            _fill(plan, v, know, links, node._mcu.local_now(), ovx, ovy, ow, yaw,  # ages on its own clock
                  last if last is not None else _NO_ACTION, ranges[idx], level, offset, slots, flags[idx])
            if cython.compiled:  # float64 -> float32 rounding, as astype(np.float32)
                for k in range(size):
                    rows[i, k] = v[k]
            else:
                block[i] = v
            obs[agent] = block[i]  # a row of its own: what the agent gets is its own
        return obs
