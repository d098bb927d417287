"""Run the comparison grid (:mod:`petswarm.evaluation.grid_spec`): every cell's candidate team and its
reference on the same seeds, their ratios with bootstrap CIs and both collision counts, written as
JSON after every cell (atomically), so a killed run keeps its finished cells and ``--resume``
reuses them.

The result (``petswarm eval --grid FILE --json OUT``), in the style of ``petswarm eval``'s::

    {"kind": "grid", "grid": FILE, "label", "candidate", "reference", "policy_sha256",
     "seed", "episodes_per_cell", "target_ratio", "metric", "others_tolerance", "refill_settle_s",
     "complete", "config", "set",
     "cells": [{"index", "name", "group", "axes", "overrides", "team", "seeds", "key",
                "candidate": RUN, "reference": RUN, "ratio", "median_ratio", "episodes_better",
                "mix_robots_ratio", "ratio_ci95", "hold_ratio", "building_ratio", "settle_ratio", "mix_robots_hold_ratio",
                "others_hold_ratio", "others_ratio" (each NAME_ratio with NAME_ratio_ci95),
                "score_metric", "score_ratio", "score_ratio_ci95", "score_pairs", "p_improvement",
                "collisions_not_more", "built_not_fewer", "others_no_worse", "lost_only_candidate", "no_new_lost",
                "meets_target", "wall_s"}],
     "summary": {...}, "episodes": []}

where a RUN is ``{"label", "episodes", "formation_rmse_m", "formation_rmse_ci95",
"formation_hold_rmse_m", "formation_hold_rmse_ci95", "formations_built", "building_time_s",
"refill_settle_rmse_m", "refills_settled", "collisions", "robot_robot", "robot_user", "robot_wall",
"emergencies", "slaves_missing", "mix_robots_rmse_m", "lost_episodes", "per_episode": [{"seed", "formation_rmse_m",
"collisions", "slaves_missing", "building_time_s", "formation_hold_rmse_m", "refill_settle_rmse_m", "lost_robot_s"
(and in a mixed cell "mix_robots_rmse_m", "mix_robots_hold_rmse_m", "others_rmse_m",
"others_hold_rmse_m")}]}``. The hold and building figures of a RUN are means over the episodes that
built their formation (``formations_built`` of them), the settle figure over the episodes with a
refill (:mod:`petswarm_env.metrics`).

``ratio`` is the candidate's mean formation RMSE over the reference's (``median_ratio`` the
medians', ``episodes_better`` the seeds on which the candidate did better). Every other
``NAME_ratio`` is the candidate's mean of a per-episode figure over the reference's, on the seeds
where both have it, with ``NAME_ratio_ci95``, a 95 % percentile bootstrap interval over those seeds
resampled in pairs (:func:`petswarm.evaluation.stats.paired_ratio`): ``hold`` the hold RMSE, ``building``
the building time (on the seeds where both built), ``settle`` the
RMSE in the settle window after a refill, ``mix_robots_hold`` the mixed-in candidate robots' own hold
RMSE, ``others``/``others_hold`` the other robots' (a mixed cell).

A cell is judged on the grid file's ``metric`` (default ``formation_hold_rmse_m``): ``score_ratio``
is its ratio, in a mixed cell the candidate robots' own (the team's ratio mixes both policies: one
robot carries a fraction of the team's error, so even a perfect robot moves the team's ratio
little): the ``mix`` robots' when the candidate drives them, the other slaves' when the candidate
drives the team and the reference the ``mix`` robots; ``p_improvement`` the probability that a
candidate episode scores below a reference episode. It *meets the target* when ``score_ratio`` is
at most ``target_ratio``, the candidate collided no more often than the reference, built its
formation in no fewer episodes, had no lost-robot episode the reference did not also have on the
same seed (``lost_only_candidate``: those seeds, a slave at least ``metrics.LOST_M`` from its
reference point for ``metrics.LOST_S`` without a break once built, :mod:`petswarm_env.metrics`;
``no_new_lost``: none), and in a mixed cell the robots the reference drives held no worse
than in the reference's own run (``others_no_worse``: their ratio at most 1 + ``others_tolerance``). ``episodes`` is empty: the
per-episode figures are inside the cells (so ``petswarm report`` tells the file from an ``eval``
result and draws the grid's heatmap).
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
from petswarm.evaluation.grid_spec import Cell, Grid, check_previous_cells
from petswarm.evaluation.runner import run_episode
from petswarm.evaluation.stats import as_number, mean_ci95, paired_ratio, probability_of_improvement, stratified_ratio_aggregates
from petswarm_env.config import Config, load_config
from petswarm_env.env import PetSwarmEnv
from petswarm_env.files import write_json_atomic
from petswarm_env.metrics import REFILL_SETTLE_S, lost_robot_episode

GRID_KIND = "grid"
RUN_VERSION = 2  # the RUN record's fields (2: hold, building, settle, the mix robots' and the others' figures per episode)


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
    blob = json.dumps({"config": cell.config.to_dict(), "team": team, "reference": identities[reference], "seeds": seeds,
                       "runs": RUN_VERSION}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def _rms(sq: float, n: int) -> float:
    return math.sqrt(sq / n) if n else math.nan


def run_team(cfg: Config, policy: str, mix: dict[str, str], seeds: list[int], watch: set[str] | None = None) -> dict[str, Any]:
    """One team (``policy`` with the ``mix`` robots' own policies) over ``seeds``: the cell's RUN
    record (module docstring). ``mix_robots_rmse_m``: the RMS of the formation errors of the robots
    in ``watch`` (default: the ``mix`` robots) over the steps they drove (emergency steps
    included), NaN for none; the reference run watches the same robots so the two compare. With
    robots watched, each episode also gives their RMS from the step the formation was built on
    (``mix_robots_hold_rmse_m``) and the same two figures of the other slaves (``others_*``)."""
    env = PetSwarmEnv(cfg)
    team = make_team(env, policy, mix, seeds[0] if seeds else 0)
    episodes, per_episode = [], []
    sq, n = 0.0, 0
    watched = set(mix) if watch is None else watch
    for seed in seeds:
        # squared errors and counts: watched robots, whole and from built; the other slaves, whole and from built
        acc = {k: [0.0, 0] for k in ("mix", "mix_hold", "others", "others_hold")}

        def on_step(infos: dict[str, dict[str, Any]]) -> None:
            built = math.isfinite(env.episode.metrics.building_time_s)  # set by this step's experimenter once every slave is in place
            for agent, info in infos.items():
                if not info["active"]:  # an agent waiting to join has no formation error yet
                    continue
                e = info["formation_error_m"]
                for key in ("mix", "mix_hold") if agent in watched else ("others", "others_hold"):
                    if built or not key.endswith("_hold"):
                        acc[key][0] += e * e
                        acc[key][1] += 1

        ep = run_episode(env, team, seed, on_step=on_step if watched else None)
        sq += acc["mix"][0]
        n += acc["mix"][1]
        episodes.append(ep)
        per_episode.append({
            "seed": ep["seed"], "formation_rmse_m": ep["formation_rmse_m"], "collisions": ep["collisions"],
            "slaves_missing": ep.get("slaves_missing", 0), "building_time_s": ep["building_time_s"],
            "formation_hold_rmse_m": ep["formation_hold_rmse_m"], "refill_settle_rmse_m": ep["refill_settle_rmse_m"],
            "lost_robot_s": ep.get("lost_robot_s", math.nan),
            **({"mix_robots_rmse_m": _rms(*acc["mix"]), "mix_robots_hold_rmse_m": _rms(*acc["mix_hold"]),
                "others_rmse_m": _rms(*acc["others"]), "others_hold_rmse_m": _rms(*acc["others_hold"])} if watched else {})})
    env.close()
    mean, half, _ = mean_ci95(e["formation_rmse_m"] for e in episodes)
    hold, hold_half, built = mean_ci95(e["formation_hold_rmse_m"] for e in episodes)
    building, _, _ = mean_ci95(e["building_time_s"] for e in episodes)
    settle, _, settled = mean_ci95(e["refill_settle_rmse_m"] for e in episodes)
    total = {k: sum(e["collisions"][k] for e in episodes) for k in ("robot_robot", "robot_user", "robot_wall")}
    return {
        "label": team_label(policy, mix),
        "episodes": len(episodes),
        "formation_rmse_m": mean,
        "formation_rmse_ci95": half,
        "formation_hold_rmse_m": hold,  # over the episodes that built their formation
        "formation_hold_rmse_ci95": hold_half,
        "formations_built": built,
        "building_time_s": building,  # over the episodes that built their formation
        "refill_settle_rmse_m": settle,  # over the episodes with a refill
        "refills_settled": settled,
        "collisions": sum(total.values()),
        **total,
        "emergencies": sum(e.get("events", {}).get("emergencies", 0) for e in episodes),
        "slaves_missing": sum(e.get("slaves_missing", 0) for e in episodes),
        "mix_robots_rmse_m": math.sqrt(sq / n) if n else math.nan,
        "lost_episodes": sum(map(lost_robot_episode, episodes)),
        "unorganized": [e["organize_problem"] for e in episodes if e.get("organized") is False],
        "per_episode": per_episode,
    }


def _ratio(num: float, den: float) -> float:
    return num / den if math.isfinite(num) and math.isfinite(den) and den > 0 else math.nan


def _values(run: dict[str, Any], key: str) -> list[float]:
    return [as_number(e.get(key)) for e in run["per_episode"]]


# a cell's ratios, each the candidate's mean over the reference's on the seeds where both have the
# figure, with its paired bootstrap CI: name -> the per-episode key it compares
RATIOS = {
    "hold": "formation_hold_rmse_m",
    "building": "building_time_s",
    "settle": "refill_settle_rmse_m",
    "mix_robots_hold": "mix_robots_hold_rmse_m",
    "others_hold": "others_hold_rmse_m",
    "others": "others_rmse_m",
}
# the per-episode figure a cell is judged on (the grid file's ``metric``), for a whole team and for the
# candidates of a mixed team (their own error: the others are guarded)
SCORED = {"formation_hold_rmse_m": ("formation_hold_rmse_m", "mix_robots_hold_rmse_m", "others_hold_rmse_m"),
          "formation_rmse_m": ("formation_rmse_m", "mix_robots_rmse_m", "others_rmse_m")}


def compare_runs(cand: dict[str, Any], ref: dict[str, Any], mixed: bool, metric: str, target: float,
                 others_tolerance: float, candidate_in_mix: bool = True) -> dict[str, Any]:
    """A cell's comparison of its two RUNs (the module docstring's fields from ``ratio_ci95`` on):
    every ratio with its CI, the scored ratio (``metric``; in a mixed cell the candidate robots'
    own: the mix robots when the candidate drives them (``candidate_in_mix``), else the other
    robots), the probability of improvement on it, the guards and the verdict ``meets_target``."""
    out: dict[str, Any] = {"ratio_ci95": paired_ratio(_values(cand, "formation_rmse_m"), _values(ref, "formation_rmse_m"))["ci95"]}
    for name, key in RATIOS.items():
        r = paired_ratio(_values(cand, key), _values(ref, key))
        out[f"{name}_ratio"], out[f"{name}_ratio_ci95"] = r["ratio"], r["ci95"]
    team_key, own_key, others_key = SCORED[metric]
    if not candidate_in_mix:  # the candidate drives the team, the reference the mix robots: those are guarded
        own_key, others_key = others_key, own_key
    key = own_key if mixed else team_key
    scored = paired_ratio(_values(cand, key), _values(ref, key))
    not_more = cand["collisions"] <= ref["collisions"]
    built_not_fewer = cand.get("formations_built", 0) >= ref.get("formations_built", 0)
    others = paired_ratio(_values(cand, others_key), _values(ref, others_key))["ratio"] if mixed else math.nan
    others_ok = (not mixed) or (math.isfinite(others) and others <= 1.0 + others_tolerance)
    lost_only = lost_only_candidate(cand, ref)
    return {**out,
            "score_metric": key,
            "score_ratio": scored["ratio"],
            "score_ratio_ci95": scored["ci95"],
            "score_pairs": scored["n"],
            "p_improvement": probability_of_improvement(_values(cand, key), _values(ref, key)),
            "collisions_not_more": not_more,
            "built_not_fewer": built_not_fewer,
            "others_no_worse": others_ok if mixed else None,
            "lost_only_candidate": lost_only,
            "no_new_lost": not lost_only,
            "meets_target": bool(math.isfinite(scored["ratio"]) and scored["ratio"] <= target and not_more and built_not_fewer
                                 and others_ok and not lost_only)}


def lost_only_candidate(cand: dict[str, Any], ref: dict[str, Any]) -> list[int]:
    """The seeds of the candidate's lost-robot episodes (``lost_robot_s`` >= ``LOST_S``,
    :mod:`petswarm_env.metrics`) on which the reference lost no robot (a record without the figure
    counts as none lost)."""
    def lost(run: dict[str, Any]) -> list[int]:  # (a record without seeds pairs its episodes by their order)
        return [e.get("seed", i) for i, e in enumerate(run["per_episode"]) if lost_robot_episode(e)]

    ref_lost = set(lost(ref))
    return [s for s in lost(cand) if s not in ref_lost]


def _candidate_in_mix(grid: Grid, cell: Cell) -> bool:
    """Whether a mixed cell's candidate robots are its ``mix`` robots (one candidate among the
    reference) rather than the others (one reference among the candidate)."""
    return cell.policy != grid.candidate


def run_cell(grid: Grid, cell: Cell, key: str) -> dict[str, Any]:
    """Both runs of one cell and their comparison (the module docstring's cell record)."""
    start = time.perf_counter()
    seeds = grid.seeds()
    cand = run_team(cell.config, cell.policy, cell.mix, seeds)
    # the reference drives every slave; with a mix it watches the same robots
    ref = run_team(cell.config, grid.reference, {}, seeds, watch=set(cell.mix))
    return {**_cell_fields(grid, cell, seeds, key, cand, ref), **paired(cand, ref),
        "ratio": _ratio(cand["formation_rmse_m"], ref["formation_rmse_m"]),
        "mix_robots_ratio": _ratio(cand["mix_robots_rmse_m"], ref["mix_robots_rmse_m"]),
        **compare_runs(cand, ref, bool(cell.mix), grid.metric, grid.target_ratio, grid.others_tolerance, _candidate_in_mix(grid, cell)),
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
    and the ``worst`` cells (highest scored ratio; cells without one first); over the scored ratios
    also their interquartile mean and the mean probability of improvement, each with a stratified
    bootstrap CI (:func:`petswarm.evaluation.stats.stratified_ratio_aggregates`)."""
    ratios = [c["ratio"] for c in cells if math.isfinite(c["ratio"])]
    scores = [as_number(c.get("score_ratio")) for c in cells]
    finite_scores = sorted(x for x in scores if math.isfinite(x))
    ordered = sorted(cells, key=lambda c: -math.inf if not math.isfinite(as_number(c.get("score_ratio")))
                     else -as_number(c.get("score_ratio")))
    srt = sorted(ratios)
    holds = sorted(x for x in (as_number(c.get("hold_ratio")) for c in cells) if math.isfinite(x))
    settles = sorted(x for x in (as_number(c.get("settle_ratio")) for c in cells) if math.isfinite(x))
    agg = stratified_ratio_aggregates([(_values(c["candidate"], c["score_metric"]), _values(c["reference"], c["score_metric"]))
                                       for c in cells if c.get("score_metric")])
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
        "cells_with_score": len(finite_scores),
        "score_at_or_below_target": sum(x <= target for x in finite_scores),
        "score_at_or_below_1": sum(x <= 1.0 for x in finite_scores),
        "score_ratio_min": finite_scores[0] if finite_scores else math.nan,
        "score_ratio_median": _median(finite_scores),
        "score_ratio_max": finite_scores[-1] if finite_scores else math.nan,
        "score_ratio_iqm": agg["ratio_iqm"],
        "score_ratio_iqm_ci95": agg["ratio_iqm_ci95"],
        "p_improvement": agg["p_improvement"],
        "p_improvement_ci95": agg["p_improvement_ci95"],
        "hold_ratio_median": _median(holds),
        "cells_with_settle": len(settles),
        "settle_ratio_median": _median(settles),
        "building_time_candidate_s": _mean_of(c["candidate"].get("building_time_s") for c in cells),
        "building_time_reference_s": _mean_of(c["reference"].get("building_time_s") for c in cells),
        "formations_built": [sum(c["candidate"].get("formations_built", 0) for c in cells),
                             sum(c["reference"].get("formations_built", 0) for c in cells)],
        "lost_episodes": [sum(c["candidate"].get("lost_episodes", 0) for c in cells),
                          sum(c["reference"].get("lost_episodes", 0) for c in cells)],
        "lost_only_candidate": sum(len(c.get("lost_only_candidate", [])) for c in cells),
        "collisions_candidate": sum(c["candidate"]["collisions"] for c in cells),
        "collisions_reference": sum(c["reference"]["collisions"] for c in cells),
        "worst": [{"name": c["name"], "ratio": as_number(c.get("score_ratio")), "metric": c.get("score_metric"),
                   "collisions": [c["candidate"]["collisions"], c["reference"]["collisions"]]} for c in ordered[:worst]],
        "wall_s": round(sum(c.get("wall_s", 0.0) for c in cells), 1),
    }


def _mean_of(values) -> float:
    return mean_ci95(values)[0]


def previous_cells(path: str | None) -> dict[str, dict[str, Any]]:
    """The finished cells of an earlier grid result at ``path``, by key (none if there is no such file)."""
    if not path or not Path(path).is_file():
        return {}
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as exc:  # not JSON, not UTF-8, nested too deep, a number too long
        raise ValueError(f"--resume: '{path}' is not a readable grid result ({str(exc)[:120] or type(exc).__name__}); "
                         "remove it or drop --resume") from None
    if not isinstance(data, dict) or data.get("kind") != GRID_KIND or not isinstance(data.get("cells"), list):
        raise ValueError(f"--resume: '{path}' is not a grid result of petswarm eval --grid; choose another --json")
    check_previous_cells(path, data["cells"])  # every cell whole, before anything runs or is rewritten (grid_spec.py)
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
        "seed": grid.seed, "episodes_per_cell": grid.episodes, "target_ratio": grid.target_ratio, "metric": grid.metric,
        "others_tolerance": grid.others_tolerance, "refill_settle_s": REFILL_SETTLE_S, "complete": False,
        "config": base.to_dict(), "set": grid.base, "cells": [], "summary": {}, "episodes": [],
    }
    seeds = grid.seeds()
    for cell in grid.cells:
        key = cell_key(cell, seeds, grid.reference, identities)
        reused = key in done
        if reused:  # its figures as recorded; where it stands in this grid and the seed-by-seed figures from them
            old = done[key]
            record = {**old, "index": cell.index, "name": cell.name, "group": cell.group, "axes": cell.axes,
                      **paired(old["candidate"], old["reference"]),
                      **compare_runs(old["candidate"], old["reference"], bool(cell.mix), grid.metric, grid.target_ratio,
                                     grid.others_tolerance, _candidate_in_mix(grid, cell))}
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


def _ci(ci: Any) -> str:
    lo, hi = (as_number(x) for x in ci) if isinstance(ci, list) and len(ci) == 2 else (math.nan, math.nan)
    return f"[{_f(lo, 2)}, {_f(hi, 2)}]"


def progress_line(cell: dict[str, Any], k: int, n: int, reused: bool = False) -> str:
    c, r = cell["candidate"], cell["reference"]
    mark = "ok" if cell["meets_target"] else "--"
    how = "kept from --resume" if reused else f"{cell.get('wall_s', 0):.1f} s"
    bad = c.get("unorganized", []) + r.get("unorganized", [])
    note = f"  {len(bad)} episode(s) not organized, e.g. {bad[0]}" if bad else ""
    own = " (candidates' own)" if cell["team"].get("mix") else ""
    return (f"[{k:>3}/{n}] {mark} {cell['score_metric']} ratio{own} {_f(cell['score_ratio'], 2)} {_ci(cell['score_ratio_ci95'])}  "
            f"rmse {_f(c['formation_rmse_m'])} vs {_f(r['formation_rmse_m'])} (ratio {_f(cell['ratio'], 2)})  "
            f"hold {_f(c['formation_hold_rmse_m'])} vs {_f(r['formation_hold_rmse_m'])}  "
            f"built {c['formations_built']} vs {r['formations_built']}  collisions {c['collisions']} vs {r['collisions']}  "
            f"{cell['name']}  ({how}){note}")


def format_grid_summary(result: dict[str, Any]) -> str:
    s = result["summary"]
    t = result["target_ratio"]
    metric = result.get("metric", "formation_rmse_m")
    lines = [
        f"{result['label']}: {s['cells']} cells x {result['episodes_per_cell']} episodes (seeds {result['seed']}.."
        f"{result['seed'] + result['episodes_per_cell'] - 1}), {s['wall_s']:.0f} s of cell time",
        f"judged on {metric} (mixed cells: the candidate robots' own, the others within +{result.get('others_tolerance', 0):.0%}): "
        f"ratio <= {t:.2f} in {s['score_at_or_below_target']} of {s['cells_with_score']} cells, <= 1 in {s['score_at_or_below_1']}; "
        f"target met (and no more collisions, no fewer formations built, no new lost robot): {s['meets_target']} of {s['cells']}; ratio min "
        f"{_f(s['score_ratio_min'], 2)} median {_f(s['score_ratio_median'], 2)} max {_f(s['score_ratio_max'], 2)}; "
        f"IQM {_f(s['score_ratio_iqm'], 2)} {_ci(s['score_ratio_iqm_ci95'])}; probability of improvement "
        f"{_f(s['p_improvement'], 2)} {_ci(s['p_improvement_ci95'])} (95 % stratified bootstrap)",
        f"whole-episode formation_rmse_m ratio <= {t:.2f}: {s['ratio_at_or_below_target']} of {s['cells_with_ratio']} cells; "
        f"median {_f(s['ratio_median'], 2)}; hold ratio median {_f(s['hold_ratio_median'], 2)}; settle-after-refill ratio median "
        f"{_f(s['settle_ratio_median'], 2)} ({s['cells_with_settle']} cells); building {_f(s['building_time_candidate_s'], 1)} s vs "
        f"{_f(s['building_time_reference_s'], 1)} s, built {s['formations_built'][0]} vs {s['formations_built'][1]}; "
        f"collisions {s['collisions_candidate']} vs {s['collisions_reference']}; lost-robot episodes "
        f"{s.get('lost_episodes', [0, 0])[0]} vs {s.get('lost_episodes', [0, 0])[1]} ({s.get('lost_only_candidate', 0)} on seeds "
        f"where the reference lost none)",
        f"seed by seed: the candidate's RMSE is lower in {s['episodes_better']} of {s['episodes']} episodes; median ratio <= {t:.2f} in "
        f"{s['median_ratio_at_or_below_target']} cells",
        "worst cells: " + "; ".join(f"{w['name']} {_f(w['ratio'], 2)} ({w['collisions'][0]} vs {w['collisions'][1]} collisions)"
                                    for w in s["worst"]),
    ]
    return "\n".join(lines)
