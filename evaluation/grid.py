"""Run the comparison grid (:mod:`petswarm.evaluation.grid_spec`): every cell's candidate team and its
reference on the same seeds, the learned / scripted formation-RMSE ratio and both collision
counts, written as JSON after every cell (atomically), so a killed run keeps its finished cells
and ``--resume`` reuses them.

The result (``petswarm eval --grid FILE --json OUT``), in the style of ``petswarm eval``'s::

    {"kind": "grid", "grid": FILE, "label", "candidate", "reference", "policy_sha256",
     "seed", "episodes_per_cell", "target_ratio", "complete", "config", "set",
     "cells": [{"index", "name", "group", "axes", "overrides", "team", "seeds", "key",
                "candidate": RUN, "reference": RUN, "ratio", "median_ratio", "episodes_better",
                "mix_robots_ratio", "collisions_not_more", "meets_target", "wall_s"}],
     "summary": {...}, "episodes": []}

where a RUN is ``{"label", "episodes", "formation_rmse_m", "formation_rmse_ci95", "collisions",
"robot_robot", "robot_user", "robot_wall", "emergencies", "slaves_missing", "mix_robots_rmse_m",
"per_episode": [{"seed", "formation_rmse_m", "collisions", "slaves_missing"}]}``. ``ratio`` is the
candidate's mean formation RMSE over the reference's (``median_ratio`` the medians', ``episodes_better``
the seeds on which the candidate did better); a cell *meets the target* when the ratio is
at most ``target_ratio`` and the candidate collided no more often than the reference.
``episodes`` is empty: the per-episode figures are inside the cells (so ``petswarm report`` tells
the file from an ``eval`` result and draws the grid's heatmap).
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from petswarm.baselines.policy import PolicySpec
from petswarm.evaluation.evaluate import make_team, team_label
from petswarm.evaluation.grid_spec import Cell, Grid
from petswarm.evaluation.runner import run_episode
from petswarm.evaluation.stats import as_number, mean_ci95
from petswarm_env.config import Config, load_config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.files import write_json_atomic

GRID_KIND = "grid"


def policy_identity(name: str) -> str:
    """A policy's name, and for a policy file (``learned`` = the shipped one) its SHA-256, so a
    resumed grid never reuses cells of another model."""
    path = None
    if name == "learned":
        from petswarm.baselines.learned import shipped_policy_path

        path = shipped_policy_path()
    elif name.endswith(".npz"):
        path = Path(name)
    if path is None:
        return name
    return f"{name}@sha256:{hashlib.sha256(Path(path).read_bytes()).hexdigest()}"


def cell_key(cell: Cell, seeds: list[int], reference: str, identities: dict[str, str]) -> str:
    """What a cell's figures depend on, hashed: its resolved config, its team, the reference, the seeds."""
    team = {"policy": identities[cell.policy], "mix": {r: identities[p] for r, p in sorted(cell.mix.items())}}
    blob = json.dumps({"config": cell.config.to_dict(), "team": team, "reference": identities[reference], "seeds": seeds},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def run_team(cfg: Config, policy: str, mix: dict[str, str], seeds: list[int], watch: set[str] | None = None) -> dict[str, Any]:
    """One team (``policy`` with the ``mix`` robots' own policies) over ``seeds``: the cell's RUN
    record (module docstring). ``mix_robots_rmse_m``: the RMS of the formation errors of the robots
    in ``watch`` (default: the ``mix`` robots) over the steps they drove (emergency steps
    included), NaN for none; the reference run watches the same robots so the two compare."""
    env = PetSwarmEnv(cfg)
    team = make_team(env, policy, mix, seeds[0] if seeds else 0)
    episodes = []
    sq, n = 0.0, 0
    watched = set(mix) if watch is None else watch
    for seed in seeds:
        errors: list[float] = []

        def on_step(infos: dict[str, dict[str, Any]]) -> None:
            errors.extend(info["formation_error_m"] for agent, info in infos.items() if agent in watched)

        ep = run_episode(env, team, seed, on_step=on_step if watched else None)
        sq += sum(e * e for e in errors)
        n += len(errors)
        episodes.append(ep)
    env.close()
    mean, half, _ = mean_ci95(e["formation_rmse_m"] for e in episodes)
    total = {k: sum(e["collisions"][k] for e in episodes) for k in ("robot_robot", "robot_user", "robot_wall")}
    return {
        "label": team_label(policy, mix),
        "episodes": len(episodes),
        "formation_rmse_m": mean,
        "formation_rmse_ci95": half,
        "collisions": sum(total.values()),
        **total,
        "emergencies": sum(e.get("events", {}).get("emergencies", 0) for e in episodes),
        "slaves_missing": sum(e.get("slaves_missing", 0) for e in episodes),
        "mix_robots_rmse_m": math.sqrt(sq / n) if n else math.nan,
        "per_episode": [{"seed": e["seed"], "formation_rmse_m": e["formation_rmse_m"], "collisions": e["collisions"],
                         "slaves_missing": e.get("slaves_missing", 0)} for e in episodes],
    }


def _ratio(num: float, den: float) -> float:
    return num / den if math.isfinite(num) and math.isfinite(den) and den > 0 else math.nan


def run_cell(grid: Grid, cell: Cell, key: str) -> dict[str, Any]:
    """Both runs of one cell and their comparison (the module docstring's cell record)."""
    start = time.perf_counter()
    seeds = grid.seeds()
    cand = run_team(cell.config, cell.policy, cell.mix, seeds)
    # the reference drives every slave; with a mix it watches the same robots
    ref = run_team(cell.config, grid.reference, {}, seeds, watch=set(cell.mix))
    ratio = _ratio(cand["formation_rmse_m"], ref["formation_rmse_m"])
    not_more = cand["collisions"] <= ref["collisions"]
    return {**_cell_fields(grid, cell, seeds, key, cand, ref), **paired(cand, ref),
        "ratio": ratio,
        "mix_robots_ratio": _ratio(cand["mix_robots_rmse_m"], ref["mix_robots_rmse_m"]),
        "collisions_not_more": not_more,
        "meets_target": bool(math.isfinite(ratio) and ratio <= grid.target_ratio and not_more),
        "wall_s": round(time.perf_counter() - start, 2),
    }


def _cell_fields(grid: Grid, cell: Cell, seeds: list[int], key: str, cand: dict[str, Any], ref: dict[str, Any]) -> dict[str, Any]:
    return {"index": cell.index, "name": cell.name, "group": cell.group, "axes": cell.axes, "overrides": cell.overrides,
            "team": cell.team, "seeds": seeds, "key": key, "candidate": cand, "reference": ref}


def _median(xs: list[float]) -> float:
    xs = sorted(x for x in xs if math.isfinite(x))
    if not xs:
        return math.nan
    return xs[len(xs) // 2] if len(xs) % 2 else (xs[len(xs) // 2 - 1] + xs[len(xs) // 2]) / 2


def paired(cand: dict[str, Any], ref: dict[str, Any]) -> dict[str, Any]:
    """Seed by seed: ``episodes_better`` (seeds on which the candidate's RMSE is below the
    reference's) and ``median_ratio`` (median over median): the mean ratio alone follows the one
    episode in which either team lost its formation."""
    a = [e["formation_rmse_m"] for e in cand["per_episode"]]
    b = [e["formation_rmse_m"] for e in ref["per_episode"]]
    return {"episodes_better": sum(x < y for x, y in zip(a, b) if math.isfinite(x) and math.isfinite(y)),
            "median_ratio": _ratio(_median(a), _median(b))}


def summarize_grid(cells: list[dict[str, Any]], target: float, worst: int = 5) -> dict[str, Any]:
    """How many cells reach the target ratio, meet it with no more collisions, the ratios' spread
    and the ``worst`` cells (highest ratio; cells without a ratio first)."""
    ratios = [c["ratio"] for c in cells if math.isfinite(c["ratio"])]
    ordered = sorted(cells, key=lambda c: (-math.inf if not math.isfinite(c["ratio"]) else -c["ratio"]))
    srt = sorted(ratios)
    return {
        "cells": len(cells),
        "cells_with_ratio": len(ratios),
        "ratio_at_or_below_target": sum(r <= target for r in ratios),
        "median_ratio_at_or_below_target": sum(as_number(c.get("median_ratio")) <= target for c in cells),
        "episodes_better": sum(c.get("episodes_better", 0) for c in cells),
        "episodes": sum(c["candidate"]["episodes"] for c in cells),
        "meets_target": sum(c["meets_target"] for c in cells),
        "collisions_not_more": sum(c["collisions_not_more"] for c in cells),
        "ratio_min": srt[0] if srt else math.nan,
        "ratio_median": _median(srt),
        "ratio_max": srt[-1] if srt else math.nan,
        "collisions_candidate": sum(c["candidate"]["collisions"] for c in cells),
        "collisions_reference": sum(c["reference"]["collisions"] for c in cells),
        "worst": [{"name": c["name"], "ratio": c["ratio"], "collisions": [c["candidate"]["collisions"], c["reference"]["collisions"]]}
                  for c in ordered[:worst]],
        "wall_s": round(sum(c.get("wall_s", 0.0) for c in cells), 1),
    }


def previous_cells(path: str | None) -> dict[str, dict[str, Any]]:
    """The finished cells of an earlier grid result at ``path``, by key (none if there is no such file)."""
    if not path or not Path(path).is_file():
        return {}
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"--resume: '{path}' is not a readable grid result ({exc}); remove it or drop --resume") from None
    if not isinstance(data, dict) or data.get("kind") != GRID_KIND or not isinstance(data.get("cells"), list):
        raise ValueError(f"--resume: '{path}' is not a grid result of petswarm eval --grid; choose another --json")
    return {c["key"]: c for c in data["cells"] if isinstance(c, dict) and isinstance(c.get("key"), str)}


def run_grid(grid: Grid, base_config: Config, json_out: str | None = None, resume: bool = False,
             progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Every cell of ``grid`` in order; after each, the whole result so far is written to
    ``json_out`` (atomically, ``"complete": false`` until the last). With ``resume`` the cells of
    an earlier ``json_out`` whose key matches (same config, team, policies, seeds) are kept, not run."""
    policies = {grid.candidate, grid.reference} | {c.policy for c in grid.cells} | {p for c in grid.cells for p in c.mix.values()}
    identities = {p: policy_identity(p) for p in policies}
    done = previous_cells(json_out) if resume else {}
    base = load_config(overrides={**_flat(base_config), **grid.base})
    result: dict[str, Any] = {
        "kind": GRID_KIND, "grid": grid.path, "label": f"grid: {grid.candidate} vs {grid.reference}",
        "candidate": grid.candidate, "reference": grid.reference,
        "policy_sha256": {p: i.split("@sha256:")[1] for p, i in identities.items() if "@sha256:" in i},
        "seed": grid.seed, "episodes_per_cell": grid.episodes, "target_ratio": grid.target_ratio, "complete": False,
        "config": base.to_dict(), "set": grid.base, "cells": [], "summary": {}, "episodes": [],
    }
    seeds = grid.seeds()
    for cell in grid.cells:
        key = cell_key(cell, seeds, grid.reference, identities)
        reused = key in done
        if reused:  # its figures as recorded; where it stands in this grid and the seed-by-seed figures from them
            old = done[key]
            record = {**old, "index": cell.index, "name": cell.name, "group": cell.group, "axes": cell.axes,
                      **paired(old["candidate"], old["reference"])}
        else:
            record = run_cell(grid, cell, key)
        result["cells"].append(record)
        result["summary"] = summarize_grid(result["cells"], grid.target_ratio)
        if json_out:
            write_json_atomic(json_out, result)
        if progress:
            progress(progress_line(record, len(result["cells"]), len(grid.cells), reused))
    result["complete"] = True
    if json_out:
        write_json_atomic(json_out, result)
    return result


def _flat(cfg: Config) -> dict[str, Any]:
    from petswarm_env.config import flatten_dotted

    return flatten_dotted(cfg.to_dict())


def _f(x: float, digits: int = 3) -> str:
    return f"{x:.{digits}f}" if math.isfinite(x) else "n/a"


def progress_line(cell: dict[str, Any], k: int, n: int, reused: bool = False) -> str:
    c, r = cell["candidate"], cell["reference"]
    mark = "ok" if cell["meets_target"] else "--"
    how = "kept from --resume" if reused else f"{cell.get('wall_s', 0):.1f} s"
    return (f"[{k:>3}/{n}] {mark} ratio {_f(cell['ratio'], 2):>5}  rmse {_f(c['formation_rmse_m'])} vs {_f(r['formation_rmse_m'])}  "
            f"collisions {c['collisions']} vs {r['collisions']}  {cell['name']}  ({how})")


def format_grid_summary(result: dict[str, Any]) -> str:
    s = result["summary"]
    t = result["target_ratio"]
    lines = [
        f"{result['label']}: {s['cells']} cells x {result['episodes_per_cell']} episodes (seeds {result['seed']}.."
        f"{result['seed'] + result['episodes_per_cell'] - 1}), {s['wall_s']:.0f} s of cell time",
        f"ratio <= {t:.2f}: {s['ratio_at_or_below_target']} of {s['cells_with_ratio']} cells; target met (and no more collisions): "
        f"{s['meets_target']} of {s['cells']}; ratio min {_f(s['ratio_min'], 2)} median {_f(s['ratio_median'], 2)} max {_f(s['ratio_max'], 2)}; "
        f"collisions {s['collisions_candidate']} vs {s['collisions_reference']}",
        f"seed by seed: the candidate's RMSE is lower in {s['episodes_better']} of {s['episodes']} episodes; median ratio <= {t:.2f} in "
        f"{s['median_ratio_at_or_below_target']} cells",
        "worst cells: " + "; ".join(f"{w['name']} {_f(w['ratio'], 2)} ({w['collisions'][0]} vs {w['collisions'][1]} collisions)"
                                    for w in s["worst"]),
    ]
    return "\n".join(lines)
