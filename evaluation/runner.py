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
    user = [round(v, 3) for v in env.world.user.position]
    robots = {f"robot_{r.index}": [round(v, 3) for v in r.position] for r in env.world.robots}
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
    observations, _ = env.reset(seed=seed)
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
        # act for the live agents only (one that just left slave-role driving gets its last observation)
        raise_pending_signal()  # a Ctrl-C or SIGTERM that a C callback swallowed (petswarm_env/files.py)
        observations, _, _, _, infos = env.step(policy.act_all({a: observations[a] for a in env.agents}))
        if on_step:
            on_step(infos)
        if on_frame:
            on_frame()
    summary = env.episode_summary()  # the episode's, after its last step
    summary["seed"] = seed
    if record:
        summary["error_trace"] = [round(e, 4) for e in env.metrics.error_trace]
        summary["trajectory"] = {
            "dt_s": TRAJECTORY_EVERY * env.cfg.control_period_s,
            "user": traj_user,
            "master": f"robot_{env.swarm.master.node_id}",
            "robots": traj_robots,
        }
    return summary


def summarize(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """Run summary: mean formation RMSE, total collisions, mean organize time, total retries, missing
    slaves, mean building time over the episodes that built their formation and how many did."""
    n = len(episodes)
    finite = [e["formation_rmse_m"] for e in episodes if math.isfinite(e["formation_rmse_m"])]
    built = [e["building_time_s"] for e in episodes if math.isfinite(e.get("building_time_s", math.nan))]
    return {
        "episodes": n,
        "formation_rmse_m": sum(finite) / len(finite) if finite else math.nan,
        "collisions": sum(sum(e["collisions"].values()) for e in episodes),
        "robot_robot_collisions": sum(e["collisions"]["robot_robot"] for e in episodes),
        "organize_time_s": sum(e["organize_time_s"] for e in episodes) / n if n else math.nan,
        "join_retries": sum(e["join_retries"] for e in episodes),
        "slaves_missing": sum(e.get("slaves_missing", 0) for e in episodes),
        "building_time_s": sum(built) / len(built) if built else math.nan,  # over the episodes that built their formation
        "formations_built": len(built),
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

