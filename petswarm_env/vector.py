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
  agent that left slave-role driving in this step; ``truncated`` the agents of an episode that
  reached ``max_cycles``.
- **Auto-reset**: a copy whose episode has no agent left after a step starts its next episode in
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

SEED_BOUND = 2**31  # the episode seeds are drawn in [0, SEED_BOUND)


class _Gathered:
    """(copy, slot) -> value entries of one step, for one indexed write per array."""

    __slots__ = ("copies", "slots", "items")

    def __init__(self):
        self.copies: list[int] = []
        self.slots: list[int] = []
        self.items: list = []

    def add(self, n: int, j: int, value) -> None:
        self.copies.append(n)
        self.slots.append(j)
        self.items.append(value)


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
        acts = acts.astype(np.float32)
        if not np.isfinite(acts[self.active]).all():
            bad = np.argwhere(~np.isfinite(acts).all(axis=2) & self.active)[0]
            raise ValueError(f"the action of copy {bad[0]}'s {self.possible_agents[bad[1]]} contains NaN or inf; actions must be finite")
        np.minimum(acts, 1.0, out=acts)  # clipped to [-1, 1] (np.clip's values, without its wrapper)
        np.maximum(acts, -1.0, out=acts)
        n_envs, m = self.num_envs, self.max_agents
        obs = np.zeros((n_envs, m, self.obs_dim), np.float32)
        rewards = np.zeros((n_envs, m), np.float32)
        terminated = np.zeros((n_envs, m), bool)
        truncated = np.zeros((n_envs, m), bool)
        infos: list[dict[str, Any]] = [{} for _ in range(n_envs)]
        slot = self._slot
        # every copy's results gathered as (copy, slot) lists and written with one indexed
        # assignment per array after the loop (a numpy item write per agent costs more)
        at, values, ended = _Gathered(), _Gathered(), []
        for n, episode in enumerate(self.episodes):
            row = acts[n]
            observations, rew, term, trunc, _ = episode.advance(row[[slot[a] for a in episode.agents]])  # (a new array)
            for a, r in rew.items():
                at.add(n, slot[a], (r, term[a], trunc[a]))
            for a, o in observations.items():
                values.add(n, slot[a], o)
            if not episode.agents:  # the episode is over: its last arrays below, then the next episode
                ended.append((n, observations))
        if at.copies:
            r, te, tr = zip(*at.items)
            rewards[at.copies, at.slots], terminated[at.copies, at.slots], truncated[at.copies, at.slots] = r, te, tr
        if values.copies:
            obs[values.copies, values.slots] = values.items
        self.active[:] = False
        live = _Gathered()
        for n, episode in enumerate(self.episodes):
            for a in episode.agents:
                live.add(n, slot[a], True)
        for n, observations in ended:
            episode = self.episodes[n]
            observed = np.zeros(m, bool)
            observed[[slot[a] for a in observations]] = True
            infos[n] = {"final_observation": obs[n].copy(), "final_active": observed, "final_state": episode.state(),
                        "episode_summary": episode.summary(), "finished_seed": int(self.episode_seeds[n])}
            infos[n].update(self._start(n, obs))  # the next episode's first row of obs and active
        if live.copies:
            self.active[live.copies, live.slots] = True
        return obs, rewards, terminated, truncated, infos

    def state(self) -> np.ndarray:
        """Every copy's global state now (``state_space``; docs/state.md): ``[num_envs, state_dim]``."""
        if self._rng is None:
            raise RuntimeError("call reset() before state()")
        return np.stack([episode.state() for episode in self.episodes])

    def close(self) -> None:
        self.episodes = [None] * self.num_envs
