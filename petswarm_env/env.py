"""petswarm_v1 — a PettingZoo ``ParallelEnv`` of a Pet-Bot swarm accompanying a walking user.

Each user (``world.num_users``) wears a smart belt and a smart watch (seed 002); the robot that
pairs with the belt becomes the master of the user's swarm and accompanies the user through the
wearables (LF localisation, activity and rotation recognition, gestures, over BLE). The other
robots (the *agents*) are the slaves that joined a swarm through the join protocol of seed 000 and
keep a leader–follower formation. Every robot runs the swarm middleware on one discrete-event
clock: radio frames on a shared 802.15.4-like medium (one PAN per swarm), the IR token ring with
heading exchange, the master's status broadcast, mode changes with master change (Table 3).

This module is the PettingZoo face: the config, the spaces, the seeds and the checks of what a
caller passes. Each ``reset(seed)`` builds a new :class:`~petswarm_env.episode.Episode`
(``env.episode``), which owns everything of that episode: the world from the scenario
(:mod:`petswarm_env.scenarios`: each user's walking script, the robots' placement), the radio
medium and the IR channel (:mod:`petswarm_env.comms`), the fleet with a swarm per user
(:mod:`petswarm_env.middleware`), the user sessions, each robot's control arbiter
(:mod:`petswarm_env.control`), the sensors (:mod:`petswarm_env.sim.sensors`), the runtime changes,
the observer and the experimenter; it runs, on the clock, the pairing, the user's start-up commands
(driving mode, then organize — in leading mode after the master shifted to its place) and the join
protocol (its duration and retries are in ``organize_summary()``; a swarm that organized short of
``swarm.num_slaves`` says by how many in ``infos[agent]["slaves_missing"]`` and the episode
summary's ``slaves_missing``); the agents are the robots that joined. Each ``step(actions)`` is the
episode's ``advance``: every robot's command through its arbiter (safety > user > policy, seed 001),
the clock for one control period (0.1 s), the sensors, then the experimenter's errors and contacts
(:mod:`petswarm_env.metrics`: ground truth), the rewards (:mod:`petswarm_env.reward`) and the
observations from each slave's sensors and middleware only (:mod:`petswarm_env.observe`).

The agents: every robot of ``possible_agents`` is in ``agents`` from ``reset`` on, so no agent ever
joins after it (what TorchRL's ``PettingZooWrapper`` reads at reset, and RLlib's spaces). A robot in
slave-role driving is *active* (``infos[a]["active"]`` 1, its own observation; ``active_agents``);
one not (yet) in it — a master that may hand over, an arrival not yet switched on or joining, a
slave the swarm did not recruit — *waits*: a zero observation (never a real one: its yaw sin/cos lie
on the unit circle), ``active`` 0, reward 0.0, its action checked and ignored; it turns active under
the same id whenever it becomes a slave. Agents follow the middleware, by the lifecycle of
:mod:`petswarm_env.episode`: a robot that stops being a slave (it became the master, its master
lost it, a transient fault) waits again, and turns active again if it is recruited again; only a
robot off for good (a permanent ``dead`` or ``battery`` fault) is terminated, and never comes back
in that episode. The experimenter's tools read the ground truth through ``env.truth``
(:class:`~petswarm_env.episode.Truth`, read-only); a policy reads only its observation.

Runtime changes (docs/faults.md; none by default): ``faults`` break parts of robots and
``arrivals`` switch robots on mid-episode (:mod:`petswarm_env.runtime`); a dead slave is
terminated (a transient one waits), a slave that lost its master (no status broadcast for
``protocol.status_timeout_s``) stops and waits, an arrival waits until it joins (``possible_agents`` ends with the arrival
robots).

Spaces: observation ``Box(low, high, (N,), float32)`` with values scaled to about [-1, 1] and each
field's bounds in docs/observation.md (N = 83 with 8 ultrasonic sensors), action ``Box(-1, 1, (3,),
float32)`` = (Vx, Vy, ω) scaled by ``robot.max_speed_mps`` and ``robot.max_omega_rps``; the global
state ``state()`` in ``state_space`` (docs/state.md). Infos are flat and numeric, the keys of
:data:`INFO_DEFAULTS` for every agent at reset and at every step; the episode's figures come from
``episode_summary()`` (after the last step too) and ``organize_summary()``. Episodes truncate after
``max_cycles`` steps. The env pickles between episodes (``__getstate__``).
"""
from __future__ import annotations

import functools
from typing import Any

import gymnasium
import numpy as np
from pettingzoo import ParallelEnv

from petswarm_env.config_yaml import dotted_keywords
from petswarm_env.config import DRIVING_MODES, Config, ConfigError, arrival_slots, describe_value, flatten_dotted, load_config
from petswarm_env.episode import INFO_DEFAULTS, OTHER_USER_ID, SWARM_PAN, WAKE_PATTERN, Episode, Setup  # noqa: F401 (re-exported)
from petswarm_env.inputs import check_reset_options, checked_action
from petswarm_env.middleware.formation import formation_for_mode, leading_user, user_position_in_formation
from petswarm_env.observe import OBS_VERSION, ObservationLayout, ir_distance_bound, observation_bounds
from petswarm_env.robot_types import DEFAULT_TYPE, episode_scenarios, max_pool_size, pool_problem, pool_types
from petswarm_env.robot_types import resolve as resolve_type
from petswarm_env.scenarios import SCENARIOS
from petswarm_env.step_kernel import stack_actions
from petswarm_env.state import StateLayout

ENV_NAME = "petswarm_v1"


def _swarm_reach_m(cfg: Config) -> float | None:
    """How far from its user a swarm's robots are planned to stand: the farthest slot of the
    configured formation in either driving mode (seed 000 Fig. 10), plus a robot's radius. None
    for a neighbour table that cannot be built (reset says why)."""
    reach = 0.0
    for mode in DRIVING_MODES:
        try:
            plan = formation_for_mode(cfg.swarm, cfg.swarm.num_slaves + 1, mode, leading_user(cfg))
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
        overrides = dotted_keywords(overrides)  # swarm__num_slaves=3 is swarm.num_slaves=3, as in parallel_env
        if isinstance(config, Config):
            cfg = load_config(overrides={**flatten_dotted(config.to_dict()), **overrides}) if overrides else config
        else:
            cfg = load_config(config, overrides)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"unknown render_mode '{render_mode}'; allowed: human, rgb_array, or None")
        self.cfg = cfg
        self._max_cycles = cfg.max_cycles  # read every step (the config is frozen)
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
        self.layout = ObservationLayout(cfg.robot.ultrasonic.count, self._limits, cfg.robot.ultrasonic.max_range_m,
                                        ir_distance_bound(cfg.ir))
        self.observation_bounds = observation_bounds(self.layout, cfg)  # (low, high) of every agent's observation
        self._act_space = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float32)
        self._zero = np.zeros(self.layout.size, np.float32)  # a waiting agent's observation (module docstring)
        self.state_layout = StateLayout(cfg)
        self.setup = Setup(cfg, self._bodies, self._reach_m, self._arrival_slots, frozenset(self.possible_agents), self.layout,
                           self._limits, self.state_layout)
        self._seed_seq: np.random.SeedSequence | None = None
        self._renderer = None
        self.episode: Episode | None = None  # the current episode (petswarm_env/episode.py), from the first reset()
        # the experimenter's radio trace (comms/radio.py RadioTrace; evaluation/pcap.py, evaluation/replay.py):
        # every frame of each episode's medium from its reset on; None = off
        self.radio_trace = None

    # -- PettingZoo API --------------------------------------------------------------------------
    # The two Boxes are built when first asked for: gymnasium's Box formats its bounds as text when built,
    # which cost more than the rest of the env's construction (training/randomize.py builds an env of
    # every combination of its pools to size their spaces).
    @functools.cached_property
    def _obs_space(self) -> gymnasium.spaces.Box:
        return gymnasium.spaces.Box(*self.observation_bounds, dtype=np.float32)

    @functools.cached_property
    def state_space(self) -> gymnasium.spaces.Box:
        """The global state's space (:meth:`state`; petswarm_env/state.py)."""
        return gymnasium.spaces.Box(self.state_layout.low, self.state_layout.high, dtype=np.float32)

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
        self._reset_seed = seed  # named when the swarm cannot organize
        if seed is not None:
            seed = _checked_seed(seed)
            self._seed_seq = np.random.SeedSequence(seed)
        elif self._seed_seq is None:
            self._seed_seq = np.random.SeedSequence(self.cfg.seed)
        streams = self._seed_seq.spawn(1)[0].spawn(8)  # the 8th (faults) leaves the first seven as they were
        self.agents = []
        self.episode = Episode(self.setup, streams, self.radio_trace, seed=self._reset_seed)
        observations, infos = self.episode.start()
        self.agents = self._present()
        for a in self.agents[len(self.episode.agents):]:  # waiting to join (module docstring)
            observations[a], infos[a] = self._zero.copy(), dict(INFO_DEFAULTS)
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def step(self, actions: dict[str, Any]):
        if self.episode is None:
            raise RuntimeError("call reset() before step()")
        if not self.agents:
            raise RuntimeError("the episode is over (no live agents); call reset()")
        acts = self._validate(actions)
        ep = self.episode
        before = self.agents
        live = len(ep.agents)  # the episode's agents come first in self.agents (_present)
        waiting = before[live:]  # present, not (yet) in slave-role driving: their actions are ignored
        observations, rewards, terminations, truncations, infos = ep.advance(acts if live == len(acts) else acts[:live])
        truncated = ep.num_cycles >= self._max_cycles
        for a in waiting:
            if a not in rewards:  # still waiting (one that joined in this step has the episode's own entries)
                observations[a], infos[a] = self._zero.copy(), dict(INFO_DEFAULTS)
                rewards[a], terminations[a], truncations[a] = 0.0, False, truncated
        self.agents = [] if truncated else self._present()
        if not ep.steady:  # an agent that left slave-role driving in this step waits from now on (zeros)
            for a in (before if truncated else self.agents):
                if a not in observations and not terminations.get(a, False):
                    observations[a], infos[a] = self._zero.copy(), dict(INFO_DEFAULTS)
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def _present(self) -> list[str]:
        """The agents after a reset or a step: the episode's agents in slave-role driving (in the
        episode's order), then the possible agents waiting to join (in ``possible_agents`` order):
        neither an agent now nor one that left for good (a terminated agent never comes back)."""
        ep = self.episode
        agents, possible = ep.agents, self.possible_agents
        if len(agents) == len(possible) and self._possible.issuperset(agents):
            return list(agents)  # every possible agent is live (none waits)
        live, left = set(agents), ep.left
        return agents + [a for a in possible if a not in live and a not in left]  # (a new list)

    def render(self, mode: str | None = None):
        """The current frame (``rgb_array``) or the window (``human``) of the env's ``render_mode``.
        ``mode``, if given, must be that mode (RLlib's ``ParallelPettingZooEnv`` passes it)."""
        if mode is not None and mode != self.render_mode:
            raise ValueError(f"render('{mode}'): this env renders in render_mode={self.render_mode!r}; "
                             "create it with render_mode='rgb_array' or 'human'")
        if self.render_mode is None:
            gymnasium.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        self._episode_or("render()")
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
        return self._episode_or("state()").state()

    # -- pickling: between episodes --------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        """The env without its episode (the clock's SimPy processes are generators, which do not
        pickle) and without its window: the config, the spaces and the seed sequence. A copy
        (``pickle``, ``copy.deepcopy``, a worker process) has no episode until its ``reset()``; its
        next ``reset()`` without a seed gives the episode the original's next ``reset()`` gives.
        Pickle between episodes: a copy taken mid-episode does not carry the episode on."""
        return {**self.__dict__, "episode": None, "agents": [], "_renderer": None}

    # -- per step --------------------------------------------------------------------------------
    def _validate(self, actions: dict[str, Any]) -> np.ndarray:
        """Every live agent's action, checked and clipped to [-1, 1]: a new float32 array
        ``(len(agents), 3)`` in the order of ``agents``. An id that is not a possible agent is
        refused; an action for a possible agent that is not live now (it left, or has not joined)
        is ignored, as PettingZoo's own conversions do (``aec_to_parallel`` steps only the live
        agents); a live agent without an action stands still."""
        if not isinstance(actions, dict):
            raise TypeError(f"actions must be a dict agent -> array of 3 floats, got {type(actions).__name__}")
        if not self._possible.issuperset(actions):
            unknown = [a for a in actions if a not in self._possible]
            raise KeyError(f"actions for agents not in the episode: {sorted(map(str, unknown))}; live agents: {self.agents}")
        # the common case in one pass (step_kernel.py): a float numpy array of shape (3,) for every
        # agent, all finite, clipped to [-1, 1] (np.clip's values); anything else takes the loop below
        if len(actions) >= len(self.agents):
            arr = stack_actions(actions, self.agents)
            if arr is not None:
                return arr
        out = np.zeros((len(self.agents), 3), np.float32)  # a missing action means "stand still"
        for k, agent in enumerate(self.agents):
            a = actions.get(agent)
            if a is not None:
                out[k] = checked_action(agent, a)  # numbers, no boolean, shape (3,), finite (inputs.py)
        return out

    # -- the episode's views ---------------------------------------------------------------------
    @property
    def active_agents(self) -> list[str]:
        """The agents in slave-role driving (infos ``active`` 1): ``agents`` without those waiting
        to join. What the experimenter's tools and a policy that skips padding act for."""
        return list(self.episode.agents) if self.episode is not None and self.agents else []

    @property
    def truth(self):
        """The current episode's ground truth for the experimenter's tools (evaluation, metrics,
        render, the privileged teacher): :class:`petswarm_env.episode.Truth`, read-only. A policy
        never reads it."""
        return self._episode_or("truth").truth

    def _episode_or(self, what: str) -> Episode:
        if self.episode is None:
            raise RuntimeError(f"call reset() before {what}")
        return self.episode

    @property
    def num_cycles(self) -> int:
        """The steps of the current episode so far (it truncates at ``max_cycles``)."""
        return self._episode_or("num_cycles").num_cycles

    @property
    def scenario(self) -> str:
        """The current episode's scenario (drawn from ``user.scenario_pool`` when it has one)."""
        return self._episode_or("scenario").scenario

    def agent_robot(self, agent: str) -> int:
        """The robot index of ``agent`` (``robot_3`` -> 3) in this episode's world."""
        return self._episode_or("agent_robot()").agent_index[agent]

    def reference_positions(self) -> dict[int, np.ndarray]:
        """True reference position of every slave (robot index -> (x, y)): the experimenter's view
        (:meth:`.metrics.Experimenter.reference_positions`)."""
        return self._episode_or("reference_positions()").experimenter.reference_positions()

    def episode_summary(self) -> dict[str, Any]:
        """The episode's figures so far (:meth:`.metrics.Experimenter.summary`); after the last
        step, the episode's summary (it stays until the next ``reset``)."""
        return self._episode_or("episode_summary()").summary()

    def organize_summary(self) -> list[dict[str, Any]]:
        """How each user's swarm organized in this episode's reset (the join protocol, seed 000
        §3.4): ``organize_time_s``, ``join_retries``, ``members`` (member number -> robot index) and
        ``slaves_missing`` (the required slaves that did not join)."""
        return self._episode_or("organize_summary()").organize_summary()

    def scene(self):
        """A plain description of the current truth for the renderer (:meth:`.metrics.Experimenter.scene`)."""
        return self._episode_or("scene()").scene()


def _checked_seed(seed: Any) -> int:
    """``reset``'s seed: an integer ≥ 0 (Python or numpy; a boolean is not a seed)."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"reset(seed=...) takes an integer >= 0 or None, got {describe_value(seed)}")
    if seed < 0:
        raise ValueError(f"reset(seed=...) takes an integer >= 0 or None, got {int(seed)}")
    return int(seed)

