"""The papers' experiments that ``petswarm reproduce`` runs (SPEC §3.7), in the order of SPEC §3.7
(names are part of the interface):

* ``ir_accuracy``   seed 000 §4.3, Fig. 18–19, Table 4 (:mod:`petswarm.experiments.ir_accuracy`)
* ``reaction_time`` seed 000 §4.4, Fig. 20–21 (:mod:`petswarm.experiments.reaction_time`)
* ``organize_time`` seed 000 §4.5, Fig. 22, Table 5 (:mod:`petswarm.experiments.organize_time`)
* ``lf_accuracy``   seed 002 §4.2, Table 3 (:mod:`petswarm.experiments.lf_accuracy`)
* ``rotation_sync`` seed 002 §4.3, Table 4 (:mod:`petswarm.experiments.rotation_sync`)
* ``sensor_mapping`` seed 001 §VI.A, Tables III–V (:mod:`petswarm.experiments.sensor_mapping`)
* ``ruta_example``  seed 003 §5.2.1 (:mod:`petswarm.experiments.ruta_example`)

Each runs one of the papers' own evaluations through the code the environment uses and returns
rows of *paper figure vs simulated figure* with its tolerance and the row's basis
(``calibrated`` or ``validated``, :mod:`petswarm.experiments.results`).
No experiment computes its answer from a formula of the result.

    results = run_experiments(["ir_accuracy", "organize_time"], load_config(), seed=0, quick=False)
    data = results_json(results)        # {"experiments": {name: {"rows": [...], ...}}, "summary": {...}}
    ok = check_passed(results)
    basis_summary(results)              # {"validated": {"rows": n, "ok": k}, "calibrated": ..., ...}

A new experiment is a module with an ``EXPERIMENT`` (:class:`~petswarm.experiments.results.Experiment`)
added to :data:`EXPERIMENTS` below.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import Any

from petswarm.experiments import ir_accuracy, lf_accuracy, organize_time, reaction_time, rotation_sync
from petswarm.experiments import reassignment, ruta_example, sensor_mapping
from petswarm.experiments.results import BASES, Experiment, ExperimentResult, NotAvailable, Progress
from petswarm_env.config import Config
from petswarm_env.files import jsonable

EXPERIMENTS: dict[str, Experiment] = {
    m.EXPERIMENT.name: m.EXPERIMENT for m in (ir_accuracy, reaction_time, organize_time, lf_accuracy, rotation_sync)
}
EXPERIMENTS.update({m.EXPERIMENT.name: m.EXPERIMENT for m in (sensor_mapping, ruta_example, reassignment)})  # seeds 001 and 003


def parse_only(text: str | None) -> list[str]:
    """``--only a,b``: the named experiments in the given order (all when ``text`` is None).
    Raises ``ValueError`` naming the unknown ones and listing the valid names."""
    if text is None:
        return list(EXPERIMENTS)
    names = list(dict.fromkeys(s.strip() for s in text.split(",") if s.strip()))
    valid = ", ".join(EXPERIMENTS)
    if not names:
        raise ValueError(f"no experiment named; valid experiments: {valid}")
    unknown = [n for n in names if n not in EXPERIMENTS]
    if unknown:
        raise ValueError(f"unknown experiment{'s' if len(unknown) > 1 else ''} {', '.join(map(repr, unknown))}; valid experiments: {valid}")
    return names


def _no_progress(done: int, total: int) -> None:
    pass


def run_experiments(
    names: Iterable[str],
    cfg: Config,
    seed: int,
    quick: bool,
    progress_for: Callable[[str], Progress] | None = None,
) -> dict[str, ExperimentResult]:
    """Run the named experiments in order; ``progress_for(name)`` gives each its progress callback."""
    out: dict[str, ExperimentResult] = {}
    for name in names:
        exp = EXPERIMENTS[name]
        progress = progress_for(name) if progress_for else _no_progress
        t0 = time.perf_counter()
        try:
            res = exp.run(cfg, seed, quick, progress)
        except NotAvailable as e:
            res = ExperimentResult(rows=[], available=False, note=f"not available yet: {e}")
            progress(1, 1)
        res.wall_s = time.perf_counter() - t0
        out[name] = res
    return out


def check_passed(results: dict[str, ExperimentResult]) -> bool:
    """``--check``: every experiment ran (none "not available yet") and every row is within
    tolerance, whatever its basis (a calibrated row that drifts from its fit fails too)."""
    return bool(results) and all(r.ok for r in results.values())


def basis_summary(results: dict[str, ExperimentResult]) -> dict[str, dict[str, int]]:
    """Rows within tolerance per basis: ``{basis: {"rows": n, "ok": k}}`` for every basis of
    :data:`~petswarm.experiments.results.BASES` (validated rows are the ones that confirm the simulation)."""
    out = {b: {"rows": 0, "ok": 0} for b in BASES}
    for res in results.values():
        for row in res.rows:
            out[row.basis]["rows"] += 1
            out[row.basis]["ok"] += int(row.ok)
    return out


def results_json(results: dict[str, ExperimentResult], seed: int | None = None, quick: bool | None = None) -> dict[str, Any]:
    """``{"experiments": {name: {"rows": [{metric, paper, sim, tolerance, ok, basis}], ...}},
    "summary": {"by_basis": {basis: {"rows", "ok"}}, "passed": bool}}``. A row's ``basis`` is
    ``calibrated`` (a parameter was fitted to that figure) or ``validated`` (predicted, nothing
    fitted to it). Beside ``rows`` each experiment has ``title``, ``available``, ``note``,
    ``calibration`` (what was fitted to which rows, and the command that fits it), ``ok``,
    ``wall_s``, ``seed``, ``quick`` and its ``data``. Strict JSON: a value that is not finite is
    written as null."""
    exps = {}
    for name, r in results.items():
        exps[name] = {
            "rows": [row.to_json() for row in r.rows],
            "title": EXPERIMENTS[name].title if name in EXPERIMENTS else name,
            "available": r.available,
            "ok": r.ok,
            "note": r.note,
            "calibration": r.calibration,
            "wall_s": round(r.wall_s, 3),
            "seed": seed,
            "quick": quick,
            "data": r.data,
        }
    summary = {"by_basis": basis_summary(results), "passed": check_passed(results)}
    return jsonable({"experiments": exps, "summary": summary})
