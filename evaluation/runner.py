"""Run episodes of the swarm with a slave policy and collect the per-episode metrics."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from petswarm.baselines.policy import Policy, PolicySpec
from petswarm.baselines.registry import make_policy
from petswarm_env import PetSwarmEnv
from petswarm_env.config import Config
from petswarm_env.files import raise_pending_signal
from petswarm_env.metrics import lost_robot_episode
from petswarm_env.middleware.join import OrganizeError

TRAJECTORY_EVERY = 5  # record positions every 5 steps (0.5 s)
VIDEO_EVERY = 2  # a GIF frame every 2 steps (5 frames/s of simulated time at the default 0.1 s step)


class VideoRecorder:
    """Renders every ``VIDEO_EVERY``-th step of an env into a GIF (written atomically on close)."""

    def __init__(self, env: PetSwarmEnv, path: str):
        from petswarm_env.render import GifWriter

        self.env = env
        self.path = path
        self.writer = GifWriter(path, fps=env.cfg.render.fps / VIDEO_EVERY)
        self._calls = 0

    def __call__(self) -> None:
        if self._calls % VIDEO_EVERY == 0:
            self.writer.append(self.env.render())
        self._calls += 1

    def close(self) -> str | None:
        return self.writer.close()


def chain(calls: list[Callable[[], None]]) -> Callable[[], None] | None:
    """One ``on_frame`` callback that calls each of ``calls`` in order (None for none)."""
    if not calls:
        return None
    if len(calls) == 1:
        return calls[0]

    def each() -> None:
        for call in calls:
            call()

    return each


def _positions(env: PetSwarmEnv) -> tuple[list[float], dict[str, list[float]]]:
    user = [round(v, 3) for v in env.truth.user.position]
    robots = {f"robot_{r.index}": [round(v, 3) for v in r.position] for r in env.truth.robots}
    return user, robots


def run_episode(
    env: PetSwarmEnv,
    policy: Policy,
    seed: int,
    on_frame: Callable[[], None] | None = None,
    record: bool = False,
    on_step: Callable[[dict[str, dict[str, Any]]], None] | None = None,
) -> dict[str, Any]:
    """One episode with ``policy`` driving every slave; returns ``env.episode_summary()`` plus the
    seed, and with ``record`` the per-step mean formation error and the trajectories (truth).
    ``on_step`` is called with each step's infos (the comparison grid's per-robot errors)."""
    try:
        observations, _ = env.reset(seed=seed)
    except OrganizeError as exc:  # recorded, and the run goes on
        return unorganized_episode(env, seed, str(exc))
    policy.reset(seed)
    if on_frame:
        on_frame()
    traj_user, traj_robots = [], {}
    while env.agents:
        if record and env.num_cycles % TRAJECTORY_EVERY == 0:
            user, robots = _positions(env)
            traj_user.append(user)
            for rid, p in robots.items():
                traj_robots.setdefault(rid, []).append(p)
        # act for the robots in slave-role driving only (a waiting agent's zero observation is padding)
        raise_pending_signal()  # a Ctrl-C or SIGTERM that a C callback swallowed (petswarm_env/files.py)
        observations, _, _, _, infos = env.step(policy.act_all({a: observations[a] for a in env.active_agents}))
        if on_step:
            on_step(infos)
        if on_frame:
            on_frame()
    summary = env.episode_summary()  # the episode's, after its last step
    summary["seed"] = seed
    if record:
        summary["error_trace"] = [round(e, 4) for e in env.truth.error_trace]
        summary["trajectory"] = {
            "dt_s": TRAJECTORY_EVERY * env.cfg.control_period_s,
            "user": traj_user,
            "master": f"robot_{env.truth.swarms[0].master.node_id}",
            "robots": traj_robots,
        }
    return summary


def _finite_mean(episodes: list[dict[str, Any]], key: str) -> tuple[float, int]:
    """The mean of ``key`` over the episodes where it is a finite number, and how many those are."""
    xs = [e[key] for e in episodes if isinstance(e.get(key), (int, float)) and math.isfinite(e[key])]
    return (sum(xs) / len(xs) if xs else math.nan), len(xs)


def unorganized_episode(env: PetSwarmEnv, seed: int, problem: str) -> dict[str, Any]:
    """The record of an episode whose swarm could not organize at reset (``organized: false``, the
    reason in ``organize_problem``): no figure of a formation, every required slave missing."""
    return {"seed": seed, "organized": False, "organize_problem": problem, "scenario": getattr(env, "scenario", None),
            "slaves": 0, "formation_rmse_m": math.nan, "building_time_s": math.nan, "organize_time_s": math.nan,
            "formation_hold_rmse_m": math.nan, "formation_hold_steps": 0, "refill_settle_rmse_m": math.nan, "lost_robot_s": math.nan,
            "join_retries": 0, "token_recoveries": 0, "slaves_missing": env.cfg.swarm.num_slaves * env.cfg.world.num_users,
            "collisions": {"robot_robot": 0, "robot_user": 0, "robot_wall": 0}, "frames": {"sent": 0, "lost": 0, "collided": 0},
            "events": {}}


def summarize(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """Run summary: mean formation RMSE, total collisions, mean organize time, total retries, missing
    slaves, mean building time over the episodes that built their formation and how many did.

    Building and holding apart (:mod:`petswarm_env.metrics`): ``formation_hold_rmse_m`` is the mean
    of the episodes' hold RMSEs over the episodes that built their formation (the others have none:
    ``formations_built`` says how many did, so an episode that never built is never hidden), and
    ``refill_settle_rmse_m`` the mean over the episodes with a refill (``refills_settled`` of them);
    ``lost_robot_episodes``: the episodes in which a slave stayed ``LOST_M`` from its reference point for
    ``LOST_S`` without a break once built (``lost_robot_s``).
    The episodes whose swarm could not organize are counted (``unorganized``, their seeds in
    ``unorganized_seeds``) and left out of the means."""
    unorganized = [e for e in episodes if e.get("organized") is False]
    total = len(episodes)
    episodes = [e for e in episodes if e.get("organized") is not False]
    n = len(episodes)
    rmse, _ = _finite_mean(episodes, "formation_rmse_m")
    building, built = _finite_mean(episodes, "building_time_s")
    hold, _ = _finite_mean(episodes, "formation_hold_rmse_m")
    settle, settled = _finite_mean(episodes, "refill_settle_rmse_m")
    return {
        "episodes": total,
        "formation_rmse_m": rmse,
        "formation_hold_rmse_m": hold,  # over the episodes that built their formation
        "collisions": sum(sum(e["collisions"].values()) for e in episodes),
        "robot_robot_collisions": sum(e["collisions"]["robot_robot"] for e in episodes),
        "organize_time_s": sum(e["organize_time_s"] for e in episodes) / n if n else math.nan,
        "join_retries": sum(e["join_retries"] for e in episodes),
        "slaves_missing": sum(e.get("slaves_missing", 0) for e in episodes),
        "building_time_s": building,  # over the episodes that built their formation
        "formations_built": built,
        "refill_settle_rmse_m": settle,  # over the episodes with a refill
        "refills_settled": settled,
        "lost_robot_episodes": sum(map(lost_robot_episode, episodes)),
        "unorganized": len(unorganized),
        "unorganized_seeds": [e["seed"] for e in unorganized],
    }


def run(
    config: Config,
    policy_name: str = "scripted",
    episodes: int = 1,
    seed: int | None = None,
    render_mode: str | None = None,
    video: str | None = None,
    progress: Callable[[dict[str, Any]], None] | None = None,
    pcap: str | None = None,
) -> dict[str, Any]:
    """Run ``episodes`` episodes (seeds ``seed, seed+1, …``); return the JSON-ready result. ``video``
    (a GIF) and ``pcap`` (the radio trace, :mod:`petswarm.evaluation.pcap`) record the first episode."""
    base_seed = config.seed if seed is None else seed
    mode = "rgb_array" if video else render_mode
    env = PetSwarmEnv(config, render_mode=mode)
    policy = make_policy(policy_name, PolicySpec.from_env(env), base_seed)
    writer = None
    on_frame = None
    if video:
        from petswarm_env.render import GifWriter

        writer = GifWriter(video, fps=config.render.fps)
        on_frame = lambda: writer.append(env.render())
    elif render_mode == "human":
        on_frame = env.render
    results = []
    pcap_recorder = None
    if pcap:
        from petswarm.evaluation.pcap import PcapRecorder

        pcap_recorder = PcapRecorder(env, pcap)
    try:
        for i in range(episodes):
            first = chain([c for c in (on_frame, pcap_recorder) if c is not None])
            ep = run_episode(env, policy, base_seed + i, first if i == 0 else None if video else on_frame)
            if pcap_recorder is not None and i == 0:
                ep["pcap"] = pcap_recorder.close()
            ep["policy"] = policy_name
            results.append(ep)
            if progress:
                progress(ep)
    finally:
        env.close()
        if writer is not None:
            writer.close()
    return {"config": config.to_dict(), "episodes": results, "summary": summarize(results)}

