"""RLlib's sampling throughput with 0, 1, 2, … env runners on this machine (needs the rllib extra)::

    python -m petswarm.bench.rllib_scaling --runners 0,1,2 --iterations 4 [--repeat 3] [--envs-per-runner 1] [--json OUT]

One local Ray (bound to 127.0.0.1, :func:`petswarm.training.rllib_backend.start_ray`), then for each runner
count the training config's PPO (``configs/train/ppo.yaml``, warm start off) for ``iterations``
``algo.train()`` calls; the first (actor start-up, first sync) is not counted. Reported per count:
agent-steps/s over whole iterations (sampling + learning) and over sampling alone (the wall time
of PPO's ``synchronous_parallel_sample`` calls, timed here), the CPU time of the driver and of each runner process, and the
machine's load average (the cores are shared: a loaded machine gains nothing from more runners).
Speed is a ratio here too: the runners' figures are read against the 0-runner one of the same run.
With ``--repeat K`` the runner counts are measured K times in turn (0, 1, 2, 0, 1, 2, …), so a drift
of the machine's speed touches every count alike, and each count's figure is the median of its K
rows (``summary``); the ratios are those of the medians.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from petswarm_env.files import write_json_atomic


def _cpu_s(pid: int) -> float:
    """utime + stime of a process (all its threads), s."""
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def measure(runners: list[int], iterations: int, envs_per_runner: int, overrides: dict | None = None, repeat: int = 1) -> dict:
    """The figures of each runner count (``runners`` measured ``repeat`` times in turn), from one local Ray instance."""
    import ray
    import torch

    from petswarm.training import rllib_backend as rb
    from petswarm.training.config import load_train_config

    torch.set_num_threads(1)  # as train_rllib: one thread in the driver (more ran the driver's sampler 6x slower, loaded)
    cfg = load_train_config(overrides={"pretrain.samples": 0, **(overrides or {})})
    import ray.rllib.algorithms.ppo.ppo as ppo_module

    sampled = []  # wall time of each sampling round (RLlib's own timer is a moving average)
    sample = ppo_module.synchronous_parallel_sample

    def timed_sample(*args, **kwargs):
        t = time.perf_counter()
        out = sample(*args, **kwargs)
        sampled.append(time.perf_counter() - t)
        return out

    ppo_module.synchronous_parallel_sample = timed_sample
    rb.start_ray(None, max(1, max(runners)))
    rb.register_env(rb.ENV_ID, rb.make_env)
    rows = []
    try:
        for n in runners * repeat:
            c = cfg.model_copy(update={"rllib": cfg.rllib.model_copy(update={"num_env_runners": n,
                                                                             "num_envs_per_env_runner": envs_per_runner})})
            algo = rb.algorithm_config(c, c.env_config(), c.seed).build_algo()
            pids = [os.getpid()] + (algo.env_runner_group.foreach_env_runner(lambda er: os.getpid(), local_env_runner=False) if n else [])
            algo.train()  # warm-up: not counted
            steps = wall = 0.0
            cpu0, load0, first = [_cpu_s(p) for p in pids], os.getloadavg()[0], len(sampled)
            for _ in range(iterations - 1):
                t = time.perf_counter()
                result = algo.train()
                wall += time.perf_counter() - t
                steps += float(sum(result["env_runners"]["num_agent_steps_sampled"].values()))
            sample_s = sum(sampled[first:])
            cpu = [round(_cpu_s(p) - c0, 1) for p, c0 in zip(pids, cpu0)]
            rows.append({"env_runners": n, "envs_per_runner": envs_per_runner, "agent_steps": int(steps),
                         "agent_steps_per_s": round(float(steps / wall), 1),
                         "sampling_agent_steps_per_s": round(steps / sample_s, 1) if sample_s > 0 else None,
                         "cpu_s_driver": cpu[0], "cpu_s_runners": cpu[1:], "load_before": round(load0, 2),
                         "load_after": round(os.getloadavg()[0], 2)})
            algo.stop()
            print(rows[-1], flush=True)
    finally:
        ray.shutdown()
    summary = summarize(rows)
    return {"cpus": os.cpu_count(), "repeat": repeat, "rows": rows, "summary": summary,
            "train_batch_env_steps": cfg.ppo.n_steps * cfg.num_envs}


def summarize(rows: list[dict]) -> list[dict]:
    """Per runner count (in first-seen order): the median agent-steps/s over its rows, whole
    iterations and sampling alone, and their ratios to the 0-runner medians (None without a
    0-runner row). Each row also gets its ratio to the 0-runner row measured just before it."""
    counts = list(dict.fromkeys(row["env_runners"] for row in rows))
    median = {key: {n: float(np.median([r[key] for r in rows if r["env_runners"] == n and r[key] is not None] or [np.nan]))
                    for n in counts} for key in ("agent_steps_per_s", "sampling_agent_steps_per_s")}
    base = None
    for row in rows:
        base = row["agent_steps_per_s"] if row["env_runners"] == 0 else base
        row["ratio_to_0_runners"] = round(row["agent_steps_per_s"] / base, 2) if base else None
    out = []
    for n in counts:
        whole, sampling = median["agent_steps_per_s"][n], median["sampling_agent_steps_per_s"][n]
        b0, s0 = median["agent_steps_per_s"].get(0), median["sampling_agent_steps_per_s"].get(0)
        out.append({"env_runners": n, "rows": sum(r["env_runners"] == n for r in rows),
                    "agent_steps_per_s": round(whole, 1), "sampling_agent_steps_per_s": round(sampling, 1),
                    "ratio_to_0_runners": round(whole / b0, 2) if b0 else None,
                    "sampling_ratio_to_0_runners": round(sampling / s0, 2) if s0 else None})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="RLlib samples/s with 0, 1, 2 … env runners")
    parser.add_argument("--runners", default="0,1,2")
    parser.add_argument("--iterations", type=int, default=4)
    parser.add_argument("--repeat", type=int, default=1, help="measure the runner counts this many times in turn; medians (default 1)")
    parser.add_argument("--envs-per-runner", type=int, default=4, help="rllib.num_envs_per_env_runner (default 4, the config's)")
    parser.add_argument("--json", metavar="OUT")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    result = measure([int(x) for x in args.runners.split(",")], max(2, args.iterations), args.envs_per_runner, repeat=args.repeat)
    print(json.dumps(result, indent=1))
    for row in result["summary"]:
        print(f"{row['env_runners']} env runners ({row['rows']} rows): {row['agent_steps_per_s']:.0f} agent-steps/s "
              f"({row['ratio_to_0_runners']} x 0 runners), sampling alone {row['sampling_agent_steps_per_s']:.0f} "
              f"({row['sampling_ratio_to_0_runners']} x)")
    if args.json:
        write_json_atomic(args.json, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
