"""Residual policy learning: the trained network corrects the scripted reference.

With ``residual_of: scripted`` in the training config, PPO's action for a robot is not the robot's
command but a correction: :class:`ResidualActions` sends ``clip(scripted(obs) + s · clip(a, -1,
1), -1, 1)`` to the env (``s`` = ``residual_scale``, :class:`petswarm.baselines.learned.Residual`), where
``obs`` is the observation the robot received with the last reset or step (the one the network
read to choose ``a``) and ``scripted`` the leader–follower reference
(:class:`petswarm.baselines.leader_follower.LeaderFollowerPolicy`, a function of the observation alone).
The exported file says ``residual_of: scripted`` and ``residual_scale: s``, and
:class:`petswarm.baselines.learned.LearnedPolicy` adds the same reference at run time, so training and
evaluation act alike. A bound below the reference's recovery speeds (its rejoin and search speeds,
0.5 m/s = 0.33 of the petbot's 1.5 m/s) keeps a correction from overpowering the reference's way
back to a swarm it lost (configs/train/residual.yaml).

The training starts at the reference: the action head's weights and bias are zero
(:func:`zero_action_head`), so the first policy is the scripted one, and PPO explores around it
(``ppo.log_std_init``). The warm start would imitate the reference again and is refused
(training/config.py). The network reads only the observation, as the reference does.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from pettingzoo.utils.wrappers import BaseParallelWrapper

from petswarm.baselines.learned import Residual
from petswarm.baselines.policy import PolicySpec


def _episode_env(env):
    """The PetSwarmEnv of the current episode under ``FixedAgents`` (a RandomizedEnv's draw)."""
    base = env.env
    return getattr(base, "current", base)


class ResidualActions(BaseParallelWrapper):
    """Over :class:`petswarm_env.wrappers.FixedAgents`: each live robot's action is a correction of
    the base policy's action for the robot's last observation (module docstring). Padding rows
    (``active`` 0) pass through; FixedAgents ignores them."""

    def __init__(self, env, residual: Residual = Residual("scripted")):
        super().__init__(env)
        self.residual = residual
        self.possible_agents = list(env.possible_agents)
        self._obs: dict[str, np.ndarray] = {}
        self._live: set[str] = set()
        self.base = None

    def reset(self, seed: int | None = None, options: dict | None = None):
        obs, infos = self.env.reset(seed=seed, options=options)
        self.base = self.residual.base_policy(PolicySpec.from_env(_episode_env(self.env)))  # the draw's limits
        self._remember(obs, infos)
        self.agents = list(self.env.agents)
        return obs, infos

    def step(self, actions: dict[str, Any]):
        sent = {}
        for agent, action in actions.items():
            if agent in self._live:
                sent[agent] = self.residual.apply(self.base.act(agent, self._obs[agent]), action)
            else:
                sent[agent] = action
        obs, rewards, terms, truncs, infos = self.env.step(sent)
        self._remember(obs, infos)
        self.agents = list(self.env.agents)
        return obs, rewards, terms, truncs, infos

    def _remember(self, obs: dict[str, np.ndarray], infos: dict[str, dict]) -> None:
        self._obs = obs
        self._live = {a for a, info in infos.items() if info.get("active", 1)}



def zero_action_head(weight: torch.Tensor, bias: torch.Tensor) -> None:
    """Zero the layer that gives the action's mean (SB3's ``action_net``; in place): the residual
    policy then starts as the base policy."""
    with torch.no_grad():
        weight.zero_()
        bias.zero_()
