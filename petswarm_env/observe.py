"""What a policy sees: one fixed-size vector per slave, built from its middleware only.

The layout is declared once, in :data:`FIELDS`; the builder, the documentation table
(:func:`markdown_table`) and the policies' accessors (:class:`ObservationLayout`) all read it.
Every value is scaled to about [-1, 1]; ``scale`` says by what (value_in_obs = value / scale).
Nothing here reads ground truth: the inputs are a node's :class:`~.middleware.node.Knowledge`,
its own sensors (odometry, AHRS, ultrasonic ring) and its last action.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from petswarm_env.middleware.formation import MAX_LINKS
from petswarm_env.middleware.node import Node
from petswarm_env.scenarios import ACTIVITIES

OBS_VERSION = 1
POS_SCALE_M = 3.0
AGE_SCALE_S = 2.0


@dataclass(frozen=True)
class Field:
    name: str
    size: int
    scale: str  # human-readable scale, for the docs
    doc: str


def _link_fields(k: int) -> list[Field]:
    p = f"link{k}."
    return [
        Field(p + "present", 1, "0/1", f"reference link {k} exists (slot 0 = primary neighbour, 1 = second, grid)"),
        Field(p + "ir_valid", 1, "0/1", "an IR measurement of that neighbour has been received"),
        Field(p + "neighbour_xy", 2, f"m / {POS_SCALE_M}", "IR-estimated position of the neighbour in own body frame (x forward, y left), carried over own rotation since (AHRS)"),
        Field(p + "ir_age", 1, f"s / {AGE_SCALE_S}, clipped to 1", "age of that IR measurement"),
        Field(p + "offset_xy", 2, f"m / {POS_SCALE_M}", "own reference offset from the neighbour, formation frame (x = swarm heading)"),
        Field(p + "heading_sincos", 2, "-", "sin, cos of θ_neighbour − θ_self from the heading exchange, carried over own rotation since (AHRS); (0, 1) if unknown"),
        Field(p + "heading_valid", 1, "0/1", "a heading exchange with that neighbour has happened"),
        Field(p + "heading_age", 1, f"s / {AGE_SCALE_S}, clipped to 1", "age of the heading estimate"),
    ]


FIELDS: list[Field] = [
    *[f for k in range(MAX_LINKS) for f in _link_fields(k)],
    Field("master.valid", 1, "0/1", "a master status broadcast has been received"),
    Field("master.age", 1, "s / 1, clipped to 1", "age of the last master broadcast"),
    Field("master.velocity", 3, "/ (v_max, v_max, ω_max)", "master's (Vx, Vy, ω) in its body frame, as broadcast"),
    Field("master.activity", len(ACTIVITIES), "one-hot", "user activity broadcast by the master: " + ", ".join(ACTIVITIES)),
    Field("master.rotating", 1, "0/1", "user rotation flag of the smart belt, as broadcast (seed 002 §3.4)"),
    Field("master.turn_rate", 1, "/ ω_max", "user angular speed from the belt's filtered gyro, as broadcast (rad/s, CCW +)"),
    Field("master.leading", 1, "0/1", "driving mode: 1 = leading, 0 = following"),
    Field("master.user_xy", 2, f"m / {POS_SCALE_M}", "user position relative to the master, master's frame, as broadcast"),
    Field("self.odometry", 3, "/ (v_max, v_max, ω_max)", "own wheel-odometry (Vx, Vy, ω), body frame"),
    Field("self.yaw_sincos", 2, "-", "own AHRS yaw (noisy, drifting)"),
    Field("self.last_action", 3, "[-1, 1]", "the action applied last step"),
    Field("self.offset_from_master_xy", 2, f"m / {POS_SCALE_M}", "own reference position relative to the master, formation frame (from the neighbour table)"),
    Field("self.ultrasonic", -1, "m / max_range", "ultrasonic ring ranges, sensor 0 forward, counter-clockwise"),
    Field("self.hierarchy", 1, "level / members", "hierarchy level (1 = farthest from the user) over the number of members"),
    Field("self.members", 1, "/ 16", "number of swarm members (master included)"),
    Field("self.member", 1, "/ 16", "own member number"),
]


# the fields after the links, in the order build_observation unpacks their start offsets
_BUILDER_FIELDS = ("master.valid", "master.activity", "master.rotating", "master.turn_rate", "master.leading", "master.user_xy",
                   "self.odometry", "self.yaw_sincos", "self.last_action", "self.offset_from_master_xy", "self.ultrasonic",
                   "self.hierarchy", "self.members", "self.member")
_ACTIVITY_INDEX = {a: i for i, a in enumerate(ACTIVITIES)}
_cos, _sin = math.cos, math.sin


class ObservationLayout:
    """Offsets of every named field; the same object documents, builds and reads observations."""

    def __init__(self, num_ultrasonic: int):
        self.slices: dict[str, slice] = {}
        self.fields: list[Field] = []
        i = 0
        for f in FIELDS:
            size = num_ultrasonic if f.size == -1 else f.size
            self.fields.append(Field(f.name, size, f.scale, f.doc))
            self.slices[f.name] = slice(i, i + size)
            i += size
        self.size = i
        # start offsets the builder writes at (resolved once, not per observation)
        st = {name: sl.start for name, sl in self.slices.items()}
        self._link_starts = tuple(st[f"link{k}.present"] for k in range(MAX_LINKS))
        self._starts = tuple(st[name] for name in _BUILDER_FIELDS)

    def get(self, obs: np.ndarray, name: str) -> np.ndarray:
        return obs[self.slices[name]]

    def signature(self) -> list[tuple[str, int]]:
        """(name, size) of every field: what a saved policy records and is matched against."""
        return [(f.name, f.size) for f in self.fields]


def markdown_table(layout: ObservationLayout) -> str:
    rows = ["| index | field | size | scale | meaning |", "|---|---|---|---|---|"]
    for f in layout.fields:
        s = layout.slices[f.name]
        idx = f"{s.start}" if f.size == 1 else f"{s.start}–{s.stop - 1}"
        rows.append(f"| {idx} | `{f.name}` | {f.size} | {f.scale} | {f.doc} |")
    return "\n".join(rows)


def build_observation(
    layout: ObservationLayout,
    out: np.ndarray | None,
    node: Node,
    now: float,
    odometry: tuple[float, float, float],
    yaw_rad: float,
    last_action: np.ndarray,
    ultrasonic_m: np.ndarray | list[float],
    hierarchy_level: int,
    offset_from_master: tuple[float, float],
    limits: tuple[float, float, float],
    us_max_range_m: float,
) -> np.ndarray:
    """The observation of one slave, written into ``out`` (layout.size,) or, with ``out=None``, a
    new float32 array. Built as a Python list and converted once (one numpy conversion instead of
    one per value), with ``np.fromiter``: the same float64 -> float32 rounding as ``np.array(v,
    dtype=np.float32)`` at a fraction of its cost. ``ultrasonic_m`` may also be a list of Python
    floats (the env converts the rings of all robots at once). Field offsets come unpacked from
    ``layout._starts``; ages are clipped to 1 as ``min(age, 1.0)`` would (``1.0 if age > 1.0
    else age``, nan passing through in both)."""
    v = [0.0] * layout.size
    vmax, _, wmax = limits
    know = node.know
    links = node.reference_links()
    if links:
        members, irs, heads = know.members, know.ir, know.heading
        for base, link in zip(layout._link_starts, links):
            v[base] = 1.0
            nb = members.get(link.neighbour)
            m = irs.get(nb)
            if m is not None:  # bearing carried over own rotation since the measurement (AHRS)
                b = m.bearing_rad - (yaw_rad - m.own_yaw_rad)
                age = (now - m.time_s) / AGE_SCALE_S
                v[base + 1] = 1.0
                v[base + 2] = m.distance_m * _cos(b) / POS_SCALE_M
                v[base + 3] = m.distance_m * _sin(b) / POS_SCALE_M
                v[base + 4] = 1.0 if age > 1.0 else age
            else:
                v[base + 4] = 1.0
            ox, oy = link.offset_m
            v[base + 5] = ox / POS_SCALE_M
            v[base + 6] = oy / POS_SCALE_M
            h = heads.get(nb)
            if h is not None:  # θ_nb − θ_self falls as we turn: carry it over own rotation (AHRS)
                rel = h.relative_rad - (yaw_rad - h.own_yaw_rad)
                age = (now - h.time_s) / AGE_SCALE_S
                v[base + 7] = _sin(rel)
                v[base + 8] = _cos(rel)
                v[base + 9] = 1.0
                v[base + 10] = 1.0 if age > 1.0 else age
            else:
                v[base + 8] = 1.0
                v[base + 10] = 1.0
    (i, activity, rotating, turn_rate, leading, user_xy, odo, yaw, last, offset, us,
     hierarchy, members_at, member_at) = layout._starts
    st = know.status
    if st is not None:
        age = now - st.time_s  # / 1.0
        svx, svy, sw = st.velocity
        ux, uy = st.user_position_m
        v[i] = 1.0
        v[i + 1] = 1.0 if age > 1.0 else age
        v[i + 2] = svx / vmax
        v[i + 3] = svy / vmax
        v[i + 4] = sw / wmax
        v[activity + _ACTIVITY_INDEX[st.activity]] = 1.0
        v[rotating] = 1.0 if st.user_rotating else 0.0
        v[turn_rate] = st.user_turn_rate_rps / wmax
        v[leading] = 1.0 if st.mode == "leading" else 0.0
        v[user_xy] = ux / POS_SCALE_M
        v[user_xy + 1] = uy / POS_SCALE_M
    else:
        v[i + 1] = 1.0
    v[odo] = odometry[0] / vmax
    v[odo + 1] = odometry[1] / vmax
    v[odo + 2] = odometry[2] / wmax
    v[yaw] = _sin(yaw_rad)
    v[yaw + 1] = _cos(yaw_rad)
    v[last : last + 3] = last_action.tolist()
    v[offset] = offset_from_master[0] / POS_SCALE_M
    v[offset + 1] = offset_from_master[1] / POS_SCALE_M
    if isinstance(ultrasonic_m, np.ndarray):
        v[us : us + len(ultrasonic_m)] = (ultrasonic_m / us_max_range_m).tolist()
    else:  # Python floats (the env's call): Python's division rounds as numpy's float64 one
        v[us : us + len(ultrasonic_m)] = [r / us_max_range_m for r in ultrasonic_m]
    total = max(know.total_members, 1)
    v[hierarchy] = hierarchy_level / total
    v[members_at] = total / 16.0
    v[member_at] = know.member / 16.0
    if out is None:
        return np.fromiter(v, np.float32, len(v))
    out[:] = v
    return out


if __name__ == "__main__":  # python -m petswarm_env.observe > docs/observation.md
    from petswarm_env.config import load_config

    _layout = ObservationLayout(load_config().robot.ultrasonic.count)
    print(f"# Observation of a slave (petswarm_v0, layout version {OBS_VERSION}, {_layout.size} values)\n")
    print("Generated by `python -m petswarm_env.observe`; built only from the slave's middleware and own sensors.\n")
    print(markdown_table(_layout))
