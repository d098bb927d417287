"""The vector env PPO trains on: one row per possible slave of every env copy.

Two paths, one row layout (row ``n · max_agents + j`` is copy ``n``'s ``possible_agents[j]``,
zeros while that robot is not in slave-role driving):

* ``vec_env="petswarm"`` (the default where it applies): :class:`PetswarmVecEnv`, SB3's ``VecEnv``
  over :func:`petswarm_env.vector_env` — every copy's episode stepped in this process, arrays in
  and out, so the learner's forward pass and rollout buffer take the ``num_envs × max_agents`` rows
  in one call per step. It holds one config: a run with ``randomize:`` pools (each episode its drawn
  config) or ``residual_of`` (actions that correct a policy's, a PettingZoo wrapper) takes the
  SuperSuit path.
* ``vec_env="supersuit"``: ``make_vec_env`` chains :class:`petswarm_env.wrappers.FixedAgents` (every
  possible agent at every step), SuperSuit's
``pettingzoo_env_to_vec_env_v1`` (one vector row per possible slave: parameter sharing) and
``concat_vec_envs_v1`` (``num_envs`` copies over ``num_cpus`` worker processes), then
:class:`SeededVecEnv` (SB3's interface, with ``seed``) and SB3's ``VecMonitor`` (per-row episode
return and length, for ``rollout/ep_rew_mean``).

``training_env`` is the PettingZoo env under the vector: ``PetSwarmEnv`` of the training config, or
with ``randomize:`` pools a :class:`petswarm.training.randomize.RandomizedEnv` (each episode its drawn
config; ``FixedAgents`` over it is sized for the largest draw), with ``residual_of: scripted``
each action a correction of the scripted reference's (:class:`petswarm.training.residual.ResidualActions`),
and with ``ppo.critic: state`` every row followed by the global state
(:class:`petswarm.training.randomize.WithState`, MAPPO's critic input).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.spaces import Box
from stable_baselines3.common.vec_env import VecEnv, VecMonitor
from supersuit import concat_vec_envs_v1, pettingzoo_env_to_vec_env_v1
from supersuit.vector.sb3_vector_wrapper import SB3VecEnvWrapper

from petswarm_env.config import Config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.vector import VectorEnv
from petswarm_env.wrappers import FixedAgents
from petswarm.training.randomize import PoolSpaces, RandomizedEnv, WithState
from petswarm.baselines.learned import Residual
from petswarm.training.residual import ResidualActions


class SeededVecEnv(SB3VecEnvWrapper):
    """SuperSuit's SB3 wrapper plus ``seed()`` (SB3 ≥ 2.x calls it; SuperSuit lacks it): the seed
    is kept for the next ``reset``, which passes it on to the vector."""

    def __init__(self, venv):
        super().__init__(venv)
        self._next_seed: int | None = None

    def get_attr(self, attr_name: str, indices=None):
        if attr_name == "render_mode":  # SB3's wrappers ask for it (and warn on stderr without it); the vector has none
            return [None] * self.num_envs
        return super().get_attr(attr_name, indices)

    def seed(self, seed: int | None = None):
        self._next_seed = seed
        return [seed]

    def reset(self, seed=None, options=None):
        seed = self._next_seed if seed is None else seed
        self._next_seed = None
        observations, self.reset_infos = self.venv.reset(seed=seed, options=options)
        return observations


def training_env(env_cfg: Config, pools: dict | None = None, overrides: dict | None = None, with_state: bool = False,
                 spaces: PoolSpaces | None = None, residual: Residual | None = None):
    """The fixed-agents ParallelEnv of a run (module docstring): ``env_cfg``, or with ``pools`` a
    :class:`RandomizedEnv` over the ``overrides`` (the training config's ``env:``; ``spaces``
    computed once if given); with ``residual`` its actions correct that policy's; with
    ``with_state`` its rows carry the state after the observation."""
    base = RandomizedEnv(overrides or {}, pools, spaces) if pools else PetSwarmEnv(env_cfg)
    env = FixedAgents(base)
    env = ResidualActions(env, residual) if residual else env
    return WithState(env) if with_state else env


class PetswarmVecEnv(VecEnv):
    """SB3's ``VecEnv`` over :class:`petswarm_env.vector.VectorEnv` (module docstring): ``num_envs
    × max_agents`` rows, each with the rows of :class:`~petswarm_env.wrappers.FixedAgents` under
    SuperSuit — a slot's own observation while it is an agent, else zeros (``infos[row]["active"]``
    says which), its reward (0.0 when inactive), and every row of a copy done at once when the
    copy's episode ends (its next episode then starts; ``terminal_observation`` is the last row).
    As on the SuperSuit path, a truncation is a done without ``TimeLimit.truncated``. With
    ``with_state`` every row is followed by its copy's global state (MAPPO's critic input, as
    :class:`petswarm.training.randomize.WithState`)."""

    def __init__(self, env_cfg: Config, num_envs: int, with_state: bool = False):
        self.venv = VectorEnv(num_envs, env_cfg)
        v = self.venv
        self.copies, self.slots, self.with_state = v.num_envs, v.max_agents, with_state
        obs = v.single_observation_space
        if with_state:
            st = v.state_space
            obs = Box(np.concatenate([obs.low, st.low]), np.concatenate([obs.high, st.high]), dtype=np.float32)
        super().__init__(self.copies * self.slots, obs, v.single_action_space)
        self.render_mode = None
        self._next_seed: int | None = None
        self._actions: np.ndarray | None = None

    def _rows(self, obs: np.ndarray, state: np.ndarray | None = None) -> np.ndarray:
        """``obs[copies, slots, obs_dim]`` as rows (followed by each copy's ``state[copies, state_dim]``)."""
        rows = obs.reshape(obs.shape[0] * self.slots, -1)
        if not self.with_state:
            return rows
        state = self.venv.state() if state is None else state
        return np.concatenate([rows, np.repeat(state, self.slots, axis=0)], axis=1)

    def _row_infos(self) -> list[dict[str, Any]]:
        """Every row's ``{"active": 0 or 1}`` (one ``tolist`` of the mask: Python ints, no per-row conversion)."""
        return [{"active": a} for a in self.venv.active.reshape(-1).view(np.uint8).tolist()]

    def seed(self, seed: int | None = None):
        """Kept for the next ``reset`` (SB3 calls it with the model's seed): the copies' episode
        seeds are drawn from it (:mod:`petswarm_env.vector`)."""
        self._next_seed = seed
        return [seed]

    def reset(self):
        obs, _ = self.venv.reset(seed=self._next_seed)
        self._next_seed = None
        self.reset_infos = self._row_infos()
        return self._rows(obs)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions, np.float32).reshape(self.copies, self.slots, -1)

    def step_wait(self):
        obs, rewards, _, _, infos = self.venv.step(self._actions)
        ended = np.array(["final_observation" in i for i in infos])
        dones = np.repeat(ended, self.slots)
        out = self._rows(obs)
        row_infos = self._row_infos()
        for n in np.flatnonzero(ended):
            info = infos[n]
            last = info["final_observation"][None]
            final = self._rows(last, info["final_state"][None]) if self.with_state else last.reshape(self.slots, -1)
            for j in range(self.slots):
                row = row_infos[n * self.slots + j]
                row["terminal_observation"] = final[j]
                row["active"] = int(info["final_active"][j])
        return out, rewards.reshape(-1), dones, row_infos

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        value = None if attr_name == "render_mode" else getattr(self.venv, attr_name)
        return [value] * len(self._get_indices(indices))

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        raise AttributeError(f"the petswarm vector env's rows share one env: cannot set {attr_name!r} per row")

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        raise AttributeError(f"the petswarm vector env's rows share one env: no per-row method {method_name!r}")

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False] * len(self._get_indices(indices))


VEC_ENVS = ("petswarm", "supersuit")


def make_vec_env(env_cfg: Config, num_envs: int, num_cpus: int, seed: int, pools: dict | None = None,
                 overrides: dict | None = None, with_state: bool = False, residual: Residual | None = None,
                 vec_env: str = "petswarm") -> VecMonitor:
    """An SB3 VecEnv (one row per slave per copy), seeded with ``seed`` (``pools``, ``overrides``,
    ``with_state``, ``residual``: :func:`training_env`): ``vec_env="petswarm"`` the batched vector
    env in this process (``num_cpus`` unused), unless the run has pools or a residual (module
    docstring); ``"supersuit"`` SuperSuit's pipeline over ``num_cpus`` worker processes."""
    if vec_env not in VEC_ENVS:
        raise ValueError(f"unknown vec env '{vec_env}'; choose {' or '.join(VEC_ENVS)}")
    if vec_env == "petswarm" and not pools and residual is None:
        venv = PetswarmVecEnv(env_cfg, num_envs, with_state)
        venv.seed(seed)
        return VecMonitor(venv)
    spaces = PoolSpaces.of(overrides or {}, pools) if pools else None
    vec = pettingzoo_env_to_vec_env_v1(training_env(env_cfg, pools, overrides, with_state, spaces, residual))
    vec = concat_vec_envs_v1(vec, num_envs, num_cpus=num_cpus, base_class="gymnasium")
    venv = SeededVecEnv(vec)
    venv.seed(seed)
    return VecMonitor(venv)
