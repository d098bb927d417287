"""TorchRL over the batched vector env: :class:`PetswarmTorchRLEnv`, an ``EnvBase`` whose batch is
the ``num_envs`` copies of :func:`petswarm_env.vector_env` (the ``torchrl`` extra)::

    from petswarm.training.torchrl_env import PetswarmTorchRLEnv
    env = PetswarmTorchRLEnv(64, max_cycles=300)          # batch_size [64]
    td = env.rollout(100, policy)                          # or torchrl.collectors.Collector(env, policy, ...)

The layout is VMAS's in TorchRL: one agent group, ``"robot"`` (the slots ``possible_agents``),
- ``("robot", "observation")`` ``[num_envs, max_agents, obs_dim]`` (zeros for an inactive slot),
- ``("robot", "action")`` ``[num_envs, max_agents, 3]`` in [-1, 1] (an inactive slot's is ignored),
- ``("robot", "reward")`` ``[num_envs, max_agents, 1]``,
- ``("robot", "mask")`` ``[num_envs, max_agents]``: the slots in slave-role driving (``vector_env.active``),
- ``"state"`` ``[num_envs, state_dim]`` (``return_state=True``): ``state()``, a centralized critic's input,
- ``"done"``, ``"terminated"``, ``"truncated"`` ``[num_envs, 1]``: a copy's episode is over (``Episode.over``: every robot off for good;
  truncated when it reached ``max_cycles``).

The vector env starts a finished copy's next episode inside its own ``step``; here the step returns
the finished episode's last observation (its ``final_observation``) with ``done`` set, and the
partial reset that TorchRL's collectors then ask for (``"_reset"``) hands out the new episode's first
observation: nothing is run twice and no step is lost. Every copy's episode is bit for bit the
``parallel_env`` episode of its seed (:mod:`petswarm_env.vector`); the seeds are drawn from the one
given to :meth:`set_seed` (default: the config's ``seed``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Binary, Bounded, Composite, Unbounded
from torchrl.envs import EnvBase

import petswarm_env

GROUP = "robot"


class PetswarmTorchRLEnv(EnvBase):
    """``num_envs`` petswarm swarms of one config as one batched TorchRL env (module docstring)."""

    batch_locked = True

    def __init__(self, num_envs: int, config: Any = None, return_state: bool = True, **overrides: Any):
        self.venv = petswarm_env.vector_env(num_envs, config, **overrides)
        super().__init__(batch_size=torch.Size([self.venv.num_envs]), device="cpu")
        self.return_state = return_state
        n, m, d = self.venv.num_envs, self.venv.max_agents, self.venv.obs_dim
        obs_space = self.venv.single_observation_space
        group = Composite(
            observation=Bounded(low=torch.as_tensor(np.broadcast_to(obs_space.low, (n, m, d)).copy()),
                                high=torch.as_tensor(np.broadcast_to(obs_space.high, (n, m, d)).copy()),
                                shape=(n, m, d), dtype=torch.float32),
            mask=Binary(n=m, shape=(n, m), dtype=torch.bool),
            shape=(n, m),
        )
        observation = Composite({GROUP: group}, shape=(n,))
        if return_state:
            observation["state"] = Unbounded(shape=(n, self.venv.state_dim), dtype=torch.float32)
        self.observation_spec = observation
        self.action_spec = Composite(
            {GROUP: Composite(action=Bounded(low=-1.0, high=1.0, shape=(n, m, 3), dtype=torch.float32), shape=(n, m))},
            shape=(n,))
        self.reward_spec = Composite(
            {GROUP: Composite(reward=Unbounded(shape=(n, m, 1), dtype=torch.float32), shape=(n, m))}, shape=(n,))
        self.done_spec = Composite(
            done=Binary(n=1, shape=(n, 1), dtype=torch.bool),
            terminated=Binary(n=1, shape=(n, 1), dtype=torch.bool),
            truncated=Binary(n=1, shape=(n, 1), dtype=torch.bool),
            shape=(n,))
        self._seed: int | None = None
        self._obs: np.ndarray | None = None  # every copy's current first-or-latest observation
        self._active: np.ndarray | None = None

    # -- TorchRL's private API ---------------------------------------------------------------------
    def _set_seed(self, seed: int | None) -> None:
        self._seed = seed
        self._obs = None  # the next reset starts every copy from the seeds drawn from this one

    def _observation(self, obs: np.ndarray, active: np.ndarray, state: np.ndarray | None) -> TensorDict:
        n, m = self.venv.num_envs, self.venv.max_agents
        td = TensorDict({GROUP: TensorDict({"observation": torch.from_numpy(obs),
                                            "mask": torch.from_numpy(active.copy())}, batch_size=(n, m))},
                        batch_size=(n,))
        if self.return_state:
            td["state"] = torch.from_numpy(np.asarray(state, np.float32))
        return td

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        partial = tensordict is not None and "_reset" in tensordict.keys()
        if self._obs is None or not partial:  # a full reset: every copy starts its next episode
            self._obs, _ = self.venv.reset(seed=self._seed)
            self._seed = None  # a later full reset goes on with the same generator
            self._active = self.venv.active.copy()
        # a partial reset: the finished copies' next episodes were started by the vector env's step
        state = self.venv.state() if self.return_state else None
        td = self._observation(self._obs, self._active, state)
        zeros = torch.zeros((self.venv.num_envs, 1), dtype=torch.bool)
        td.update({"done": zeros, "terminated": zeros.clone(), "truncated": zeros.clone()})
        return td

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        actions = tensordict.get((GROUP, "action")).detach().cpu().numpy()
        obs, rewards, terminated, truncated, infos = self.venv.step(actions)
        active_now = self.venv.active.copy()
        out_obs, out_active = obs.copy(), active_now.copy()
        done = np.zeros((self.venv.num_envs, 1), bool)
        trunc = np.zeros((self.venv.num_envs, 1), bool)
        state = self.venv.state() if self.return_state else None
        for n, info in enumerate(infos):
            if "final_observation" in info:  # copy n's episode ended in this step
                out_obs[n], out_active[n] = info["final_observation"], info["final_active"]
                done[n] = True
                trunc[n] = bool(truncated[n].any())
                if state is not None:
                    state[n] = info["final_state"]
        self._obs, self._active = obs, active_now  # what the partial reset hands out
        td = self._observation(out_obs, out_active, state)
        td.set((GROUP, "reward"), torch.from_numpy(rewards).unsqueeze(-1))
        td.update({"done": torch.from_numpy(done), "terminated": torch.from_numpy(done & ~trunc),
                   "truncated": torch.from_numpy(trunc)})
        return td

    def close(self, *, raise_if_closed: bool = True) -> None:
        self.venv.close()
        super().close(raise_if_closed=raise_if_closed)
