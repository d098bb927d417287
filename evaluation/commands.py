"""The evaluation room's commands: ``petswarm run``, ``petswarm eval`` and ``petswarm report``
(printing and writing; :mod:`petswarm.cli.main` parses the arguments)."""

from __future__ import annotations

import os
import sys
from typing import Any

from petswarm.evaluation.evaluate import evaluate, format_table, parse_mix
from petswarm.evaluation.report import write_report
from petswarm.evaluation.runner import run
from petswarm_env.config import Config, ConfigError
from petswarm_env.files import JsonLines, check_output_path, jsonl_path, write_json_atomic
from petswarm_env.metrics import LOST_M, LOST_S


def format_run_table(result: dict[str, Any]) -> str:
    """The per-episode table and the summary line of ``petswarm run``."""
    lines = [f"{'episode':>7} {'seed':>5} {'slaves':>6} {'rmse_m':>7} {'build_s':>7} {'hold_m':>7} {'coll r-r':>8} {'r-user':>6} "
             f"{'r-wall':>6} {'org_s':>6} {'retries':>7} {'tok_rec':>7} {'sent':>6} {'lost':>5} {'collid':>6}"]
    for i, e in enumerate(result["episodes"]):
        c, f = e["collisions"], e["frames"]
        hold = e.get("formation_hold_rmse_m", float("nan"))
        lines.append(
            f"{i:>7} {e['seed']:>5} {e['slaves']:>6} {e['formation_rmse_m']:>7.3f} {e['building_time_s']:>7.1f} {hold:>7.3f} "
            f"{c['robot_robot']:>8} {c['robot_user']:>6} {c['robot_wall']:>6} {e['organize_time_s']:>6.2f} {e['join_retries']:>7} "
            f"{e['token_recoveries']:>7} {f['sent']:>6} {f['lost']:>5} {f['collided']:>6}"
        )
    s = result["summary"]
    settle = (f", refill_settle_rmse_m {s['refill_settle_rmse_m']:.3f} ({s['refills_settled']} episodes with a refill)"
              if s.get("refills_settled") else "")
    lines.append(
        f"summary: {s['episodes']} episodes, formation_rmse_m {s['formation_rmse_m']:.3f}, building_time_s {s['building_time_s']:.1f} "
        f"and formation_hold_rmse_m {s['formation_hold_rmse_m']:.3f} ({s['formations_built']} of {s['episodes']} built; hold: from "
        f"the moment built){settle}, collisions {s['collisions']} (robot-robot {s['robot_robot_collisions']}), organize_time_s "
        f"{s['organize_time_s']:.2f}, join_retries {s['join_retries']}"
        + (f", {s['lost_robot_episodes']} lost-robot episode(s) (a slave >= {LOST_M:g} m from its slot for >= {LOST_S:g} s once built)"
           if s.get("lost_robot_episodes") else "")
        + (f", {s['unorganized']} not organized (seeds {s['unorganized_seeds']})" if s.get("unorganized") else "")
    )
    return "\n".join(lines)


def short_swarm_warnings(episodes: list[dict[str, Any]], required: int) -> list[str]:
    """A warning line for every episode whose swarm organized short of ``swarm.num_slaves``
    (``slaves_missing`` in its summary): its figures are not a full swarm's."""
    return [
        f"warning: episode with seed {e['seed']}{' (' + e['scenario'] + ')' if e.get('scenario') else ''}: "
        f"{e['slaves_missing']} of {required} required slave(s) did not join (join retries {e['join_retries']}, "
        f"organize {e['organize_time_s']:.2f} s); see protocol.max_retries and protocol.organize_timeout_s"
        for e in episodes if e.get("slaves_missing") and e.get("organized") is not False
    ] + [f"warning: episode not organized (recorded, the run went on): {e['organize_problem']}"
         for e in episodes if e.get("organized") is False]


def _warn_short(result: dict[str, Any], cfg: Config) -> None:
    for line in short_swarm_warnings(result["episodes"], cfg.swarm.num_slaves):
        print(line, file=sys.stderr)


def run_command(cfg: Config, policy: str, episodes: int, seed: int | None, render: str | None, video: str | None,
                json_out: str | None, quiet: bool, pcap: str | None = None) -> int:
    """``petswarm run``: the episodes, their table (or with ``quiet`` the summary line), the JSON,
    the GIF and the radio trace (pcapng) of the first episode. With ``json_out`` every finished
    episode is appended at once to the JSON Lines file beside it (``OUT.jsonl``): a killed run
    keeps the episodes it finished."""
    if video and not video.lower().endswith(".gif"):
        raise ConfigError(f"--video must name a .gif file, got '{video}'")
    if pcap and not pcap.lower().endswith(".pcapng"):
        raise ConfigError(f"--pcap must name a .pcapng file (the trace is pcapng), got '{pcap}'")
    check_output_path(json_out, "--json")
    check_output_path(video, "--video")
    check_output_path(pcap, "--pcap")
    with JsonLines(jsonl_path(json_out) if json_out else None) as lines:
        result = run(cfg, policy, episodes, seed, render, video, pcap=pcap, progress=lines.append)
    _warn_short(result, cfg)
    if quiet:
        s = result["summary"]
        print(f"formation_rmse_m {s['formation_rmse_m']:.3f} building_time_s {s['building_time_s']:.1f} "
              f"formation_hold_rmse_m {s['formation_hold_rmse_m']:.3f} ({s['formations_built']} of {s['episodes']} built) "
              f"collisions {s['collisions']}")
    else:
        print(format_run_table(result))
    if json_out:
        write_json_atomic(json_out, result)
        print(f"wrote {json_out}")
    if video:
        print(f"wrote {video}")
    if pcap:
        print(f"wrote {pcap}" + (f" (episode 0 of {episodes}; eval --pcap-dir writes one file per episode)" if episodes > 1 else ""))
    return 0


def eval_command(cfg: Config, policy: str, mix: list[str], scenarios: str | None, episodes: int, seed: int | None,
                 json_out: str | None, video_dir: str | None, pcap_dir: str | None = None, replay_dir: str | None = None) -> int:
    """``petswarm eval``: ``policy`` (and the ``--mix ROBOT=POLICY`` items) on each of the
    comma-separated ``scenarios``; the table and the JSON, its GIF, pcap and replay paths relative
    to the JSON file (as the report expects), each finished episode appended at once to
    ``OUT.jsonl``."""
    names = [s.strip() for s in scenarios.split(",") if s.strip()] if scenarios else None
    check_output_path(json_out, "--json")
    check_output_path(video_dir, "--video-dir", folder=True)
    check_output_path(pcap_dir, "--pcap-dir", folder=True)
    check_output_path(replay_dir, "--replay-dir", folder=True)
    base = os.path.dirname(os.path.abspath(json_out or "."))

    def finished(ep: dict[str, Any]) -> None:
        for key in ("gif", "pcap", "replay"):
            if key in ep:
                ep[key] = os.path.relpath(os.path.abspath(ep[key]), base)
        lines.append(ep)

    with JsonLines(jsonl_path(json_out) if json_out else None) as lines:
        result = evaluate(cfg, policy, parse_mix(mix), names, episodes, seed, video_dir, pcap_dir, replay_dir,
                          on_episode=finished)
    _warn_short(result, cfg)
    print(format_table(result))
    for what, folder in (("radio traces", pcap_dir), ("replays", replay_dir)):
        if folder:
            print(f"wrote {len(result['episodes'])} {what} into {folder}")
    if json_out:
        write_json_atomic(json_out, result)
        print(f"wrote {json_out}")
    return 0


def grid_command(cfg: Config, grid_path: str, policy: str | None, episodes: int | None, seed: int | None,
                 json_out: str | None, resume: bool) -> int:
    """``petswarm eval --grid FILE``: validate the grid (every cell, before anything runs), run
    each cell's candidate team and its reference on the same seeds with a progress line per cell,
    write the result after every cell (atomically) and print the summary (:mod:`petswarm.evaluation.grid`)."""
    from petswarm.evaluation.grid import format_grid_summary, run_grid
    from petswarm.evaluation.grid_spec import load_grid

    check_output_path(json_out, "--json")
    if resume and not json_out:
        raise ConfigError("--resume reuses the finished cells of the --json file: give --json OUT")
    grid = load_grid(grid_path, cfg, candidate=policy, episodes=episodes, seed=seed)
    print(f"grid {grid_path}: {len(grid.cells)} cells, {grid.episodes} episodes each, seeds {grid.seed}..{grid.seed + grid.episodes - 1}, "
          f"{grid.candidate} vs {grid.reference}", flush=True)
    result = run_grid(grid, cfg, json_out, resume, progress=lambda line: print(line, flush=True))
    print(format_grid_summary(result))
    if json_out:
        print(f"wrote {json_out}")
    return 0


def report_command(results: list[str], out: str, replays: str = "first") -> int:
    """``petswarm report``: one HTML page comparing the result files, with the episode replays
    ``replays`` chooses (:mod:`petswarm.evaluation.replay_viewer`)."""
    check_output_path(out, "--out")
    write_report(results, out, replays)
    print(f"wrote {out}")
    return 0
