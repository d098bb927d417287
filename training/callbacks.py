"""The SB3 callback of ``petswarm train``: atomic checkpoints and periodic evaluation against the
scripted reference on the same seeds (``checkpoint:`` and ``eval:`` of the training config).

**The best policy is the one shipped.** PPO can lose what it had (a run that reached parity at
300 k agent-steps was 2.2x worse by 400 k), so a run keeps two actors: ``last.npz``, written at
every checkpoint (the state the checkpoint resumes from), and ``policy.npz``, the best evaluated
one. Every evaluation (:func:`evaluate_and_keep`) runs the actor on the evaluation episodes
(``eval.episodes`` seeds, default 10, each with the config it draws) and scores it by the median
over the seeds of its per-seed ratio to the scripted reference on the same seed and config
(``eval.metric``: ``formation_rmse_m`` by default, or ``formation_hold_rmse_m``; an episode whose
figure is NaN where the reference's is not counts as an infinite ratio). A median does not see a
lost formation in fewer than half of the seeds, so evaluations are ranked first by ``not_built``,
the seeds on which the reference built its formation and the actor did not, then by the median
ratio. An evaluation ranked before every earlier one writes ``policy.npz`` and becomes
``log["best"]``; the warm-started (or residual) actor is evaluated before PPO at agent-step 0 and
competes too. The log's evaluations say which was best (``"best": true`` at the time).
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback

from petswarm.baselines.policy import PolicySpec
from petswarm.evaluation.runner import run_episode
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


EPISODE_FIGURES = ("formation_rmse_m", "formation_hold_rmse_m", "building_time_s")
LAST_POLICY = "last.npz"  # the actor of the last checkpoint; policy.npz is the best evaluated one


def pool_episodes(cfg: TrainConfig, policy_for) -> list[dict[str, Any]]:
    """Each periodic evaluation episode (:meth:`TrainConfig.eval_episodes`: with pools, each seed's
    drawn config) of ``policy_for(spec)``, the policy for an env's spec: its seed and
    :data:`EPISODE_FIGURES`. The same seeds and configs for every policy."""
    out = []
    for env_cfg, seed in cfg.eval_episodes():
        env = PetSwarmEnv(env_cfg)
        summary = run_episode(env, policy_for(PolicySpec.from_env(env)), seed)
        env.close()
        out.append({"seed": seed, **{k: summary[k] for k in EPISODE_FIGURES}})
    return out


def _finite_mean(values) -> float:
    values = [v for v in values if math.isfinite(v)]
    return float(sum(values) / len(values)) if values else math.nan


def pool_formation_rmse(cfg: TrainConfig, policy_for) -> float:
    """Mean formation RMSE over the periodic evaluation's episodes of ``policy_for(spec)``
    (:func:`pool_episodes`); NaN episodes left out (NaN if none)."""
    return _finite_mean(e["formation_rmse_m"] for e in pool_episodes(cfg, policy_for))


def median_ratio(episodes: list[dict[str, Any]], reference: list[dict[str, Any]], metric: str) -> float:
    """The median over the seeds of ``metric``'s ratio to the reference's episode on the same seed
    (a NaN figure where the reference has one: an infinite ratio; seeds where the reference has none
    are left out); NaN if no seed counts."""
    ref = {e["seed"]: e[metric] for e in reference}
    ratios = []
    for e in episodes:
        r, x = ref.get(e["seed"], math.nan), e[metric]
        if not (math.isfinite(r) and r > 0):
            continue
        ratios.append(x / r if math.isfinite(x) else math.inf)
    return float(statistics.median(ratios)) if ratios else math.nan


def not_built(episodes: list[dict[str, Any]], reference: list[dict[str, Any]]) -> int:
    """On how many seeds the reference built its formation and the policy did not (a lost
    formation, which a median over the seeds does not see while it is under half of them)."""
    ref = {e["seed"]: math.isfinite(e["building_time_s"]) for e in reference}
    return sum(ref.get(e["seed"], False) and not math.isfinite(e["building_time_s"]) for e in episodes)


def _rank(unbuilt: int, ratio: float) -> tuple[int, float]:
    """The order of evaluations (lower is better): fewer lost formations first, then the median ratio (NaN last)."""
    return unbuilt, (math.inf if math.isnan(ratio) else ratio)


def scripted_reference(cfg: TrainConfig, log: dict[str, Any]) -> None:
    """The scripted reference's evaluation episodes and mean RMSE in ``log`` (once per run; a run
    resumed from before the per-episode figures gets them now, on the same seeds and configs)."""
    from petswarm.baselines.registry import make_policy

    if log.get("scripted_eval_episodes") is None:
        log["scripted_eval_episodes"] = pool_episodes(cfg, lambda spec: make_policy("scripted", spec))
    if log.get("scripted_eval_rmse_m") is None:
        log["scripted_eval_rmse_m"] = _finite_mean(e["formation_rmse_m"] for e in log["scripted_eval_episodes"])


def evaluate_and_keep(cfg: TrainConfig, out: Path, log: dict[str, Any], policy_for, timesteps: int,
                      export: Callable[[Path, dict[str, Any]], None], algorithm: str,
                      extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """One periodic evaluation of ``policy_for`` at ``timesteps`` (module docstring): appended to
    ``log["evaluations"]`` (with ``extra``); if its median ratio is below every earlier one's,
    ``export(path, info)`` writes the actor to ``out/policy.npz`` and ``log["best"]`` records it.
    Returns the record."""
    scripted_reference(cfg, log)
    episodes = pool_episodes(cfg, policy_for)
    metric = cfg.eval.metric
    ratio = median_ratio(episodes, log["scripted_eval_episodes"], metric)
    unbuilt = not_built(episodes, log["scripted_eval_episodes"])
    wall = log.get("wall_time_before_s", 0.0) + time.time() - log["_start"] if "_start" in log else None
    record = {"timesteps": int(timesteps), "formation_rmse_m": _finite_mean(e["formation_rmse_m"] for e in episodes),
              "scripted_rmse_m": log["scripted_eval_rmse_m"],
              "formation_hold_rmse_m": _finite_mean(e["formation_hold_rmse_m"] for e in episodes),
              "built": sum(math.isfinite(e["building_time_s"]) for e in episodes), "episodes": len(episodes),
              "metric": metric, "median_ratio": ratio, "not_built": unbuilt,
              "wall_time_s": None if wall is None else round(wall, 1), **(extra or {})}
    best = log.get("best")
    better = best is None or _rank(unbuilt, ratio) < _rank(best.get("not_built", 0), best["median_ratio"])
    record["best"] = bool(better)
    log["evaluations"].append(record)
    if better:
        info = policy_info(cfg, {**log, "timesteps": int(timesteps), "wall_time_s": wall or 0.0}, algorithm)
        info["selected"] = {"by": f"median over {len(episodes)} evaluation seeds of the {metric} ratio to scripted",
                            "median_ratio": ratio, "timesteps": int(timesteps)}
        export(Path(out) / "policy.npz", info)
        log["best"] = {"timesteps": int(timesteps), "median_ratio": ratio, "not_built": unbuilt, "metric": metric,
                       "formation_rmse_m": record["formation_rmse_m"], "wall_time_s": record["wall_time_s"]}
    return record


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
    ``last.npz`` and ``train_log.json`` in ``out``, each written atomically); every
    ``cfg.eval.every_steps`` an evaluation of the current actor on the evaluation seeds, logged
    beside the scripted reference's RMSE (``log["scripted_eval_rmse_m"]``) to ``log["evaluations"]``
    and TensorBoard ``eval/*``, which writes ``policy.npz`` when it is the best so far
    (:func:`evaluate_and_keep`). The schedule continues from ``log["timesteps"]`` (a resumed run).

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
        export_policy(self.model, self.out / LAST_POLICY, self.layout, self.cfg.ppo.activation,
                      policy_info(self.cfg, log, ALGORITHMS[self.cfg.ppo.critic]), self.cfg.residual())
        write_json_atomic(self.out / "train_log.json", public_log(log))

    def evaluate(self) -> None:
        record = evaluate_model(self.cfg, self.out, self.train_log, self.model, self.layout, int(self.num_timesteps))
        ref = record["scripted_rmse_m"]
        self.logger.record("eval/formation_rmse_m", record["formation_rmse_m"])
        self.logger.record("eval/scripted_rmse_m", ref)
        self.logger.record("eval/ratio_to_scripted", record["formation_rmse_m"] / ref if ref else math.nan)
        self.logger.record("eval/median_ratio_to_scripted", record["median_ratio"])


def evaluate_model(cfg: TrainConfig, out: Path, log: dict[str, Any], model, layout: ObservationLayout,
                   timesteps: int) -> dict[str, Any]:
    """:func:`evaluate_and_keep` for an SB3 model's current actor (also the warm-started one, before PPO)."""
    residual = cfg.residual()
    return evaluate_and_keep(
        cfg, out, log, lambda spec: learned_policy(model, spec, cfg.ppo.activation, residual), timesteps,
        lambda path, info: export_policy(model, path, layout, cfg.ppo.activation, info, residual), ALGORITHMS[cfg.ppo.critic],
        {"n_updates": int(model._n_updates)})  # an evaluation inside a rollout sees the weights of the update before it
