"""The global state: one fixed-size vector of ground truth for centralized critics (MAPPO) and
PettingZoo's ``state()``.

Unlike the observation (:mod:`petswarm_env.observe`), the state is the experimenter's view: true
poses and velocities of every robot of the world (in robot index order, masters and waiting robots
included), every robot's true reference point (:class:`~.metrics.Experimenter`), every user's true
motion and session state, and the episode's time. A policy never reads it; a critic trained beside
it may. The layout is declared once in :data:`ROBOT_FIELDS`, :data:`USER_FIELDS` and
:data:`GLOBAL_FIELDS` (the same :class:`~.observe.Field` records as the observation, with their
bounds); ``python -m petswarm_env.state > docs/state.md`` documents it.

Its size is fixed by the config: ``robots = world.num_users · (1 + swarm.num_slaves +
swarm.extra_robots, or the pool's robots with a swarm.pool or a scenario's pool) + swarm.other_user_robots`` (+ the arrival robots, ``arrivals``) blocks of :data:`ROBOT_FIELDS`, then
``world.num_users`` blocks of :data:`USER_FIELDS`, then :data:`GLOBAL_FIELDS`. Positions are
relative to user 0 (the world frame's axes), so the state does not grow with the distance walked.

Every robot block ends with ``type`` (its index in ``robot_types``) and ``fault`` (a fault is
active): their places were fixed before robot types and faults existed (then always 0), so a
critic's input size did not change when they came (state version 2).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from petswarm_env.config import arrival_slots
from petswarm_env.observe import CLIP, Field, markdown_table
from petswarm_env.scenarios import ACTIVITIES

if TYPE_CHECKING:
    from petswarm_env.config import Config

STATE_VERSION = 2  # 2: the type and fault fields carry the robot types (seeds 001, 003) and the runtime faults
STATE_POS_SCALE_M = 10.0  # positions relative to user 0, m / 10
STATE_POS_CLIP = 2.0  # … clipped to ±2 (20 m)
ERROR_SCALE_M = 3.0  # reference errors, m / 3 (the observation's POS_SCALE_M)
NUM_TYPES = 8  # type index / 8 (reserved)
ROLES = ("waiting", "master", "slave", "other")

_POS = (-STATE_POS_CLIP, STATE_POS_CLIP)
_POS_WHY = f"clipped to ±{STATE_POS_CLIP} ({STATE_POS_CLIP * STATE_POS_SCALE_M:g} m from user 0)"

ROBOT_FIELDS: list[Field] = [
    Field("role", len(ROLES), "one-hot", "the robot's role: " + ", ".join(ROLES) + " (connected to another user, seed 000 Table 1)"),
    Field("user", 1, "(u + 1) / users", "the user whose swarm the robot is in (as master or slave); 0 = none",
          (0.0, 1.0), "u in 0 … users − 1"),
    Field("member", 1, "/ 16", "member number in its swarm (0 = master); -1 = none", (-1 / 16, 1.0), "-1 (none) … 16"),
    Field("xy", 2, f"m / {STATE_POS_SCALE_M:g}", "true position relative to user 0, world frame", _POS, _POS_WHY),
    Field("heading_sincos", 2, "-", "sin, cos of the true heading", (-1.0, 1.0), "a unit vector"),
    Field("velocity", 3, "/ (v_max, v_max, ω_max)", "achieved body-frame velocity (Vx, Vy, ω) of the last physics substep",
          (-CLIP, CLIP), f"clipped to ±{CLIP}"),
    Field("reference.valid", 1, "0/1", "the robot is a slave with a reference point"),
    Field("reference.xy", 2, f"m / {STATE_POS_SCALE_M:g}", "its true reference point relative to user 0, world frame (0 if none)",
          _POS, _POS_WHY),
    Field("reference.error_xy", 2, f"m / {ERROR_SCALE_M:g}", "reference point minus true position, world frame (0 if none)",
          (-STATE_POS_CLIP, STATE_POS_CLIP), f"clipped to ±{STATE_POS_CLIP}"),
    Field("type", 1, f"index / {NUM_TYPES}", "robot type: its index in the config's robot_types (0 = petbot, then "
          "mybot, r1, r2 by default)", (0.0, 1.0), f"a type index in 0 … {NUM_TYPES} (a later one reads 1)"),
    Field("fault", 1, "0/1", "a fault is active on the robot (robot.health, docs/faults.md; an arrival robot "
          "parked switched off is not faulty)"),
]
USER_FIELDS: list[Field] = [
    Field("xy", 2, f"m / {STATE_POS_SCALE_M:g}", "true position relative to user 0 (user 0: 0, 0)", _POS, _POS_WHY),
    Field("heading_sincos", 2, "-", "sin, cos of the true heading", (-1.0, 1.0), "a unit vector"),
    Field("velocity", 2, "/ user.run_speed_mps", "walking velocity of the script, world frame", (-1.0, 1.0), "clipped to ±1"),
    Field("turn_rate", 1, "/ ω_max", "turn rate of the script (rad/s, CCW +)", (-CLIP, CLIP), f"clipped to ±{CLIP}"),
    Field("walking", 1, "0/1", "the user's script runs (from the end of reset)"),
    Field("activity", len(ACTIVITIES), "one-hot", "the user's true activity: " + ", ".join(ACTIVITIES)),
    Field("leading", 1, "0/1", "the user's swarm drives in leading mode"),
    Field("emergency", 1, "0/1", "the user session is in emergency (no LF fix for 2 s, seed 002 Fig. 4)"),
    Field("exception", 1, "0/1", "the user session is in the leading mode's obstacle exception"),
]
GLOBAL_FIELDS: list[Field] = [
    Field("time", 1, "step / max_cycles", "the episode's progress", (0.0, 1.0), "0 … max_cycles steps"),
]
_ACTIVITY_INDEX = {a: i for i, a in enumerate(ACTIVITIES)}


class _Block:
    """Offsets of a list of fields (what :func:`~.observe.markdown_table` reads)."""

    def __init__(self, fields: list[Field]):
        self.fields, self.slices, i = list(fields), {}, 0
        for f in fields:
            self.slices[f.name] = slice(i, i + f.size)
            i += f.size
        self.size = i

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        low, high = np.zeros(self.size), np.zeros(self.size)
        for f in self.fields:
            low[self.slices[f.name]], high[self.slices[f.name]] = f.bounds
        return low, high


ROBOT_BLOCK, USER_BLOCK, GLOBAL_BLOCK = _Block(ROBOT_FIELDS), _Block(USER_FIELDS), _Block(GLOBAL_FIELDS)


def num_robots(cfg: Config) -> int:
    """The robots a world of ``cfg`` holds (each user's master and pool, then another user's robots,
    then the arrival robots, petswarm_env/runtime.py)."""
    return cfg.robot_count(arrival_slots(cfg))


class StateLayout:
    """Where every block starts: ``robot(i)`` and ``user(u)`` give a block's offset, ``size`` the
    state's length; ``low``/``high`` its bounds (float32)."""

    def __init__(self, cfg: Config):
        self.num_robots, self.num_users = num_robots(cfg), cfg.world.num_users
        self.users_at = self.num_robots * ROBOT_BLOCK.size
        self.global_at = self.users_at + self.num_users * USER_BLOCK.size
        self.size = self.global_at + GLOBAL_BLOCK.size
        parts = [ROBOT_BLOCK.bounds()] * self.num_robots + [USER_BLOCK.bounds()] * self.num_users + [GLOBAL_BLOCK.bounds()]
        self.low = np.concatenate([p[0] for p in parts]).astype(np.float32)
        self.high = np.concatenate([p[1] for p in parts]).astype(np.float32)

    def robot(self, i: int) -> int:
        return i * ROBOT_BLOCK.size

    def user(self, u: int) -> int:
        return self.users_at + u * USER_BLOCK.size

    def field(self, state: np.ndarray, block: str, index: int, name: str) -> np.ndarray:
        """``state``'s values of one field, e.g. ``field(s, "robot", 2, "xy")``."""
        start = self.robot(index) if block == "robot" else self.user(index) if block == "user" else self.global_at
        sl = {"robot": ROBOT_BLOCK, "user": USER_BLOCK, "global": GLOBAL_BLOCK}[block].slices[name]
        return state[start + sl.start:start + sl.stop]


def _clip(x: float, c: float) -> float:
    return -c if x < -c else c if x > c else x


def build_state(layout: StateLayout, env: Any) -> np.ndarray:
    """The state of ``env`` (an :class:`~.episode.Episode`) now: ground truth from its world,
    swarms, user sessions and experimenter. One function: the fields in the layout's order."""
    cfg, world = env.cfg, env.world
    if len(world.robots) != layout.num_robots:
        raise RuntimeError(f"scenario '{env.scenario}' placed {len(world.robots)} robots; the state has room for "
                           f"{layout.num_robots} (state.num_robots)")
    v = np.zeros(layout.size, np.float64)
    centers, _, headings = world.truth_arrays()
    ox, oy = centers[len(world.robots)]  # user 0
    vmax, wmax = cfg.robot.max_speed_mps, cfg.robot.max_omega_rps
    user_of, role = {}, {i: 0 for i in range(layout.num_robots)}
    for u, sw in enumerate(env.swarms):
        role[sw.master.node_id], user_of[sw.master.node_id] = 1, u
        for i in sw.slave_ids():
            role[i], user_of[i] = 2, u
    for i in env.other_user_robots:
        role[i] = 3
    refs = env.experimenter.reference_points(centers.tolist(), headings.tolist())
    type_index = {name: k for k, name in enumerate(cfg.robot_types)}
    parked = set(env.runtime.parked())  # arrival robots not switched on yet
    r = ROBOT_BLOCK.slices
    for i, robot in enumerate(world.robots):
        b = layout.robot(i)
        v[b + role[i]] = 1.0
        if i in user_of:
            v[b + r["user"].start] = (user_of[i] + 1) / layout.num_users
        node = env.fleet.nodes.get(i)
        v[b + r["member"].start] = (node.know.member if node is not None else -1) / 16.0
        x, y = centers[i]
        v[b + r["xy"].start:b + r["xy"].stop] = [_clip((x - ox) / STATE_POS_SCALE_M, STATE_POS_CLIP),
                                                 _clip((y - oy) / STATE_POS_SCALE_M, STATE_POS_CLIP)]
        v[b + r["heading_sincos"].start:b + r["heading_sincos"].stop] = [math.sin(headings[i]), math.cos(headings[i])]
        bvx, bvy, bw = robot.velocity_body
        v[b + r["velocity"].start:b + r["velocity"].stop] = [_clip(bvx / vmax, CLIP), _clip(bvy / vmax, CLIP), _clip(bw / wmax, CLIP)]
        v[b + r["type"].start] = min(type_index.get(robot.type_name, 0), NUM_TYPES) / NUM_TYPES
        v[b + r["fault"].start] = float(bool(robot.health.active) and i not in parked)
        ref = refs.get(i)
        if ref is not None:
            v[b + r["reference.valid"].start] = 1.0
            v[b + r["reference.xy"].start:b + r["reference.xy"].stop] = [
                _clip((ref[0] - ox) / STATE_POS_SCALE_M, STATE_POS_CLIP), _clip((ref[1] - oy) / STATE_POS_SCALE_M, STATE_POS_CLIP)]
            v[b + r["reference.error_xy"].start:b + r["reference.error_xy"].stop] = [
                _clip((ref[0] - x) / ERROR_SCALE_M, STATE_POS_CLIP), _clip((ref[1] - y) / ERROR_SCALE_M, STATE_POS_CLIP)]
    q = USER_BLOCK.slices
    for u, (user, session, swarm) in enumerate(zip(world.users, env.sessions, env.swarms)):
        b = layout.user(u)
        x, y = centers[len(world.robots) + u]
        th = user.heading
        speed = user.segment.speed_mps if user.walking else 0.0
        turn = math.radians(user.segment.turn_rate_dps) if user.walking else 0.0
        run = cfg.user.run_speed_mps
        v[b + q["xy"].start:b + q["xy"].stop] = [_clip((x - ox) / STATE_POS_SCALE_M, STATE_POS_CLIP),
                                                 _clip((y - oy) / STATE_POS_SCALE_M, STATE_POS_CLIP)]
        v[b + q["heading_sincos"].start:b + q["heading_sincos"].stop] = [math.sin(th), math.cos(th)]
        v[b + q["velocity"].start:b + q["velocity"].stop] = [_clip(speed * math.cos(th) / run, 1.0), _clip(speed * math.sin(th) / run, 1.0)]
        v[b + q["turn_rate"].start] = _clip(turn / wmax, CLIP)
        v[b + q["walking"].start] = float(user.walking)
        v[b + q["activity"].start + _ACTIVITY_INDEX[user.activity]] = 1.0
        v[b + q["leading"].start] = float(swarm.mode == "leading")
        v[b + q["emergency"].start] = float(session.state == "emergency")
        v[b + q["exception"].start] = float(session.state == "exception")
    v[layout.global_at] = min(env.num_cycles / cfg.max_cycles, 1.0)
    return v.astype(np.float32)


def markdown(cfg: Config) -> str:
    """docs/state.md: the three blocks' tables and the default config's offsets."""
    layout = StateLayout(cfg)
    out = [f"# Global state (petswarm_v1 `state()`, state version {STATE_VERSION}, {layout.size} values for the default config)\n",
           "Generated by `python -m petswarm_env.state`. Ground truth for centralized critics; a policy never reads it "
           "(see the module docstring of `petswarm_env/state.py`).\n",
           f"Layout: {layout.num_robots} robot blocks of {ROBOT_BLOCK.size} values (robot index order: each user's master, "
           f"then its pool, then robots of another user), at offsets 0, {ROBOT_BLOCK.size}, …; then {layout.num_users} user "
           f"block(s) of {USER_BLOCK.size} from offset {layout.users_at}; then the global block at {layout.global_at}. "
           "The number of robot blocks is `world.num_users · (1 + swarm.num_slaves + swarm.extra_robots) + "
           "swarm.other_user_robots` (with a `swarm.pool`, or a scenario's pool, its robots instead of `num_slaves + extra_robots`). `state_space` is `Box(low, high)` with the bounds below; *clipped* values are "
           "clipped when the state is built.\n"]
    for title, block in (("Per robot", ROBOT_BLOCK), ("Per user", USER_BLOCK), ("Global", GLOBAL_BLOCK)):
        out.append(f"## {title} ({block.size} values; index relative to the block)\n")
        out.append(markdown_table(block, block.bounds()) + "\n")
    return "\n".join(out)


if __name__ == "__main__":  # python -m petswarm_env.state > docs/state.md
    from petswarm_env.config import load_config

    print(markdown(load_config()), end="")
