"""The batched vector env: N swarms (N episodes) stepped in one process, speaking arrays.

``petswarm_env.vector_env(num_envs, config=None, **overrides)`` holds one
:class:`~petswarm_env.episode.Episode` per copy, all of one config, and gives every copy the same
``max_agents`` slots — slot ``j`` is ``possible_agents[j]`` in every copy::

    venv = petswarm_env.vector_env(64, **{"swarm.num_slaves": 5})
    obs, infos = venv.reset(seed=0)                 # obs[num_envs, max_agents, obs_dim]
    obs, rewards, terminated, truncated, infos = venv.step(actions)   # actions[num_envs, max_agents, 3]
    venv.active                                     # [num_envs, max_agents]: the slots in slave-role driving
    venv.state()                                    # [num_envs, state_dim]: each copy's global state

- A slot is *active* while its robot is an agent of its copy's episode (slave-role driving, the
  lifecycle of :mod:`petswarm_env.episode`); an inactive slot's action is ignored and its
  observation is zeros, as :class:`~petswarm_env.wrappers.FixedAgents` pads the dict env.
- ``rewards[n, j]``, ``terminated[n, j]``, ``truncated[n, j]``: what copy ``n``'s episode gave
  agent ``j`` in this step (0 / False for a slot that did not act in it). ``terminated`` marks an
  agent whose robot went off for good in this step (one that only left slave-role driving waits:
  inactive, not terminated); ``truncated`` the agents of an episode that reached ``max_cycles``.
- **Auto-reset**: a copy whose episode is over after a step (``Episode.over``) starts its next episode in
  the same call; its row of ``obs`` and ``active`` is then the new episode's first, and
  ``infos[n]`` holds the finished episode's ``final_observation``, ``final_active`` and
  ``final_state`` (the arrays of its last step), ``episode_summary`` and ``finished_seed``, and the
  new episode's ``episode_seed``.
- **Seeds**: ``reset(seed=s)`` draws every episode's seed — each copy's first, then every
  auto-reset's, in copy order — from one generator seeded with ``s`` (``episode_seeds`` holds
  each copy's current one). Episode ``k`` of copy ``n`` is bit for bit the episode of
  ``parallel_env(...).reset(seed=episode_seeds[n])`` under the same actions: the copies share
  nothing but the config (tests/env/test_vector.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from petswarm_env.config import Config
from petswarm_env.env import PetSwarmEnv, _checked_seed
from petswarm_env.episode import Episode
from petswarm_env.step_kernel import clip_finite

SEED_BOUND = 2**31  # the episode seeds are drawn in [0, SEED_BOUND)


class VectorEnv:
    """``num_envs`` copies of the env of one config (module docstring)."""

    def __init__(self, num_envs: int, config: Config | str | None = None, **overrides: Any):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"vector_env(num_envs=...) takes an integer >= 1, got {num_envs!r}")
        # the config checks, spaces, possible agents and the episodes' shared setup are the env's own
        self.env = env = PetSwarmEnv(config, **overrides)
        self.cfg, self.setup = env.cfg, env.setup
        self.num_envs = int(num_envs)
        self.possible_agents = list(env.possible_agents)
        self.max_agents = len(self.possible_agents)
        self._slot = {a: j for j, a in enumerate(self.possible_agents)}
        self.single_observation_space = env.observation_space(self.possible_agents[0])
        self.single_action_space = env.action_space(self.possible_agents[0])
        self.state_space = env.state_space
        self.obs_dim = self.single_observation_space.shape[0]
        self.state_dim = self.state_space.shape[0]
        self.episodes: list[Episode | None] = [None] * self.num_envs
        self.episode_seeds = np.zeros(self.num_envs, np.int64)
        self.active = np.zeros((self.num_envs, self.max_agents), bool)
        self._rng: np.random.Generator | None = None
        self._rows_cache: dict[tuple, list[int]] = {}
        self._agent_rows: tuple | None = None  # (_gather)

    # -- the episodes ------------------------------------------------------------------------------
    def _next_seed(self) -> int:
        return int(self._rng.integers(SEED_BOUND))

    def _start(self, n: int, obs: np.ndarray) -> dict[str, Any]:
        """Copy ``n``'s next episode, with the next drawn seed; its first observations into ``obs[n]``."""
        seed = self._next_seed()
        # the streams of PetSwarmEnv.reset(seed): its eight, from the seed's first spawned child
        streams = np.random.SeedSequence(seed).spawn(1)[0].spawn(8)
        episode = Episode(self.setup, streams)
        observations, _ = episode.start()
        self.episodes[n], self.episode_seeds[n] = episode, seed
        self._fill(n, obs, observations, episode.agents)
        return {"episode_seed": seed}

    def _fill(self, n: int, obs: np.ndarray, observations: dict[str, np.ndarray], agents: list[str]) -> None:
        obs[n] = 0.0
        slot = self._slot
        for a, o in observations.items():
            obs[n, slot[a]] = o
        self.active[n] = False
        for a in agents:
            self.active[n, slot[a]] = True

    def _rows_of(self, n: int, agents) -> list[int]:
        """The rows ``n · max_agents + slot`` of ``agents`` (names, in their order) of copy ``n``
        (cached per copy and agent list: they change seldom)."""
        key = (n, *agents)
        rows = self._rows_cache.get(key)
        if rows is None:
            slot, base = self._slot, n * self.max_agents
            rows = self._rows_cache[key] = [base + slot[a] for a in agents]
        return rows

    def _gather(self) -> tuple[list[list[str]], np.ndarray, list[int], list[int]]:
        """The copies' agents now, the flat rows of all of them (copy ``n``'s are
        ``rows[bounds[n]:bounds[n + 1]]``), the bounds and the rows as a list; kept until an agent list changes."""
        if self._agent_rows is None:
            agents = [list(episode.agents) for episode in self.episodes]
            flat, bounds = [], [0]
            for n, names in enumerate(agents):
                flat += self._rows_of(n, names)
                bounds.append(len(flat))
            self._agent_rows = agents, np.array(flat, np.intp), bounds, flat
        return self._agent_rows

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, list[dict[str, Any]]]:
        """Every copy's next episode; the seeds drawn from ``seed`` (module docstring; None: the
        config's ``seed`` on the first reset, else the generator goes on)."""
        if options is not None:
            raise ValueError(f"vector_env.reset takes no options, got {options!r}")
        if seed is not None:
            self._rng = np.random.default_rng(_checked_seed(seed))
        elif self._rng is None:
            self._rng = np.random.default_rng(self.cfg.seed)
        obs = np.zeros((self.num_envs, self.max_agents, self.obs_dim), np.float32)
        infos = [self._start(n, obs) for n in range(self.num_envs)]
        self._agent_rows = None
        return obs, infos

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        """One control step of every copy with ``actions[num_envs, max_agents, 3]`` in [-1, 1]
        (clipped; the inactive slots' are ignored); finished copies start their next episode."""
        if self._rng is None:
            raise RuntimeError("call reset() before step()")
        acts = np.asarray(actions)
        shape = (self.num_envs, self.max_agents, 3)
        if acts.shape != shape or acts.dtype.kind not in "iuf":
            raise ValueError(f"actions must be numbers of shape {shape} (num_envs, max_agents, Vx/Vy/ω), "
                             f"got {acts.dtype} of shape {acts.shape}")
        n_envs, m = self.num_envs, self.max_agents
        # the agents' actions of every copy, in each copy's agent order, gathered by one flat index
        # (row n·m + slot of acts[n_envs·m, 3]); copy n's are the rows bounds[n]:bounds[n + 1]
        agents, flat, bounds, flat_rows = self._gather()
        picked = acts.reshape(-1, 3)[flat].astype(np.float32, copy=False)  # (a new array)
        if not clip_finite(picked):  # clipped to [-1, 1] in place (np.clip's values) when all are finite
            bad = np.argwhere(~np.isfinite(acts).all(axis=2) & self.active)[0]
            raise ValueError(f"the action of copy {bad[0]}'s {self.possible_agents[bad[1]]} contains NaN or inf; actions must be finite")
        obs = np.zeros((n_envs, m, self.obs_dim), np.float32)
        rewards = np.zeros((n_envs, m), np.float32)
        terminated = np.zeros((n_envs, m), bool)
        truncated = np.zeros((n_envs, m), bool)
        infos: list[dict[str, Any]] = [{} for _ in range(n_envs)]
        blocks, r_v, steady, changed, ended = [], [], [], False, []
        for n, episode in enumerate(self.episodes):
            # each copy's rows of picked: a slice, its own array for the episode to keep as its last actions
            lo, hi = bounds[n], bounds[n + 1]
            observations, rew, term, trunc, _ = episode.advance(picked[lo:hi], with_infos=False)  # (it reports none)
            if episode.steady:  # the common step (Episode._lifecycle): the gathered agents, none ended
                if hi > lo:  # its observations are the rows of one block, in its agents' order (Observer.observe)
                    blocks.append(next(iter(observations.values())).base)
                    r_v += rew.values()
                    steady.append(n)
            else:
                changed = True
                if self._write(n, observations, rew, term, trunc, obs, rewards, terminated, truncated):
                    ended.append((n, observations))
        if r_v:  # the steady copies' observations and rewards by one indexed assignment each
            rows = [row for n in steady for row in flat_rows[bounds[n]:bounds[n + 1]]] if changed else flat
            obs.reshape(-1, self.obs_dim)[rows] = np.concatenate(blocks)
            rewards.reshape(-1)[rows] = np.array(r_v, np.float32)
        if changed:
            self._agent_rows = None
        for n, observations in ended:
            episode = self.episodes[n]
            observed = np.zeros(m, bool)
            observed[self._rows_of(0, observations)] = True
            infos[n] = {"final_observation": obs[n].copy(), "final_active": observed, "final_state": episode.state(),
                        "episode_summary": episode.summary(), "finished_seed": int(self.episode_seeds[n])}
            infos[n].update(self._start(n, obs))  # the next episode's first row of obs and active
        return obs, rewards, terminated, truncated, infos

    def _write(self, n: int, observations: dict[str, np.ndarray], rew: dict[str, float], term: dict[str, bool],
               trunc: dict[str, bool], obs: np.ndarray, rewards: np.ndarray, terminated: np.ndarray,
               truncated: np.ndarray) -> bool:
        """Copy ``n``'s step (its ``Episode.advance``) into the arrays and ``active`` (a step whose agents
        changed); returns whether its episode is over."""
        slot = self._slot
        cols = [slot[a] for a in rew]
        rewards[n, cols] = list(rew.values())
        terminated[n, cols] = [term[a] for a in rew]
        truncated[n, cols] = [trunc[a] for a in rew]
        for a, o in observations.items():
            obs[n, slot[a]] = o
        episode = self.episodes[n]
        self.active[n] = False
        self.active[n, [slot[a] for a in episode.agents]] = True
        return episode.over

    def state(self) -> np.ndarray:
        """Every copy's global state now (``state_space``; docs/state.md): ``[num_envs, state_dim]``."""
        if self._rng is None:
            raise RuntimeError("call reset() before state()")
        return np.stack([episode.state() for episode in self.episodes])

    def close(self) -> None:
        self.episodes = [None] * self.num_envs
