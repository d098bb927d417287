"""The evaluation room's commands: ``petswarm run``, ``petswarm eval`` and ``petswarm report``
(printing and writing; :mod:`cli.main` parses the arguments)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from evaluation.evaluate import evaluate, format_table, parse_mix
from evaluation.report import write_report
from evaluation.runner import run
from petswarm_env.config import Config, ConfigError
from petswarm_env.files import JsonLines, jsonl_path, write_json_atomic


def format_run_table(result: dict[str, Any]) -> str:
    """The per-episode table and the summary line of ``petswarm run``."""
    lines = [f"{'episode':>7} {'seed':>5} {'slaves':>6} {'rmse_m':>7} {'coll r-r':>8} {'r-user':>6} {'r-wall':>6} {'org_s':>6} "
             f"{'retries':>7} {'tok_rec':>7} {'sent':>6} {'lost':>5} {'collid':>6}"]
    for i, e in enumerate(result["episodes"]):
        c, f = e["collisions"], e["frames"]
        lines.append(
            f"{i:>7} {e['seed']:>5} {e['slaves']:>6} {e['formation_rmse_m']:>7.3f} {c['robot_robot']:>8} {c['robot_user']:>6} "
            f"{c['robot_wall']:>6} {e['organize_time_s']:>6.2f} {e['join_retries']:>7} {e['token_recoveries']:>7} "
            f"{f['sent']:>6} {f['lost']:>5} {f['collided']:>6}"
        )
    s = result["summary"]
    lines.append(
        f"summary: {s['episodes']} episodes, formation_rmse_m {s['formation_rmse_m']:.3f}, collisions {s['collisions']} "
        f"(robot-robot {s['robot_robot_collisions']}), organize_time_s {s['organize_time_s']:.2f}, join_retries {s['join_retries']}"
    )
    return "\n".join(lines)


def check_output(path: str | None, flag: str, folder: bool = False) -> None:
    """Refuse, before any episode runs, an output that cannot be written: a file where a folder
    is wanted, or a folder where a file is."""
    if path is None:
        return
    p = Path(path)
    if folder and p.exists() and not p.is_dir():
        raise ConfigError(f"{flag} '{path}' is a file; name a folder (it is created if missing)")
    if not folder and (p.is_dir() or path.endswith(os.sep)):
        raise ConfigError(f"{flag} '{path}' is a folder; name a file, e.g. {os.path.join(path, 'results.json')}")
    for parent in p.parents if not folder else (p, *p.parents):
        if parent.exists():
            if not parent.is_dir():
                raise ConfigError(f"{flag} '{path}' cannot be written: '{parent}' is a file, not a folder")
            break


def run_command(cfg: Config, policy: str, episodes: int, seed: int | None, render: str | None, video: str | None,
                json_out: str | None, quiet: bool) -> int:
    """``petswarm run``: the episodes, their table (or with ``quiet`` the summary line), the JSON
    and the GIF. With ``json_out`` every finished episode is appended at once to the JSON Lines
    file beside it (``OUT.jsonl``): a killed run keeps the episodes it finished."""
    if video and not video.lower().endswith(".gif"):
        raise ConfigError(f"--video must name a .gif file, got '{video}'")
    check_output(json_out, "--json")
    check_output(video, "--video")
    with JsonLines(jsonl_path(json_out) if json_out else None) as lines:
        result = run(cfg, policy, episodes, seed, render, video, progress=lines.append)
    if quiet:
        s = result["summary"]
        print(f"formation_rmse_m {s['formation_rmse_m']:.3f} collisions {s['collisions']}")
    else:
        print(format_run_table(result))
    if json_out:
        write_json_atomic(json_out, result)
        print(f"wrote {json_out}")
    if video:
        print(f"wrote {video}")
    return 0


def eval_command(cfg: Config, policy: str, mix: list[str], scenarios: str | None, episodes: int, seed: int | None,
                 json_out: str | None, video_dir: str | None) -> int:
    """``petswarm eval``: ``policy`` (and the ``--mix ROBOT=POLICY`` items) on each of the
    comma-separated ``scenarios``; the table and the JSON, its GIF paths relative to the JSON file
    (as the report expects), each finished episode appended at once to ``OUT.jsonl``."""
    names = [s.strip() for s in scenarios.split(",") if s.strip()] if scenarios else None
    check_output(json_out, "--json")
    check_output(video_dir, "--video-dir", folder=True)
    base = os.path.dirname(os.path.abspath(json_out or "."))

    def finished(ep: dict[str, Any]) -> None:
        if "gif" in ep:
            ep["gif"] = os.path.relpath(os.path.abspath(ep["gif"]), base)
        lines.append(ep)

    with JsonLines(jsonl_path(json_out) if json_out else None) as lines:
        result = evaluate(cfg, policy, parse_mix(mix), names, episodes, seed, video_dir, on_episode=finished)
    print(format_table(result))
    if json_out:
        write_json_atomic(json_out, result)
        print(f"wrote {json_out}")
    return 0


def report_command(results: list[str], out: str) -> int:
    """``petswarm report``: one HTML page comparing the result files."""
    check_output(out, "--out")
    write_report(results, out)
    print(f"wrote {out}")
    return 0
