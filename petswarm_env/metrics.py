"""The experimenter's view: per-step and per-episode figures from ground truth (never observed).

A slave's *reference point* is the mean over its reference links of its neighbour's true position
plus its offset rotated by the formation heading (the master's true heading); its *formation
error* is its true distance from that point and its *heading error* its true heading minus the
master's. :class:`Experimenter` computes these, counts what began in the episode (contacts, frames,
middleware events, arbiter wins) and writes the episode summary; rewards (:mod:`.reward`) are
computed from its figures (every slave, every step).

The summary's formation figures:

* ``formation_rmse_m``: the RMS of the formation error over the slaves and steps after organizing
  *out of emergency*: a slave's error at a step counts only while its user's session is not in the
  emergency state (seed 002 Fig. 4: the user lost, the whole swarm stopped), so a swarm parked in
  emergency cannot look good; NaN if no step counts. ``formation_rmse_steps``: the number of steps
  it covers (steps with at least one slave's error counted).
* ``emergency_s``: the time spent in emergency, read from each user session's state after every
  step, summed over the users (with one user: the time its swarm stood in emergency).
* ``error_trace`` (every step, emergency included) is the mean formation error of the step's slaves.
* runtime changes (docs/faults.md; :mod:`petswarm_env.runtime`): ``faults_injected``; ``faults_detected``,
  the faults the middleware noticed — the robot declared lost by its master's ring, or, for a
  master, its loss noticed by a slave's status timeout (sensor faults are not detected: the robot
  still answers); ``detection_time_s``, the mean time from a fault to its detection (NaN if
  none); ``reassignments``, robots recruited into a slot opened by a lost member;
  ``reassignment_time_s``, the mean time from a detected slave fault until its swarm held as many
  members as before the fault again (NaN if never); ``slots_unfilled_s``, slot-seconds with fewer
  live slaves (agents) than required, summed over the users; ``arrivals_joined``, arrival robots
  that joined a swarm.
* ``building_time_s``: how long after organizing (the end of ``reset``) the swarm built its
  formation (seed 000 §3.5, Fig. 10): the first step's end at which every slave stood within
  ``BUILT_WITHIN_M`` of its reference point (truth); NaN if that never happened in the episode.

Building and holding, measured apart (from the default scattered start most of the reference's
squared error falls in the first seconds, while the slaves drive to their slots):

* ``formation_hold_rmse_m``: ``formation_rmse_m`` from the moment the formation is built: the RMS of
  the same counted errors (every slave with a reference point, out of emergency) over the step at
  whose end ``building_time_s`` was reached and every later step; NaN when the formation was never
  built. Whatever happens after building (a turn, a dropout and its refill, a lost robot) counts.
  ``formation_hold_steps``: the steps it covers.
* ``lost_robot_s``: the longest time a slave stayed at least ``LOST_M`` from its reference point
  without a break, counted from the step the formation was built on (0.0 before or without it). An
  episode with ``lost_robot_s >= LOST_S`` is a *lost-robot episode*: a slave left its formation
  (drove off, fell behind a walking swarm, was left standing) for longer than a turn or a refill
  lets one lag (a robot its master removes as astray, ``middleware/recovery.py``, is usually one: it
  had no fresh IR fix for 3 s and stood beyond 1.5 IR reaches from its master). Judged seed by seed against a reference in the comparison grid
  (``evaluation/grid.py``: a lost-robot episode the reference does not also have).
* ``refill_settle_rmse_m``: the RMS of the same counted errors over the ``REFILL_SETTLE_S`` seconds
  after each refill (a slave fault detected and its swarm back to as many members as before: the
  end of ``reassignment_time_s``), i.e. the steps ending in ``(t_refill, t_refill + REFILL_SETTLE_S]``,
  the windows of several refills joined (a step counts once), cut at the episode's end; NaN with no
  refill. It scores how fast the swarm settles again around its recruit, which the whole episode's
  figures dilute.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from petswarm_env.control.arbiter import SOURCES
from petswarm_env.observe import AGE_SCALE_S
from petswarm_env.references import ReferenceTable
from petswarm_env.render import RobotView, Scene
from petswarm_env.step_kernel import slave_truth, sum_squares
from petswarm_env.step_kernel import stale_fixes as _stale_fixes

if TYPE_CHECKING:
    from petswarm_env.comms.radio import RadioMedium
    from petswarm_env.config import Config
    from petswarm_env.control.arbiter import ControlArbiter
    from petswarm_env.middleware.swarm import Fleet, Swarm
    from petswarm_env.middleware.user_session import UserSession
    from petswarm_env.sim.world import World

BUILT_WITHIN_M = 0.3  # the formation is built once every slave is this close to its reference point (chosen)
BUILT_FACING_RAD = math.radians(90.0)  # the user also waits until no slave faces away: each heading this close to its master's (chosen)
# a lost robot (chosen): this far from its reference point (about the IR's detection range, 2.4-2.8 m, less
# a slot's distance: where its fixes of its neighbours stop), for this long without a break (a u-turn's or a
# refill's lag stays shorter: of the scripted reference's 240 episodes of configs/eval/heldout_recurrent.yaml on
# seeds 920000000, 931000000, 950000000 and 960000000, three ran 5.0-9.7 s, two users or loss 0.3, the others <= 2.9 s)
LOST_M = 2.0
LOST_S = 5.0


def lost_robot_episode(record: dict[str, Any]) -> bool:
    """Whether an episode record (a summary, or a grid's per-episode record) is a lost-robot episode
    (module docstring: ``lost_robot_s`` >= ``LOST_S``); a record without the figure is not."""
    lost_s = record.get("lost_robot_s")
    return isinstance(lost_s, (int, float)) and lost_s >= LOST_S
# the settle window after a refill: 10 s, the settling the fault figures allow (docs/faults.md
# judges the dropout's largest error from 10 s after the refill on; this scores the 10 s before)
REFILL_SETTLE_S = 10.0
_EVENTS = ("master_changes", "mode_changes", "token_recoveries", "emergencies", "exceptions")


@dataclass
class EpisodeMetrics:
    sq_error_sum: float = 0.0
    error_count: int = 0
    steps: int = 0
    rmse_steps: int = 0  # steps whose errors entered the RMSE (some slave out of emergency)
    emergency_steps: int = 0  # user-steps in the emergency state, summed over the users
    organize_time_s: float = math.nan
    join_retries: int = 0
    building_time_s: float = math.nan  # from organized to every slave within BUILT_WITHIN_M of its reference
    slaves_missing: int = 0  # required minus joined when the swarms organized, over every swarm
    stale_fix_s: float = 0.0  # slave time with no IR fix of any reference neighbour within AGE_SCALE_S
    error_trace: list[float] = field(default_factory=list)  # mean formation error per step (m)
    slots_unfilled_s: float = 0.0  # slot-seconds with fewer live slaves than required (docs/faults.md)
    hold_sq_error_sum: float = 0.0  # the counted errors from the step the formation was built on
    hold_error_count: int = 0
    hold_steps: int = 0
    lost_robot_s: float = 0.0  # the longest run of a slave at least LOST_M from its reference point, once built
    # every step's end time (s, the clock's) and its counted errors' squared sum and number: the
    # settle windows after refills (REFILL_SETTLE_S) are cut from them once the episode is over
    step_end_s: list[float] = field(default_factory=list)
    step_sq: list[float] = field(default_factory=list)
    step_n: list[int] = field(default_factory=list)

    def add_step(self, errors_m: list[float], counted_m: list[float] | None = None, emergencies: int = 0,
                 end_s: float = math.nan) -> None:
        """One step: the formation errors of its slaves (``errors_m``, for the trace), those that
        count toward the RMSE (``counted_m``, the slaves out of emergency; all if None), how many
        users were in emergency and the clock time at the step's end (``end_s``). A step added
        once ``building_time_s`` is set counts toward the hold RMSE too."""
        self.steps += 1
        if emergencies:
            self.emergency_steps += emergencies
        counted = errors_m if counted_m is None else counted_m
        sq = sum_squares(counted)  # sum(e * e for e in counted), in one typed loop (step_kernel.py)
        n = len(counted)
        if n:
            self.sq_error_sum += sq
            self.error_count += n
            self.rmse_steps += 1
            if not math.isnan(self.building_time_s):
                self.hold_sq_error_sum += sq
                self.hold_error_count += n
                self.hold_steps += 1
        self.step_end_s.append(end_s)
        self.step_sq.append(sq)
        self.step_n.append(n)
        if errors_m:
            self.error_trace.append(sum(errors_m) / len(errors_m))

    @property
    def formation_rmse_m(self) -> float:
        return math.sqrt(self.sq_error_sum / self.error_count) if self.error_count else math.nan

    @property
    def formation_hold_rmse_m(self) -> float:
        """The RMSE from the step on which the formation was built (NaN if it never was)."""
        return math.sqrt(self.hold_sq_error_sum / self.hold_error_count) if self.hold_error_count else math.nan

    def window_rmse_m(self, starts_s: list[float], length_s: float) -> float:
        """The RMS of the counted errors of the steps ending in ``(t, t + length_s]`` for any ``t``
        of ``starts_s`` (each step once); NaN if no such step has a counted error."""
        sq, n = 0.0, 0
        eps = 1e-6  # the clock's sums of substeps: a step ending at t + length_s must not fall out by a rounding
        for end, s, k in zip(self.step_end_s, self.step_sq, self.step_n):
            if any(t < end <= t + length_s + eps for t in starts_s):
                sq, n = sq + s, n + k
        return math.sqrt(sq / n) if n else math.nan


class SlaveTruth(NamedTuple):
    """One step's truth for the live agents, in their order: ``errors`` only for the agents that
    have a reference point (what the RMSE averages); the lists for every agent (0 without one)."""

    errors: dict[str, float]
    formation_error_m: list[float]
    heading_error_rad: list[float]
    new_contacts: list[int]


_new_tuple = tuple.__new__


class Experimenter:
    """The experimenter's view of one episode of a world, its swarms and users: built at the end of
    ``reset`` (the episode's counts start there), then asked once per step (:meth:`step`)."""

    def __init__(self, cfg: Config, world: World, fleet: Fleet, swarms: list[Swarm], sessions: list[UserSession],
                 arbiters: dict[int, ControlArbiter], radio: RadioMedium, agent_index: dict[str, int],
                 other_user_robots: list[int]):
        self.cfg, self.world, self.fleet, self.swarms, self.sessions = cfg, world, fleet, swarms, sessions
        self.arbiters, self.radio, self.agent_index = arbiters, radio, agent_index
        self.other_user_robots = other_user_robots
        c, st = world.collisions, radio.stats
        self._contacts_seen = dict(c.per_robot)
        self._far_s: dict[str, float] = {}  # each slave's run of steps at least LOST_M from its reference point, once built
        self._collisions_at_start = (c.robot_robot, c.robot_user, c.robot_wall)
        self._events_at_start = self.event_counts()
        self.metrics = EpisodeMetrics(organize_time_s=swarms[0].organize_result.elapsed_s,
                                      join_retries=sum(sw.organize_result.retries for sw in swarms),
                                      slaves_missing=sum(sw.slaves_missing() for sw in swarms))
        self._radio_at_start = (st.frames_sent, st.frames_lost, st.frames_collided)
        self._start_s = world.now  # organized: the end of reset
        self.runtime = None  # the episode's faults and arrivals (petswarm_env/runtime.py), set by the env
        self.organized_at_s = world.now
        self._table = ReferenceTable()  # the swarms' reference links as C arrays (references.py)
        # plain copies of the config's values that every step reads (the config is frozen)
        self._period_s, self._slots = cfg.control_period_s, cfg.world.num_users * cfg.swarm.num_slaves

    # -- reference points and errors -------------------------------------------------------------
    def reference_positions(self) -> dict[int, np.ndarray]:
        """True reference position of every slave (robot index -> (x, y)), from each swarm's
        current neighbour table and its master's true heading."""
        return {idx: np.array(p) for idx, p in self.reference_points().items()}

    def reference_points(self, xy: list | None = None, th: list | None = None) -> dict[int, tuple[float, float]]:
        """:meth:`reference_positions` as Python floats (the mean over a slave's links taken as
        numpy's mean of so few points is: their sum in order, over their number). Positions and
        headings are the world's truth arrays as lists (``xy``, ``th``; read here if not given):
        the values Chipmunk gives each body, read once per physics step."""
        if xy is None or th is None:
            centers, _, headings = self.world.truth_arrays()
            xy, th = centers.tolist(), headings.tolist()
        return {idx: (x, y) for idx, (x, y, _) in self._references(xy, th).items()}

    def references(self) -> dict[int, tuple[float, float, float]]:
        """Every slave's true reference point and the true heading of the master whose table
        defines it: robot index -> (x, y, θ_master) (a training teacher's view, never a policy's)."""
        centers, _, headings = self.world.truth_arrays()
        return self._references(centers.tolist(), headings.tolist())

    def _references(self, xy: list, th: list) -> dict[int, tuple[float, float, float]]:
        """Every slave's reference point and the true heading of the master whose neighbour table
        defines it: robot index -> (x, y, θ_master) (:class:`.references.ReferenceTable`)."""
        self._table.update(self.swarms)
        return self._table.references(xy, th)

    def formation_errors(self, agents: list[str]) -> tuple[dict[str, float], dict[str, float]]:
        """Each agent's distance from its reference point and heading error from the heading of the
        master whose table defines that point (truth); agents without a reference point are left out."""
        errs, heads, has = self._errors(agents)
        errors = {a: e for a, e, h in zip(agents, errs, has) if h}
        heading = {a: e for a, e, h in zip(agents, heads, has) if h}
        return errors, heading

    def _errors(self, agents: list[str], robot_ids: list[int] | None = None) -> tuple[list[float], list[float], list[bool]]:
        """Each agent's formation error and heading error (0.0 without a reference point) and
        whether it has one, from the truth arrays as lists (one conversion for all robots);
        ``robot_ids``: the agents' robot indices, if the caller has them."""
        centers, _, headings = self.world.truth_arrays()
        self._table.update(self.swarms)
        if robot_ids is None:
            agent_index = self.agent_index
            robot_ids = [agent_index[a] for a in agents]
        return self._table.errors(centers.tolist(), headings.tolist(), robot_ids)

    def step(self, agents: list[str], robot_ids: list[int] | None = None) -> SlaveTruth:
        """The step's truth for ``agents`` (robots ``robot_ids``, their indices, if the caller has
        them): formation and heading errors, contacts each robot began since the last step; adds
        the step to :attr:`metrics`."""
        agent_index, world = self.agent_index, self.world
        if robot_ids is None:
            robot_ids = [agent_index[a] for a in agents]
        centers, _, headings = world.truth_arrays()
        self._table.update(self.swarms)
        errors, errs, heads, contacts, worst = slave_truth(self._table, centers, headings, agents, robot_ids,
                                                           world.collisions.per_robot, self._contacts_seen)
        m = self.metrics
        now = world.clock.now
        if worst is not None and math.isnan(m.building_time_s) and worst <= BUILT_WITHIN_M:
            m.building_time_s = now - self._start_s
        if worst is not None and worst >= LOST_M and not math.isnan(m.building_time_s):
            far, period = self._far_s, self._period_s
            self._far_s = far = {a: far.get(a, 0.0) + period for a, e in errors.items() if e >= LOST_M}
            m.lost_robot_s = max(m.lost_robot_s, max(far.values()))
        elif self._far_s:
            self._far_s = {}
        parked = None
        for se in self.sessions:
            if se.state == "emergency":
                parked = [se.swarm for se in self.sessions if se.state == "emergency"]
                break
        if parked:  # the slaves of a swarm in emergency stand still: their errors do not count
            stopped = {i for sw in parked for i in sw.slave_ids()}
            counted = [e for agent, e in errors.items() if agent_index[agent] not in stopped]
            m.add_step(list(errors.values()), counted, len(parked), end_s=now)
        else:
            m.add_step(list(errors.values()), end_s=now)
        period = self._period_s
        m.stale_fix_s += period * _stale_fixes(robot_ids, self.fleet.nodes, self._start_s, AGE_SCALE_S)
        missing = self._slots - len(agents)
        if missing > 0:
            m.slots_unfilled_s += missing * period
        return _new_tuple(SlaveTruth, (errors, errs, heads, contacts))  # SlaveTruth(...) without its Python __new__

    def stale_fixes(self, agents: list[str]) -> int:
        """How many of ``agents`` have no IR fix of any reference neighbour younger than the
        observation's age range (``observe.AGE_SCALE_S``; none yet counts from the episode's start):
        a slave that cannot know where its neighbours are (the scripted one then only moves with the
        swarm, :mod:`petswarm.baselines.leader_follower`)."""
        agent_index = self.agent_index
        return _stale_fixes([agent_index[a] for a in agents], self.fleet.nodes, self._start_s, AGE_SCALE_S)

    # -- counts and the summary ------------------------------------------------------------------
    def event_counts(self) -> dict[str, Any]:
        """Middleware and user events so far (totals over swarms and users) and arbiter wins."""
        wins = {s: sum(a.counts.wins[s] for a in self.arbiters.values()) for s in SOURCES}
        return {
            "master_changes": sum(sw.events["master_changes"] for sw in self.swarms),
            "mode_changes": sum(sw.events["mode_changes"] for sw in self.swarms),
            "token_recoveries": sum(sw.token_recoveries() for sw in self.swarms),
            "emergencies": sum(se.events["emergencies"] for se in self.sessions),
            "exceptions": sum(se.events["exceptions"] for se in self.sessions),
            "arbiter_wins": wins,
        }

    def summary(self, scenario: str, slaves: int) -> dict[str, Any]:
        """The episode summary (``env.episode_summary()``; after the last step, the episode's)."""
        c = self.world.collisions
        c0 = self._collisions_at_start
        st = self.radio.stats
        r0 = self._radio_at_start
        m = self.metrics
        now, start = self.event_counts(), self._events_at_start
        events = {k: now[k] - start[k] for k in _EVENTS}
        events["join_retries"] = m.join_retries
        events["arbiter_wins"] = now["arbiter_wins"]  # counted from the end of reset
        events["foreign_pan_frames_processed"] = self.fleet.foreign_pan_frames_processed()
        return {
            "scenario": scenario,
            "steps": m.steps,
            "formation_rmse_m": m.formation_rmse_m,
            "formation_rmse_steps": m.rmse_steps,
            "emergency_s": m.emergency_steps * self.cfg.control_period_s,
            "collisions": {
                "robot_robot": c.robot_robot - c0[0],
                "robot_user": c.robot_user - c0[1],
                "robot_wall": c.robot_wall - c0[2],
            },
            "organize_time_s": m.organize_time_s,
            "building_time_s": m.building_time_s,
            "formation_hold_rmse_m": m.formation_hold_rmse_m,
            "formation_hold_steps": m.hold_steps,
            "lost_robot_s": round(m.lost_robot_s, 6),
            "join_retries": m.join_retries,
            "slaves_missing": m.slaves_missing,
            "stale_fix_s": round(m.stale_fix_s, 6),
            "token_recoveries": now["token_recoveries"],
            "frames": {"sent": st.frames_sent - r0[0], "lost": st.frames_lost - r0[1], "collided": st.frames_collided - r0[2]},
            "foreign_pan_frames_processed": events["foreign_pan_frames_processed"],
            "slaves": slaves,
            "users": self.cfg.world.num_users,
            "events": events,
            **self.runtime_summary(),
        }

    def runtime_summary(self) -> dict[str, Any]:
        """The runtime-change figures of the summary (module docstring), from the fault log
        (:mod:`petswarm_env.runtime`), the masters' member logs and the slaves' status timeouts."""
        runtime = self.runtime
        log = runtime.faults.log if runtime is not None else []
        arrivals = {idx for _, idx in runtime.arrived} if runtime is not None else set()
        detections, refills, refilled_at, reassigned = [], [], [], 0
        for f in log:
            t = self._detected_at(f)
            if t is None:
                continue
            detections.append(t - f.time_s)
            if f.role != "master":
                filled = self._refilled_at(f.robot, f.time_s)
                if filled is not None:
                    refills.append(filled - f.time_s)
                    refilled_at.append(filled)
        joined = set()
        for sw in self.swarms:
            lost_seen = False
            for _, event, ids in sw.member_log:
                lost_seen |= event == "lost"
                if event == "joined":
                    joined.update(ids)
                    reassigned += len(ids) if lost_seen else 0
        nan = math.nan
        return {
            "faults_injected": len(log),
            "faults_detected": len(detections),
            "detection_time_s": sum(detections) / len(detections) if detections else nan,
            "reassignments": reassigned,
            "reassignment_time_s": sum(refills) / len(refills) if refills else nan,
            "refill_settle_rmse_m": self.metrics.window_rmse_m(refilled_at, REFILL_SETTLE_S) if refilled_at else nan,
            "slots_unfilled_s": round(self.metrics.slots_unfilled_s, 6),
            "arrivals_joined": len(arrivals & joined),
        }

    def _detected_at(self, fault) -> float | None:
        """When the middleware noticed ``fault`` (a FaultRecord), or None."""
        if fault.role == "master":
            # the slaves log on their own clocks: read on the true one
            times = [t for n in self.fleet.nodes.values() for t in (n.clock.true_time(t_local) for t_local, m, _ in n.seq.master_lost_at
                                                                     if m == fault.robot) if t >= fault.time_s]
            return min(times, default=None)
        times = [t for sw in self.swarms for t, event, ids in sw.member_log
                 if event == "lost" and fault.robot in ids and t >= fault.time_s]
        return min(times, default=None)

    def _refilled_at(self, robot: int, fault_s: float) -> float | None:
        """When the swarm that lost ``robot`` (after ``fault_s``) held as many members again as just
        before ``fault_s``."""
        for sw in self.swarms:
            size = len(sw.organize_result.members)
            lost_at, before = None, None
            for t, event, ids in sw.member_log:
                if before is None and t >= fault_s:
                    before = size
                size += len(ids) if event == "joined" else -len(ids)
                if event == "lost" and robot in ids and before is not None:
                    lost_at = t
                if lost_at is not None and size >= before:
                    return t
        return None

    # -- what a person watching sees -------------------------------------------------------------
    def roles(self) -> list[str]:
        """Every robot's role, by robot index: ``master``, ``slave``, ``waiting`` or ``other`` (connected
        to another user)."""
        masters = {sw.master.node_id for sw in self.swarms}
        slaves = {i for sw in self.swarms for i in sw.slave_ids()}
        other = set(self.other_user_robots)
        return ["other" if i in other else "master" if i in masters else "slave" if i in slaves else "waiting"
                for i in range(len(self.world.robots))]

    def link_pairs(self) -> list[tuple[int, int]]:
        """Every formation link of the organized swarms as (neighbour's robot index, member's robot index)."""
        pairs = []
        for swarm in self.swarms:
            if swarm.formation is None or not swarm.organized:
                continue
            members = swarm.master.know.members
            for m, lks in swarm.formation.links.items():
                for lk in lks:
                    if m in members and lk.neighbour in members:
                        pairs.append((members[lk.neighbour], members[m]))
        return pairs

    def scene(self, scenario: str, step: int) -> Scene:
        """A plain description of the current truth for the renderer (:mod:`petswarm_env.render`):
        every body, each robot's role and member number, the formation links and reference points,
        walls and boxes, and a HUD with the scenario, the step and each user's robot state."""
        cfg, world = self.cfg, self.world
        robots = []
        parked = set(self.runtime.parked()) if self.runtime is not None else set()
        for r, role in zip(world.robots, self.roles()):
            if r.index in parked:
                continue  # an arrival not switched on yet: not in the scene
            node = self.fleet.nodes.get(r.index)
            label = str(node.know.member) if node is not None and node.know.member >= 0 else f"r{r.index}"
            robots.append(RobotView(r.position, r.heading, r.radius_m, role, label, tuple(sorted(r.health.active)),
                                    r.type_name))
        links = [(world.robots[a].position, world.robots[b].position) for a, b in self.link_pairs()]
        refs = [tuple(p) for p in self.reference_positions().values()]
        err = self.metrics.error_trace[-1] if self.metrics.error_trace else float("nan")
        states = "  ".join(f"user {u}: {se.state}, master r{se.swarm.master.node_id}" for u, se in enumerate(self.sessions))
        text = [
            f"scenario {scenario}   formation {cfg.swarm.formation}   mode {self.swarms[0].mode}",
            f"step {step}/{cfg.max_cycles}   mean formation error {err:.2f} m",
            states,
        ]
        return Scene(
            time_s=world.now,
            user_position_m=world.user.position,
            user_heading_rad=world.user.heading,
            user_radius_m=cfg.user.radius_m,
            robots=robots,
            links=links,
            references_m=refs,
            walls=list(world.wall_segments[:4]) if cfg.world.arena_m[0] > 0 else [],
            boxes=[(tuple(b.center_m), tuple(b.size_m)) for b in cfg.world.obstacles],
            text=text,
            other_users=[(u.position, u.heading) for u in world.users[1:]],
        )
