"""Domain randomization: each training episode draws its environment configuration from pools.

``randomize:`` in the training config (``configs/train/ppo.yaml``) maps a dotted key of the
environment config (``swarm.formation``, ``swarm.num_slaves``, ``radio.loss_prob``, …: any key of
``configs/default.yaml``) to a list of values; every episode draws one value of each pool, seeded,
over the ``env:`` overrides. A pool entry that is a mapping of dotted keys is drawn as one bundle
(``{swarm.formation: custom, swarm.custom_links: [...]}``, ``{user.scenario: mode_change,
user.scenario_pool: []}``); a pool whose entries are all bundles may have any name (a label).
Repeating a value weights it.

- :func:`check_pools` validates the pools (an unknown key, an empty pool, a value the env config
  refuses: a one-line :class:`~petswarm_env.config.ConfigError` naming the pool and the value),
  then every combination of the pools (each must build an env; the spaces are their union).
- :func:`draw` is the draw of one episode: a function of the pools and the episode's seed only.
- :class:`RandomizedEnv` is the ParallelEnv over the drawn configs: its agents are the union of
  every combination's possible agents (so :class:`~petswarm_env.wrappers.FixedAgents` over it is
  sized for the largest draw), its observation bounds the union of theirs, its state
  (``state()``) every combination's state laid into the largest one's blocks (robots, users, the
  clock; an absent robot's block is zeros, its role one-hot empty). ``reset(seed=s)`` draws with
  ``s`` and resets the drawn env with ``s``: the episode is the same as ``PetSwarmEnv(draw_config)``
  reset with ``s``. An unseeded reset (a vector env's auto-reset) takes the next seed of a stream
  started by the last seeded reset.
"""

from __future__ import annotations

import itertools
import json
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, Mapping

import gymnasium
import numpy as np
from pettingzoo import ParallelEnv

from pydantic import ValidationError

from petswarm_env.config import (Config, ConfigError, describe_value, flatten_dotted, format_validation_error, load_config,
                                 merge_mappings, nest_dotted)
from petswarm_env.env import PetSwarmEnv
from petswarm_env.state import GLOBAL_BLOCK, ROBOT_BLOCK, USER_BLOCK

MAX_COMBINATIONS = 4096  # every combination of the pools is built once to check it and to size the spaces
DRAW_SALT = 0xD0_4A1  # the draw's stream is (seed, DRAW_SALT): independent of the env's own streams of the same seed
CACHE = 6  # drawn envs kept for reuse (one per distinct config)


class _Configs:
    """Validated configs of ``env`` overrides plus a draw's, without re-reading the defaults' YAML
    each time (the same result as ``load_config(overrides={**env, **over})``)."""

    def __init__(self, env: Mapping[str, Any]):
        self.base = load_config(overrides=dict(env)).to_dict()

    def __call__(self, over: Mapping[str, Any]) -> Config:
        try:
            return Config.model_validate(merge_mappings(self.base, nest_dotted(dict(over))))
        except ValidationError as exc:
            raise ConfigError(format_validation_error(exc)) from None


def _entries(name: str, pool: Any) -> list[dict[str, Any]]:
    """A pool as a list of override dicts (a value of the pool's key, or a bundle)."""
    if not isinstance(pool, list) or not pool:
        raise ConfigError(f"randomize.{name}: a pool must be a non-empty list of values, got {describe_value(pool)}")
    return [dict(v) if isinstance(v, Mapping) else {name: v} for v in pool]


def check_pools(env: Mapping[str, Any], pools: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Validate ``pools`` over the ``env`` overrides; return every combination's overrides (the
    ``env`` overrides then one entry of each pool, in the pools' order). Raises a one-line
    :class:`ConfigError` naming the pool, the key and the value of the first problem."""
    known = flatten_dotted(load_config(overrides=dict(env)).to_dict())
    entries = {}
    for name, pool in pools.items():
        entries[name] = _entries(name, pool)
        for entry in entries[name]:
            for key in entry:
                if key not in known:
                    why = "" if any(isinstance(v, Mapping) for v in pool) else " (or make its entries bundles of dotted keys)"
                    raise ConfigError(f"randomize.{name}: unknown env config key '{key}'; use a dotted key of "
                                      f"configs/default.yaml such as swarm.num_slaves{why}")
            try:
                load_config(overrides={**env, **entry})
            except ConfigError as exc:
                raise ConfigError(f"randomize.{name}: entry {describe_value(entry if len(entry) > 1 else next(iter(entry.values())))}"
                                  f" is refused: {exc}") from None
    count = int(np.prod([len({json.dumps(e, sort_keys=True) for e in v}) for v in entries.values()])) if entries else 1
    if count > MAX_COMBINATIONS:
        raise ConfigError(f"randomize: the pools make {count} distinct combinations, more than {MAX_COMBINATIONS} (each is "
                          "checked once); use fewer values or bundles")
    unique = [list({json.dumps(e, sort_keys=True): e for e in v}.values()) for v in entries.values()]
    combos = []
    for parts in itertools.product(*unique):
        over = dict(env)
        for part in parts:
            over.update(part)
        combos.append(over)
    return combos


def draw(env: Mapping[str, Any], pools: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """The overrides of the episode with ``seed``: ``env``, then one entry of each pool (in the
    pools' order), drawn from the stream (seed, DRAW_SALT). Same seed, same draw."""
    rng = np.random.default_rng([int(seed), DRAW_SALT])
    over = dict(env)
    for name, pool in pools.items():
        entries = _entries(name, pool)
        over.update(entries[int(rng.integers(len(entries)))])
    return over


def draw_config(env: Mapping[str, Any], pools: Mapping[str, Any], seed: int) -> Config:
    """:func:`draw` as a validated environment config."""
    return load_config(overrides=draw(env, pools, seed))


@dataclass
class PoolSpaces:
    """What every combination of the pools shares: the union of the possible agents (robot index
    order), of the observation bounds, and the largest robot and user counts of the state."""

    agents: list[str]
    obs_low: np.ndarray
    obs_high: np.ndarray
    layout_signature: tuple
    max_robots: int
    max_users: int

    @classmethod
    def of(cls, env: Mapping[str, Any], pools: Mapping[str, Any]) -> PoolSpaces:
        agents: set[str] = set()
        low = high = sig = None
        max_robots = max_users = 0
        configs = _Configs(env)
        for over in check_pools(env, pools):
            try:
                e = PetSwarmEnv(configs(over))
            except (ConfigError, ValueError) as exc:
                varied = {k: v for k, v in over.items() if env.get(k, object()) != v}
                raise ConfigError(f"randomize: the combination {describe_value(varied, 200)} does not build an env: {exc}") from None
            s = e.layout.signature()
            if sig is not None and tuple(s) != sig:
                raise ConfigError(f"randomize: the combination {describe_value(over, 200)} changes the observation layout "
                                  "(e.g. robot.ultrasonic.count); a pool may not change the observation's size")
            sig = tuple(s)
            e_low, e_high = e.observation_bounds
            low = e_low if low is None else np.minimum(low, e_low)
            high = e_high if high is None else np.maximum(high, e_high)
            agents.update(e.possible_agents)
            max_robots = max(max_robots, e.state_layout.num_robots)
            max_users = max(max_users, e.state_layout.num_users)
        return cls(sorted(agents, key=lambda a: int(a.split("_")[1])), low, high, sig, max_robots, max_users)

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        parts = [ROBOT_BLOCK.bounds()] * self.max_robots + [USER_BLOCK.bounds()] * self.max_users + [GLOBAL_BLOCK.bounds()]
        return (np.concatenate([p[0] for p in parts]).astype(np.float32),
                np.concatenate([p[1] for p in parts]).astype(np.float32))


class RandomizedEnv(ParallelEnv):
    """A ParallelEnv whose every episode runs a :class:`PetSwarmEnv` of the drawn config (module
    docstring). ``spaces`` is :meth:`PoolSpaces.of` (computed once and shared by the copies)."""

    metadata = dict(PetSwarmEnv.metadata)

    def __init__(self, env: Mapping[str, Any], pools: Mapping[str, Any], spaces: PoolSpaces | None = None,
                 render_mode: str | None = None):
        self.env_overrides, self.pools = dict(env), dict(pools)
        self.spaces = spaces or PoolSpaces.of(env, pools)
        self.render_mode = render_mode
        self.possible_agents = list(self.spaces.agents)
        self._obs_space = gymnasium.spaces.Box(self.spaces.obs_low, self.spaces.obs_high, dtype=np.float32)
        self._act_space = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.state_space = gymnasium.spaces.Box(*self.spaces.state_bounds(), dtype=np.float32)
        self._envs: OrderedDict[str, PetSwarmEnv] = OrderedDict()
        self._configs: _Configs | None = None
        self._stream: np.random.Generator | None = None
        self.current: PetSwarmEnv | None = None
        self.drawn: dict[str, Any] = {}
        self.agents: list[str] = []

    def observation_space(self, agent: str):
        return self._obs_space

    def action_space(self, agent: str):
        return self._act_space

    def _env_for(self, over: dict[str, Any]) -> PetSwarmEnv:
        key = json.dumps(over, sort_keys=True, default=str)
        if key in self._envs:
            self._envs.move_to_end(key)
        else:
            if self._configs is None:
                self._configs = _Configs(self.env_overrides)
            self._envs[key] = PetSwarmEnv(self._configs(over), render_mode=self.render_mode)
            while len(self._envs) > CACHE:
                self._envs.popitem(last=False)[1].close()
        return self._envs[key]

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._stream = np.random.default_rng([int(seed), DRAW_SALT, 1])
        else:
            if self._stream is None:
                self._stream = np.random.default_rng([0, DRAW_SALT, 1])
            seed = int(self._stream.integers(2**31 - 1))
        self.drawn = draw(self.env_overrides, self.pools, seed)
        self.current = self._env_for(self.drawn)
        self.episode_seed = seed
        obs, infos = self.current.reset(seed=seed, options=options)
        self.agents = list(self.current.agents)
        return obs, infos

    def step(self, actions: dict[str, Any]):
        out = self.current.step(actions)
        self.agents = list(self.current.agents)
        return out

    def state(self) -> np.ndarray:
        """The drawn env's state in the largest combination's blocks (module docstring)."""
        inner = self.current.state()
        lay, sp = self.current.state_layout, self.spaces
        out = np.zeros(self.state_space.shape, np.float32)
        out[:lay.users_at] = inner[:lay.users_at]
        users_at = sp.max_robots * ROBOT_BLOCK.size
        out[users_at:users_at + lay.num_users * USER_BLOCK.size] = inner[lay.users_at:lay.global_at]
        out[-GLOBAL_BLOCK.size:] = inner[lay.global_at:]
        return out

    def render(self, mode: str | None = None):
        return self.current.render() if mode is None else self.current.render(mode)

    def close(self):
        for e in self._envs.values():
            e.close()
        self._envs.clear()

    def __getattr__(self, name: str):  # cfg, layout, truth, episode_summary(), …: the drawn env's
        if name.startswith("_") or "current" not in self.__dict__ or self.__dict__["current"] is None:
            raise AttributeError(name)
        return getattr(self.__dict__["current"], name)

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_envs"] = OrderedDict()  # rebuilt on demand
        state["_configs"] = None
        state["current"] = None
        return state


class WithState(ParallelEnv):
    """Every agent's observation followed by the global state (``state()``): the input of a
    centralized critic (MAPPO's agent-specific global state). The actor reads only the first
    ``obs_size`` values (:class:`petswarm.training.state_critic.StateCriticPolicy`)."""

    def __init__(self, env):
        self.env = env
        self.possible_agents = list(env.possible_agents)
        self.metadata = getattr(env, "metadata", {})
        self.render_mode = getattr(env, "render_mode", None)
        obs = env.observation_space(self.possible_agents[0])
        st = env.state_space
        self.obs_size = obs.shape[0]
        self._space = gymnasium.spaces.Box(np.concatenate([obs.low, st.low]), np.concatenate([obs.high, st.high]),
                                           dtype=np.float32)
        self.state_space = st
        self.agents: list[str] = []

    def observation_space(self, agent: str):
        return self._space

    def action_space(self, agent: str):
        return self.env.action_space(agent)

    def _with(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        s = np.asarray(self.env.state(), np.float32)
        return {a: np.concatenate([o, s]) for a, o in obs.items()}

    def reset(self, seed: int | None = None, options: dict | None = None):
        obs, infos = self.env.reset(seed=seed, options=options)
        self.agents = list(self.env.agents)
        return self._with(obs), infos

    def step(self, actions):
        obs, rew, term, trunc, infos = self.env.step(actions)
        self.agents = list(self.env.agents)
        return self._with(obs), rew, term, trunc, infos

    def state(self):
        return self.env.state()

    def render(self, mode: str | None = None):
        return self.env.render() if mode is None else self.env.render(mode)

    def close(self):
        self.env.close()

    def __getattr__(self, name: str):  # cfg, layout, episode_summary(), …: the env's
        if name.startswith("_") or "env" not in self.__dict__:
            raise AttributeError(name)
        return getattr(self.__dict__["env"], name)
