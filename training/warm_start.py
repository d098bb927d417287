"""The warm start: imitate the scripted reference before PPO takes over (``pretrain:`` of the
training config; ``pretrain.samples: 0`` trains from scratch).

The scripted leader–follower drives the slaves with action noise, so that the demonstrations
cover recovering from errors; the actor learns the reference's noise-free actions (behaviour
cloning, MSE on the mean action) and the critic the discounted returns of the executed
trajectories.
"""

from __future__ import annotations

import math
import time

import numpy as np
import torch

from baselines.policy import PolicySpec
from baselines.registry import make_policy
from petswarm_env.config import Config
from petswarm_env.env import PetSwarmEnv
from training.config import TrainConfig


def discounted_returns(rewards: list[float], gamma: float) -> list[float]:
    """``G_t = r_t + γ·G_{t+1}`` for every step of one trajectory (in step order)."""
    g = 0.0
    returns = []
    for r in reversed(rewards):
        g = r + gamma * g
        returns.append(g)
    return returns[::-1]


def collect_demonstrations(env_cfg: Config, samples: int, noise_std: float, seed: int, gamma: float):
    """Run the scripted reference with action noise over episodes ``seed, seed + 1, …`` until
    ``samples`` agent-steps; return observations, the reference's (noise-free) actions and the
    discounted returns of the executed trajectories (for the critic)."""
    env = PetSwarmEnv(env_cfg)
    teacher = make_policy("scripted", PolicySpec.from_env(env))
    rng = np.random.default_rng(seed)
    obs_l, act_l, ret_l = [], [], []
    episode = 0
    while len(obs_l) < samples:
        obs, _ = env.reset(seed=seed + episode)
        episode += 1
        traj: dict[str, list[tuple[np.ndarray, np.ndarray, float]]] = {a: [] for a in env.agents}
        while env.agents:
            target = teacher.act_all({a: obs[a] for a in env.agents})
            noisy = {a: np.clip(v + rng.normal(0.0, noise_std, 3), -1.0, 1.0).astype(np.float32) for a, v in target.items()}
            next_obs, rewards, _, _, _ = env.step(noisy)
            for a in target:
                traj.setdefault(a, []).append((obs[a], target[a], rewards[a]))
            obs = next_obs
        for steps in traj.values():
            for (o, t, _), g in zip(steps, discounted_returns([r for _, _, r in steps], gamma)):
                obs_l.append(o)
                act_l.append(t)
                ret_l.append(g)
    env.close()
    return np.array(obs_l[:samples]), np.array(act_l[:samples]), np.array(ret_l[:samples], dtype=np.float32)


def fit_actor_critic(actor, critic, params: list, cfg: TrainConfig, env_cfg: Config) -> dict:
    """Behaviour cloning of the scripted reference into ``actor`` (a function of an observation
    batch to mean actions; MSE) and a regression of ``critic`` (observations -> values) on the
    demonstrations' returns, optimising ``params`` with Adam: the warm start of every back end."""
    p = cfg.pretrain
    t0 = time.time()
    obs, act, ret = collect_demonstrations(env_cfg, p.samples, p.noise_std, cfg.seed + 100_000, cfg.ppo.gamma)
    x = torch.as_tensor(obs, dtype=torch.float32)
    y = torch.as_tensor(act, dtype=torch.float32)
    g = torch.as_tensor(ret, dtype=torch.float32)[:, None]
    opt = torch.optim.Adam(params, lr=p.learning_rate)
    gen = torch.Generator().manual_seed(cfg.seed)
    n = len(x)
    actor_loss = critic_loss = math.nan
    for _ in range(p.epochs):
        perm = torch.randperm(n, generator=gen)
        for i in range(0, n, p.batch_size):
            idx = perm[i:i + p.batch_size]
            a_loss = ((actor(x[idx]) - y[idx]) ** 2).mean()
            v_loss = ((critic(x[idx]) - g[idx]) ** 2).mean()
            opt.zero_grad()
            (a_loss + 0.01 * v_loss).backward()
            opt.step()
            actor_loss, critic_loss = float(a_loss.detach()), float(v_loss.detach())
    return {"samples": n, "actor_mse": actor_loss, "critic_mse": critic_loss, "wall_time_s": round(time.time() - t0, 1)}


def pretrain_policy(model, cfg: TrainConfig, env_cfg: Config) -> dict:
    """The warm start of an SB3 PPO model: its actor MLP and action head, its critic MLP and value
    head (:func:`fit_actor_critic`)."""
    policy = model.policy
    params = [*policy.mlp_extractor.parameters(), *policy.action_net.parameters(), *policy.value_net.parameters(),
              *policy.features_extractor.parameters()]
    return fit_actor_critic(lambda x: policy.action_net(policy.mlp_extractor(policy.extract_features(x))[0]),
                            lambda x: policy.value_net(policy.mlp_extractor(policy.extract_features(x))[1]), params, cfg, env_cfg)
