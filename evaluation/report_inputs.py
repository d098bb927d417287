"""Reading a result file for the report (``petswarm report``): :func:`load_result` reads it and
refuses, naming the file and the field, what the report would choke on or draw wrong — numbers
beyond any figure, figures of the wrong type or sign, links and replays that are not plain files,
and a grid result's cells as ``eval --grid --resume`` checks them (grid_spec.py)."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

from petswarm.evaluation.grid_report import is_grid

# -- loading -------------------------------------------------------------------------------------
def load_result(path: str | os.PathLike) -> dict[str, Any]:
    """Read and check one result file. Raises ``ValueError("<path>: <problem>")`` on a missing,
    unreadable, non-JSON or wrongly shaped file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ValueError(f"{path}: result file not found") from None
    except IsADirectoryError:
        raise ValueError(f"{path}: is a directory, not a result file") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a JSON result file (not UTF-8 text)") from None
    except OSError as e:
        raise ValueError(f"{path}: cannot read result file ({e.strerror or e})") from None
    if not text.strip():
        raise ValueError(f"{path}: result file is empty")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: not valid JSON ({e.msg} at line {e.lineno} column {e.colno})") from None
    except RecursionError:
        raise ValueError(f"{path}: not valid JSON (nested too deeply)") from None
    except ValueError as e:  # a number beyond Python's 4300-digit limit
        raise ValueError(f"{path}: not a result file ({' '.join(str(e).split())[:100]})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object with an 'episodes' list, got {type(data).__name__}")  # noqa: TRY004 (bad file content)
    if "episodes" not in data:
        keys = ", ".join(sorted(map(str, data))[:5]) or "none"
        raise ValueError(f"{path}: has no 'episodes' list (its keys: {keys}); pass the JSON of petswarm run or petswarm eval")
    episodes = data["episodes"]
    if episodes is None:
        episodes = []
    if not isinstance(episodes, list):
        raise ValueError(f"{path}: 'episodes' must be a list, got {type(episodes).__name__}")  # noqa: TRY004 (bad file content)
    for i, ep in enumerate(episodes):
        if not isinstance(ep, dict):
            raise ValueError(f"{path}: episode {i} must be a JSON object, got {type(ep).__name__}")  # noqa: TRY004 (bad file content)
    data["episodes"] = episodes
    if data.get("config") is None:
        data["config"] = {}
    _check_inputs(path, data)
    return data


MAX_REPLAY_BYTES = 500_000_000  # a replay file embedded in the page (a 600-step episode's is about 1 MB)
MAX_INT_BITS = 64  # no count, seed or figure of a result needs more (a 401-digit number is no result's)
MAX_FIGURE = 1e15  # no measured float of a result comes near (metres, seconds, ratios); 1e308 overflows the plots
MAX_TRACE = 1_000_000  # points of an episode's error_trace: one a step, and an episode is at most 1e6 steps (config max_cycles)
# an episode's figures the report reads: a number, never negative; NaN or null = not measured (no formation built)
EPISODE_FIGURES = ("formation_rmse_m", "formation_hold_rmse_m", "building_time_s", "refill_settle_rmse_m", "organize_time_s",
                   "join_retries", "token_recoveries", "seed")
TEXT_FIELDS = ("label", "policy", "kind")  # the result's own names, shown in the page


def _figure_problem(value: Any) -> str | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"must be a number, got {type(value).__name__} {str(value)[:40]!r}"
    if value < 0:
        return f"must not be negative, got {value:g}"
    return None


def _check_fields(path: str | os.PathLike, data: dict[str, Any]) -> None:
    """The result's fields the report reads, of their types: text names, a config mapping, and
    each episode's figures (numbers, never negative), collision counts, scenario name and error
    trace (numbers, at most :data:`MAX_TRACE`); a grid's cells as ``eval --grid --resume`` checks
    them (grid_spec.py)."""
    for key in TEXT_FIELDS:
        if data.get(key) is not None and not isinstance(data[key], str):
            raise ValueError(f"{path}: field '{key}' must be text, got {type(data[key]).__name__}; repair the file or evaluate again")
    if not isinstance(data["config"], dict):
        raise ValueError(f"{path}: field 'config' must be a JSON object (the run's config), got {type(data['config']).__name__}; "
                         "repair the file or evaluate again")
    for i, ep in enumerate(data["episodes"]):
        for key in EPISODE_FIGURES:
            problem = _figure_problem(ep.get(key))
            if problem:
                raise ValueError(f"{path}: episode {i} field '{key}' {problem}; repair the file or evaluate again")
        collisions = ep.get("collisions")
        counts = collisions.items() if isinstance(collisions, dict) else [("", collisions)]
        for kind, n in counts:
            problem = _figure_problem(n)
            if problem:
                raise ValueError(f"{path}: episode {i} field 'collisions{'.' + kind if kind else ''}' {problem}; repair the file")
        if ep.get("scenario") is not None and not isinstance(ep["scenario"], str):
            raise ValueError(f"{path}: episode {i} field 'scenario' must be a scenario name (text), got {type(ep['scenario']).__name__}")
        trace = ep.get("error_trace")
        if trace is not None:
            if not isinstance(trace, list) or len(trace) > MAX_TRACE:
                raise ValueError(f"{path}: episode {i} field 'error_trace' must be a list of at most {MAX_TRACE} errors (one a "
                                 f"step), got {type(trace).__name__} of {len(trace) if isinstance(trace, list) else 1}; repair the file")
            bad = next((v for v in trace if _figure_problem(v)), None)
            if bad is not None or any(v is None for v in trace):
                raise ValueError(f"{path}: episode {i} field 'error_trace' holds {str(bad)[:40]!r}: {_figure_problem(bad) or 'not a number'}; "
                                 "repair the file or evaluate again")
    if data.get("kind") == "grid":
        from petswarm.evaluation.grid_spec import check_previous_cells

        if not isinstance(data.get("cells"), list):
            raise ValueError(f"{path}: field 'cells' of a grid result must be a list of cells, got {type(data.get('cells')).__name__}")
        check_previous_cells(str(path), data["cells"], what="report", fix="repair the file or run the grid again")


def _check_inputs(path: str | os.PathLike, data: dict[str, Any]) -> None:
    """Refuse, naming the file and the field, what the report would choke on or follow blindly:
    an integer beyond 64 bits (no float holds it), a float beyond :data:`MAX_FIGURE`, a grid cell or run that is not an object, a
    ``gif``/``pcap``/``replay`` that is not text, a replay that is not a regular file (``/dev/zero``
    would be read forever) or is larger than :data:`MAX_REPLAY_BYTES`."""
    stack: list[tuple[Any, str]] = [(data, "")]
    while stack:
        value, where = stack.pop()
        if isinstance(value, dict):
            stack.extend((v, f"{where}.{k}" if where else str(k)) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, f"{where}[{i}]") for i, v in enumerate(value))
        elif isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > MAX_INT_BITS:
            digits = len(str(value)) if value.bit_length() < 40_000 else "thousands of"
            raise ValueError(f"{path}: field '{where}' is a number of {digits} digits, beyond any figure of a result; "
                             "repair the file or evaluate again")
        elif isinstance(value, float) and math.isfinite(value) and abs(value) > MAX_FIGURE:
            raise ValueError(f"{path}: field '{where}' is {value:g}, beyond any figure of a result (positions, times and "
                             f"errors stay within ±{MAX_FIGURE:g}); repair the file or evaluate again")
    if is_grid(data):
        for k, cell in enumerate(data["cells"]):
            if not isinstance(cell, dict):
                raise ValueError(f"{path}: cell {k} must be a JSON object, got {type(cell).__name__}")  # noqa: TRY004
            for side in ("candidate", "reference"):
                run = cell.get(side)
                if run is not None and not isinstance(run, dict):
                    raise ValueError(f"{path}: cell {k} field '{side}' must be a JSON object (a team's run), got "
                                     f"{type(run).__name__}; repair the file or run the grid again")
                per = run.get("per_episode") if isinstance(run, dict) else None
                if per is not None and not (isinstance(per, list) and all(isinstance(e, dict) for e in per)):
                    raise ValueError(f"{path}: cell {k} field '{side}.per_episode' must be a list of JSON objects")
    _check_fields(path, data)
    result_dir = Path(path).resolve().parent
    for i, ep in enumerate(data["episodes"]):
        for key in ("gif", "pcap", "replay"):
            value = ep.get(key)
            if value is not None and not isinstance(value, str):
                raise ValueError(f"{path}: episode {i} field '{key}' must be a path (text), got {type(value).__name__}")
        replay = ep.get("replay")
        if isinstance(replay, str) and replay:
            from petswarm.evaluation.replay_viewer import _replay_path

            target = _replay_path(result_dir, replay)
            try:
                if target.exists() and not target.is_file():
                    raise ValueError(f"{path}: episode {i} field 'replay' '{replay[:80]}' is not a regular file (a device, a pipe "
                                     "or a folder); name a replay file of petswarm eval --replay-dir")
                if target.is_file() and target.stat().st_size > MAX_REPLAY_BYTES:
                    raise ValueError(f"{path}: episode {i} field 'replay' '{replay[:80]}' is {target.stat().st_size / 1e6:.0f} MB, "
                                     f"more than the {MAX_REPLAY_BYTES / 1e6:.0f} MB a report embeds; pass --replays none")
            except OSError as exc:
                raise ValueError(f"{path}: episode {i} field 'replay' '{replay[:80]}' cannot be read ({exc.strerror or exc})") from None
