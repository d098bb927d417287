"""Training throughput: PPO samples/s through the training vector env (:mod:`training`)."""

from __future__ import annotations

import os
import time
import warnings
from typing import Any

from petswarm.bench.settings import BenchSettings, log


def bench_training(s: BenchSettings, verbose: bool = False) -> dict:
    """PPO samples/s (agent-steps per second of ``model.learn``, updates included) through the
    training vector env: 1 worker = the env copy in this process (num_envs 1, num_cpus 0);
    k workers = k env copies in k worker processes (num_envs k, num_cpus k)."""
    try:
        import stable_baselines3  # noqa: F401  (the training stack, used by _one_run)
        import torch

        from petswarm.training.config import load_train_config
    except ImportError as exc:
        return {"skipped": f"{exc.name or exc} is not installed; set up the training stack with: bash scripts/setup.sh train"}

    tcfg = load_train_config()
    env_cfg = tcfg.env_config()
    slaves = env_cfg.swarm.num_slaves + env_cfg.swarm.extra_robots
    p = tcfg.ppo
    torch.set_num_threads(1)  # as `petswarm train`: the cores run the env workers
    runs = [_one_run(path, k, s, p, env_cfg, slaves, verbose)
            for path, k in [("supersuit", w) for w in s.training_workers] + [("petswarm", n) for n in s.training_vector_envs]]
    out: dict[str, Any] = {
        "env": f"training env (configs/train/ppo.yaml): {slaves} slaves, max_cycles {env_cfg.max_cycles}",
        "net_arch": list(p.net_arch),
        "torch_threads": 1,
        "runs": runs,
        "method": "wall time of model.learn(total_timesteps) for a fresh PPO (configs/train/ppo.yaml "
        "hyper-parameters, n_steps = rollout / vector rows); includes env steps, policy inference and "
        "the PPO updates; model and env construction are excluded. *supersuit*: SuperSuit's pipeline over "
        "FixedAgents, 1 worker = one env copy in this process (num_envs 1, num_cpus 0), k workers = k copies "
        "in k processes; *petswarm*: the batched vector env (`petswarm_env.vector_env`, `--vec-env petswarm`, "
        "the default of `petswarm train`), num_envs copies in this process. *per CPU-s*: the samples over the "
        "CPU time of this process and its joined worker processes (`os.times`).",
    }
    base = next((r for r in runs if r["path"] == "supersuit" and r["num_envs"] == 1), None)
    vec = [r for r in runs if r["path"] == "petswarm"]
    if base is not None and vec:
        best = max(vec, key=lambda r: r["samples_per_s"])
        out["vector_vs_supersuit_1"] = best["samples_per_s"] / base["samples_per_s"]
        out["vector_vs_supersuit_1_num_envs"] = best["num_envs"]
    return out


def _one_run(path: str, k: int, s: BenchSettings, p: Any, env_cfg: Any, slaves: int, verbose: bool) -> dict:
    """One fresh PPO trained for ``s.training_samples`` samples on vector path ``path`` with ``k``
    copies (SuperSuit: ``k`` worker processes, or one copy in this process for 1)."""
    from stable_baselines3.common.utils import set_random_seed

    from petswarm.training.train import build_model
    from petswarm.training.vec_env import make_vec_env

    if path == "supersuit":  # k workers: k copies in k processes; 1: one copy in this process
        num_envs, num_cpus = (1, 0) if k <= 1 else (k, k)
    else:  # the batched vector env: k copies in this process
        num_envs, num_cpus = k, 0
    rows = num_envs * slaves
    n_steps = max(8, s.training_rollout // rows)
    rollout = n_steps * rows
    batch = min(p.batch_size, rollout)
    log(verbose, f"training: {path}, {num_envs} cop{'ies' if num_envs > 1 else 'y'}, {num_cpus} processes, "
                 f"{s.training_samples} samples, n_steps {n_steps}")
    set_random_seed(s.seed)
    with warnings.catch_warnings():  # SB3 notes SuperSuit's vector env has no render_mode
        warnings.filterwarnings("ignore", message="The `render_mode` attribute is not defined")
        venv = make_vec_env(env_cfg, num_envs, num_cpus, s.seed, vec_env=path)
    try:
        model = build_model(p, venv, s.seed, n_steps=n_steps, batch_size=batch)
        env_cpu = _time_step_wait(venv.venv)
        c0 = _cpu()
        t0, thread0 = time.perf_counter(), time.thread_time()
        model.learn(total_timesteps=s.training_samples, progress_bar=False)
        wall, thread = time.perf_counter() - t0, time.thread_time() - thread0
        samples = int(model.num_timesteps)
    finally:
        venv.close()
    cpu = _cpu() - c0  # the worker processes count once joined at close
    return {
        "path": path,
        "workers": max(1, num_cpus),
        "num_envs": num_envs,
        "num_cpus": num_cpus,
        "vector_rows": rows,
        "n_steps": n_steps,
        "rollout_samples": rollout,
        "batch_size": batch,
        "n_epochs": p.n_epochs,
        "samples": samples,
        "wall_s": wall,
        "cpu_s": cpu,
        "samples_per_s": samples / wall,
        "samples_per_cpu_s": samples / cpu if cpu > 0 else None,
        "env_cpu_share": env_cpu[0] / thread if thread > 0 else None,
    }


def _time_step_wait(vec: Any) -> list[float]:
    """Count this thread's CPU time in ``vec.step_wait`` (the vector env under SB3's VecMonitor, that the
    learner waits on each step) into the returned one-item list: over the thread's CPU time in
    ``learn()`` the env's share of it (in this process: with worker processes only the waiting)."""
    spent, step_wait = [0.0], vec.step_wait

    def timed():
        t = time.thread_time()
        try:
            return step_wait()
        finally:
            spent[0] += time.thread_time() - t

    vec.step_wait = timed
    return spent


def _cpu() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system
