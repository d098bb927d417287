"""petswarm_v0 — a PettingZoo ``ParallelEnv`` of a Pet-Bot swarm accompanying a walking user.

One master robot accompanies the user; the other robots (the *agents*) are the slaves that joined
its swarm through the join protocol of seed 000 and keep a leader–follower formation. Every robot
runs the swarm middleware on one discrete-event clock: radio frames on a shared 802.15.4-like
medium, the IR token ring with heading exchange, the master's status broadcast.

``reset(seed)`` builds the world and runs the organize phase on the clock (its duration and
retries are in ``infos[agent]["organize"]``); the agents are the robots that joined. Each
``step(actions)`` applies the slaves' body-frame commands, the master's controller, and runs the
clock for one control period (0.1 s). Observations come from each slave's middleware only
(:mod:`petswarm_env.observe`); rewards and metrics from ground truth (:mod:`petswarm_env.reward`).

Spaces: observation ``Box(-inf, inf, (N,), float32)`` with values scaled to about [-1, 1]
(N = 57 with 8 ultrasonic sensors), action ``Box(-1, 1, (3,), float32)`` = (Vx, Vy, ω) scaled by
``robot.max_speed_mps`` and ``robot.max_omega_rps``. Episodes truncate after ``max_cycles`` steps.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium
import numpy as np
from pettingzoo import ParallelEnv

from petswarm_env.comms.ir_channel import IRChannel
from petswarm_env.comms.radio import RadioMedium
from petswarm_env.config import Config, flatten_dotted, load_config
from petswarm_env.control.master import MasterController
from petswarm_env.metrics import EpisodeMetrics
from petswarm_env.middleware.swarm import Swarm
from petswarm_env.observe import OBS_VERSION, ObservationLayout, build_observation
from petswarm_env.reward import slave_reward
from petswarm_env.sim.scenarios import ScenarioScript, build_scenario
from petswarm_env.sim.world import World

ENV_NAME = "petswarm_v0"
OTHER_USER_ID = 99  # the user that "other user" robots are connected to (Table 1)
SWARM_PAN = 0x1001


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


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
        n_candidates = cfg.swarm.num_slaves + cfg.swarm.extra_robots
        self.possible_agents = [f"robot_{i}" for i in range(1, n_candidates + 1)]
        self.agents: list[str] = []
        self.layout = ObservationLayout(cfg.robot.ultrasonic.count)
        self._obs_space = gymnasium.spaces.Box(-np.inf, np.inf, (self.layout.size,), np.float32)
        self._act_space = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float32)
        self._limits = (cfg.robot.max_speed_mps, cfg.robot.max_speed_mps, cfg.robot.max_omega_rps)
        self._seed_seq: np.random.SeedSequence | None = None
        self._renderer = None
        self.world: World | None = None
        self.swarm: Swarm | None = None

    # -- PettingZoo API --------------------------------------------------------------------------
    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        return self._obs_space

    def action_space(self, agent: str) -> gymnasium.spaces.Box:
        return self._act_space

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._seed_seq = np.random.SeedSequence(seed)
        elif self._seed_seq is None:
            self._seed_seq = np.random.SeedSequence(self.cfg.seed)
        streams = self._seed_seq.spawn(1)[0].spawn(6)
        rng_world, rng_radio, rng_ir, rng_swarm, rng_sensors, rng_script = (np.random.default_rng(s) for s in streams)
        self._rng_sensors = rng_sensors
        cfg = self.cfg
        pool = cfg.user.scenario_pool
        self.scenario = pool[int(rng_script.integers(len(pool)))] if pool else cfg.user.scenario
        script = ScenarioScript(build_scenario(self.scenario, cfg.user, rng_script))
        self.world = world = World(cfg, script)
        self._place_robots(world, rng_world)
        self.radio = RadioMedium(world.clock, cfg.radio, rng_radio)
        self.ir_channel = IRChannel(world, cfg.ir, rng_ir)
        pool = [r.index for r in world.robots[1:]]
        self.swarm = swarm = Swarm(cfg, world, self.radio, self.ir_channel, rng_swarm, 0, SWARM_PAN, 0, pool)
        for idx in self._other_user_robots:
            swarm.nodes[idx].connected_user = OTHER_USER_ID
        self.master_ctrl = MasterController(cfg)
        for robot, ss in zip(world.robots, rng_world.spawn(len(world.robots))):
            robot.ahrs_rng = ss

        swarm.start_organize()
        limit = int(math.ceil(cfg.protocol.organize_timeout_s / cfg.control_period_s))
        for _ in range(limit):
            world.advance(cfg.physics_substeps)
            if swarm.organized:
                break
        if not swarm.organized or not swarm.slave_ids():
            raise RuntimeError(
                f"the swarm did not organize within protocol.organize_timeout_s={cfg.protocol.organize_timeout_s} s "
                f"(radio.loss_prob={cfg.radio.loss_prob}); raise the timeout or protocol.max_retries"
            )
        self._slave_ids = swarm.slave_ids()
        self.agents = [f"robot_{i}" for i in self._slave_ids]
        self._agent_index = {a: i for a, i in zip(self.agents, self._slave_ids)}
        formation = swarm.formation
        slots = formation.slot_positions()
        self._offset_from_master = {m: (float(slots[m][0]), float(slots[m][1])) for m in range(formation.size)}
        self._formation_depth_m = -float(slots[:, 0].min())
        user_f = (cfg.master.distance_m, 0.0) if cfg.swarm.mode == "following" else (-self._formation_depth_m - cfg.master.distance_m, 0.0)
        self._levels = formation.hierarchy_levels(user_f)
        self._last_action = {a: np.zeros(3, np.float32) for a in self.agents}
        self._obs_buf = {a: np.zeros(self.layout.size, np.float32) for a in self.agents}
        self._contacts_seen = dict(world.collisions.per_robot)
        self._collisions_at_start = (world.collisions.robot_robot, world.collisions.robot_user, world.collisions.robot_wall)
        self.metrics = EpisodeMetrics(
            organize_time_s=swarm.organize_result.elapsed_s, join_retries=swarm.organize_result.retries
        )
        self._radio_at_start = (self.radio.stats.frames_sent, self.radio.stats.frames_lost, self.radio.stats.frames_collided)
        world.user.walking = True
        self.num_cycles = 0
        observations = self._observe()
        org = {
            "organize_time_s": swarm.organize_result.elapsed_s,
            "join_retries": swarm.organize_result.retries,
            "members": dict(swarm.organize_result.members),
        }
        infos = {a: {"member": swarm.nodes[self._agent_index[a]].know.member, "organize": org} for a in self.agents}
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def step(self, actions: dict[str, Any]):
        if self.world is None:
            raise RuntimeError("call reset() before step()")
        if not self.agents:
            raise RuntimeError("the episode is over (all agents truncated); call reset()")
        cfg = self.cfg
        world = self.world
        acts = self._validate(actions)
        for agent, a in acts.items():
            world.robots[self._agent_index[agent]].set_command(a[0] * self._limits[0], a[1] * self._limits[1], a[2] * self._limits[2])
        self._drive_master()
        world.advance(cfg.physics_substeps)
        self.num_cycles += 1

        errors, heading_errs = self._formation_errors()
        rewards = {}
        per_robot = world.collisions.per_robot
        infos = {}
        for agent in self.agents:
            idx = self._agent_index[agent]
            new_contacts = per_robot.get(idx, 0) - self._contacts_seen.get(idx, 0)
            self._contacts_seen[idx] = per_robot.get(idx, 0)
            rewards[agent] = slave_reward(cfg.reward, errors[agent], heading_errs[agent], new_contacts, acts[agent], self._last_action[agent])
            infos[agent] = {"formation_error_m": errors[agent], "new_contacts": new_contacts}
            self._last_action[agent] = acts[agent]
        self.metrics.add_step(list(errors.values()))
        observations = self._observe()
        truncated = self.num_cycles >= cfg.max_cycles
        terminations = {a: False for a in self.agents}
        truncations = {a: truncated for a in self.agents}
        if truncated:
            for a in self.agents:
                infos[a]["episode_summary"] = self.episode_summary()
            self.agents = []
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def render(self):
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

    # -- construction ----------------------------------------------------------------------------
    def _place_robots(self, world: World, rng: np.random.Generator) -> None:
        """Master 1 m from the user; waiting robots around their formation slots (jittered);
        extra candidates farther out; robots of another user to the side."""
        cfg = self.cfg
        from petswarm_env.middleware.formation import build_formation

        d = cfg.master.distance_m
        n = cfg.swarm.num_slaves
        leading = cfg.swarm.mode == "leading"
        slots = build_formation(cfg.swarm, n + 1).slot_positions()
        depth = -float(slots[:, 0].min())
        master_pos = np.array([d + depth, 0.0]) if leading else np.array([-d, 0.0])
        world.add_robot(master_pos, 0.0)
        jitter = cfg.swarm.spawn_jitter_m
        for m in range(1, n + 1):
            offset = rng.uniform(-jitter, jitter, 2)
            world.add_robot(master_pos + slots[m] + offset, float(rng.uniform(-0.3, 0.3)))
        for k in range(cfg.swarm.extra_robots):
            side = 1.0 if k % 2 == 0 else -1.0
            world.add_robot(master_pos + np.array([-depth - 0.8 - 0.6 * (k // 2), side * 1.6]), 0.0)
        self._other_user_robots = []
        for k in range(cfg.swarm.other_user_robots):
            r = world.add_robot(master_pos + np.array([0.6 * k, -1.8 - 0.2 * (k % 2)]) * np.array([-1, 1]), 0.0)
            self._other_user_robots.append(r.index)

    # -- per step --------------------------------------------------------------------------------
    def _validate(self, actions: dict[str, Any]) -> dict[str, np.ndarray]:
        if not isinstance(actions, dict):
            raise TypeError(f"actions must be a dict agent -> array of 3 floats, got {type(actions).__name__}")
        unknown = set(actions) - set(self.agents)
        if unknown:
            raise KeyError(f"actions for agents not in the episode: {sorted(unknown)}; live agents: {self.agents}")
        out = {}
        for agent in self.agents:
            a = actions.get(agent)
            if a is None:
                out[agent] = np.zeros(3, np.float32)  # a missing action means "stand still"
                continue
            arr = np.asarray(a, dtype=np.float32)
            if arr.shape != (3,):
                raise ValueError(f"action of {agent} must have shape (3,) = (Vx, Vy, ω) in [-1, 1], got shape {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"action of {agent} contains NaN or inf: {arr.tolist()}; actions must be finite")
            out[agent] = np.clip(arr, -1.0, 1.0)
        return out

    def _drive_master(self) -> None:
        swarm, world = self.swarm, self.world
        swarm.sense_user()
        master = world.robots[swarm.master.node_id]
        cmd = self.master_ctrl.command(swarm.user_estimate, self._odometry(master.index), self.cfg.swarm.mode,
                                       self.cfg.control_period_s, self._formation_depth_m)
        master.set_command(*cmd)

    def _odometry(self, index: int) -> tuple[float, float, float]:
        vx, vy, w = self.world.robots[index].velocity_body
        k = self.cfg.robot.odometry_noise_rel
        if k > 0:
            e = self._rng_sensors.normal(0.0, k, 3)
            return vx * (1 + e[0]), vy * (1 + e[1]), w * (1 + e[2])
        return vx, vy, w

    def _observe(self) -> dict[str, np.ndarray]:
        world = self.world
        now = world.now
        indices = [self._agent_index[a] for a in self.agents]
        ranges = world.ultrasonic_ranges(indices, self._rng_sensors)
        obs = {}
        for k, agent in enumerate(self.agents):
            idx = indices[k]
            node = self.swarm.nodes[idx]
            member = node.know.member
            obs[agent] = build_observation(
                self.layout,
                self._obs_buf[agent],
                node,
                now,
                self._odometry(idx),
                self.world.robots[idx].ahrs_yaw(now),
                self._last_action[agent],
                ranges[k],
                self._levels.get(member, 0),
                self._offset_from_master.get(member, (0.0, 0.0)),
                self._limits,
                self.cfg.robot.ultrasonic.max_range_m,
            ).copy()
        return obs

    def reference_positions(self) -> dict[int, np.ndarray]:
        """True reference position of every slave (robot index -> (x, y)): the experimenter's view."""
        swarm, world = self.swarm, self.world
        members = swarm.master.know.members
        th = world.robots[swarm.master.node_id].heading
        c, s = math.cos(th), math.sin(th)
        out = {}
        for idx in self._slave_ids:
            node = swarm.nodes[idx]
            pts = []
            for link in swarm.formation.links.get(node.know.member, ()):
                nx, ny = world.robots[members[link.neighbour]].position
                ox, oy = link.offset_m
                pts.append((nx + c * ox - s * oy, ny + s * ox + c * oy))
            out[idx] = np.mean(np.array(pts), axis=0)
        return out

    def _formation_errors(self) -> tuple[dict[str, float], dict[str, float]]:
        refs = self.reference_positions()
        th_f = self.world.robots[self.swarm.master.node_id].heading
        errors, heading = {}, {}
        for agent in self.agents:
            idx = self._agent_index[agent]
            x, y = self.world.robots[idx].position
            rx, ry = refs[idx]
            errors[agent] = math.hypot(x - rx, y - ry)
            heading[agent] = _wrap(self.world.robots[idx].heading - th_f)
        return errors, heading

    # -- reporting -------------------------------------------------------------------------------
    def episode_summary(self) -> dict[str, Any]:
        c = self.world.collisions
        c0 = self._collisions_at_start
        st = self.radio.stats
        r0 = self._radio_at_start
        m = self.metrics
        return {
            "scenario": self.scenario,
            "steps": m.steps,
            "formation_rmse_m": m.formation_rmse_m,
            "collisions": {
                "robot_robot": c.robot_robot - c0[0],
                "robot_user": c.robot_user - c0[1],
                "robot_wall": c.robot_wall - c0[2],
            },
            "organize_time_s": m.organize_time_s,
            "join_retries": m.join_retries,
            "token_recoveries": self.swarm.token_recoveries(),
            "frames": {"sent": st.frames_sent - r0[0], "lost": st.frames_lost - r0[1], "collided": st.frames_collided - r0[2]},
            "foreign_pan_frames_processed": self.swarm.foreign_pan_frames_processed(),
            "slaves": len(self._slave_ids),
        }

    def scene(self):
        """A plain description of the current truth for the renderer."""
        from petswarm_env.render import RobotView, Scene

        world, swarm = self.world, self.swarm
        members = swarm.master.know.members
        robots = []
        for r in world.robots:
            node = swarm.nodes.get(r.index)
            role = "master" if r.index == swarm.master.node_id else "slave" if r.index in self._slave_ids else "waiting"
            if r.index in self._other_user_robots:
                role = "other"
            label = str(node.know.member) if node is not None and node.know.member >= 0 else f"r{r.index}"
            robots.append(RobotView(r.position, r.heading, self.cfg.robot.radius_m, role, label))
        links = []
        if swarm.formation is not None:
            for m, lks in swarm.formation.links.items():
                for lk in lks:
                    if m in members and lk.neighbour in members:
                        links.append((world.robots[members[lk.neighbour]].position, world.robots[members[m]].position))
        refs = [tuple(p) for p in self.reference_positions().values()]
        err = self.metrics.error_trace[-1] if self.metrics.error_trace else float("nan")
        text = [
            f"scenario {self.scenario}   formation {self.cfg.swarm.formation}   mode {self.cfg.swarm.mode}",
            f"step {self.num_cycles}/{self.cfg.max_cycles}   mean formation error {err:.2f} m",
        ]
        return Scene(
            time_s=world.now,
            user_position_m=world.user.position,
            user_heading_rad=world.user.heading,
            user_radius_m=self.cfg.user.radius_m,
            robots=robots,
            links=links,
            references_m=refs,
            walls=list(world.wall_segments[:4]) if self.cfg.world.arena_m[0] > 0 else [],
            boxes=[(tuple(b.center_m), tuple(b.size_m)) for b in self.cfg.world.obstacles],
            text=text,
        )

