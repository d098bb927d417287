"""Train one slave policy shared by all slaves with Stable-Baselines3 PPO.

The PettingZoo env goes through SuperSuit: ``black_death_v3`` (an agent that is not in the
episode — a slave that did not join, or one that left — gets zero observations and its actions are
ignored, so the vector stays fixed-size), ``pettingzoo_env_to_vec_env_v1`` (one vector row per
slave: parameter sharing) and ``concat_vec_envs_v1`` (``num_envs`` copies over ``num_cpus``
processes). Everything of a run lives in its folder::

    runs/NAME/train_config.yaml      the resolved training config (hyper-parameters + env overrides)
    runs/NAME/env_config.yaml        the resolved environment config
    runs/NAME/checkpoints/latest.zip SB3 checkpoint, written atomically (temp file + rename)
    runs/NAME/policy.npz             the exported actor (weights-only, see baselines/learned.py)
    runs/NAME/train_log.json         timesteps, wall time, evaluations against the scripted reference
    runs/NAME/tb/                    TensorBoard logs
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from baselines.learned import LearnedPolicy, save_policy
from baselines.policy import PolicySpec
from baselines.registry import make_policy
from evaluation.runner import run_episode
from petswarm_env.config import (
    Config,
    ConfigError,
    format_validation_error,
    load_config,
    merge_mappings,
    nest_dotted,
    read_yaml,
)
from petswarm_env.env import PetSwarmEnv
from petswarm_env.files import write_atomic, write_json_atomic
from petswarm_env.observe import ObservationLayout

DEFAULT_TRAIN_CONFIG = Path(__file__).resolve().parents[1] / "configs" / "train" / "ppo.yaml"


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class PPOConfig(_Section):
    learning_rate: float = Field(gt=0)
    n_steps: int = Field(ge=8)
    batch_size: int = Field(ge=8)
    n_epochs: int = Field(ge=1)
    gamma: float = Field(gt=0, le=1)
    gae_lambda: float = Field(gt=0, le=1)
    clip_range: float = Field(gt=0)
    ent_coef: float = Field(ge=0)
    vf_coef: float = Field(ge=0)
    max_grad_norm: float = Field(gt=0)
    net_arch: list[int]
    activation: Literal["tanh", "relu"]
    log_std_init: float


class EvalConfig(_Section):
    every_steps: int = Field(ge=1)
    episodes: int = Field(ge=1)
    seed: int = Field(ge=0)
    max_cycles: int = Field(ge=1)


class CheckpointConfig(_Section):
    every_steps: int = Field(ge=1)


class PretrainConfig(_Section):
    samples: int = Field(ge=0, description="agent-samples of the scripted reference to imitate; 0 = no warm start")
    noise_std: float = Field(ge=0, description="action noise while collecting (visits recovery states)")
    epochs: int = Field(ge=1)
    batch_size: int = Field(ge=8)
    learning_rate: float = Field(gt=0)


class TrainConfig(_Section):
    seed: int = Field(ge=0)
    timesteps: int = Field(ge=1)
    num_envs: int = Field(ge=1)
    num_cpus: int = Field(ge=0)
    env: dict[str, Any]
    ppo: PPOConfig
    eval: EvalConfig
    checkpoint: CheckpointConfig
    pretrain: PretrainConfig

    def env_config(self) -> Config:
        return load_config(overrides=self.env)


def load_train_config(path: str | os.PathLike | None = None, overrides: dict[str, Any] | None = None) -> TrainConfig:
    """Defaults from configs/train/ppo.yaml, then ``path``, then dotted overrides; validated.
    Keys under ``env.`` are checked against the environment config too."""
    data = read_yaml(DEFAULT_TRAIN_CONFIG)
    if path is not None:
        user = read_yaml(path)
        env_user = user.pop("env", None)
        data = merge_mappings(data, user)
        if env_user is not None:
            data["env"] = {**data.get("env", {}), **env_user}
    for key, value in (overrides or {}).items():
        if key.startswith("env."):
            data["env"] = {**data.get("env", {}), key[4:]: value}
        else:
            data = merge_mappings(data, nest_dotted({key: value}))
    try:
        cfg = TrainConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc)) from None
    cfg.env_config()  # validates the env overrides (unknown key / bad value -> ConfigError)
    return cfg


# -- vector env ------------------------------------------------------------------------------------
def black_death(env: PetSwarmEnv):
    """Keep every possible agent in the vector: a robot that is not (or no longer) a slave of the
    episode gets zero observations and zero reward and its action is dropped; the episode ends for
    all when the env's episode ends. (SuperSuit's ``black_death_v3`` in 3.11 only ends an episode
    whose agents are terminated *and* truncated, so a truncated episode never resets.)"""
    from pettingzoo.utils.wrappers import BaseParallelWrapper

    class BlackDeath(BaseParallelWrapper):
        def reset(self, seed=None, options=None):
            obs, infos = self.env.reset(seed=seed, options=options)
            self.agents = list(self.env.possible_agents)
            return self._fill(obs), {a: infos.get(a, {}) for a in self.agents}

        def _fill(self, obs):
            zero = np.zeros(self.observation_space(self.agents[0]).shape, np.float32)
            return {a: obs.get(a, zero) for a in self.agents}

        def step(self, actions):
            live = {a: actions[a] for a in self.env.agents if a in actions}
            obs, rews, terms, truncs, infos = self.env.step(live)
            done = not self.env.agents
            term = {a: done and terms.get(a, False) for a in self.agents}
            trunc = {a: done and not term[a] for a in self.agents}
            out = (self._fill(obs), {a: rews.get(a, 0.0) for a in self.agents}, term, trunc,
                   {a: infos.get(a, {}) for a in self.agents})
            if done:
                self.agents = []
            return out

    return BlackDeath(env)


def make_vec_env(env_cfg: Config, num_envs: int, num_cpus: int, seed: int):
    """SuperSuit pipeline to an SB3 VecEnv (one row per slave per copy)."""
    import supersuit as ss
    from supersuit.vector.sb3_vector_wrapper import SB3VecEnvWrapper

    class SeededVecEnv(SB3VecEnvWrapper):
        """SuperSuit's SB3 wrapper plus ``seed()`` (SB3 ≥ 2.x calls it; SuperSuit lacks it)."""

        def __init__(self, venv):
            super().__init__(venv)
            self._next_seed: int | None = None

        def seed(self, seed: int | None = None):
            self._next_seed = seed
            return [seed]

        def reset(self, seed=None, options=None):
            seed = self._next_seed if seed is None else seed
            self._next_seed = None
            observations, self.reset_infos = self.venv.reset(seed=seed, options=options)
            return observations

    env = black_death(PetSwarmEnv(env_cfg))
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    vec = ss.concat_vec_envs_v1(vec, num_envs, num_cpus=num_cpus, base_class="gymnasium")
    from stable_baselines3.common.vec_env import VecMonitor

    venv = SeededVecEnv(vec)
    venv.seed(seed)
    return VecMonitor(venv)  # per-row episode return/length for SB3's rollout/ep_rew_mean


# -- export ----------------------------------------------------------------------------------------
def actor_layers(model) -> list[tuple[np.ndarray, np.ndarray]]:
    """(weight, bias) of the actor MLP and the action head of an SB3 PPO MlpPolicy."""
    import torch

    linears = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    linears.append(model.policy.action_net)
    return [(m.weight.detach().cpu().numpy().copy(), m.bias.detach().cpu().numpy().copy()) for m in linears]


def export_policy(model, path: str | os.PathLike, layout: ObservationLayout, activation: str, info: dict) -> None:
    save_policy(path, actor_layers(model), activation, layout, info)


# -- evaluation ------------------------------------------------------------------------------------
def evaluate_policy(env_cfg: Config, policy, seeds: list[int]) -> float:
    """Mean formation RMSE of ``policy`` over ``seeds`` (NaN-free episodes)."""
    env = PetSwarmEnv(env_cfg)
    values = [run_episode(env, policy, s)["formation_rmse_m"] for s in seeds]
    env.close()
    values = [v for v in values if math.isfinite(v)]
    return float(np.mean(values)) if values else math.nan


# -- warm start: imitate the scripted reference ---------------------------------------------------
def collect_demonstrations(env_cfg: Config, samples: int, noise_std: float, seed: int, gamma: float):
    """Run the scripted reference with action noise; return observations, the reference's
    (noise-free) actions and discounted returns of the executed trajectories (for the critic)."""
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
            g = 0.0
            returns = []
            for _, _, r in reversed(steps):
                g = r + gamma * g
                returns.append(g)
            for (o, t, _), g in zip(steps, reversed(returns)):
                obs_l.append(o)
                act_l.append(t)
                ret_l.append(g)
    env.close()
    return np.array(obs_l[:samples]), np.array(act_l[:samples]), np.array(ret_l[:samples], dtype=np.float32)


def pretrain_policy(model, cfg: TrainConfig, env_cfg: Config) -> dict:
    """Behaviour cloning of the scripted reference into the actor (MSE on the mean action) and a
    regression of the critic on the demonstrations' returns, before PPO takes over."""
    import torch

    p = cfg.pretrain
    t0 = time.time()
    obs, act, ret = collect_demonstrations(env_cfg, p.samples, p.noise_std, cfg.seed + 100_000, cfg.ppo.gamma)
    x = torch.as_tensor(obs, dtype=torch.float32)
    y = torch.as_tensor(act, dtype=torch.float32)
    g = torch.as_tensor(ret, dtype=torch.float32)[:, None]
    policy = model.policy
    params = [*policy.mlp_extractor.parameters(), *policy.action_net.parameters(), *policy.value_net.parameters(),
              *policy.features_extractor.parameters()]
    opt = torch.optim.Adam(params, lr=p.learning_rate)
    gen = torch.Generator().manual_seed(cfg.seed)
    n = len(x)
    actor_loss = critic_loss = math.nan
    for _ in range(p.epochs):
        perm = torch.randperm(n, generator=gen)
        for i in range(0, n, p.batch_size):
            idx = perm[i:i + p.batch_size]
            features = policy.extract_features(x[idx])
            latent_pi, latent_vf = policy.mlp_extractor(features)
            a_loss = ((policy.action_net(latent_pi) - y[idx]) ** 2).mean()
            v_loss = ((policy.value_net(latent_vf) - g[idx]) ** 2).mean()
            opt.zero_grad()
            (a_loss + 0.01 * v_loss).backward()
            opt.step()
            actor_loss, critic_loss = float(a_loss), float(v_loss)
    return {"samples": n, "actor_mse": actor_loss, "critic_mse": critic_loss, "wall_time_s": round(time.time() - t0, 1)}


def _make_callback(cfg: TrainConfig, out: Path, layout: ObservationLayout, log: dict, eval_cfg: Config):
    from stable_baselines3.common.callbacks import BaseCallback

    seeds = list(range(cfg.eval.seed, cfg.eval.seed + cfg.eval.episodes))

    class Periodic(BaseCallback):
        """Atomic checkpoints and evaluation against the scripted reference on the same seeds."""

        def __init__(self):
            super().__init__()
            self.next_ckpt = (log["timesteps"] // cfg.checkpoint.every_steps + 1) * cfg.checkpoint.every_steps
            self.next_eval = (log["timesteps"] // cfg.eval.every_steps + 1) * cfg.eval.every_steps

        def _on_step(self) -> bool:
            n = self.num_timesteps
            if n >= self.next_eval:
                self.next_eval += cfg.eval.every_steps
                self.evaluate()
            if n >= self.next_ckpt:
                self.next_ckpt += cfg.checkpoint.every_steps
                self.checkpoint()
            return True

        def checkpoint(self) -> None:
            log["timesteps"] = int(self.num_timesteps)
            log["wall_time_s"] = log["wall_time_before_s"] + time.time() - log["_start"]
            write_atomic(out / "checkpoints" / "latest.zip", self.model.save)
            export_policy(self.model, out / "policy.npz", layout, cfg.ppo.activation, _policy_info(cfg, log))
            write_json_atomic(out / "train_log.json", {k: v for k, v in log.items() if not k.startswith("_")})

        def evaluate(self) -> None:
            spec = PolicySpec.from_env(PetSwarmEnv(eval_cfg))
            learned = LearnedPolicy(spec, actor_layers(self.model), cfg.ppo.activation, np.arange(layout.size))
            rmse = evaluate_policy(eval_cfg, learned, seeds)
            ref = log["scripted_eval_rmse_m"]
            log["evaluations"].append({"timesteps": int(self.num_timesteps), "formation_rmse_m": rmse, "scripted_rmse_m": ref})
            self.logger.record("eval/formation_rmse_m", rmse)
            self.logger.record("eval/scripted_rmse_m", ref)
            self.logger.record("eval/ratio_to_scripted", rmse / ref if ref else math.nan)

    return Periodic()


def _policy_info(cfg: TrainConfig, log: dict) -> dict:
    return {
        "algorithm": "PPO (stable-baselines3), parameter sharing over slaves",
        "timesteps": log["timesteps"],
        "wall_time_s": round(log["wall_time_s"], 1),
        "train_config": cfg.model_dump(mode="json"),
        "command": log.get("command", ""),
    }


def train(cfg: TrainConfig, out_dir: str | os.PathLike, resume: bool = False, progress_bar: bool = True,
          command: str = "") -> dict:
    """Train (or resume) a run in ``out_dir``; returns the train log."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.utils import set_random_seed

    out = Path(out_dir)
    ckpt = out / "checkpoints" / "latest.zip"
    if resume:
        saved = out / "train_config.yaml"
        if not saved.is_file() or not ckpt.is_file():
            raise ConfigError(f"cannot resume: '{out}' has no train_config.yaml and checkpoints/latest.zip; train without --resume first")
        saved_cfg = load_train_config(saved)
        cfg = saved_cfg.model_copy(update={"timesteps": cfg.timesteps})
        log = json.loads((out / "train_log.json").read_text())
    else:
        if ckpt.exists():
            raise ConfigError(f"'{out}' already holds a run; pass --resume to continue it or choose another --out")
        log = {"timesteps": 0, "wall_time_s": 0.0, "evaluations": [], "scripted_eval_rmse_m": None}
    out.mkdir(parents=True, exist_ok=True)
    env_cfg = cfg.env_config()
    (out / "train_config.yaml").write_text(yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False))
    (out / "env_config.yaml").write_text(yaml.safe_dump(env_cfg.to_dict(), sort_keys=False))
    log["command"] = command or log.get("command", "")
    log["wall_time_before_s"] = log.get("wall_time_s", 0.0)
    log["_start"] = time.time()

    torch.set_num_threads(1)  # reproducible CPU math; the cores run the env workers
    set_random_seed(cfg.seed)
    eval_cfg = load_config(overrides={**cfg.env, "max_cycles": cfg.eval.max_cycles})
    layout = PetSwarmEnv(env_cfg).layout
    if log["scripted_eval_rmse_m"] is None:
        spec = PolicySpec.from_env(PetSwarmEnv(eval_cfg))
        seeds = list(range(cfg.eval.seed, cfg.eval.seed + cfg.eval.episodes))
        log["scripted_eval_rmse_m"] = evaluate_policy(eval_cfg, make_policy("scripted", spec), seeds)

    venv = make_vec_env(env_cfg, cfg.num_envs, cfg.num_cpus, cfg.seed + log["timesteps"])
    try:
        if resume:
            try:
                model = PPO.load(ckpt, env=venv, device="cpu")
            except Exception as exc:  # SB3 raises many types for a damaged zip
                raise ConfigError(f"checkpoint '{ckpt}' cannot be loaded ({type(exc).__name__}: {exc}); it may be corrupt") from None
        else:
            p = cfg.ppo
            act = torch.nn.Tanh if p.activation == "tanh" else torch.nn.ReLU
            model = PPO(
                "MlpPolicy",
                venv,
                learning_rate=p.learning_rate,
                n_steps=p.n_steps,
                batch_size=p.batch_size,
                n_epochs=p.n_epochs,
                gamma=p.gamma,
                gae_lambda=p.gae_lambda,
                clip_range=p.clip_range,
                ent_coef=p.ent_coef,
                vf_coef=p.vf_coef,
                max_grad_norm=p.max_grad_norm,
                policy_kwargs={"net_arch": {"pi": list(p.net_arch), "vf": list(p.net_arch)}, "activation_fn": act,
                               "log_std_init": p.log_std_init},
                tensorboard_log=str(out / "tb"),
                seed=cfg.seed,
                device="cpu",
                verbose=0,
            )
            if cfg.pretrain.samples > 0:
                log["pretrain"] = pretrain_policy(model, cfg, env_cfg)
                spec = PolicySpec.from_env(PetSwarmEnv(eval_cfg))
                imitation = LearnedPolicy(spec, actor_layers(model), cfg.ppo.activation, np.arange(layout.size))
                seeds = list(range(cfg.eval.seed, cfg.eval.seed + cfg.eval.episodes))
                log["pretrain"]["eval_formation_rmse_m"] = evaluate_policy(eval_cfg, imitation, seeds)
        callback = _make_callback(cfg, out, layout, log, eval_cfg)
        remaining = cfg.timesteps - model.num_timesteps
        if remaining > 0:
            model.learn(remaining, callback=callback, reset_num_timesteps=False, tb_log_name="ppo", progress_bar=progress_bar)
        callback.checkpoint()
        if not log["evaluations"] or log["evaluations"][-1]["timesteps"] != model.num_timesteps:
            callback.evaluate()
        write_json_atomic(out / "train_log.json", {k: v for k, v in log.items() if not k.startswith("_")})
    finally:
        venv.close()
    return {k: v for k, v in log.items() if not k.startswith("_")}
