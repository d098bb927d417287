"""The SB3 callback of ``petswarm train``: atomic checkpoints and periodic evaluation against the
scripted reference on the same seeds (``checkpoint:`` and ``eval:`` of the training config)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback

from petswarm.baselines.policy import PolicySpec
from petswarm.evaluation.evaluate import mean_formation_rmse
from petswarm_env.env import PetSwarmEnv
from petswarm_env.files import write_json_atomic
from petswarm_env.observe import ObservationLayout
from petswarm.training.checkpoint import checkpoint_path, save_checkpoint
from petswarm.training.config import TrainConfig
from petswarm.training.export import export_policy, learned_policy


def public_log(log: dict[str, Any]) -> dict[str, Any]:
    """The train log without its in-memory bookkeeping (keys starting with ``_``)."""
    return {k: v for k, v in log.items() if not k.startswith("_")}


ALGORITHMS = {"local": "PPO (stable-baselines3)", "state": "MAPPO (stable-baselines3 PPO, centralized critic on env.state())"}


def pool_formation_rmse(cfg: TrainConfig, policy_for) -> float:
    """Mean formation RMSE over the periodic evaluation's episodes (:meth:`TrainConfig.eval_episodes`:
    with pools, each seed's drawn config) of ``policy_for(spec)``, the policy for an env's spec;
    NaN episodes left out (NaN if none). The same seeds and configs for every policy."""
    values = []
    for env_cfg, seed in cfg.eval_episodes():
        values.append(mean_formation_rmse(env_cfg, policy_for(PolicySpec.from_env(PetSwarmEnv(env_cfg))), [seed]))
    values = [v for v in values if math.isfinite(v)]
    return float(sum(values) / len(values)) if values else math.nan


def policy_info(cfg: TrainConfig, log: dict[str, Any], algorithm: str = "PPO (stable-baselines3)") -> dict[str, Any]:
    """How an exported policy was trained (stored in the policy file)."""
    return {
        "algorithm": f"{algorithm}, parameter sharing over slaves",
        "timesteps": log["timesteps"],
        "wall_time_s": round(log["wall_time_s"], 1),
        "train_config": cfg.model_dump(mode="json"),
        "command": log.get("command", ""),
    }


class PeriodicCallback(BaseCallback):
    """Every ``cfg.checkpoint.every_steps`` agent-steps a checkpoint (``checkpoints/latest.npz``,
    ``policy.npz`` and ``train_log.json`` in ``out``, each written atomically); every
    ``cfg.eval.every_steps`` an evaluation of the current actor on the evaluation seeds, logged
    beside the scripted reference's RMSE (``log["scripted_eval_rmse_m"]``) to ``log["evaluations"]``
    and TensorBoard ``eval/*``. The schedule continues from ``log["timesteps"]`` (a resumed run).

    ``log`` is the run's train log, updated in place; it holds ``wall_time_before_s`` and ``_start``
    (the wall time of earlier sessions and this session's start time)."""

    def __init__(self, cfg: TrainConfig, out: Path, layout: ObservationLayout, log: dict[str, Any]):
        super().__init__()
        self.cfg, self.out, self.layout, self.train_log = cfg, Path(out), layout, log
        self.eval_cfg = cfg.eval_env_config()
        self.seeds = cfg.eval_seeds()
        self.next_ckpt = (log["timesteps"] // cfg.checkpoint.every_steps + 1) * cfg.checkpoint.every_steps
        self.next_eval = (log["timesteps"] // cfg.eval.every_steps + 1) * cfg.eval.every_steps

    def _on_step(self) -> bool:
        n = self.num_timesteps
        # rows of robots in slave-role driving (FixedAgents' "active"): the agent-steps that were not padding
        self.train_log["active_agent_steps"] = self.train_log.get("active_agent_steps", 0) + sum(
            int(i.get("active", 1)) for i in self.locals.get("infos", ()))
        if n >= self.next_eval:
            self.next_eval += self.cfg.eval.every_steps
            self.evaluate()
        if n >= self.next_ckpt:
            self.next_ckpt += self.cfg.checkpoint.every_steps
            self.checkpoint()
        return True

    def checkpoint(self) -> None:
        log = self.train_log
        log["timesteps"] = int(self.num_timesteps)
        log["wall_time_s"] = log["wall_time_before_s"] + time.time() - log["_start"]
        save_checkpoint(checkpoint_path(self.out), self.model, self.cfg.ppo.activation, list(self.cfg.ppo.net_arch))
        export_policy(self.model, self.out / "policy.npz", self.layout, self.cfg.ppo.activation,
                      policy_info(self.cfg, log, ALGORITHMS[self.cfg.ppo.critic]), self.cfg.residual())
        write_json_atomic(self.out / "train_log.json", public_log(log))

    def evaluate(self) -> None:
        rmse = pool_formation_rmse(self.cfg, lambda spec: learned_policy(self.model, spec, self.cfg.ppo.activation, self.cfg.residual()))
        ref = self.train_log["scripted_eval_rmse_m"]
        log = self.train_log
        wall = log.get("wall_time_before_s", 0.0) + time.time() - log["_start"] if "_start" in log else None
        log["evaluations"].append({"timesteps": int(self.num_timesteps), "formation_rmse_m": rmse, "scripted_rmse_m": ref,
                                   "wall_time_s": None if wall is None else round(wall, 1)})
        self.logger.record("eval/formation_rmse_m", rmse)
        self.logger.record("eval/scripted_rmse_m", ref)
        self.logger.record("eval/ratio_to_scripted", rmse / ref if ref else math.nan)
