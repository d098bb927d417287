"""Residual policy learning (issue 16): the trained network corrects the scripted reference.

With ``residual_of: scripted`` in the training config, PPO's action for a robot is not the robot's
command but a correction: :class:`ResidualActions` sends ``clip(scripted(obs) + clip(a, -1, 1),
-1, 1)`` to the env, where ``obs`` is the observation the robot received with the last reset or
step (the one the network read to choose ``a``) and ``scripted`` the leader–follower reference
(:class:`baselines.leader_follower.LeaderFollowerPolicy`, a function of the observation alone).
The exported file says ``residual_of: scripted`` and :class:`baselines.learned.LearnedPolicy`
adds the same reference at run time, so training and evaluation act alike.

The training starts at the reference: the action head's weights and bias are zero
(:func:`zero_action_head`), so the first policy is the scripted one, and PPO explores around it
(``ppo.log_std_init``). The warm start would imitate the reference again and is refused
(training/config.py). The network reads only the observation, as the reference does.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pettingzoo.utils.wrappers import BaseParallelWrapper

from baselines.learned import RESIDUAL_BASES
from baselines.policy import PolicySpec


def _episode_env(env):
    """The PetSwarmEnv of the current episode under ``FixedAgents`` (a RandomizedEnv's draw)."""
    base = env.env
    return getattr(base, "current", base)


class ResidualActions(BaseParallelWrapper):
    """Over :class:`petswarm_env.wrappers.FixedAgents`: each live robot's action is a correction of
    the base policy's action for the robot's last observation (module docstring). Padding rows
    (``active`` 0) pass through; FixedAgents ignores them."""

    def __init__(self, env, base: str = "scripted"):
        super().__init__(env)
        if base not in RESIDUAL_BASES:
            raise ValueError(f"residual_of must be one of {sorted(RESIDUAL_BASES)}, got {base!r}")
        self.base_name = base
        self.possible_agents = list(env.possible_agents)
        self.state_space = getattr(env, "state_space", None)
        self._obs: dict[str, np.ndarray] = {}
        self._live: set[str] = set()
        self.base = None

    def reset(self, seed: int | None = None, options: dict | None = None):
        obs, infos = self.env.reset(seed=seed, options=options)
        self.base = RESIDUAL_BASES[self.base_name](PolicySpec.from_env(_episode_env(self.env)))  # the draw's limits
        self._remember(obs, infos)
        self.agents = list(self.env.agents)
        return obs, infos

    def step(self, actions: dict[str, Any]):
        sent = {}
        for agent, action in actions.items():
            if agent in self._live:
                correction = np.clip(np.asarray(action, dtype=np.float32), -1.0, 1.0)
                sent[agent] = np.clip(self.base.act(agent, self._obs[agent]) + correction, -1.0, 1.0)
            else:
                sent[agent] = action
        obs, rewards, terms, truncs, infos = self.env.step(sent)
        self._remember(obs, infos)
        self.agents = list(self.env.agents)
        return obs, rewards, terms, truncs, infos

    def _remember(self, obs: dict[str, np.ndarray], infos: dict[str, dict]) -> None:
        self._obs = obs
        self._live = {a for a, info in infos.items() if info.get("active", 1)}

    def state(self) -> np.ndarray:
        return self.env.state()

    def render(self, mode: str | None = None):
        return self.env.render(mode)


def zero_action_head(weight, bias) -> None:
    """Zero the rows of an action head that give the action's mean (torch tensors, in place): the
    residual policy then starts as the base policy."""
    import torch

    with torch.no_grad():
        weight.zero_()
        bias.zero_()
