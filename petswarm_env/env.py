"""petswarm_v0 — a PettingZoo ``ParallelEnv`` of a Pet-Bot swarm accompanying a walking user.

Each user (``world.num_users``) wears a smart belt and a smart watch (seed 002); the robot that
pairs with the belt becomes the master of the user's swarm and accompanies the user through the
wearables (LF localisation, activity and rotation recognition, gestures, over BLE). The other
robots (the *agents*) are the slaves that joined a swarm through the join protocol of seed 000 and
keep a leader–follower formation. Every robot runs the swarm middleware on one discrete-event
clock: radio frames on a shared 802.15.4-like medium (one PAN per swarm), the IR token ring with
heading exchange, the master's status broadcast, mode changes with master change (Table 3).

This module only wires the parts. ``reset(seed)`` builds the world from the scenario
(:mod:`petswarm_env.scenarios`: each user's walking script, the robots' placement), the radio
medium and the IR channel (:mod:`petswarm_env.comms`), the fleet with a swarm per user
(:mod:`petswarm_env.middleware`), the user sessions, each robot's control arbiter
(:mod:`petswarm_env.control`) and the sensors (:mod:`petswarm_env.sim.sensors`); then it runs, on
the clock, the pairing, the user's start-up commands (driving mode, then organize — in leading mode
after the master shifted to its place) and the join protocol (its duration and retries are in
``organize_summary()``; a swarm that organized short of ``swarm.num_slaves`` says by how many in
``infos[agent]["slaves_missing"]`` and the episode summary's ``slaves_missing``); the agents are
the robots that joined. Each ``step(actions)``
passes every robot's command through its arbiter (safety > user > policy, seed 001), runs the clock
for one control period (0.1 s), reads the sensors, then asks the experimenter
(:mod:`petswarm_env.metrics`: ground truth) for errors and contacts, computes the rewards
(:mod:`petswarm_env.reward`) and builds the observations from each slave's sensors and middleware
only (:mod:`petswarm_env.observe`). Agents come and go with the middleware: a robot that stops
being a slave (it became the master, or the swarm dispersed) is terminated; a robot that becomes
a slave joins ``agents``.

Runtime changes (issue 15, docs/faults.md; none by default): ``faults`` break parts of robots and
``arrivals`` switch robots on mid-episode (:mod:`petswarm_env.runtime`); a dead slave is
terminated, a slave that lost its master (no status broadcast for ``protocol.status_timeout_s``)
stops and is terminated, an arrival that joins is a new agent (``possible_agents`` ends with the
arrival robots).

Spaces: observation ``Box(low, high, (N,), float32)`` with values scaled to about [-1, 1] and each
field's bounds in docs/observation.md (N = 83 with 8 ultrasonic sensors), action ``Box(-1, 1, (3,),
float32)`` = (Vx, Vy, ω) scaled by ``robot.max_speed_mps`` and ``robot.max_omega_rps``; the global
state ``state()`` in ``state_space`` (docs/state.md). Infos are flat and numeric, the keys of
:data:`INFO_DEFAULTS` for every agent at reset and at every step; the episode's figures come from
``episode_summary()`` (after the last step too) and ``organize_summary()``. Episodes truncate after
``max_cycles`` steps. The env pickles between episodes (``__getstate__``).
"""
from __future__ import annotations

import math
from typing import Any

import gymnasium
import numpy as np
from pettingzoo import ParallelEnv

from petswarm_env.comms.ir_channel import IRChannel
from petswarm_env.comms.radio import RadioMedium
from petswarm_env.config import DRIVING_MODES, Config, ConfigError, arrival_slots, describe_value, flatten_dotted, load_config
from petswarm_env.inputs import check_reset_options, check_start_clear_of_boxes, checked_action
from petswarm_env.control.arbiter import ControlArbiter, SafetyStage
from petswarm_env.metrics import BUILT_WITHIN_M, Experimenter
from petswarm_env.middleware.formation import formation_for_mode, user_position_in_formation
from petswarm_env.middleware.fleet import Fleet
from petswarm_env.middleware.swarm import Swarm
from petswarm_env.middleware.user_session import UserSession, master_distance_m
from petswarm_env.observe import OBS_VERSION, ObservationLayout, Observer, observation_bounds
from petswarm_env.reward import slave_rewards
from petswarm_env.runtime import Runtime, arrival_specs, park_positions
from petswarm_env.robot_types import (DEFAULT_TYPE, body_plan, episode_scenarios, max_pool_size, placement_config, pool_problem,
                                      pool_types)
from petswarm_env.robot_types import resolve as resolve_type
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.state import StateLayout, build_state
from petswarm_env.sim.sensors import Sensors
from petswarm_env.sim.world import World

ENV_NAME = "petswarm_v0"
OTHER_USER_ID = 99  # the user that "other user" robots are connected to (Table 1)
SWARM_PAN = 0x1001  # user u's swarm uses PAN SWARM_PAN + u
WAKE_PATTERN = 0x5A00  # user u's belt and robot share the LF wake-up pattern WAKE_PATTERN + u
# every agent's infos, at reset and at every step: flat, numeric, always these keys (the value of an
# agent that has no such figure yet): its member number, its true formation error (m), the contacts it
# began this step, 1 on the step it joined (the old master after a mode change), else 0, and how many of
# the required slaves its swarm lacked when it organized (Swarm.slaves_missing)
INFO_DEFAULTS: dict[str, float | int] = {"member": -1, "formation_error_m": 0.0, "new_contacts": 0, "joined": 0,
                                         "slaves_missing": 0}


def _swarm_reach_m(cfg: Config) -> float | None:
    """How far from its user a swarm's robots are planned to stand: the farthest slot of the
    configured formation in either driving mode (seed 000 Fig. 10), plus a robot's radius. None
    for a neighbour table that cannot be built (reset says why)."""
    reach = 0.0
    for mode in DRIVING_MODES:
        try:
            plan = formation_for_mode(cfg.swarm, cfg.swarm.num_slaves + 1, mode)
        except ValueError:
            return None
        ux, uy = user_position_in_formation(plan, cfg.master.distance_m)
        slots = plan.slot_positions()
        reach = max(reach, float(np.hypot(slots[:, 0] - ux, slots[:, 1] - uy).max()))
    return reach + cfg.robot.radius_m


class PetSwarmEnv(ParallelEnv):
    metadata = {
        "name": ENV_NAME,
        "render_modes": ["human", "rgb_array"],
        "render_fps": 10,
        "is_parallelizable": True,
        "observation_version": OBS_VERSION,
    }

    def __init__(self, config: Config | str | None = None, render_mode: str | None = None, **overrides: Any):
        if isinstance(config, Config):
            cfg = load_config(overrides={**flatten_dotted(config.to_dict()), **overrides}) if overrides else config
        else:
            cfg = load_config(config, overrides)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"unknown render_mode '{render_mode}'; allowed: human, rgb_array, or None")
        self.cfg = cfg
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=cfg.render.fps)
        self._bodies = {name: resolve_type(cfg, name) for name in cfg.robot_types}  # each robot type, resolved once
        for name in episode_scenarios(cfg):  # a scenario's own pool (robot_types.pool_types) must fit the config
            problem = pool_problem(cfg, list(SCENARIOS[name].robot_pool), f"scenario '{name}' robot_pool")
            if problem and not cfg.swarm.pool:
                raise ConfigError(problem)
        per_user = 1 + max_pool_size(cfg)
        # the bodies this env's robots may have (every master is a petbot): what a policy attaches to
        self.body_types = tuple(self._bodies[n] for n in sorted({DEFAULT_TYPE}.union(
            *(pool_types(cfg, SCENARIOS[name]) for name in episode_scenarios(cfg)))))
        may_change_master = cfg.swarm.master_change and any(
            SCENARIOS[name].changes_master for name in (*cfg.user.scenario_pool, cfg.user.scenario))
        self._arrival_slots = arrival_slots(cfg)  # robots switched on mid-episode (runtime.py), after every other robot
        first_arrival = cfg.robot_count(0)
        self.possible_agents = [
            f"robot_{u * per_user + k}" for u in range(cfg.world.num_users) for k in range(0 if may_change_master else 1, per_user)
        ] + [f"robot_{first_arrival + j}" for j in range(self._arrival_slots)]
        self._possible = set(self.possible_agents)
        self._reach_m = _swarm_reach_m(cfg)
        for name in dict.fromkeys((*cfg.user.scenario_pool, cfg.user.scenario)):  # the user stays in the world
            problem = SCENARIOS[name].arena_problem(cfg, self._reach_m or 0.0) if self._reach_m is not None else None
            if problem:
                raise ConfigError(problem)
        self.agents: list[str] = []
        self._limits = (cfg.robot.max_speed_mps, cfg.robot.max_speed_mps, cfg.robot.max_omega_rps)
        self.layout = ObservationLayout(cfg.robot.ultrasonic.count, self._limits, cfg.robot.ultrasonic.max_range_m)
        self._obs_space = gymnasium.spaces.Box(*observation_bounds(self.layout, cfg), dtype=np.float32)
        self._act_space = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.state_layout = StateLayout(cfg)
        self.state_space = gymnasium.spaces.Box(self.state_layout.low, self.state_layout.high, dtype=np.float32)
        self._seed_seq: np.random.SeedSequence | None = None
        self._renderer = None
        self.world: World | None = None
        self.swarm: Swarm | None = None
        # the experimenter's radio trace (comms/radio.py RadioTrace; evaluation/pcap.py, evaluation/replay.py):
        # every frame of each episode's medium from its reset on; None = off
        self.radio_trace = None

    # -- PettingZoo API --------------------------------------------------------------------------
    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        if agent not in self._possible:
            raise KeyError(self._unknown_agent(agent))
        return self._obs_space

    def action_space(self, agent: str) -> gymnasium.spaces.Box:
        if agent not in self._possible:
            raise KeyError(self._unknown_agent(agent))
        return self._act_space

    def _unknown_agent(self, agent: Any) -> str:
        return f"{agent!r} is not an agent of this env; the possible agents are {', '.join(self.possible_agents)}"

    def reset(self, seed: int | None = None, options: dict | None = None):
        check_reset_options(options)  # None or a dict; an unknown key is warned (inputs.py)
        if seed is not None:
            seed = _checked_seed(seed)
            self._seed_seq = np.random.SeedSequence(seed)
        elif self._seed_seq is None:
            self._seed_seq = np.random.SeedSequence(self.cfg.seed)
        streams = self._seed_seq.spawn(1)[0].spawn(8)  # the 8th (faults) leaves the first seven as they were
        self._build(*(np.random.default_rng(s) for s in streams[:7]))
        self.runtime = Runtime(self.cfg, self.world, self.fleet, self.swarms, SCENARIOS[self.scenario], self._arrivals,
                               np.random.default_rng(streams[7]), on_change=self.sensors.fault_changed)
        self._check_inside_arena()
        check_start_clear_of_boxes(self.cfg, self.world)  # no body starts in a box (inputs.py)
        self._organize()
        if self.cfg.swarm.spawn == "at_slots":
            self._stand_members_at_their_slots()
        world = self.world
        for arb in self.arbiters.values():  # the episode's counts start now
            arb.counts = type(arb.counts)()
        self._slave_ids = self._current_slaves()
        self.agents = [f"robot_{i}" for i in self._slave_ids]
        self._agent_index = {f"robot_{i}": i for i in range(len(world.robots))}
        self._last_action = {a: np.zeros(3, np.float32) for a in self.agents}
        self.observer = Observer(self.layout, self.fleet.nodes, self.sensors, [r.ahrs_yaw for r in world.robots],
                                 self._agent_index, self.cfg.master.distance_m)
        self.experimenter = Experimenter(self.cfg, world, self.fleet, self.swarms, self.sessions, self.arbiters, self.radio,
                                         self._agent_index, self._other_user_robots)
        self.metrics = self.experimenter.metrics
        self.experimenter.runtime = self.runtime
        self._start_walks({})
        self.runtime.start()  # faults and arrivals, in episode time from now
        self.num_cycles = 0
        observations = self.observer.observe(self.agents, self._last_action, world.now)
        self._missing_by_pan = {sw.pan: sw.slaves_missing() for sw in self.swarms}  # as organized (metrics.py's figure)
        errors, _ = self.experimenter.formation_errors(self.agents)
        infos = {a: self._info(a, errors.get(a, 0.0), 0, 0) for a in self.agents}
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def _build(self, rng_world, rng_radio, rng_ir, rng_swarm, rng_sensors, rng_script, rng_users) -> None:
        """The episode's parts, from its seven streams: the world from the scenario (each user's
        script, the robots' placement), the radio medium and the IR channel, the fleet and a swarm
        per user, the user sessions, each robot's arbiter and the sensors."""
        cfg = self.cfg
        pool = cfg.user.scenario_pool
        self.scenario = pool[int(rng_script.integers(len(pool)))] if pool else cfg.user.scenario
        scenario = SCENARIOS[self.scenario]
        scripts = [scenario.script(cfg.user, r, scenario.arena(cfg, self._reach_m or 0.0, u))
                   for u, r in enumerate(rng_script.spawn(cfg.world.num_users))]
        self.world = world = World(cfg, scripts[0])
        world.body_plan = body_plan(cfg, scenario, self._bodies)  # each robot's type, in placement order
        place_cfg = placement_config(cfg, scenario)
        for u in range(1, cfg.world.num_users):
            world.add_user(scripts[u], (0.0, u * cfg.world.user_spacing_m), 0.0)
        plan = formation_for_mode(cfg.swarm, cfg.swarm.num_slaves + 1, cfg.swarm.mode)
        placement = scenario.place(world, place_cfg, plan.slot_positions(), user_position_in_formation(plan, cfg.master.distance_m)[0],
                                   rng_world, master_distance_m(cfg, None, cfg.swarm.mode))
        self._other_user_robots = placement.other_user_robots
        self.radio = RadioMedium(world.clock, cfg.radio, rng_radio)
        self.radio.trace = self.radio_trace
        self.ir_channel = IRChannel(world, cfg.ir, rng_ir)
        self.fleet = fleet = Fleet(cfg, world, self.radio, self.ir_channel, rng_swarm)
        self.swarms = [Swarm(fleet, u, SWARM_PAN + u, master, pool) for u, (master, pool) in enumerate(placement.pools)]
        self._pools = [pool for _, pool in placement.pools]
        for idx in self._other_user_robots:
            fleet.add_node(idx, self.swarms[0]).connected_user = OTHER_USER_ID
        # arrival robots (runtime.py): parked switched off, in user 0's pool; each of its type (robot_types)
        arriving = [self._bodies[a.type] for a in arrival_specs(cfg, scenario)]
        world.body_plan = world.body_plan[:len(world.robots)] + arriving
        self._arrivals = [world.add_robot(p, 0.0).index for p in park_positions(cfg, self._arrival_slots)]
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
        cfg, world = self.cfg, self.world
        limit = int(math.ceil((cfg.lf.wake_period_s + cfg.ble.connect_s + cfg.protocol.organize_timeout_s + 10.0) / cfg.control_period_s))
        for _ in range(limit):
            self._control(None)
            world.advance(cfg.physics_substeps)
            self.sensors.read_rings()
            if all(sw.organized for sw in self.swarms):
                break
        for u, (session, swarm) in enumerate(zip(self.sessions, self.swarms)):
            if session.connected_robot is None:
                raise RuntimeError(
                    f"user {u}'s belt never woke up: its robot must start within lf.wake_range_m={cfg.lf.wake_range_m} m "
                    "and burst the belt's wake-up pattern")
            if not swarm.organized or not swarm.slave_ids():
                raise RuntimeError(
                    f"user {u}'s swarm did not organize within protocol.organize_timeout_s={cfg.protocol.organize_timeout_s} s "
                    f"(radio.loss_prob={cfg.radio.loss_prob}); raise the timeout or protocol.max_retries"
                )

    def step(self, actions: dict[str, Any]):
        if self.world is None:
            raise RuntimeError("call reset() before step()")
        if not self.agents:
            raise RuntimeError("the episode is over (no live agents); call reset()")
        cfg = self.cfg
        world = self.world
        acts = self._validate(actions)
        self._control(acts)
        world.advance(cfg.physics_substeps)
        self.runtime.check_batteries()  # a drained battery is a fault (runtime.py)
        self.sensors.read_rings()
        self.num_cycles += 1

        truth = self.experimenter.step(self.agents)  # formation and heading errors, contacts (metrics.py)
        if not all(session.user.walking for session in self.sessions):  # only while a user still stands
            self._start_walks(dict(zip(self.agents, truth.formation_error_m)))
        infos = {agent: self._info(agent, err, c, 0) for agent, err, c in zip(self.agents, truth.formation_error_m, truth.new_contacts)}
        # every slave's reward in one pass over the slaves (reward.py)
        now_acts = np.array([acts[a] for a in self.agents], dtype=np.float32).reshape(-1, 3)
        last_acts = np.array([self._last_action[a] for a in self.agents], dtype=np.float32).reshape(-1, 3)
        rewards = dict(zip(self.agents, slave_rewards(cfg.reward, truth.formation_error_m, truth.heading_error_rad,
                                                      truth.new_contacts, now_acts, last_acts)))
        for agent in self.agents:
            self._last_action[agent] = acts[agent]
        truncated = self.num_cycles >= cfg.max_cycles
        # agents follow the middleware: a robot that left slave-role driving is done, a new slave joins
        slaves = self._current_slaves()
        live = {f"robot_{i}" for i in slaves}
        terminations = {a: a not in live for a in self.agents}
        for a, done in terminations.items():  # a robot that left slave-role driving and drives no user stands still
            if done and self.fleet.nodes[self._agent_index[a]].state != "master":
                world.robots[self._agent_index[a]].set_command(0.0, 0.0, 0.0)
        truncations = {a: truncated for a in self.agents}
        joined = [f"robot_{i}" for i in slaves if f"robot_{i}" not in self.agents and f"robot_{i}" in self._possible]
        for a in joined:
            self._last_action[a] = np.zeros(3, np.float32)
        self._slave_ids = slaves
        before = list(self.agents)
        self.agents = [a for a in before if a in live and not truncated] + ([] if truncated else joined)
        observations = self.observer.observe(before + [a for a in joined if a not in before], self._last_action, world.now)
        for a in joined:
            rewards[a], terminations[a], truncations[a] = 0.0, False, truncated
            infos[a] = self._info(a, 0.0, 0, 1)
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def render(self, mode: str | None = None):
        """The current frame (``rgb_array``) or the window (``human``) of the env's ``render_mode``.
        ``mode``, if given, must be that mode (RLlib's ``ParallelPettingZooEnv`` passes it)."""
        if mode is not None and mode != self.render_mode:
            raise ValueError(f"render('{mode}'): this env renders in render_mode={self.render_mode!r}; "
                             "create it with render_mode='rgb_array' or 'human'")
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        if self.world is None:
            raise RuntimeError("call reset() before render()")
        from petswarm_env.render import Renderer

        if self._renderer is None:
            r = self.cfg.render
            self._renderer = Renderer(size_px=tuple(r.size_px), pixels_per_m=r.pixels_per_m, fps=r.fps, mode=self.render_mode)
        return self._renderer.render(self.scene())

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def state(self) -> np.ndarray:
        """The global state: ground truth of every robot, user and the episode's time, fixed size
        (``state_space``; every field in docs/state.md, :mod:`petswarm_env.state`). For
        centralized critics: a policy reads only its observation."""
        if self.world is None:
            raise RuntimeError("call reset() before state()")
        return build_state(self.state_layout, self)

    # -- pickling: between episodes --------------------------------------------------------------
    _EPISODE = ("world", "swarm", "session", "swarms", "sessions", "radio", "ir_channel", "fleet", "arbiters", "sensors", "runtime",
                "_arrivals",
                "observer", "experimenter", "metrics", "_renderer", "_other_user_robots", "_slave_ids", "_agent_index",
                "_last_action", "scenario", "num_cycles")

    def __getstate__(self) -> dict[str, Any]:
        """The env without its episode (the clock's SimPy processes are generators, which do not
        pickle): the config, the spaces and the seed sequence. A copy (``pickle``, ``copy.deepcopy``,
        a worker process) has no episode until its ``reset()``; its next ``reset()`` without a seed
        gives the episode the original's next ``reset()`` gives. Pickle between episodes: a copy
        taken mid-episode does not carry the episode on."""
        state = {k: v for k, v in self.__dict__.items() if k not in self._EPISODE}
        state["agents"] = []
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.world = self.swarm = self._renderer = None

    # -- per step --------------------------------------------------------------------------------
    def _info(self, agent: str, error_m: float, contacts: int, joined: int) -> dict[str, float | int]:
        """One agent's infos (the keys of :data:`INFO_DEFAULTS`)."""
        node = self.fleet.nodes[self._agent_index[agent]]
        return {"member": node.know.member, "formation_error_m": error_m, "new_contacts": contacts, "joined": joined,
                "slaves_missing": self._missing_by_pan.get(node.swarm_pan, 0)}

    def _validate(self, actions: dict[str, Any]) -> dict[str, np.ndarray]:
        if not isinstance(actions, dict):
            raise TypeError(f"actions must be a dict agent -> array of 3 floats, got {type(actions).__name__}")
        unknown = set(actions) - set(self.agents)
        if unknown:
            raise KeyError(f"actions for agents not in the episode: {sorted(unknown)}; live agents: {self.agents}")
        # the common case in one numpy pass: a float array for every agent, all finite, shape (3,)
        if len(actions) == len(self.agents):
            values = [actions[a] for a in self.agents]
            arr = None
            if all(type(v) is np.ndarray and v.dtype.kind == "f" for v in values):
                try:
                    arr = np.array(values, dtype=np.float32)
                except ValueError:  # ragged shapes: the loop below names the agent
                    arr = None
            if arr is not None and arr.shape == (len(self.agents), 3) and np.isfinite(arr).all():
                np.clip(arr, -1.0, 1.0, out=arr)
                return dict(zip(self.agents, arr))
        out = {}
        for agent in self.agents:
            a = actions.get(agent)
            if a is None:
                out[agent] = np.zeros(3, np.float32)  # a missing action means "stand still"
                continue
            out[agent] = checked_action(agent, a)  # numbers, no boolean, shape (3,), finite (inputs.py)
        return out

    def _control(self, acts: dict[str, np.ndarray] | None) -> None:
        """One command per robot through its arbiter (seed 001): masters from their user session,
        slaves from the agents' actions; the slaves stop when their master broadcasts an emergency."""
        world = self.world
        lim = self._limits
        ranges = self.sensors.ranges
        masters = set()
        for session in self.sessions:
            idx = session.swarm.master.node_id
            masters.add(idx)
            policy, user_cmd, stop = session.step(self.sensors.odometry(idx), ranges[idx])
            cmd, _ = self.arbiters[idx].decide(policy, user_cmd, ranges[idx], stop)
            robot = world.robots[idx]
            if robot.health.powered:
                robot.set_command(*cmd)
            else:  # a master that is off (a fault): motors off
                robot.set_command(0.0, 0.0, 0.0)
        if acts is None:
            return
        for agent, a in acts.items():
            idx = self._agent_index[agent]
            if idx in masters:
                continue
            node = self.fleet.nodes[idx]
            if node.seq.master_lost(world.now):  # no status broadcast for protocol.status_timeout_s: emergency stop, waiting
                world.robots[idx].set_command(0.0, 0.0, 0.0)
                continue
            st = node.know.status
            stop = st is not None and st.mode == "emergency"
            cmd, _ = self.arbiters[idx].decide((a[0] * lim[0], a[1] * lim[1], a[2] * lim[2]), None, ranges[idx], stop)
            world.robots[idx].set_command(*cmd)

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

    def _start_walks(self, errors_m: dict[str, float]) -> None:
        """Start the script of each user who has stood long enough (chosen): once their swarm is
        organized, a user stands until they see its formation built — every slave of it within
        ``metrics.BUILT_WITHIN_M`` of its reference point (``errors_m``, agent -> formation error) —
        or for ``user.formation_wait_s`` at most; the script's own stand (``user.start_delay_s``)
        counts from organizing, so the user walks off at the later of the two."""
        waited = self.world.now - self.experimenter.organized_at_s
        limit = self.cfg.user.formation_wait_s
        for session in self.sessions:
            user = session.user
            if user.walking or session.paused:
                continue
            slaves = [f"robot_{i}" for i in session.swarm.slave_ids()]
            if waited >= limit - 1e-9 or all(errors_m.get(a, math.inf) <= BUILT_WITHIN_M for a in slaves):
                user.walking = True
                user.script_time_s = min(waited, self.cfg.user.start_delay_s)

    def _current_slaves(self) -> list[int]:
        return sorted(i for sw in self.swarms for i in sw.slave_ids())

    def agent_robot(self, agent: str) -> int:
        """The robot index of ``agent`` (``robot_3`` -> 3) in this episode's world."""
        return self._agent_index[agent]

    def reference_positions(self) -> dict[int, np.ndarray]:
        """True reference position of every slave (robot index -> (x, y)): the experimenter's view
        (:meth:`.metrics.Experimenter.reference_positions`)."""
        return self.experimenter.reference_positions()

    def episode_summary(self) -> dict[str, Any]:
        """The episode's figures so far (:meth:`.metrics.Experimenter.summary`); after the last
        step, the episode's summary (it stays until the next ``reset``)."""
        if self.world is None:
            raise RuntimeError("call reset() before episode_summary()")
        return self.experimenter.summary(self.scenario, len(self._slave_ids))

    def organize_summary(self) -> list[dict[str, Any]]:
        """How each user's swarm organized in this episode's reset (the join protocol, seed 000
        §3.4): ``organize_time_s``, ``join_retries``, ``members`` (member number -> robot index) and
        ``slaves_missing`` (the required slaves that did not join)."""
        if self.world is None:
            raise RuntimeError("call reset() before organize_summary()")
        return [{"user": u, "organize_time_s": sw.organize_result.elapsed_s, "join_retries": sw.organize_result.retries,
                 "members": dict(sw.organize_result.members), "slaves_missing": self._missing_by_pan[sw.pan]}
                for u, sw in enumerate(self.swarms)]

    def scene(self):
        """A plain description of the current truth for the renderer (:meth:`.metrics.Experimenter.scene`)."""
        return self.experimenter.scene(self.scenario, self.num_cycles)


def _checked_seed(seed: Any) -> int:
    """``reset``'s seed: an integer ≥ 0 (Python or numpy; a boolean is not a seed)."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"reset(seed=...) takes an integer >= 0 or None, got {describe_value(seed)}")
    if seed < 0:
        raise ValueError(f"reset(seed=...) takes an integer >= 0 or None, got {int(seed)}")
    return int(seed)

