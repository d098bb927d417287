"""The warm start's DAgger rounds (training/warm_start.py, pretrain.dagger_rounds): the actor
drives, the scripted reference labels, the data grows by pretrain.dagger_samples a round."""

import numpy as np
import torch

from petswarm_env.env import PetSwarmEnv
from petswarm.training.config import load_train_config
from petswarm.training.warm_start import collect_demonstrations, fit_actor_critic


def test_dagger_rounds_add_the_actors_states_labelled_by_the_reference():
    cfg = load_train_config(overrides={"env.max_cycles": 15, "pretrain.samples": 60, "pretrain.epochs": 1,
                                       "pretrain.dagger_rounds": 2, "pretrain.dagger_samples": 40})
    env_cfg = cfg.env_config()
    size = PetSwarmEnv(env_cfg).layout.size
    actor, critic = torch.nn.Linear(size, 3), torch.nn.Linear(size, 1)
    out = fit_actor_critic(actor, critic, [*actor.parameters(), *critic.parameters()], cfg, env_cfg)
    assert out["samples"] == 60 + 2 * 40 and out["dagger_rounds"] == 2 and np.isfinite(out["actor_mse"])
    # with a driver the labels are still the reference's: the same states give the same labels
    still = lambda rows: np.zeros((len(rows), 3), np.float32)  # noqa: E731
    obs, act, _ = collect_demonstrations(env_cfg, 30, 0.0, 5, 0.98, driver=still)
    obs2, act2, _ = collect_demonstrations(env_cfg, 30, 0.0, 5, 0.98, driver=still)
    assert np.array_equal(obs, obs2) and np.array_equal(act, act2) and np.abs(act).max() > 0
