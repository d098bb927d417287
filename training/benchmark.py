"""The benchmark of slave policies on named tasks (``petswarm benchmark``), after BenchMARL's for VMAS
(Bettini et al. 2024) and rliable's statistics (Agarwal et al. 2021).

Read :func:`run_benchmark` top to bottom: for every task (env overrides) and every algorithm of
:data:`ALGORITHMS` named in the config, each training seed trains a policy on the task
(:func:`petswarm.training.train.train`, its own run folder), then the policy drives every slave on
the held-out seeds (:func:`petswarm.evaluation.grid.run_team`); the untrained rows (the scripted
reference, the privileged teacher) are evaluated once on the same seeds. Each finished run is
written to the JSON at once (atomically), so an interrupted benchmark resumes where it stopped: a
run whose task, algorithm, seed and settings are unchanged is kept. :func:`summarize` gives per task
and algorithm the interquartile mean of the score with a 95 % bootstrap interval, the probability
of improvement over the scripted reference (:mod:`petswarm.evaluation.stats`), building, collisions,
training wall time and agent-steps; :func:`write_markdown` and :func:`write_plot` the page and its figure.

An algorithm is a row added with a small adapter: :class:`Algorithm` (``train`` returns the policy
file and its cost, ``unavailable`` says why it cannot run here, and the row says "not run").
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from pydantic import Field, ValidationError, field_validator

from petswarm_env.config import (ConfigError, Section, format_validation_error, load_config, parse_override, read_yaml)
from petswarm_env.files import check_output_path, jsonable, write_json_atomic, write_text_atomic

BENCHMARK_VERSION = 1  # the JSON's layout; a run recorded by another version is run again
REFERENCE = "scripted"  # the row every probability of improvement is over


class BenchmarkConfig(Section):
    seed: int = Field(ge=0, le=2**62, description="the first held-out evaluation seed")
    episodes: int = Field(ge=1, le=10_000, description="held-out episodes per policy and task")
    training_seeds: list[int] = Field(min_length=1, max_length=100)
    metric: str = "formation_hold_rmse_m"
    set: dict[str, Any] = Field(default_factory=dict)
    train: dict[str, Any] = Field(default_factory=dict)
    tasks: dict[str, dict[str, Any]] = Field(min_length=1)
    algorithms: dict[str, dict[str, Any]] = Field(min_length=1)

    @field_validator("metric")
    @classmethod
    def _metric(cls, v: str) -> str:
        if v not in SCORES:
            raise ValueError(f"metric must be one of {', '.join(SCORES)}")
        return v

    @field_validator("training_seeds")
    @classmethod
    def _seeds(cls, v: list[int]) -> list[int]:
        if len(set(v)) != len(v) or min(v) < 0:
            raise ValueError("training_seeds must be distinct non-negative integers")
        return v

    def eval_seeds(self) -> list[int]:
        return list(range(self.seed, self.seed + self.episodes))

    def task_overrides(self, task: str) -> dict[str, Any]:
        """The env overrides of a task's evaluation: ``set`` then the task's own."""
        return {**self.set, **self.tasks[task]}


SCORES = ("formation_hold_rmse_m", "formation_rmse_m")


# -- the algorithms: each a row, added with an adapter -------------------------------------------------


@dataclass
class Trained:
    """What an algorithm's training returns: the policy file and what it cost."""

    policy: str
    wall_time_s: float
    agent_steps: int  # every agent-step of the env the training consumed (warm start, DAgger, RL)
    detail: dict[str, Any]


@dataclass
class Algorithm:
    """A row of the benchmark. ``policy``: the name the evaluation drives every slave with, for an
    untrained row; ``train(train_config_overrides, out_dir, seed)`` for a trained one;
    ``unavailable()``: None, or why this row cannot run in this petswarm (it is reported "not run")."""

    name: str
    description: str
    policy: str | None = None
    train: Callable[[dict[str, Any], Path, int], Trained] | None = None
    unavailable: Callable[[], str | None] = lambda: None


def _train_ppo(critic: str) -> Callable[[dict[str, Any], Path, int], Trained]:
    def run(overrides: dict[str, Any], out: Path, seed: int) -> Trained:
        from petswarm.training.checkpoint import has_checkpoint
        from petswarm.training.config import load_train_config
        from petswarm.training.train import train

        cfg = load_train_config(overrides={**overrides, "seed": seed, "ppo.critic": critic})
        log = train(cfg, out, resume=has_checkpoint(out), progress_bar=False, command="petswarm benchmark")
        if log.get("finished"):  # trained before an interruption: its log is in the folder
            log = json.loads((out / "train_log.json").read_text(encoding="utf-8"))
        pre = log.get("pretrain") or {}
        warm = int(pre.get("samples", 0)) + int(pre.get("dagger_samples", 0) or 0)
        return Trained(str(out / "last.npz"), float(log["wall_time_s"]), int(log["timesteps"]) + warm,
                       {"ppo_agent_steps": int(log["timesteps"]), "warm_start_samples": warm})
    return run


def _train_recurrent(overrides: dict[str, Any], out: Path, seed: int) -> Trained:
    """The teacher-distilled recurrent policy (training/recurrent.py) from configs/train/recurrent.yaml
    and the row's overrides; its budget is the labelled agent-samples (``timesteps``). A finished run
    in ``out`` is read back; a half-trained one is refused by the trainer (it is not resumable)."""
    from petswarm import shipped
    from petswarm.training.config import load_train_config
    from petswarm.training.recurrent import train_recurrent

    log_path = out / "train_log.json"
    if not (log_path.exists() and (out / "policy.npz").exists()):
        cfg = load_train_config(shipped("recurrent"), overrides={**overrides, "seed": seed})
        train_recurrent(cfg, None, None, out, command="petswarm benchmark")
    log = json.loads(log_path.read_text(encoding="utf-8"))
    return Trained(str(out / "policy.npz"), float(log["wall_time_s"]), int(log["timesteps"]),
                   {"dagger_samples": int(log["timesteps"]), "rounds": len(log.get("rounds", []))})


def _teacher_name() -> str:
    from petswarm.training.teacher import TEACHER_NAME

    return TEACHER_NAME


ALGORITHMS: dict[str, Algorithm] = {a.name: a for a in (
    Algorithm("scripted", "the leader-follower reference (seed 000 §3.6.3), not trained", policy="scripted"),
    Algorithm("teacher", "the privileged teacher (training/teacher.py): reads ground truth, a ceiling, not trained",
              policy=_teacher_name()),
    Algorithm("ippo", "PPO with one policy shared by the slaves, the critic on the observation (stable-baselines3)",
              train=_train_ppo("local")),
    Algorithm("mappo", "PPO with one shared actor and a centralized critic on env.state() (training/state_critic.py)",
              train=_train_ppo("state")),
    Algorithm("recurrent", "a GRU actor distilled from the privileged teacher by DAgger (training/recurrent.py)",
              train=_train_recurrent),
)}


# -- the config ----------------------------------------------------------------------------------------


def load_benchmark_config(path: str | Path, settings: list[str] | tuple[str, ...] = ()) -> BenchmarkConfig:
    """The benchmark config of ``path`` with ``--set KEY=VALUE`` overrides of its top-level keys
    (``episodes=3``, ``training_seeds=[0]``), validated: every task's env and every trained
    algorithm's training config are built once here, so a bad key is one line before any work."""
    data = read_yaml(path, "benchmark file")
    for item in settings:
        key, value = parse_override(item)
        if key not in BenchmarkConfig.model_fields:
            raise ConfigError(f"--set {key}: the benchmark file has no such key; keys: {', '.join(BenchmarkConfig.model_fields)}")
        data[key] = value
    try:
        cfg = BenchmarkConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(f"benchmark file '{path}': {format_validation_error(exc)}") from None
    unknown = [a for a in cfg.algorithms if a not in ALGORITHMS]
    if unknown:
        raise ConfigError(f"benchmark file '{path}': unknown algorithm {unknown[0]!r}; choose from {', '.join(ALGORITHMS)}")
    if REFERENCE not in cfg.algorithms:
        raise ConfigError(f"benchmark file '{path}': algorithms must include {REFERENCE!r}, the row the probability of "
                          "improvement is over")
    for task in cfg.tasks:
        try:
            load_config(overrides=cfg.task_overrides(task))
        except ConfigError as exc:
            raise ConfigError(f"benchmark file '{path}', task {task!r}: {exc}") from None
        for name, extra in cfg.algorithms.items():
            algo = ALGORITHMS[name]
            if algo.train is not None and algo.unavailable() is None:
                from petswarm.training.config import load_train_config

                try:
                    load_train_config(overrides=train_overrides(cfg, task, name))
                except ConfigError as exc:
                    raise ConfigError(f"benchmark file '{path}', task {task!r}, algorithm {name!r}: {exc}") from None
            elif extra:
                raise ConfigError(f"benchmark file '{path}': algorithm {name!r} is not trained here, its settings "
                                  f"{sorted(extra)} would be ignored; write it as {name}: {{}}")
    return cfg


def train_overrides(cfg: BenchmarkConfig, task: str, algorithm: str) -> dict[str, Any]:
    """The training config's overrides for one task and algorithm: the common ``train:``, the
    algorithm's own, and the task's env (one scenario, no scenario pool)."""
    env = {f"env.{k}": v for k, v in cfg.task_overrides(task).items()}
    return {**cfg.train, **cfg.algorithms[algorithm], "env.user.scenario_pool": [], **env}


def fingerprint(cfg: BenchmarkConfig, task: str, algorithm: str) -> str:
    """What a run's figures depend on, hashed: the task, the algorithm's training settings, the
    held-out seeds, this layout."""
    blob = json.dumps({"task": cfg.task_overrides(task), "algorithm": algorithm,
                       "train": train_overrides(cfg, task, algorithm) if ALGORITHMS[algorithm].train else None,
                       "seeds": cfg.eval_seeds(), "version": BENCHMARK_VERSION}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


# -- running -------------------------------------------------------------------------------------------


def _run_key(task: str, algorithm: str, seed: int | None) -> str:
    return f"{task}/{algorithm}/{'-' if seed is None else seed}"


def read_results(path: Path) -> dict[str, Any]:
    """The runs already recorded in ``path`` (none if it does not exist); a file that is not a
    benchmark's JSON is refused in one line."""
    if not path.exists():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        runs = data["runs"]
        if not isinstance(runs, dict):
            raise TypeError
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError):
        raise ConfigError(f"'{path}' is not a benchmark's JSON (no runs mapping); remove it or name another --json") from None
    return {k: v for k, v in runs.items() if isinstance(v, dict) and v.get("status") == "done"}


def evaluate_policy(cfg: BenchmarkConfig, task: str, policy: str) -> tuple[list[dict[str, Any]], float]:
    """``policy`` on every slave of the task over the held-out seeds: per-episode records
    (:func:`petswarm.evaluation.grid.run_team`) and the wall time."""
    from petswarm.evaluation.grid import run_team

    start = time.time()
    run = run_team(load_config(overrides=cfg.task_overrides(task)), policy, {}, cfg.eval_seeds())
    return run["per_episode"], time.time() - start


def run_benchmark(cfg: BenchmarkConfig, json_path: str | Path, out_dir: str | Path, command: str = "",
                  say: Callable[[str], None] = print) -> dict[str, Any]:
    """Train and evaluate every (task, algorithm, training seed) not yet recorded in ``json_path``;
    returns the whole result (also written to ``json_path`` after each run)."""
    json_path, out_dir = Path(json_path), Path(out_dir)
    done = read_results(json_path)
    runs: dict[str, Any] = {}
    not_run: dict[str, str] = {}
    data = {"version": BENCHMARK_VERSION, "command": command, "config": cfg.model_dump(mode="json"), "runs": runs,
            "not_run": not_run}
    total = sum(1 if ALGORITHMS[a].train is None else len(cfg.training_seeds) for a in cfg.algorithms) * len(cfg.tasks)
    count = 0
    for task in cfg.tasks:
        for name in cfg.algorithms:
            algo = ALGORITHMS[name]
            reason = algo.unavailable()
            if reason:
                not_run[name] = reason
                count += 1 if algo.train is None else len(cfg.training_seeds)
                continue
            fp = fingerprint(cfg, task, name)
            for seed in (cfg.training_seeds if algo.train else [None]):
                count += 1
                key = _run_key(task, name, seed)
                kept = done.get(key)
                if kept and kept.get("fingerprint") == fp:
                    runs[key] = kept
                    continue
                record: dict[str, Any] = {"task": task, "algorithm": name, "training_seed": seed, "fingerprint": fp}
                if algo.train:
                    trained = algo.train(train_overrides(cfg, task, name), out_dir / task / name / f"seed{seed}-{fp}", seed)
                    policy = trained.policy
                    record.update({"policy": policy, "wall_time_s": trained.wall_time_s, "agent_steps": trained.agent_steps,
                                   **trained.detail})
                else:
                    policy = algo.policy
                    record.update({"policy": policy, "wall_time_s": 0.0, "agent_steps": 0})
                record["episodes"], record["eval_wall_s"] = evaluate_policy(cfg, task, policy)
                record["status"] = "done"
                runs[key] = record
                write_json_atomic(json_path, jsonable(data))
                score = [e.get(cfg.metric) for e in record["episodes"]]
                finite = [s for s in score if isinstance(s, (int, float)) and math.isfinite(s)]
                say(f"[{count}/{total}] {key}: {cfg.metric} mean {sum(finite) / len(finite) if finite else math.nan:.3f} "
                    f"over {len(finite)}/{len(score)} built episodes; trained {record['wall_time_s']:.0f} s, "
                    f"{record['agent_steps']} agent-steps")
    write_json_atomic(json_path, jsonable(data))
    return data


# -- the summary ---------------------------------------------------------------------------------------


def _scores(run: dict[str, Any], metric: str) -> list[float]:
    from petswarm.evaluation.stats import worst_for_missing

    return list(worst_for_missing(e.get(metric) for e in run["episodes"]))


def _metrics(primary: str) -> list[str]:
    """The scores summarized: the config's metric first, then the other of :data:`SCORES`."""
    return [primary, *(m for m in SCORES if m != primary)]


def summarize(data: dict[str, Any]) -> dict[str, Any]:
    """Per task and algorithm, over its runs (training seeds) and their held-out episodes, for each
    score of :data:`SCORES` (``by_metric``; the config's metric also at the top level): the
    interquartile mean with its 95 % bootstrap interval and the probability of improvement over the
    scripted reference with its interval; the episodes that built their formation, collisions per
    episode, the mean training wall time and agent-steps per run. Over all tasks (``overall``, per
    score): each score divided by the reference's IQM on its task, the IQM and probability of
    improvement with 95 % intervals stratified over tasks."""
    import numpy as np

    from petswarm.evaluation.stats import task_aggregates

    cfg = data["config"]
    metrics = _metrics(cfg["metric"])
    by: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for run in data["runs"].values():
        by.setdefault((run["task"], run["algorithm"]), []).append(run)
    rows: dict[str, dict[str, Any]] = {}
    normalized: dict[str, dict[str, list[tuple[Any, Any]]]] = {m: {} for m in metrics}
    for task in cfg["tasks"]:
        ref_runs = by.get((task, REFERENCE), [])
        rows[task] = {}
        for name in cfg["algorithms"]:
            runs = sorted(by.get((task, name), []), key=lambda r: -1 if r["training_seed"] is None else r["training_seed"])
            if not runs or not ref_runs:
                rows[task][name] = {"status": "not run", "reason": data.get("not_run", {}).get(name, "no finished run")}
                continue
            row: dict[str, Any] = {"by_metric": {}}
            for m in metrics:
                cand, ref = (np.array([_scores(r, m) for r in rr]) for rr in (runs, ref_runs))
                row["by_metric"][m] = task_aggregates(cand, ref)
                ref_iqm = task_aggregates(ref, ref, reps=1)["iqm"]  # the reference's IQM on this task
                if math.isfinite(ref_iqm) and ref_iqm > 0:
                    normalized[m].setdefault(name, []).append((cand / ref_iqm, ref / ref_iqm))
            eps = [e for r in runs for e in r["episodes"]]
            row.update(row["by_metric"][metrics[0]])
            row.update({
                "status": "done",
                "training_seeds": [r["training_seed"] for r in runs if r["training_seed"] is not None],
                "built": sum(1 for e in eps if isinstance(e.get("building_time_s"), (int, float)) and math.isfinite(e["building_time_s"])),
                "refilled": sum(1 for e in eps if isinstance(e.get("refill_settle_rmse_m"), (int, float))
                                and math.isfinite(e["refill_settle_rmse_m"])),  # a dead slave's place refilled
                "collisions_per_episode": sum(sum(e["collisions"].values()) for e in eps) / len(eps),
                "wall_time_s": float(np.mean([r["wall_time_s"] for r in runs])),
                "agent_steps": int(np.mean([r["agent_steps"] for r in runs])),
            })
            rows[task][name] = row
    overall = {m: _overall(normalized[m], rows, cfg) for m in metrics}
    return {"metric": metrics[0], "metrics": metrics, "tasks": rows, "overall": overall}


def _overall(normalized: dict[str, list[tuple[Any, Any]]], rows: dict[str, Any], cfg: dict[str, Any]) -> dict[str, Any]:
    """Each algorithm's pooled figures over every task (stratified), or why there are none."""
    from petswarm.evaluation.stats import stratified_aggregates

    out = {}
    for name in cfg["algorithms"]:
        if len(normalized.get(name, [])) == len(cfg["tasks"]):
            out[name] = {**stratified_aggregates(normalized[name]), "status": "done"}
        elif all(rows[t][name]["status"] != "done" for t in rows):
            out[name] = {"status": "not run"}
        else:  # a task without this row, or whose reference IQM is not a positive number to divide by (+inf: not built)
            out[name] = {"status": f"not pooled: {len(normalized.get(name, []))} of {len(cfg['tasks'])} tasks (the others lack "
                                   "this row or a finite scripted IQM)"}
    return out


def _ci(point: float, ci: list[float], digits: int) -> str:
    f = lambda x: "∞" if x == math.inf else f"{x:.{digits}f}"  # noqa: E731
    return f"{f(point)} [{f(ci[0])}, {f(ci[1])}]"


def markdown(data: dict[str, Any], summary: dict[str, Any], plot_name: str | None) -> str:
    """The page: how it was made, the budget of each algorithm, one table per task, the aggregate."""
    cfg = data["config"]
    metric = summary["metric"]
    lines = ["# Benchmark of slave policies", "",
             "<!-- written by `petswarm benchmark` (training/benchmark.py); edit configs/benchmark.yaml and run it again -->", "",
             f"Made by `{data.get('command') or 'petswarm benchmark'}`. Each trained algorithm is trained on each task "
             f"from {len(cfg['training_seeds'])} training seeds ({', '.join(map(str, cfg['training_seeds']))}); every policy "
             f"then drives every slave on the same {cfg['episodes']} held-out seeds ({cfg['seed']} … "
             f"{cfg['seed'] + cfg['episodes'] - 1}, never seen in training). Two scores per episode, lower is better: "
             "`formation_hold_rmse_m`, the formation RMSE from the moment the formation is built (an episode whose "
             "formation never built scores +∞, the worst, never dropped), and `formation_rmse_m`, the whole episode's "
             f"(building from the scattered start included). The first named ({metric}) is the config's metric.", "",
             "Statistics after rliable (Agarwal et al. 2021), computed with numpy and scipy in evaluation/stats.py "
             "(rliable 1.2 pins arch < 8, which does not import beside pandas 3): **IQM**, the interquartile mean over "
             "all runs' episodes; its **95 % CI**, a percentile bootstrap drawing the training runs, then each drawn "
             "run's episodes, with replacement (2000 copies); **P(impr.)**, the probability that an episode of the row "
             "scores below one of the scripted reference, ties half, with its bootstrap interval. The last table pools "
             "the tasks, each score divided by the reference's IQM on its task, the bootstrap stratified over tasks.", "",
             "## Budgets", ""]
    lines.append("| algorithm | what | training budget per run |")
    lines.append("|---|---|---|")
    for name, extra in cfg["algorithms"].items():
        algo = ALGORITHMS.get(name)
        budget = ", ".join(f"{k}: {v}" for k, v in extra.items()) or "none (not trained)"
        if algo and algo.train:
            common = {k: v for k, v in cfg["train"].items() if k not in extra}
            budget += "; common: " + ", ".join(f"{k}: {v}" for k, v in common.items())
        lines.append(f"| {name} | {algo.description if algo else '?'} | {budget} |")
    lines += ["", "Agent-steps: every agent-step of the env a training consumed (the warm start's demonstrations and PPO's "
              "samples); training wall time: the run's own clock, its start and end evaluations included, on a shared "
              "two-core machine. Short budgets: the figures say where each algorithm stands after this budget, not what "
              "it can reach.", ""]
    if plot_name:
        lines += [f"![IQM with 95 % CIs per task]({plot_name})", ""]
    short = {"formation_hold_rmse_m": "hold RMSE", "formation_rmse_m": "whole-episode RMSE"}
    ms = summary["metrics"]
    header = ("| algorithm | runs × episodes | " + " | ".join(f"IQM {short[m]} (m) [95 % CI] | P(impr.) {short[m]} [95 % CI]"
                                                            for m in ms)
              + " | built | collisions / episode | training wall time (s) | agent-steps / run |")
    rule = "|---" * (6 + 2 * len(ms)) + "|"
    for task, rows in summary["tasks"].items():
        lines += [f"## {task}", "", f"Env overrides: `{json.dumps(cfg['tasks'][task])}`", ""]
        done = [(n, r) for n, r in rows.items() if r["status"] == "done"]
        if any(r["refilled"] for _, r in done) or cfg["tasks"][task].get("faults"):  # a recruit took a dead robot's slot (petswarm_env/metrics.py)
            lines += ["Episodes in which a dead slave's place was refilled: "
                      + ", ".join(f"{n} {r['refilled']}/{r['episodes']}" for n, r in done) + ".", ""]
        lines += [header, rule]
        for name, r in rows.items():
            if r["status"] != "done":
                lines.append(f"| {name} | not run: {r['reason']} |" + " |" * (4 + 2 * len(ms)))
                continue
            cells = []
            for m in ms:
                a = r["by_metric"][m]
                cells += [_ci(a["iqm"], a["iqm_ci95"], 3), "—" if name == REFERENCE else _ci(a["p_improvement"], a["p_improvement_ci95"], 2)]
            lines.append(f"| {name} | {r['runs']} × {r['episodes'] // r['runs']} | " + " | ".join(cells)
                         + f" | {r['built']}/{r['episodes']} | {r['collisions_per_episode']:.2f} | {r['wall_time_s']:.0f} | "
                         f"{r['agent_steps']} |")
        lines.append("")
    lines += ["## All tasks", "", "Each score divided by the scripted reference's IQM on its task (1 = the reference); "
              "a score whose scripted IQM is +∞ on some task (half its episodes never built) cannot be pooled.", "",
              "| algorithm | " + " | ".join(f"normalized IQM {short[m]} [95 % CI] | mean P(impr.) {short[m]} [95 % CI]" for m in ms)
              + " |", "|---" * (1 + 2 * len(ms)) + "|"]
    for name in cfg["algorithms"]:
        cells = []
        for m in ms:
            r = summary["overall"][m][name]
            if r["status"] != "done":
                cells += [r["status"], ""]
                continue
            cells += [_ci(r["iqm"], r["iqm_ci95"], 2), "—" if name == REFERENCE else _ci(r["p_improvement"], r["p_improvement_ci95"], 2)]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write_plot(summary: dict[str, Any], path: str | Path) -> None:
    """One row of panels per score, one panel per task and one for all tasks: each algorithm's IQM
    with its 95 % interval (rliable's interval-estimate plot); an interval reaching +∞ is drawn to
    the panel's edge and marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ms, tasks = summary["metrics"], list(summary["tasks"])
    names = list(next(iter(summary["tasks"].values())))
    fig, axes = plt.subplots(len(ms), len(tasks) + 1, figsize=(2.9 * (len(tasks) + 1), (0.45 * len(names) + 1.4) * len(ms)),
                             sharey=True, squeeze=False)
    for i, m in enumerate(ms):
        panels = [(t, {n: (r["by_metric"][m] if r["status"] == "done" else None) for n, r in summary["tasks"][t].items()}, "m")
                  for t in tasks]
        panels.append(("all tasks (÷ scripted)", {n: (r if r["status"] == "done" else None) for n, r in summary["overall"][m].items()}, ""))
        for ax, (title, rows, unit) in zip(axes[i], panels):
            finite = [v for r in rows.values() if r for v in (r["iqm"], *r["iqm_ci95"]) if math.isfinite(v)]
            edge = max(finite) * 1.15 if finite else 1.0
            for y, name in enumerate(names):
                r = rows.get(name)
                if r is None:
                    ax.text(0.02 * edge, y, "not run / not pooled", va="center", fontsize=7, color="grey")
                    continue
                lo, hi = (min(v, edge) for v in r["iqm_ci95"])
                ax.barh(y, hi - lo, left=lo, height=0.6, alpha=0.35, color=f"C{y}")
                ax.plot([min(r["iqm"], edge)] * 2, [y - 0.3, y + 0.3], color=f"C{y}", lw=2)
                if not math.isfinite(r["iqm_ci95"][1]):
                    ax.text(edge, y, "→∞ ", va="center", ha="right", fontsize=8)
            ax.set_title(title, fontsize=9)
            ax.set_xlim(0, edge)
            ax.set_ylim(len(names) - 0.4, -0.6)  # the first algorithm on top
            ax.set_xlabel(f"IQM {m}" + (f" ({unit})" if unit else ""), fontsize=7)
            ax.tick_params(labelsize=7)
            ax.grid(axis="x", alpha=0.3)
        axes[i][0].set_yticks(range(len(names)), names)
    fig.tight_layout()

    def save(tmp: str) -> None:
        fig.savefig(tmp, format="png", dpi=100)

    from petswarm_env.files import write_atomic

    write_atomic(path, save, suffix=".png")
    plt.close(fig)


def benchmark_command(config: str, settings: list[str], json_path: str, out_dir: str, md: str | None, command: str) -> int:
    """``petswarm benchmark``: run (or resume) the benchmark, then write the page and the plot beside it."""
    check_output_path(json_path, "--json")
    check_output_path(md, "--md")
    check_output_path(out_dir, "--out", folder=True)
    cfg = load_benchmark_config(config, settings)
    data = run_benchmark(cfg, json_path, out_dir, command)
    summary = summarize(data)
    data["summary"] = summary
    write_json_atomic(json_path, jsonable(data))
    if md:
        plot = Path(md).with_suffix(".png")
        write_plot(summary, plot)
        write_text_atomic(md, markdown(data, summary, plot.name))
        print(f"wrote {md} and {plot}")
    print(f"benchmark: {len(data['runs'])} runs in {json_path}" + (f"; not run: {', '.join(data['not_run'])}" if data["not_run"] else ""))
    return 0
