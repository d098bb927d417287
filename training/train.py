"""Train one slave policy shared by all slaves with Stable-Baselines3 PPO (``petswarm train``).

Read :func:`train` top to bottom: the run folder, the seeds, the scripted reference's score, the
vector env (:mod:`training.vec_env`), the PPO model, the warm start (:mod:`training.warm_start`),
``model.learn`` with the checkpoint/evaluation callback (:mod:`training.callbacks`), the last
checkpoint. Every hyper-parameter is in the training config (:mod:`training.config`,
``configs/train/ppo.yaml``). Everything of a run lives in its folder::

    runs/NAME/train_config.yaml      the resolved training config (hyper-parameters + env overrides)
    runs/NAME/env_config.yaml        the resolved environment config
    runs/NAME/checkpoints/latest.zip SB3 checkpoint, written atomically (temp file + rename)
    runs/NAME/policy.npz             the exported actor (weights-only, see baselines/learned.py)
    runs/NAME/train_log.json         timesteps, wall time, evaluations against the scripted reference
    runs/NAME/tb/                    TensorBoard logs
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import torch
import yaml
from stable_baselines3 import PPO
from stable_baselines3.common.utils import set_random_seed

from baselines.policy import PolicySpec
from baselines.registry import make_policy
from evaluation.evaluate import mean_formation_rmse
from petswarm_env.config import ConfigError, parse_override
from petswarm_env.env import PetSwarmEnv
from petswarm_env.files import write_json_atomic, write_text_atomic
from training.callbacks import PeriodicCallback, public_log
from training.config import PPOConfig, TrainConfig, load_train_config
from training.export import learned_policy
from training.vec_env import make_vec_env
from training.warm_start import pretrain_policy


def build_model(p: PPOConfig, venv, seed: int, tensorboard_log: str | None = None, n_steps: int | None = None,
                batch_size: int | None = None) -> PPO:
    """A fresh SB3 PPO ``MlpPolicy`` with the hyper-parameters of ``p`` (``n_steps`` and
    ``batch_size`` may be overridden: the benchmark sizes its rollouts itself)."""
    act = torch.nn.Tanh if p.activation == "tanh" else torch.nn.ReLU
    return PPO(
        "MlpPolicy",
        venv,
        learning_rate=p.learning_rate,
        n_steps=p.n_steps if n_steps is None else n_steps,
        batch_size=p.batch_size if batch_size is None else batch_size,
        n_epochs=p.n_epochs,
        gamma=p.gamma,
        gae_lambda=p.gae_lambda,
        clip_range=p.clip_range,
        ent_coef=p.ent_coef,
        vf_coef=p.vf_coef,
        max_grad_norm=p.max_grad_norm,
        policy_kwargs={"net_arch": {"pi": list(p.net_arch), "vf": list(p.net_arch)}, "activation_fn": act,
                       "log_std_init": p.log_std_init},
        tensorboard_log=tensorboard_log,
        seed=seed,
        device="cpu",
        verbose=0,
    )


def load_model(ckpt: Path, venv) -> PPO:
    """The checkpoint of a run, attached to ``venv``; a damaged file is a one-line ConfigError."""
    try:
        return PPO.load(ckpt, env=venv, device="cpu")
    except Exception as exc:  # SB3 raises many types for a damaged zip
        raise ConfigError(f"checkpoint '{ckpt}' cannot be loaded ({type(exc).__name__}: {exc}); it may be corrupt") from None


def open_run(cfg: TrainConfig, out: Path, resume: bool, checkpoint: str = "latest.zip") -> tuple[TrainConfig, dict[str, Any]]:
    """The config and train log of the run in ``out``: a new one (refused if ``out`` holds a
    run), or with ``resume`` the saved config (with ``cfg``'s timesteps) and log. ``checkpoint``:
    the back end's checkpoint file in ``out/checkpoints``."""
    ckpt = out / "checkpoints" / checkpoint
    if not resume:
        if ckpt.exists():
            raise ConfigError(f"'{out}' already holds a run; pass --resume to continue it or choose another --out")
        return cfg, {"timesteps": 0, "wall_time_s": 0.0, "evaluations": [], "scripted_eval_rmse_m": None}
    saved = out / "train_config.yaml"
    if not saved.is_file() or not ckpt.is_file():
        raise ConfigError(f"cannot resume: '{out}' has no train_config.yaml and checkpoints/{checkpoint}; train without --resume first")
    cfg = load_train_config(saved).model_copy(update={"timesteps": cfg.timesteps})
    return cfg, json.loads((out / "train_log.json").read_text())


def train(cfg: TrainConfig, out_dir: str | os.PathLike, resume: bool = False, progress_bar: bool = True,
          command: str = "") -> dict:
    """Train (or resume) a run in ``out_dir``; returns the train log."""
    out = Path(out_dir)
    cfg, log = open_run(cfg, out, resume)
    env_cfg, eval_cfg = cfg.env_config(), cfg.eval_env_config()
    write_text_atomic(out / "train_config.yaml", yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False))
    write_text_atomic(out / "env_config.yaml", yaml.safe_dump(env_cfg.to_dict(), sort_keys=False))
    log["command"] = command or log.get("command", "")
    log["wall_time_before_s"] = log.get("wall_time_s", 0.0)
    log["_start"] = time.time()

    torch.set_num_threads(1)  # reproducible CPU math; the cores run the env workers
    set_random_seed(cfg.seed)
    layout = PetSwarmEnv(env_cfg).layout
    eval_spec = PolicySpec.from_env(PetSwarmEnv(eval_cfg))
    if log["scripted_eval_rmse_m"] is None:  # the reference every evaluation is compared with
        log["scripted_eval_rmse_m"] = mean_formation_rmse(eval_cfg, make_policy("scripted", eval_spec), cfg.eval_seeds())

    venv = make_vec_env(env_cfg, cfg.num_envs, cfg.num_cpus, cfg.seed + log["timesteps"])
    try:
        if resume:
            model = load_model(out / "checkpoints" / "latest.zip", venv)
        else:
            model = build_model(cfg.ppo, venv, cfg.seed, tensorboard_log=str(out / "tb"))
            if cfg.pretrain.samples > 0:  # warm start: imitate the scripted reference
                log["pretrain"] = pretrain_policy(model, cfg, env_cfg)
                imitation = learned_policy(model, eval_spec, cfg.ppo.activation)
                log["pretrain"]["eval_formation_rmse_m"] = mean_formation_rmse(eval_cfg, imitation, cfg.eval_seeds())
        callback = PeriodicCallback(cfg, out, layout, log)
        remaining = cfg.timesteps - model.num_timesteps
        if remaining > 0:
            model.learn(remaining, callback=callback, reset_num_timesteps=False, tb_log_name="ppo", progress_bar=progress_bar)
        callback.checkpoint()
        if not log["evaluations"] or log["evaluations"][-1]["timesteps"] != model.num_timesteps:
            callback.evaluate()
        write_json_atomic(out / "train_log.json", public_log(log))
    finally:
        venv.close()
    return public_log(log)


def train_command(config: str | None, settings: list[str], timesteps: int | None, out: str, resume: bool,
                  progress_bar: bool, command: str, run=None, **run_options) -> int:
    """``petswarm train``: the config from ``config`` and ``--set KEY=VALUE`` ``settings`` (and
    ``--timesteps``), the run — :func:`train` (SB3), or ``run`` with ``run_options`` (the CLI passes
    :func:`training.rllib_backend.train_rllib` and its ``address``) — and one summary line."""
    overrides = dict(parse_override(item) for item in settings)
    if timesteps:
        overrides["timesteps"] = timesteps
    log = (run or train)(load_train_config(config, overrides), out, resume=resume, progress_bar=progress_bar, command=command,
                         **run_options)
    last = log["evaluations"][-1] if log["evaluations"] else {}
    print(f"trained {log['timesteps']} agent-steps in {log['wall_time_s']:.0f} s; "
          f"eval formation_rmse_m {last.get('formation_rmse_m', float('nan')):.3f} "
          f"(scripted {log['scripted_eval_rmse_m']:.3f}); policy: {out}/policy.npz")
    return 0
