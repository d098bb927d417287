"""One episode of a Pet-Bot swarm: everything a ``reset`` builds and a ``step`` advances.

An :class:`Episode` owns the episode's parts — the world from the scenario (each user's walking
script, the robots' placement), the radio medium and the IR channel (:mod:`petswarm_env.comms`),
the fleet with a swarm per user (:mod:`petswarm_env.middleware`), the user sessions, each robot's
control arbiter (:mod:`petswarm_env.control`), the sensors (:mod:`petswarm_env.sim.sensors`), the
runtime changes (:mod:`petswarm_env.runtime`), the observer (:mod:`petswarm_env.observe`) and the
experimenter (:mod:`petswarm_env.metrics`). Building one runs the clock through the pairing, the
user's start-up commands and the join protocol (seed 002 Fig. 4, seed 000 §3.4-3.5);
:meth:`Episode.advance` is one control step. :class:`~petswarm_env.env.PetSwarmEnv` holds one
episode at a time and the vector env (:mod:`petswarm_env.vector`) holds one per copy: the
episode's dynamics are in this module only.

**The agent lifecycle** (:meth:`Episode._lifecycle`, the one place that decides who is an agent):
the agents are the robots in slave-role driving. A robot that leaves it (it became the master, its
master lost it, it left its slot for its own fault, a transient fault took it out) *waits*: it is out
of ``agents``, its motors commanded to zero unless it drives a user, and it becomes an agent again,
under the same id and driven by the same policy, when the middleware makes it a slave again (the
master's scan recruits it after a reboot, a second master change makes the master a slave again).
Only a robot that is off for good (a permanent ``dead`` or ``battery`` fault, :mod:`.sim.faults`)
is *terminated*: it stays out of ``agents`` (``left``) for the rest of the episode. (A member that
no policy drove would stand in its slot as an obstacle its neighbours follow, and fall behind a
walking swarm: loss 0.3, a slave the ring lost at 4 s and recruited again at 12 s stood until its
master removed it and the neighbour that kept its distance from it.) A robot that becomes a slave
for the first time (the old master after a master change, an arrival) joins ``agents``. (The env
puts the possible agents that are not live in its own ``agents``, waiting with a zero observation,
so no adapter sees an agent appear or come back: :mod:`petswarm_env.env`.) The episode is over
(:attr:`Episode.over`) at ``max_cycles``, or when every possible agent is off for good.

What a step returns: ``rewards``, ``terminations`` and ``truncations`` for every agent that acted
in it and every agent that joined in it; ``observations`` and ``infos`` for the agents live after
it (``agents``) and, on the step that truncates the episode, for the truncated ones (their last
observation, for bootstrapping). An agent that left in the step gets its reward and its
termination (True only when it is off for good), but no observation: a loop that feeds every
observation back as actions (``env.step(policy.act_all(observations))``) passes actions only for
live agents.

**The truth view** (:class:`Truth`, ``episode.truth``): what the experimenter's tools may read of
the ground truth — the evaluation runner, the metrics, the renderer, the replay and pcap writers,
the privileged teacher (training/teacher.py) and the figures of experiments/. It reads and never
writes; no policy ever gets it (a policy reads only its observation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from petswarm_env import step_kernel
from petswarm_env.inputs import check_start_clear_of_boxes
from petswarm_env.comms.ir_channel import IRChannel
from petswarm_env.comms.radio import RadioMedium
from petswarm_env.config import Config
from petswarm_env.control.arbiter import ControlArbiter, SafetyStage
from petswarm_env.metrics import BUILT_FACING_RAD, BUILT_WITHIN_M, Experimenter
from petswarm_env.middleware.join import OrganizeError, organize_obstacle
from petswarm_env.middleware.fleet import Fleet
from petswarm_env.middleware.formation import formation_for_mode, leading_user
from petswarm_env.middleware.swarm import Swarm
from petswarm_env.middleware.master_role import master_distance_m
from petswarm_env.middleware.user_session import UserSession
from petswarm_env.observe import ObservationLayout, Observer
from petswarm_env.reward import slave_rewards
from petswarm_env.robot_types import body_plan, placement_config
from petswarm_env.runtime import Runtime, arrival_specs, park_positions
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.sim.sensors import Sensors
from petswarm_env.sim.world import World
from petswarm_env.state import StateLayout, build_state

OTHER_USER_ID = 99  # the user that "other user" robots are connected to (Table 1)
SWARM_PAN = 0x1001  # user u's swarm uses PAN SWARM_PAN + u
WAKE_PATTERN = 0x5A00  # user u's belt and robot share the LF wake-up pattern WAKE_PATTERN + u
# every agent's infos, at reset and at every step: flat, numeric, always these keys (the value of an
# agent that has no such figure yet): its member number, its true formation error (m), the contacts it
# began this step, 1 on the step it joined (the old master after a mode change), else 0, and how many of
# the required slaves its swarm lacked when it organized (Swarm.slaves_missing); ``active`` is 1 for a robot in
# slave-role driving, 0 for an agent of the env waiting to join (its observation is zeros: env.py)
INFO_DEFAULTS: dict[str, float | int] = {"member": -1, "formation_error_m": 0.0, "new_contacts": 0, "joined": 0,
                                         "slaves_missing": 0, "active": 0}
_LIVE_INFO = {**INFO_DEFAULTS, "active": 1}  # an agent in slave-role driving: step_kernel.infos fills in its figures

StepResult = tuple[dict[str, np.ndarray], dict[str, float], dict[str, bool], dict[str, bool], dict[str, dict]]


@dataclass(frozen=True)
class Setup:
    """What every episode of one env shares, computed once from the config (``PetSwarmEnv.__init__``):
    each robot type resolved (``bodies``), how far a swarm reaches from its user (``reach_m``), how
    many arrival robots wait parked (``arrival_slots``), the possible agents, the observation
    layout, the action scale (``limits``: Vx, Vy, ω at action 1) and the state layout."""

    cfg: Config
    bodies: dict
    reach_m: float | None
    arrival_slots: int
    possible: frozenset
    layout: ObservationLayout
    limits: tuple[float, float, float]
    state_layout: StateLayout


class Episode:
    """One episode (module docstring). ``streams``: the episode's eight seed sequences (world,
    radio, IR, swarm, sensors, script, users, faults); ``radio_trace``: the experimenter's radio
    trace (comms/radio.py ``RadioTrace``) or None. Building it builds the parts; :meth:`start`
    runs the start-up and gives the first observations and infos; each :meth:`advance` is one step."""

    def __init__(self, setup: Setup, streams: list[np.random.SeedSequence], radio_trace=None, seed: int | None = None):
        self.seed = seed  # the reset's seed, named when the swarm cannot organize
        self.setup = setup
        self.cfg = cfg = setup.cfg
        # plain copies of the config's values that every step reads (the config is frozen)
        self._substeps, self._max_cycles, self._reward_cfg = cfg.physics_substeps, cfg.max_cycles, cfg.reward
        self.streams = streams  # the reset's seed sequences (each one's entropy is the reset's seed)
        rngs = [np.random.default_rng(s) for s in streams]
        self._build(*rngs[:7], radio_trace)
        self.runtime = Runtime(cfg, self.world, self.fleet, self.swarms, SCENARIOS[self.scenario], self._arrivals,
                               rngs[7], on_change=self.sensors.fault_changed)
        self.truth = Truth(self)
        self.agents: list[str] = []  # the robots in slave-role driving (module docstring), from start() on
        self.left: set[str] = set()  # agents terminated in this episode (off for good): never agents again in it
        self.num_cycles = 0
        self.steady = False  # the last step kept every agent, with none terminated or truncated (_lifecycle)

    # -- the start, the first observation and one step -------------------------------------------
    def start(self) -> tuple[dict[str, np.ndarray], dict[str, dict]]:
        """Run the start-up (pairing, the driving mode, organize) and start the users' walks, the
        faults and the arrivals; returns the first observations and infos (``reset``'s return).
        A start-up that fails raises and leaves the episode as it stood (its swarms say how far
        they organized)."""
        cfg = self.cfg
        self._check_inside_arena()
        check_start_clear_of_boxes(cfg, self.world)  # no body starts in a box (inputs.py)
        self._organize()
        if cfg.swarm.spawn == "at_slots":
            self._stand_members_at_their_slots()
        world = self.world
        for arb in self.arbiters.values():  # the episode's counts start now
            arb.counts = type(arb.counts)()
        self.slave_ids = self._current_slaves()
        self.agent_index = {f"robot_{i}": i for i in range(len(world.robots))}
        self._set_agents([f"robot_{i}" for i in self.slave_ids])
        self.last_action = {a: np.zeros(3, np.float32) for a in self.agents}
        self._last_agents: list[str] | None = None  # the agents of the last step and their actions (advance)
        self._last_acts = np.zeros((0, 3), np.float32)
        self._scale = np.array(self.setup.limits, np.float32)  # action 1 -> Vx, Vy, ω (as a float32 action times a float)
        self.observer = Observer(self.setup.layout, self.fleet.nodes, self.sensors, [r.ahrs for r in world.robots],
                                 self.agent_index, cfg.master.distance_m)
        self.experimenter = Experimenter(cfg, world, self.fleet, self.swarms, self.sessions, self.arbiters, self.radio,
                                         self.agent_index, self.other_user_robots)
        self.metrics = self.experimenter.metrics
        self.experimenter.runtime = self.runtime
        self._start_walks({}, {})
        self.runtime.start()  # faults and arrivals, in episode time from now
        self.num_cycles = 0
        self.missing_by_pan = {sw.pan: sw.slaves_missing() for sw in self.swarms}  # as organized (metrics.py's figure)
        return self.first()

    def first(self) -> tuple[dict[str, np.ndarray], dict[str, dict]]:
        """The observations and infos of the episode's start (``reset``'s return)."""
        observations = self.observer.observe(self.agents, self.last_action, self.world.now)
        errors, _ = self.experimenter.formation_errors(self.agents)
        infos = self._infos(self.agents, [errors.get(a, 0.0) for a in self.agents], [0] * len(self.agents))
        return observations, infos

    def advance(self, acts: dict[str, np.ndarray] | np.ndarray, with_infos: bool = True) -> StepResult:
        """One control step with ``acts``, a valid action in [-1, 1]^3 for every agent: agent ->
        action, or one float32 array ``(len(agents), 3)`` in the order of ``agents``
        (``PetSwarmEnv._validate``'s output; the episode keeps it as the agents' last actions, so
        the caller passes a new one every step): every robot's command through its arbiter, the
        clock for one control period, the sensors; then the truth, the rewards and the agent
        lifecycle. ``with_infos=False``: no agent's infos are made (None in their place; the vector
        env reports none), the rest of the step as with them."""
        agents = self.agents
        if isinstance(acts, dict):
            acts = np.array([acts[a] for a in agents], dtype=np.float32).reshape(-1, 3)
        self.tick(acts)
        self.runtime.check_batteries()  # a drained battery is a fault (runtime.py)
        self.num_cycles += 1

        ids = self._ids
        # formation and heading errors, contacts (metrics.py's SlaveTruth)
        _, formation_error_m, heading_error_rad, new_contacts = self.experimenter.step(agents, ids)
        if not step_kernel.all_walking(self.sessions):  # only while a user still stands
            self._start_walks(dict(zip(agents, formation_error_m)), dict(zip(agents, heading_error_rad)))
        infos = step_kernel.infos(agents, ids, self.fleet.nodes, self.missing_by_pan, formation_error_m,
                                  new_contacts, _LIVE_INFO) if with_infos else None
        # every slave's reward in one pass over the slaves (reward.py); the last actions are the
        # last step's array while the agents are the same
        if self._last_agents == agents:
            last_acts = self._last_acts
        else:
            last_acts = np.array([self.last_action[a] for a in agents], dtype=np.float32).reshape(-1, 3)
        rewards = dict(zip(agents, slave_rewards(self._reward_cfg, formation_error_m, heading_error_rad,
                                                 new_contacts, acts, last_acts)))
        self.last_action.update(zip(agents, acts))
        self._last_agents, self._last_acts = agents, acts
        return self._lifecycle(rewards, infos)

    def _lifecycle(self, rewards: dict[str, float], infos: dict[str, dict] | None) -> StepResult:
        """Who is an agent after this step (module docstring): agents follow the middleware — a
        robot that left slave-role driving waits (terminated only when it is off for good), a robot
        that became a slave (again) joins; every agent is truncated at ``max_cycles``."""
        truncated = self.num_cycles >= self._max_cycles
        slaves = step_kernel.current_slaves(self.swarms)  # (_current_slaves)
        if slaves == self.slave_ids and not truncated:
            # the slaves of the last step: every agent is one of them and none joins (the agents
            # after the last step are those slaves that are agents), so what follows gives
            # every agent its observation and no termination
            agents = self.agents
            observations = self.observer.observe(agents, self.last_action, self.world.clock.now)
            terminations = dict.fromkeys(agents, False)
            self.agents = list(agents)  # (the same robots: _ids stands)
            self.steady = True
            return observations, rewards, terminations, terminations.copy(), infos
        self.steady = False
        world, fleet, agent_index, faults = self.world, self.fleet, self.agent_index, self.runtime.faults
        live = {f"robot_{i}" for i in slaves}
        terminations = dict.fromkeys(self.agents, False)
        for a in self.agents:
            if a in live:
                continue
            idx = agent_index[a]
            if fleet.nodes[idx].state != "master":  # a robot that left slave-role driving and drives no user stands still
                world.robots[idx].set_command(0.0, 0.0, 0.0)
            if faults.off_for_good(idx):
                terminations[a] = True
                self.left.add(a)
        truncations = {a: truncated for a in self.agents}
        joined = [a for a in (f"robot_{i}" for i in slaves)
                  if a not in self.agents and a in self.setup.possible and a not in self.left]
        for a in joined:
            self.last_action[a] = np.zeros(3, np.float32)
        self.slave_ids = slaves
        before = list(self.agents)
        self._set_agents([a for a in before if a in live and not truncated] + ([] if truncated else joined))
        # observed in the order of before (the odometry noise is one draw over them, observe.py);
        # an agent that left now gets no observation (module docstring)
        observed = self.observer.observe(before + [a for a in joined if a not in before], self.last_action, world.now)
        observations = {a: o for a, o in observed.items() if a in live}
        for a in joined:
            rewards[a], terminations[a], truncations[a] = 0.0, False, truncated
            if infos is not None:
                infos[a] = self._infos([a], [0.0], [0])[a]
                infos[a]["joined"] = 1
        if infos is not None:
            infos = {a: infos[a] for a in observations}
        return observations, rewards, terminations, truncations, infos

    def tick(self, acts: np.ndarray | None = None) -> None:
        """The clock for one control period: every robot's command (``acts``, the agents' actions in their order; with
        None only the masters are driven, by their users, as while the swarm organizes), the
        physics substeps with the middleware's events, the ultrasonic rings. No step is counted:
        :meth:`advance` is the env's step; this alone serves the start-up and tools that watch the
        world go on after an episode ended (evaluation/faults_figures.py)."""
        self._control(acts)
        self.world.advance(self._substeps)
        self.sensors.read_rings()

    # -- views -----------------------------------------------------------------------------------
    @property
    def over(self) -> bool:
        """Whether the episode has ended (module docstring): ``max_cycles`` reached, or every
        possible agent off for good. The env's ``agents`` and the vector env's auto-reset both end on it."""
        return self.num_cycles >= self._max_cycles or len(self.left) == len(self.setup.possible)

    def state(self) -> np.ndarray:
        """The global state (:func:`petswarm_env.state.build_state`; docs/state.md)."""
        return build_state(self.setup.state_layout, self)

    def summary(self) -> dict[str, Any]:
        """The episode's figures so far (:meth:`.metrics.Experimenter.summary`)."""
        return self.experimenter.summary(self.scenario, len(self.slave_ids))

    def organize_summary(self) -> list[dict[str, Any]]:
        """How each user's swarm organized (the join protocol, seed 000 §3.4)."""
        return [{"user": u, "organize_time_s": sw.organize_result.elapsed_s, "join_retries": sw.organize_result.retries,
                 "members": dict(sw.organize_result.members), "slaves_missing": self.missing_by_pan[sw.pan]}
                for u, sw in enumerate(self.swarms)]

    def scene(self):
        """A plain description of the current truth for the renderer (:meth:`.metrics.Experimenter.scene`)."""
        return self.experimenter.scene(self.scenario, self.num_cycles)

    # -- building --------------------------------------------------------------------------------
    def _build(self, rng_world, rng_radio, rng_ir, rng_swarm, rng_sensors, rng_script, rng_users, radio_trace) -> None:
        """The episode's parts, from its seven streams: the world from the scenario (each user's
        script, the robots' placement), the radio medium and the IR channel, the fleet and a swarm
        per user, the user sessions, each robot's arbiter and the sensors."""
        cfg, setup = self.cfg, self.setup
        pool = cfg.user.scenario_pool
        self.scenario = pool[int(rng_script.integers(len(pool)))] if pool else cfg.user.scenario
        scenario = SCENARIOS[self.scenario]
        scripts = [scenario.script(cfg.user, r, scenario.arena(cfg, setup.reach_m or 0.0, u))
                   for u, r in enumerate(rng_script.spawn(cfg.world.num_users))]
        self.world = world = World(cfg, scripts[0])
        world.body_plan = body_plan(cfg, scenario, setup.bodies)  # each robot's type, in placement order
        place_cfg = placement_config(cfg, scenario)
        for u in range(1, cfg.world.num_users):
            world.add_user(scripts[u], (0.0, u * cfg.world.user_spacing_m), 0.0)
        plan = formation_for_mode(cfg.swarm, cfg.swarm.num_slaves + 1, cfg.swarm.mode, leading_user(cfg))
        placement = scenario.place(world, place_cfg, plan.slot_positions(), master_distance_m(cfg, None, cfg.swarm.mode), rng_world)
        self.other_user_robots = placement.other_user_robots
        self.radio = RadioMedium(world.clock, cfg.radio, rng_radio)
        self.radio.trace = radio_trace
        self.ir_channel = IRChannel(world, cfg.ir, rng_ir)
        self.fleet = fleet = Fleet(cfg, world, self.radio, self.ir_channel, rng_swarm)
        self.swarms = [Swarm(fleet, u, SWARM_PAN + u, master, pool) for u, (master, pool) in enumerate(placement.pools)]
        self._pools = [pool for _, pool in placement.pools]
        for idx in self.other_user_robots:
            fleet.add_node(idx, self.swarms[0]).connected_user = OTHER_USER_ID
        # arrival robots (runtime.py): parked switched off, in user 0's pool; each of its type (robot_types)
        arriving = [setup.bodies[a.type] for a in arrival_specs(cfg, scenario)]
        world.body_plan = world.body_plan[:len(world.robots)] + arriving
        self._arrivals = [world.add_robot(p, 0.0).index for p in park_positions(cfg, setup.arrival_slots)]
        for idx in self._arrivals:
            fleet.add_node(idx, self.swarms[0])
        self.sessions = []
        for u, (swarm, user_rng) in enumerate(zip(self.swarms, rng_users.spawn(cfg.world.num_users))):
            session = UserSession(cfg, world, swarm, world.users[u], user_rng, WAKE_PATTERN + u, WAKE_PATTERN + u)
            session.startup = [f"mode:{cfg.swarm.mode}", "organize"]
            self.sessions.append(session)
        self.swarm, self.session = self.swarms[0], self.sessions[0]
        for robot, ss in zip(world.robots, rng_world.spawn(len(world.robots))):
            robot.ahrs.power_on(ss, world.now)  # own power-on heading: no shared frame (seed 000 §3.5)
        stages: dict[float, SafetyStage | None] = {}  # one safety stage per braking limit (each body type's own)
        for r in world.robots:
            a = r.cfg.max_accel_mps2
            if a not in stages:
                stages[a] = SafetyStage(cfg.robot.ultrasonic.count, cfg.control.safety_stop_m, cfg.control.safety_backoff_mps,
                                        a) if cfg.control.safety_layer else None
        self.arbiters = {r.index: ControlArbiter(stages[r.cfg.max_accel_mps2]) for r in world.robots}
        self.sensors = Sensors(world, cfg.robot, rng_sensors)  # reads every robot's ultrasonic ring

    def _check_inside_arena(self) -> None:
        """Every robot and user starts inside the arena's walls (world.arena_m; boxes are checked
        with the config), or the episode would start with bodies outside or inside a wall."""
        w, h = self.cfg.world.arena_m
        if w <= 0 or h <= 0:
            return
        bodies = [(f"robot_{r.index}", r.position, r.radius_m) for r in self.world.robots]
        bodies += [(f"user {u.index}", u.position, self.cfg.user.radius_m) for u in self.world.users]
        for name, (x, y), r in bodies:
            if abs(x) + r > w / 2 or abs(y) + r > h / 2:
                xs = [abs(p[0]) + q for _, p, q in bodies]
                ys = [abs(p[1]) + q for _, p, q in bodies]
                raise ValueError(
                    f"{name} starts at ({x:.2f}, {y:.2f}) m, outside the walls of the {w:g} x {h:g} m arena (world.arena_m, "
                    f"centred on the origin); this start needs at least {2 * max(xs):.1f} x {2 * max(ys):.1f} m: "
                    "set a larger world.arena_m, or [0, 0] for no walls")

    def _organize(self) -> None:
        """Run the clock through each user's start-up (pairing, the driving mode, organize; seed
        002 Fig. 4, seed 000 §3.5) until every swarm is organized; a user that never paired or a
        swarm that did not organize is an error that says which setting to change."""
        cfg = self.cfg
        limit = int(math.ceil((cfg.lf.wake_period_s + cfg.ble.connect_s + cfg.protocol.organize_timeout_s + 10.0) / cfg.control_period_s))
        for _ in range(limit):
            self.tick(None)
            if all(sw.organized for sw in self.swarms):
                break
        for u, (session, swarm) in enumerate(zip(self.sessions, self.swarms)):
            if session.connected_robot is None:  # a start-up that failed, as a swarm that did not organize: a run goes on
                cause = (f"user {u}'s belt never woke up: its robot must start within lf.wake_range_m={cfg.lf.wake_range_m} m "
                         "and burst the belt's wake-up pattern")
                raise OrganizeError(f"seed {self.seed}: {cause}", self.seed, cause)
            if not swarm.organized or not swarm.slave_ids():
                cause = organize_obstacle(cfg)
                raise OrganizeError(f"seed {self.seed}: user {u}'s swarm did not organize within protocol.organize_timeout_s="
                                    f"{cfg.protocol.organize_timeout_s:g} s; likely cause: {cause}", self.seed, cause)

    def _stand_members_at_their_slots(self) -> None:
        """``swarm.spawn: at_slots`` (a formation as good as built, for comparisons): member k
        stands at slot k. The placement put the pool's k-th robot at slot k; the join numbers the
        members by the master's estimated distances (Table 2), so robots at slots of equal distance
        (a wedge's two sides) may come out exchanged: their poses are exchanged back before the
        first step (waiting robots stand still while the swarm organizes), and what the members had
        measured of each other is forgotten (the ring measures it again). A swarm that took an
        extra robot keeps its start."""
        world = self.world
        for swarm, pool in zip(self.swarms, self._pools):
            members = swarm.master.know.members
            joined = [members[k] for k in sorted(members) if k != 0]
            placed = pool[: len(joined)]
            if sorted(joined) != sorted(placed) or joined == placed:
                continue
            poses = {i: (world.robots[i].position, world.robots[i].heading) for i in placed}
            for rid, slot_robot in zip(joined, placed):
                body = world.robots[rid].body
                body.position, body.angle = poses[slot_robot]
                world.space.reindex_shapes_for_body(body)
            for rid in (swarm.master.node_id, *joined):
                know = self.fleet.nodes[rid].know
                know.ir.clear()
                know.heading.clear()
        world.invalidate_truth()

    # -- per step --------------------------------------------------------------------------------
    def _set_agents(self, agents: list[str]) -> None:
        """The agents from now on, and their robot indices in their order (``_ids``, what the
        per-step loops of :mod:`.step_kernel` read)."""
        self.agents = agents
        index = self.agent_index
        self._ids = [index[a] for a in agents]

    def _infos(self, agents: list[str], errors_m: list[float], contacts: list[int]) -> dict[str, dict[str, float | int]]:
        """The infos of ``agents`` (the keys of :data:`INFO_DEFAULTS`) with their formation errors
        and new contacts, none of them joined in this step (:func:`.step_kernel.infos`)."""
        index = self.agent_index
        return step_kernel.infos(agents, [index[a] for a in agents], self.fleet.nodes, self.missing_by_pan, errors_m,
                                 contacts, _LIVE_INFO)

    def _control(self, acts: np.ndarray | None) -> None:
        """One command per robot through its arbiter (seed 001): masters from their user session,
        slaves from the agents' actions (``acts``, in the order of ``agents``); the slaves stop
        when their master broadcasts an emergency."""
        world = self.world
        robots, arbiters, nodes = world.robots, self.arbiters, self.fleet.nodes
        rows = self.sensors.range_rows()  # every robot's last ring as Python floats
        # each master from its user session; a master that is off (a fault): motors off
        masters = step_kernel.command_masters(self.sessions, self.sensors, rows, arbiters, robots)
        if acts is None:
            return
        # a robot leaving its slot for its own fault drives out of the way
        step_kernel.command_leaving(nodes, masters, robots, arbiters, rows, world.clock.now)
        # the agents' actions times the action scale (float32 products), through their arbiters;
        # a slave whose master is lost (on its own clock) or in emergency stops
        step_kernel.command_slaves(self._ids, acts, self._scale, masters, nodes, robots, arbiters, rows)

    def _start_walks(self, errors_m: dict[str, float], headings_rad: dict[str, float]) -> None:
        """Start the script of each user who has stood long enough (chosen): once their swarm is
        organized, a user stands until they see its formation built — every slave of it within
        ``metrics.BUILT_WITHIN_M`` of its reference point (``errors_m``, agent -> formation error)
        and none facing away from the formation's way, its heading within
        ``metrics.BUILT_FACING_RAD`` (90°) of its master's (``headings_rad``, agent -> heading
        error) — or for ``user.formation_wait_s`` at most; the script's own stand
        (``user.start_delay_s``) counts from organizing, so the user walks off at the later of the two.
        (Facing too: a differential body that reached its slot backwards has to turn round before it
        can follow; a user walking off at once left an r1 (1.5 rad/s) 4 m behind, out of its IR's
        reach, and its master removed it as astray: docs/faults.md.)"""
        waited = self.world.now - self.experimenter.organized_at_s
        limit = self.cfg.user.formation_wait_s
        for session in self.sessions:
            user = session.user
            if user.walking or session.paused:
                continue
            slaves = [f"robot_{i}" for i in session.swarm.slave_ids()]
            if waited >= limit - 1e-9 or all(errors_m.get(a, math.inf) <= BUILT_WITHIN_M
                                             and abs(headings_rad.get(a, math.inf)) <= BUILT_FACING_RAD for a in slaves):
                user.walking = True
                user.script_time_s = min(waited, self.cfg.user.start_delay_s)

    def _current_slaves(self) -> list[int]:
        return step_kernel.current_slaves(self.swarms)  # every swarm's slave_ids(), sorted


class Truth:
    """The episode's ground truth for the experimenter's tools (module docstring): read, never
    written, never given to a policy. Every attribute is a view of the live episode (it follows
    the episode as it advances).

    - ``now`` (s on the episode's clock), ``num_cycles``, ``scenario``;
    - ``robots`` and ``users`` (the world's bodies: position, heading, velocity, type, health),
      ``truth_arrays()`` (every body's true centre, radius and every robot's heading, robots then
      users), ``wall_segments``;
    - ``references()`` / ``reference_points(xy, th)`` / ``reference_positions()`` / ``error_trace``
      / ``organized_at_s``: the experimenter's reference points and figures (:mod:`.metrics`);
    - ``swarms``, ``sessions``, ``nodes`` (robot index -> middleware node), ``arbiters`` (robot
      index -> its control arbiter and its win counts), ``member_log`` (user 0's swarm);
    - ``faults`` (the fault log, :mod:`.sim.faults`), ``arrivals`` / ``arrived`` / ``parked()``
      (:mod:`.runtime`), ``other_user_robots``.

    Read tables, knowledge and states through it, not a robot's sensors: a sensor read such as a
    node's ``ahrs_yaw()``, or a master's ``odometry.read()``, draws that sensor's noise from the
    episode's streams, so a tool that calls it shifts every later draw and the episode is no longer
    the one its seed gives (the true velocity and heading are ``robots[i]``'s).
    """

    __slots__ = ("_episode",)

    def __init__(self, episode: Episode):
        self._episode = episode

    @property
    def now(self) -> float:
        return self._episode.world.now

    @property
    def num_cycles(self) -> int:
        return self._episode.num_cycles

    @property
    def scenario(self) -> str:
        return self._episode.scenario

    @property
    def robots(self) -> tuple:
        return tuple(self._episode.world.robots)

    @property
    def users(self) -> tuple:
        return tuple(self._episode.world.users)

    @property
    def user(self):
        """User 0."""
        return self._episode.world.users[0]

    def truth_arrays(self):
        """(centres, radii, headings) of every body (robots, then users): :meth:`.sim.world.World.truth_arrays`."""
        return self._episode.world.truth_arrays()

    @property
    def wall_segments(self) -> list:
        return list(self._episode.world.wall_segments)

    def references(self) -> dict[int, tuple[float, float, float]]:
        return self._episode.experimenter.references()

    def reference_points(self, xy: list | None = None, th: list | None = None) -> dict[int, tuple[float, float]]:
        return self._episode.experimenter.reference_points(xy, th)

    def reference_positions(self) -> dict[int, np.ndarray]:
        return self._episode.experimenter.reference_positions()

    def roles(self) -> list[str]:
        """Every robot's role now (:meth:`.metrics.Experimenter.roles`)."""
        return self._episode.experimenter.roles()

    def link_pairs(self) -> list[tuple[int, int]]:
        """The formation's reference links as robot pairs (:meth:`.metrics.Experimenter.link_pairs`)."""
        return self._episode.experimenter.link_pairs()

    @property
    def error_trace(self) -> list[float]:
        return self._episode.metrics.error_trace

    @property
    def organized_at_s(self) -> float:
        return self._episode.experimenter.organized_at_s

    @property
    def swarms(self) -> tuple:
        return tuple(self._episode.swarms)

    @property
    def sessions(self) -> tuple:
        return tuple(self._episode.sessions)

    @property
    def nodes(self):
        return MappingProxyType(self._episode.fleet.nodes)

    @property
    def arbiters(self):
        return MappingProxyType(self._episode.arbiters)

    @property
    def member_log(self) -> list:
        return self._episode.swarms[0].member_log

    @property
    def faults(self) -> list:
        """The episode's fault log (:class:`.sim.faults.Faults` ``log``): what was injected when."""
        return self._episode.runtime.faults.log

    @property
    def arrivals(self) -> list:
        return list(self._episode.runtime.arrivals)

    @property
    def arrived(self) -> list:
        return list(self._episode.runtime.arrived)

    def parked(self) -> list[int]:
        return self._episode.runtime.parked()

    @property
    def other_user_robots(self) -> tuple:
        return tuple(self._episode.other_user_robots)
