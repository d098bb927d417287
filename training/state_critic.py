"""A centralized critic for SB3's PPO (MAPPO, ``ppo.critic: state``): the critic reads the agent's
observation and the global state, the actor only the observation.

The vector env's rows are ``[observation, state]`` (:class:`petswarm.training.randomize.WithState` before
SuperSuit's vectorization); :class:`StateCriticPolicy` is SB3's ``ActorCriticPolicy`` whose
extractor feeds the first ``obs_size`` values to the actor MLP and the whole row to the critic
MLP. The actor's layers (``mlp_extractor.policy_net`` and ``action_net``) are exactly those of an
``MlpPolicy`` on the observation, so :func:`petswarm.training.export.actor_layers` exports the actor alone
and ``policy.npz`` is read by :mod:`petswarm.baselines.learned` as any other policy (the critic is not in it).
"""

from __future__ import annotations

import torch
from stable_baselines3.common.policies import ActorCriticPolicy
from torch import nn


def _mlp(inputs: int, sizes: list[int], act: type[nn.Module]) -> nn.Sequential:
    layers: list[nn.Module] = []
    for size in sizes:
        layers += [nn.Linear(inputs, size), act()]
        inputs = size
    return nn.Sequential(*layers)


class SplitExtractor(nn.Module):
    """SB3's ``MlpExtractor`` interface: ``policy_net`` on ``features[:, :obs_size]``,
    ``value_net`` on all of ``features``."""

    def __init__(self, obs_size: int, features: int, pi: list[int], vf: list[int], act: type[nn.Module]):
        super().__init__()
        self.obs_size = obs_size
        self.policy_net = _mlp(obs_size, pi, act)
        self.value_net = _mlp(features, vf, act)
        self.latent_dim_pi = pi[-1] if pi else obs_size
        self.latent_dim_vf = vf[-1] if vf else features

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: torch.Tensor) -> torch.Tensor:
        return self.policy_net(features[..., :self.obs_size])

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return self.value_net(features)


class StateCriticPolicy(ActorCriticPolicy):
    """``ActorCriticPolicy`` with :class:`SplitExtractor` (``obs_size``: the observation's length;
    the rest of each row is the state)."""

    def __init__(self, *args, obs_size: int, **kwargs):
        self.obs_size = obs_size
        super().__init__(*args, **kwargs)

    def _build_mlp_extractor(self) -> None:
        arch = self.net_arch if isinstance(self.net_arch, dict) else {"pi": self.net_arch, "vf": self.net_arch}
        self.mlp_extractor = SplitExtractor(self.obs_size, self.features_dim, list(arch["pi"]), list(arch["vf"]),
                                            self.activation_fn)
