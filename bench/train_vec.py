"""SB3 PPO samples/s with the batched vector env against SuperSuit's pipeline, side by side.

    python -m petswarm.bench.train_vec [--samples 10240] [--rounds 2] [--num-envs 4] [--num-cpus 2] [--paths supersuit petswarm]

Each round trains a fresh PPO of ``configs/train/ppo.yaml`` (its hyper-parameters, its env, one
torch thread as ``petswarm train``) for ``--samples`` agent-steps on each path in turn:
``supersuit`` (``num_envs`` copies over ``num_cpus`` worker processes, the path ``petswarm train``
took before the vector env) and ``petswarm`` (the ``num_envs`` copies in this process,
:class:`petswarm.training.vec_env.PetswarmVecEnv`). Reported per path, the median over rounds: wall
samples/s of ``model.learn`` (env steps, inference and the PPO updates), and CPU samples/s: the
same samples over the CPU time of this process and its worker processes (``os.times``, the workers
counted once they are joined at ``close``), which other processes' load on a shared machine
disturbs less; and the env's share of ``learn()``: the wall time the learner waits in the vector
env's ``step_wait`` (``env_share``), and the CPU time of this thread in it over the thread's CPU
time in ``learn()`` (``env_cpu_share``: the same split, undisturbed by other processes; on the
SuperSuit path with worker processes it counts only the waiting, not the workers' stepping).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
import warnings


def _cpu() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def one_run(path: str, samples: int, num_envs: int, num_cpus: int, seed: int = 0) -> dict:
    import torch
    from stable_baselines3.common.utils import set_random_seed

    from petswarm.training.config import load_train_config
    from petswarm.training.train import build_model
    from petswarm.training.vec_env import make_vec_env

    tcfg = load_train_config()
    torch.set_num_threads(1)
    set_random_seed(seed)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="The `render_mode` attribute is not defined")
        venv = make_vec_env(tcfg.env_config(), num_envs, num_cpus, seed, vec_env=path)
    model = build_model(tcfg.ppo, venv, seed)
    inner, env_s, env_cpu = venv.venv, [0.0], [0.0]  # under SB3's VecMonitor: the vector env the learner waits on each step
    step_wait = inner.step_wait

    def timed_step_wait():
        t, c = time.perf_counter(), time.thread_time()
        try:
            return step_wait()
        finally:
            env_s[0] += time.perf_counter() - t
            env_cpu[0] += time.thread_time() - c

    inner.step_wait = timed_step_wait
    c0, t0, thread0 = _cpu(), time.perf_counter(), time.thread_time()
    model.learn(total_timesteps=samples, progress_bar=False)
    wall, thread = time.perf_counter() - t0, time.thread_time() - thread0
    venv.close()
    cpu = _cpu() - c0
    n = int(model.num_timesteps)
    return {"path": path, "samples": n, "rows": venv.num_envs, "wall_s": wall, "cpu_s": cpu, "env_share": env_s[0] / wall,
            "env_cpu_share": env_cpu[0] / thread,
            "samples_per_s": n / wall, "samples_per_cpu_s": n / cpu}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10240)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--num-envs", type=int, default=4)
    ap.add_argument("--num-cpus", type=int, default=2)
    ap.add_argument("--paths", nargs="+", choices=("supersuit", "petswarm"), default=["supersuit", "petswarm"])
    args = ap.parse_args(argv)
    runs = []
    for r in range(args.rounds):
        for path in args.paths:
            run = one_run(path, args.samples, args.num_envs, args.num_cpus)
            runs.append(run)
            print(f"round {r}: {path:9s} {run['samples']} samples, {run['samples_per_s']:,.0f} samples/s wall, "
                  f"{run['samples_per_cpu_s']:,.0f} samples per CPU-s, env {100 * run['env_share']:.0f} % of learn() "
                  f"({100 * run['env_cpu_share']:.0f} % of its CPU time)", flush=True)
    out = {"args": vars(args), "runs": runs}
    for path in args.paths:
        mine = [x for x in runs if x["path"] == path]
        out[path] = {k: statistics.median(x[k] for x in mine)
                     for k in ("samples_per_s", "samples_per_cpu_s", "env_share", "env_cpu_share")}
    if len(args.paths) == 2:
        out["wall_speedup"] = out["petswarm"]["samples_per_s"] / out["supersuit"]["samples_per_s"]
        out["cpu_speedup"] = out["petswarm"]["samples_per_cpu_s"] / out["supersuit"]["samples_per_cpu_s"]
    print(json.dumps({k: out[k] for k in (*args.paths, "wall_speedup", "cpu_speedup") if k in out}, indent=1))
    return out


if __name__ == "__main__":
    main()
