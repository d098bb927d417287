"""From an SB3 PPO model to petswarm's weights-only policy (:mod:`baselines.learned`): the actor
network's layers, as a :class:`~baselines.learned.LearnedPolicy` or a saved ``.npz`` file."""

from __future__ import annotations

import os

import numpy as np
import torch

from baselines.learned import LearnedPolicy, save_policy
from baselines.policy import PolicySpec
from petswarm_env.observe import ObservationLayout


def actor_layers(model) -> list[tuple[np.ndarray, np.ndarray]]:
    """(weight, bias) of the actor MLP and the action head of an SB3 PPO MlpPolicy."""
    linears = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    linears.append(model.policy.action_net)
    return [(m.weight.detach().cpu().numpy().copy(), m.bias.detach().cpu().numpy().copy()) for m in linears]


def learned_policy(model, spec: PolicySpec, activation: str) -> LearnedPolicy:
    """The model's current actor as a policy for an env of the layout it trains on."""
    return LearnedPolicy(spec, actor_layers(model), activation, np.arange(spec.layout.size))


def export_policy(model, path: str | os.PathLike, layout: ObservationLayout, activation: str, info: dict) -> None:
    """Write the model's actor to ``path`` (atomically) with ``info`` on how it was trained."""
    save_policy(path, actor_layers(model), activation, layout, info)
