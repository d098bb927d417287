"""Evaluate a slave policy — or a mixed team — scenario by scenario, with recorded traces."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from petswarm.baselines.policy import MixedPolicy, PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm.evaluation.pcap import PcapRecorder, detach_trace
from petswarm.evaluation.replay import ReplayRecorder, replay_name
from petswarm.evaluation.runner import VideoRecorder, chain, run_episode, summarize
from petswarm.evaluation.stats import mean_ci95
from petswarm_env.config import SCENARIOS, Config, ConfigError, flatten_dotted, load_config
from petswarm_env.env import PetSwarmEnv
from petswarm.training.teacher import TeacherDriver, is_teacher, teacher_gains_of


def parse_mix(items: list[str]) -> dict[str, str]:
    """``["robot_2=learned", ...]`` -> ``{"robot_2": "learned"}``."""
    mix = {}
    for item in items:
        robot, sep, policy = item.partition("=")
        if not sep or not robot.startswith("robot_") or not policy:
            raise ConfigError(f"--mix '{item}' must look like ROBOT=POLICY, e.g. robot_2=learned")
        if robot.strip() in mix:
            raise ConfigError(f"--mix names {robot.strip()} twice ({robot.strip()}={mix[robot.strip()]} and {item}); give each robot once")
        mix[robot.strip()] = policy.strip()
    return mix


def team_label(policy: str, mix: dict[str, str]) -> str:
    if not mix:
        return policy
    return f"{policy}+" + ",".join(f"{r}={p}" for r, p in sorted(mix.items()))


def _driver(env: PetSwarmEnv, name: str, spec: PolicySpec, seed: int):
    """A slave policy by name, or the privileged teacher (``privileged-teacher[:CONFIG]``: ground truth,
    an evaluation ceiling only; :class:`petswarm.training.teacher.TeacherDriver`)."""
    if is_teacher(name):
        return TeacherDriver(env, teacher_gains_of(name))
    return make_policy(name, spec, seed)


def make_team(env: PetSwarmEnv, policy: str, mix: dict[str, str], seed: int):
    spec = PolicySpec.from_env(env)
    default = _driver(env, policy, spec, seed)
    if not mix:
        return default
    unknown = sorted(set(mix) - set(env.possible_agents))
    if unknown:
        raise ConfigError(f"--mix names {unknown}, which are not slaves of this swarm; slaves: {env.possible_agents}")
    return MixedPolicy(spec, default, {r: _driver(env, p, spec, seed) for r, p in mix.items()})


def evaluate(
    config: Config,
    policy: str = "scripted",
    mix: dict[str, str] | None = None,
    scenarios: list[str] | None = None,
    episodes: int = 5,
    seed: int | None = None,
    video_dir: str | None = None,
    pcap_dir: str | None = None,
    replay_dir: str | None = None,
    on_episode: Callable[[dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """Run ``episodes`` seeds on each scenario; the same seeds for every policy, so results pair up.
    With ``video_dir`` the first episode of each scenario is a GIF there; with ``pcap_dir`` and
    ``replay_dir`` every episode's radio trace (:mod:`petswarm.evaluation.pcap`) and replay
    (:mod:`petswarm.evaluation.replay`) are written there, named by label, scenario and seed, and the
    episode's ``"gif"``, ``"pcap"`` and ``"replay"`` give the paths. ``on_episode`` is called with
    each finished episode (``petswarm eval`` appends it to its JSON Lines file)."""
    mix = mix or {}
    scenarios = scenarios or [config.user.scenario]
    bad = [s for s in scenarios if s not in SCENARIOS]
    if bad:
        raise ConfigError(f"unknown scenario(s) {bad}; choose from: {', '.join(SCENARIOS)}")
    base_seed = config.seed if seed is None else seed
    label = team_label(policy, mix)
    all_eps: list[dict[str, Any]] = []
    per_scenario: dict[str, Any] = {}
    for scenario in scenarios:
        cfg = load_config(overrides={**flatten_dotted(config.to_dict()), "user.scenario": scenario, "user.scenario_pool": []})
        env = PetSwarmEnv(cfg, render_mode="rgb_array" if video_dir else None)
        team = make_team(env, policy, mix, base_seed)
        eps = []
        for i in range(episodes):
            seed_i = base_seed + i
            recorders = {}
            if video_dir and i == 0:
                recorders["gif"] = VideoRecorder(env, str(Path(video_dir) / f"{scenario}_seed{base_seed}.gif"))
            name = replay_name(label, scenario, seed_i)
            if pcap_dir:
                recorders["pcap"] = PcapRecorder(env, Path(pcap_dir) / name.replace(".replay.json", ".pcapng"))
            if replay_dir:
                recorders["replay"] = ReplayRecorder(env, Path(replay_dir) / name, label, seed_i)
            ep = run_episode(env, team, seed_i, chain(list(recorders.values())), record=True)
            for key, recorder in recorders.items():
                if key == "replay" and ep.get("organized") is False:  # no episode to replay (its reset could not organize)
                    detach_trace(env, recorder)
                    continue
                ep[key] = recorder.close()
            ep.update({"scenario": scenario, "policy": label})
            eps.append(ep)
            if on_episode:
                on_episode(ep)
        env.close()
        mean, half, _ = mean_ci95([e["formation_rmse_m"] for e in eps])
        hold, hold_half, built = mean_ci95([e.get("formation_hold_rmse_m") for e in eps])  # over the episodes that built
        building, _, _ = mean_ci95([e.get("building_time_s") for e in eps])
        per_scenario[scenario] = {
            "episodes": len(eps),
            "formation_rmse_m": mean,
            "formation_rmse_ci95": half,
            "building_time_s": building,
            "formation_hold_rmse_m": hold,
            "formation_hold_rmse_ci95": hold_half,
            "formations_built": built,
            "collisions": sum(sum(e["collisions"].values()) for e in eps),
            "robot_robot": sum(e["collisions"]["robot_robot"] for e in eps),
            "robot_user": sum(e["collisions"]["robot_user"] for e in eps),
            "emergencies": sum(e.get("events", {}).get("emergencies", 0) for e in eps),
            "master_changes": sum(e.get("events", {}).get("master_changes", 0) for e in eps),
        }
        all_eps.extend(eps)
    return {
        "label": label,
        "policy": policy,
        "mix": mix,
        "config": config.to_dict(),
        "episodes": all_eps,
        "summary": summarize(all_eps),
        "scenarios": per_scenario,
    }


def mean_formation_rmse(config: Config, policy, seeds: list[int]) -> float:
    """Mean formation RMSE of ``policy`` over one episode per seed (NaN-free episodes; NaN if none).
    The periodic evaluation of ``petswarm train``."""
    env = PetSwarmEnv(config)
    values = [run_episode(env, policy, s)["formation_rmse_m"] for s in seeds]
    env.close()
    values = [v for v in values if math.isfinite(v)]
    return float(np.mean(values)) if values else math.nan


def format_table(result: dict[str, Any]) -> str:
    nan = float("nan")
    lines = [f"policy: {result['label']}",
             f"{'scenario':<15} {'episodes':>8} {'rmse_m':>8} {'±95%':>7} {'build_s':>7} {'hold_m':>7} {'±95%':>7} {'built':>5} "
             f"{'collisions':>10} {'r-r':>5} {'r-user':>6} {'emerg':>5} {'m-chg':>5}"]
    for name, s in result["scenarios"].items():
        half = s["formation_rmse_ci95"]
        lines.append(f"{name:<15} {s['episodes']:>8} {s['formation_rmse_m']:>8.3f} {half if math.isfinite(half) else nan:>7.3f} "
                     f"{s.get('building_time_s', nan):>7.1f} {s.get('formation_hold_rmse_m', nan):>7.3f} "
                     f"{s.get('formation_hold_rmse_ci95', nan):>7.3f} {s.get('formations_built', 0):>5} "
                     f"{s['collisions']:>10} {s.get('robot_robot', 0):>5} {s.get('robot_user', 0):>6} {s.get('emergencies', 0):>5} "
                     f"{s.get('master_changes', 0):>5}")
    lines.append("build_s: mean time to build the formation, hold_m: mean formation_hold_rmse_m (from the moment built), both "
                 "over the episodes that built it (built: how many)")
    return "\n".join(lines)
