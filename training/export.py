"""From a trained actor to petswarm's weights-only policy (:mod:`petswarm.baselines.learned`): the actor
network's layers of an SB3 PPO model (:func:`actor_layers`) or of an RLlib PPO module's state
(:func:`rllib_actor_layers`), as a :class:`~petswarm.baselines.learned.LearnedPolicy` or a saved ``.npz`` file."""

from __future__ import annotations

import os

import numpy as np
import torch

from petswarm.baselines.learned import LearnedPolicy, Residual, save_policy
from petswarm.baselines.policy import PolicySpec
from petswarm_env.observe import ObservationLayout


def actor_layers(model) -> list[tuple[np.ndarray, np.ndarray]]:
    """(weight, bias) of the actor MLP and the action head of an SB3 PPO MlpPolicy."""
    linears = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    linears.append(model.policy.action_net)
    return [(m.weight.detach().cpu().numpy().copy(), m.bias.detach().cpu().numpy().copy()) for m in linears]


def learned_policy(model, spec: PolicySpec, activation: str, residual: Residual | None = None) -> LearnedPolicy:
    """The model's current actor as a policy for an env of the layout it trains on (correcting
    ``residual``'s base, if given: training/residual.py)."""
    return LearnedPolicy(spec, actor_layers(model), activation, np.arange(spec.layout.size), residual.meta() if residual else None)


def export_policy(model, path: str | os.PathLike, layout: ObservationLayout, activation: str, info: dict,
                  residual: Residual | None = None) -> None:
    """Write the model's actor to ``path`` (atomically) with ``info`` on how it was trained."""
    save_policy(path, actor_layers(model), activation, layout, info, residual=residual)


RLLIB_ACTOR = "encoder.actor_encoder.net.mlp.{}"  # RLlib's DefaultPPOTorchRLModule: Linear at 0, 2, 4, … (activations between)
RLLIB_PI = "pi.net.mlp.0"  # the policy head: (mean, log_std) of a diagonal Gaussian


def rllib_actor_layers(state: dict[str, np.ndarray], action_size: int = 3) -> list[tuple[np.ndarray, np.ndarray]]:
    """(weight, bias) of the actor of an RLlib PPO module's state (``get_state()``: name -> array,
    ``vf_share_layers: False``): the actor encoder's linear layers, then the head's rows of the
    action mean (the first ``action_size``; the others are its log_std). The deterministic action
    is the clipped mean, as for SB3."""
    layers, i = [], 0
    while f"{RLLIB_ACTOR.format(i)}.weight" in state:
        key = RLLIB_ACTOR.format(i)
        layers.append((np.asarray(state[f"{key}.weight"]), np.asarray(state[f"{key}.bias"])))
        i += 2
    if not layers or f"{RLLIB_PI}.weight" not in state:
        raise ValueError("not the state of an RLlib PPO module with a separate actor encoder (vf_share_layers: false)")
    layers.append((np.asarray(state[f"{RLLIB_PI}.weight"])[:action_size], np.asarray(state[f"{RLLIB_PI}.bias"])[:action_size]))
    return layers
