"""The members an ensemble keeps, and their students, chosen on validation cells (``recurrent.keep_members``).

Students of one config differ from one training seed to the next by more than the count of students
changes (docs/training.md, "Three runs of the eight-student config"), and a member's own periodic
evaluation (ten short episodes of random draws) is too few to rank them. With ``keep_members: K`` below
``members``, every member's student (the one ``member_checkpoint`` names) drives alone through the cells
of a validation grid (``member_grid``, default configs/eval/heldout_recurrent.yaml) on the
``member_seeds`` (held-out seeds, >= 900 000 000, none of the sets the docs report on), beside the
grid's reference on the same seeds; the policy is the mean of the K members of the lowest score.

With ``member_checkpoint: validated`` each member offers two students, its best evaluated and its last
(one where they are the same weights), and stands for the one of the lower score: the validation cells
judge what the member's own periodic evaluation picked on too few episodes. Without ``keep_members``
every member is then kept, each its validated student.

A member's score is the geometric mean, over every cell and validation seed, of the grid's judged ratio
(``score_ratio``: the hold RMSE to the reference's, in a mixed cell the candidate robots' own;
evaluation/grid.py): a ratio of 2 in one cell costs as much as 0.5 in another gains. A cell whose ratio
is not finite (no formation built on any seed) makes the score infinite. Ties keep the lower member.
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from petswarm.training.config import TrainConfig


def _runs(job: tuple[str, int, str | None]) -> list[dict[str, Any]]:
    """Every cell of the grid at ``job``'s path and seed, driven by the member file (or, with None, by the grid's
    reference): one RUN record a cell (evaluation/grid.py's ``run_team``)."""
    from petswarm.evaluation.grid import run_team
    from petswarm.evaluation.grid_spec import load_grid

    path, seed, member = job
    grid = load_grid(path, None, candidate=member or "scripted", seed=seed)
    if member is None:
        return [run_team(c.config, grid.reference, {}, grid.seeds(), watch=set(c.mix)) for c in grid.cells]
    return [run_team(c.config, c.policy, c.mix, grid.seeds()) for c in grid.cells]


def geometric_mean(ratios: list[float]) -> float:
    """The score of module docstring: inf if any ratio is not finite or not positive."""
    if not ratios or any(not math.isfinite(r) or r <= 0 for r in ratios):
        return math.inf
    return math.exp(sum(math.log(r) for r in ratios) / len(ratios))


def _median(xs: list[float]) -> float:
    xs = sorted(x if math.isfinite(x) else math.inf for x in xs)
    return xs[len(xs) // 2] if len(xs) % 2 else (xs[len(xs) // 2 - 1] + xs[len(xs) // 2]) / 2


def _same_weights(a: Path, b: Path) -> bool:
    """Two policy files of the same arrays (a member whose best evaluated student is its last)."""
    with np.load(a, allow_pickle=False) as x, np.load(b, allow_pickle=False) as y:
        keys = [k for k in x.files if k != "meta"]
        return sorted(keys) == sorted(k for k in y.files if k != "meta") and all(np.array_equal(x[k], y[k]) for k in keys)


def _scored(grid, runs: list[list[dict[str, Any]]], reference: list[list[dict[str, Any]]]) -> dict[str, Any]:
    """One student's figures over the validation seeds: its score (module docstring), the median and worst cell
    ratio, its collisions and lost-robot episodes the reference lacks."""
    from petswarm.evaluation.grid import compare_runs

    ratios, collisions, lost = [], 0, 0
    for cand_k, ref_k in zip(runs, reference):
        for cell, cand, ref in zip(grid.cells, cand_k, ref_k):
            c = compare_runs(cand, ref, bool(cell.mix), grid.metric, grid.target_ratio, grid.others_tolerance,
                             cell.policy != grid.candidate)
            ratios.append(c["score_ratio"])
            collisions += cand["collisions"]
            lost += len(c["lost_only_candidate"])
    return {"score": geometric_mean(ratios), "median_ratio": _median(ratios),
            "worst_ratio": max(ratios, key=lambda r: r if math.isfinite(r) else math.inf),
            "collisions": collisions, "lost_only_candidate": lost}


def score_members(cfg: TrainConfig, options: list[list[Path]], progress=print) -> dict[str, Any]:
    """Each member's students ``options[m]`` (one, or its best and its last) on the validation grid (module
    docstring): the log's ``member_validation`` record. A member's ``student`` is the index of its option of the
    lowest score (the first on a tie; options of the same weights drive once), its ``score`` that one's; ``chosen``
    are the ``keep_members`` members (all with 0) of the lowest score, in member order."""
    from petswarm.evaluation.grid_spec import load_grid

    rec = cfg.recurrent
    grid = load_grid(rec.member_grid, None, seed=rec.member_seeds[0])
    seeds, keep = list(rec.member_seeds), rec.keep_members or len(options)
    files: list[Path] = []  # the distinct students; twin[m][i]: the index in files of member m's option i
    twin = []
    for opts in options:
        own = []
        for p in opts:
            same = next((j for j in own if _same_weights(files[j], p)), None)
            if same is None:
                files.append(p)
                same = len(files) - 1
            own.append(same)
        twin.append(own)
    jobs = [(rec.member_grid, s, None) for s in seeds] + [(rec.member_grid, s, str(p)) for p in files for s in seeds]
    if progress:
        progress(f"scoring {len(files)} students of {len(options)} members on {rec.member_grid} ({len(grid.cells)} cells x "
                 f"{grid.episodes} episodes, seeds {', '.join(map(str, seeds))}) to keep {keep}, {cfg.num_cpus} at a time")
    if cfg.num_cpus <= 1:
        runs = [_runs(job) for job in jobs]
    else:
        with ProcessPoolExecutor(cfg.num_cpus, mp_context=get_context("spawn")) as pool:
            runs = list(pool.map(_runs, jobs))
    n = len(seeds)
    reference = runs[:n]
    figures = [_scored(grid, runs[n + j * n:n + (j + 1) * n], reference) for j in range(len(files))]
    members = []
    for m, own in enumerate(twin):
        pick = min(range(len(own)), key=lambda i: (figures[own[i]]["score"], i))
        members.append({"member": m, "student": pick, "file": options[m][pick].name, **figures[own[pick]],
                        "scores": [figures[j]["score"] for j in own]})
    chosen = sorted(r["member"] for r in sorted(members, key=lambda r: (r["score"], r["member"]))[:keep])
    if progress:
        for r in members:
            progress(f"member_{r['member']}: {r['file']} score {r['score']:.3f} (median {r['median_ratio']:.2f}, worst "
                     f"{r['worst_ratio']:.2f}, {r['collisions']} collisions){'  chosen' if r['member'] in chosen else ''}")
    return {"grid": rec.member_grid, "seeds": seeds, "episodes": grid.episodes,
            "reference_collisions": sum(run["collisions"] for runs_k in reference for run in runs_k),
            "members": members, "chosen": chosen}
