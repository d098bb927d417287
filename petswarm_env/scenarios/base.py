"""What a scenario is: the user's walking script (segments) and where reset puts the robots.

A segment is ``(duration_s, speed_mps, turn_rate_dps, activity, command)``; the user walks at
``speed`` along their heading while the heading turns at ``turn_rate``; ``command`` (optional) is
what the user tells the robots through the watch when the segment starts (see
:data:`USER_COMMANDS`). The last segment repeats until the episode ends.

The user stays in the world: in a walled arena every script turns back at the walls
(:func:`turn_back_at_walls`: a 180° walking turn toward the arena's centre once the user comes
within the swarm's reach plus a turn and a clearance of a wall, walking toward it), and the env
refuses an arena too small for that (:meth:`Scenario.arena_problem`).

This module and the scenario modules import nothing of ``petswarm_env`` (the config validates
scenario names against the registry, so the registry sits below it): a scenario gets what it
needs — the user's config section, the world to place robots in, the formation's slots — as
arguments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

ACTIVITIES = ("stop", "rest", "walk", "run")  # seed 002 Table 2
# What a user can tell the robots through the smart watch (seed 002 §2, Fig. 4; seed 000 Fig. 4):
# the driving mode, organize / disperse the swarm, return from an exception, and the seven
# remote-control gestures of seed 002 Table 1 ("gesture:forward", ...).
USER_COMMANDS = ("mode:following", "mode:leading", "mode:remote", "organize", "disperse", "return")

SPAWN_REACH = 0.85  # chosen: waiting robots start within 85 % of the master's available region (Table 1)
PAIRING_DISTANCE_M = 0.8  # chosen: each user starts this close to their robot (LF wake-up range 1 m)
SCATTER_REACH = 0.75  # chosen: scattered robots start within 75 % of the master's available region (Table 1): 2.25 m of 3 m is 3 σ of the RSSI distance estimate inside it (radio.rssi_shadowing_db 1 dB at path loss exponent 2.5: ×1.096 per σ), so no robot declines by Table 1 but once in ~1 000 draws at the rim; and the master's IR is detected there (seed 000 Table 4 calibration: ≈ 2.5 m on axis)
SPAWN_CLEARANCE_M = 0.2  # chosen: scattered robots start at least this far (rim to rim) from each other, a user, a master's path
SPAWN_TRIES = 1000  # draws per scattered robot before the region is declared full
TURN_BACK_SPEED = 0.5  # chosen: the user turns back at a wall at half the walking speed (as in u_turn)
TURN_BACK_CLEARANCE_M = 1.0  # chosen: a swarm turning back with its user stays this far from the wall
TURN_BACK_CHECK_S = 0.1  # the script's path is checked against the walls at this step (one control period)


@dataclass(frozen=True)
class Segment:
    duration_s: float
    speed_mps: float
    turn_rate_dps: float
    activity: str
    command: str = ""


def turn(angle_deg: float, rate_dps: float, speed: float) -> Segment:
    """A turn of ``angle_deg`` (positive = left / CCW) while walking at ``speed``."""
    return Segment(abs(angle_deg) / rate_dps, speed, rate_dps if angle_deg > 0 else -rate_dps, "walk")


class ScenarioScript:
    """Evaluates a segment list at a time: speed, turn rate and activity of the user."""

    def __init__(self, segments: list[Segment]):
        self.segments = segments
        self.ends = np.cumsum([s.duration_s for s in segments]).tolist()  # floats: read every substep
        self._last = len(self.ends) - 1
        self._i = 0

    def at(self, t_s: float) -> Segment:
        i = self._i
        while i < self._last and t_s >= self.ends[i]:
            i += 1
        self._i = i
        return self.segments[i]

    def segment_end_s(self) -> float:
        """The script time at which the segment :meth:`at` returned last ends: until then :meth:`at`
        returns that segment again (the last segment repeats: inf)."""
        return self.ends[self._i] if self._i < self._last else math.inf


@dataclass(frozen=True)
class Arena:
    """The walled arena one user walks in, for :func:`turn_back_at_walls`: its half width and
    height (m), how close to a wall the user turns back (``margin_m``), where the user starts and
    facing where, and how long the episode's script runs (``horizon_s``)."""

    half_m: tuple[float, float]
    margin_m: float
    start_m: tuple[float, float]
    heading_rad: float
    horizon_s: float


def turn_back_radius_m(user: Any) -> float:
    """Radius of the user's turn back at a wall: half the walking speed at ``user.turn_rate_dps``."""
    return TURN_BACK_SPEED * user.walk_speed_mps / math.radians(user.turn_rate_dps)


def _arc(x: float, y: float, th: float, v: float, w: float, t: float) -> tuple[float, float, float]:
    """Pose after walking ``t`` s at speed ``v`` while turning at ``w`` (rad/s), in closed form."""
    if abs(w) < 1e-12:
        return x + v * t * math.cos(th), y + v * t * math.sin(th), th
    th2 = th + w * t
    return x + v / w * (math.sin(th2) - math.sin(th)), y - v / w * (math.cos(th2) - math.cos(th)), th2


def _toward_wall(x: float, y: float, th: float, hx: float, hy: float, margin: float) -> bool:
    """Inside the margin of a wall and walking toward it."""
    c, s = math.cos(th), math.sin(th)
    return ((x > hx - margin and c > 0.0) or (x < margin - hx and c < 0.0)
            or (y > hy - margin and s > 0.0) or (y < margin - hy and s < 0.0))


def turn_back_at_walls(segments: list[Segment], user: Any, arena: Arena) -> list[Segment]:
    """The scenario rule that keeps the user in the world: ``segments`` with a turn back inserted
    wherever the user, walking them from ``arena.start_m``, would come within ``arena.margin_m`` of
    a wall while walking toward it (checked every ``TURN_BACK_CHECK_S`` of the script, up to
    ``arena.horizon_s``). A turn back is a 180° walking turn at ``TURN_BACK_SPEED`` times the
    walking speed and ``user.turn_rate_dps``, toward the arena's centre; then the interrupted
    segment goes on (its command, given when it started, is not given again) and the script after
    it, from the new heading. The user is a kinematic body on the script, so its path is known here
    (in closed form; the physics integrates it in substeps, a few cm apart over a turn)."""
    hx, hy = arena.half_m
    x, y = arena.start_m
    th = arena.heading_rad
    w_back = math.radians(user.turn_rate_dps)
    out: list[Segment] = []
    queue = list(segments)
    t = 0.0
    while queue and t < arena.horizon_s:
        seg = queue.pop(0)
        w = math.radians(seg.turn_rate_dps)
        done = 0.0
        while done < seg.duration_s and t + done < arena.horizon_s:
            step = min(TURN_BACK_CHECK_S, seg.duration_s - done)
            x, y, th = _arc(x, y, th, seg.speed_mps, w, step)
            done += step
            if seg.speed_mps > 0.0 and _toward_wall(x, y, th, hx, hy, arena.margin_m):
                break
        else:
            out.append(seg)
            t += done
            continue
        left = x * math.sin(th) - y * math.cos(th) >= 0.0  # the arena's centre is on the left
        back = Segment(math.pi / w_back, TURN_BACK_SPEED * user.walk_speed_mps, user.turn_rate_dps if left else -user.turn_rate_dps,
                       "walk")
        out += [replace(seg, duration_s=done), back]
        x, y, th = _arc(x, y, th, back.speed_mps, math.radians(back.turn_rate_dps), back.duration_s)
        t += done + back.duration_s
        if seg.duration_s > done:
            queue.insert(0, replace(seg, duration_s=seg.duration_s - done, command=""))
    return out + queue


@dataclass(frozen=True)
class Placement:
    """Where reset put the robots: per user, its own robot (the future master) and its pool of
    waiting robots (world indices); and the robots already connected to another user."""

    pools: list[tuple[int, list[int]]]
    other_user_robots: list[int]


class Scenario:
    """A named scenario (VMAS's make_world / reset_world_at are the model): the user's walking
    script, :meth:`segments`, and the robots' start, :meth:`place`.

    The default script stands for ``user.start_delay_s``, walks :meth:`walk`, then walks straight
    on; the default placement is :meth:`place`'s. A scenario whose script changes the driving mode
    while the swarm is organized sets ``changes_master``: with ``swarm.master_change`` the master
    role may move to another robot (seed 000 Table 3), so the user's own robot is an agent too.
    """

    name: str = ""
    changes_master: bool = False
    # runtime changes the scenario brings when the config lists none (plain mappings of the
    # config's keys: faults [{at_s, robot, kind, duration_s}], arrivals [{at_s, type}]; petswarm_env/runtime.py)
    faults: tuple[dict[str, Any], ...] = ()
    arrivals: tuple[dict[str, Any], ...] = ()
    # the waiting robots of each user's pool by type, ((type, count), ...), used when swarm.pool is
    # empty (robot_types.pool_types); () = swarm.num_slaves + swarm.extra_robots petbots
    robot_pool: tuple[tuple[str, int], ...] = ()

    def walk(self, user: Any, rng: np.random.Generator) -> list[Segment]:
        """The segments between the start-up stand and the final straight walk (``user``: the
        ``user`` config section; ``rng``: the script's own stream)."""
        return []

    def segments(self, user: Any, rng: np.random.Generator) -> list[Segment]:
        """The whole script: stand, :meth:`walk`, walk straight on."""
        stand = Segment(user.start_delay_s, 0.0, 0.0, "stop")
        straight = Segment(1e9, user.walk_speed_mps, 0.0, "walk")
        return [stand, *self.walk(user, rng), straight]

    def script(self, user: Any, rng: np.random.Generator, arena: Arena | None = None) -> ScenarioScript:
        """The user's script: :meth:`segments`, turned back at the walls of ``arena`` if given
        (:func:`turn_back_at_walls`)."""
        segments = self.segments(user, rng)
        return ScenarioScript(turn_back_at_walls(segments, user, arena) if arena is not None else segments)

    def arena_problem(self, cfg: Any, reach_m: float) -> str | None:
        """Why the arena ``cfg.world.arena_m`` cannot hold this scenario's users and their swarms
        over ``cfg.max_cycles`` (None if it can). A swarm stands up to ``reach_m`` from its user.
        It fits when no user can walk within ``reach_m + TURN_BACK_CLEARANCE_M`` of a wall in the
        episode (the walk's length bounded by its fastest segment), or else when every user starts
        at least the turn-back margin (:meth:`turn_back_margin_m`) inside every wall, so that the
        turn back keeps the user and the swarm inside."""
        w, h = cfg.world.arena_m
        if w <= 0 or h <= 0:
            return None  # no walls
        user = cfg.user
        speed = max(seg.speed_mps for seg in self.segments(user, np.random.default_rng(0)))
        walk = speed * cfg.max_cycles * cfg.control_period_s
        reach_m = max(reach_m, self.start_reach_m(cfg))
        margin = self.turn_back_margin_m(user, reach_m)
        for u in range(cfg.world.num_users):
            room = min(w / 2, h / 2 - abs(u * cfg.world.user_spacing_m))  # start to the nearest wall
            if room - walk >= reach_m + TURN_BACK_CLEARANCE_M or room >= margin:
                continue
            return (f"world.arena_m={[w, h]} cannot hold user.scenario='{self.name}' over max_cycles={cfg.max_cycles}: "
                    f"user {u} walks up to {walk:.0f} m (user.walk_speed_mps={user.walk_speed_mps}) and starts "
                    f"{f'{room:.1f} m from a wall' if room >= 0 else f'outside the walls ({-room:.1f} m beyond one)'}, but turns back {margin:.1f} m from one (its swarm reaches {reach_m:.1f} m, a turn at "
                    f"user.turn_rate_dps={user.turn_rate_dps}); make the arena at least {2 * (margin + abs(u * cfg.world.user_spacing_m)):.1f} m "
                    "wide and high, lower max_cycles, or set world.arena_m=[0, 0] (no walls)")
        return None

    def arena(self, cfg: Any, reach_m: float, user_index: int) -> Arena | None:
        """User ``user_index``'s arena for :func:`turn_back_at_walls` (None without walls): the
        turn-back margin for a swarm reaching ``reach_m`` (or its robots' start, if farther)."""
        w, h = cfg.world.arena_m
        if w <= 0 or h <= 0:
            return None
        margin = self.turn_back_margin_m(cfg.user, max(reach_m, self.start_reach_m(cfg)))
        return Arena((w / 2, h / 2), margin, (0.0, user_index * cfg.world.user_spacing_m), 0.0,
                     cfg.max_cycles * cfg.control_period_s)

    def start_reach_m(self, cfg: Any) -> float:
        """How far from its user :meth:`place` may put a robot of the swarm: the master's start-up
        place (at most the LF range away) plus the waiting robots' spawn radius and a robot's."""
        master = max(cfg.master.distance_m, cfg.lf.reliable_range_m)
        return master + SPAWN_REACH * cfg.protocol.join_radius_m + cfg.robot.radius_m

    @staticmethod
    def turn_back_margin_m(user: Any, reach_m: float) -> float:
        """How close to a wall the user turns back: the swarm's reach, the turn's diameter and
        ``TURN_BACK_CLEARANCE_M``."""
        return reach_m + 2.0 * turn_back_radius_m(user) + TURN_BACK_CLEARANCE_M

    def place(self, world: Any, cfg: Any, slots: np.ndarray, master_distance_m: float,
              rng: np.random.Generator) -> Placement:
        """Add the robots to ``world`` (``world.add_robot(position, heading)``) for the config
        ``cfg``, given the planned formation for the configured driving mode: ``slots`` (members,
        2), the slot positions in the master's frame, and ``master_distance_m``, how far from its
        user the master organizes the swarm after its start-up shift
        (:func:`~petswarm_env.middleware.master_role.master_distance_m`).

        Per user: the user's own robot close to the user (to pair), facing them — behind the user
        in following, ahead in leading; its waiting robots by ``swarm.spawn``: ``scattered``
        (:meth:`scatter`) or ``at_slots`` (around their formation slots, jittered by
        ``swarm.spawn_jitter_m``, facing the user; in leading off the master's shifting path);
        extra candidates farther out; then robots of another user to the side. Draws from ``rng``
        in that order (the scattered robots all before the first robot is added)."""
        n = cfg.swarm.num_slaves
        leading = cfg.swarm.mode == "leading"
        heading = math.pi if leading else 0.0  # every robot faces its user
        c, s = math.cos(heading), math.sin(heading)
        world_slots = np.stack([c * slots[:, 0] - s * slots[:, 1], s * slots[:, 0] + c * slots[:, 1]], axis=1)
        # where the master organizes (a leading master's distance is capped inside its LF range, so a deep
        # leading layout's slots lie about that spot, not about one beyond the whole formation)
        final = np.array([master_distance_m, 0.0]) * (1 if leading else -1)
        depth = float(np.abs(world_slots[:, 0]).max())
        jitter = cfg.swarm.spawn_jitter_m
        ahead = 1.0 if leading else -1.0  # where the master stands: ahead of its user (leading) or behind
        bases = [np.array([0.0, u * cfg.world.user_spacing_m]) for u in range(cfg.world.num_users)]
        starts = [b + np.array([ahead * PAIRING_DISTANCE_M, 0.0]) for b in bases]
        extras = [[b + final + np.array([ahead * (depth + 0.8 + 0.6 * (k // 2)), (1.0 if k % 2 == 0 else -1.0) * 1.6])
                   for k in range(cfg.swarm.extra_robots)] for b in bases]
        others = [final + np.array([-0.6 * k, -1.8 - 0.2 * (k % 2)]) for k in range(cfg.swarm.other_user_robots)]
        scattered = None
        if cfg.swarm.spawn == "scattered":
            centres = [b + np.array([ahead * master_distance_m, 0.0]) for b in bases]
            scattered = self.scatter(cfg, bases, list(zip(starts, centres)), [p for e in extras for p in e] + others, rng)
        pools = []
        for u, base in enumerate(bases):
            master = world.add_robot(starts[u], heading)
            pool = []
            reach = SPAWN_REACH * cfg.protocol.join_radius_m
            for m in range(1, n + 1):
                if scattered is not None:
                    pool.append(world.add_robot(*scattered[u][m - 1]).index)
                    continue
                rel = world_slots[m] + rng.uniform(-jitter, jitter, 2)
                if np.hypot(*rel) > reach:  # a far slot (e.g. the 5th of a wedge, 3 m): start inside the region
                    rel = rel * (reach / np.hypot(*rel))
                p = base + final + rel
                if leading and abs(world_slots[m][1]) < 0.9:  # keep the master's shifting path clear
                    side = np.sign(world_slots[m][1]) or (1.0 if m % 2 else -1.0)
                    p[1] = base[1] + side * 0.9 + rng.uniform(-jitter, jitter) * 0.3
                pool.append(world.add_robot(p, heading + float(rng.uniform(-0.3, 0.3))).index)
            pool += [world.add_robot(p, heading).index for p in extras[u]]
            pools.append((master.index, pool))
        return Placement(pools, [world.add_robot(p, heading).index for p in others])

    def scatter(self, cfg: Any, users: list[np.ndarray], paths: list[tuple[np.ndarray, np.ndarray]],
                fixed: list[np.ndarray], rng: np.random.Generator) -> list[list[tuple[np.ndarray, float]]]:
        """Scattered start (``swarm.spawn: scattered``): for each user, ``swarm.num_slaves`` waiting
        robots drawn uniformly (by area) in the disc of ``SCATTER_REACH`` × ``protocol.join_radius_m``
        around its master's organizing place (the end of its path in ``paths``: seed 000 Table 1's
        available region, entered after the start-up shift of Fig. 10), each with a random heading;
        a draw is taken again while it lies closer than ``SPAWN_CLEARANCE_M`` (rim to rim) to a
        robot already placed or ``fixed``, a user (``users``) or a master's path (start to organizing
        place, so the shift is clear in either mode), or outside the arena's walls. Returns (position, heading) per user and robot."""
        r_robot, reach = cfg.robot.radius_m, SCATTER_REACH * cfg.protocol.join_radius_m
        gap, user_gap = 2 * r_robot + SPAWN_CLEARANCE_M, r_robot + cfg.user.radius_m + SPAWN_CLEARANCE_M
        # a leading master shifts away from its user: nothing within its obstacle-exception range (seed 002 §2)
        path_gap = 2 * r_robot + (max(SPAWN_CLEARANCE_M, cfg.master.exception_range_m + 0.1) if cfg.swarm.mode == "leading"
                                  else SPAWN_CLEARANCE_M)
        taken = [tuple(p) for p in fixed]
        half_w, half_h = (0.5 * a for a in cfg.world.arena_m)

        def inside(x: float, y: float) -> bool:  # within the arena's walls (none: [0, 0])
            return half_w <= 0 or half_h <= 0 or (abs(x) + r_robot <= half_w and abs(y) + r_robot <= half_h)
        out = []
        for _, centre in paths:
            placed = []
            walled = inside(float(centre[0]), float(centre[1]))  # a master outside the walls: refused at reset, with the start's size
            for _ in range(cfg.swarm.num_slaves):
                for _try in range(SPAWN_TRIES):
                    r, phi = reach * math.sqrt(float(rng.random())), float(rng.uniform(-math.pi, math.pi))
                    x, y = float(centre[0]) + r * math.cos(phi), float(centre[1]) + r * math.sin(phi)
                    if ((inside(x, y) or not walled) and all(math.dist((x, y), q) >= gap for q in taken)
                            and all(math.dist((x, y), u) >= user_gap for u in users)
                            and all(_segment_distance(x, y, a, b) >= path_gap for a, b in paths)):
                        break
                else:
                    raise ValueError(f"no room for swarm.num_slaves={cfg.swarm.num_slaves} waiting robots {SPAWN_CLEARANCE_M} m "
                                     f"apart within {reach:.2f} m of the master inside the walls (protocol.join_radius_m={cfg.protocol.join_radius_m}, world.arena_m={list(cfg.world.arena_m)}); use fewer slaves, a larger radius or arena, or swarm.spawn=at_slots")
                taken.append((x, y))
                placed.append((np.array([x, y]), float(rng.uniform(-math.pi, math.pi))))
            out.append(placed)
        return out


def _segment_distance(x: float, y: float, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from the point (x, y) to the segment a → b."""
    ax, ay, bx, by = float(a[0]), float(a[1]), float(b[0]), float(b[1])
    vx, vy = bx - ax, by - ay
    vv = vx * vx + vy * vy
    u = 0.0 if vv == 0.0 else min(1.0, max(0.0, ((x - ax) * vx + (y - ay) * vy) / vv))
    return math.hypot(x - ax - u * vx, y - ay - u * vy)


SCENARIOS: dict[str, Scenario] = {}  # name -> scenario, in registration order


def register(scenario: Scenario) -> Scenario:
    """Add a scenario to the registry under its ``name`` (unique)."""
    if not scenario.name or scenario.name in SCENARIOS:
        raise ValueError(f"a scenario needs a new name, got {scenario.name!r} (taken: {', '.join(SCENARIOS)})")
    SCENARIOS[scenario.name] = scenario
    return scenario
