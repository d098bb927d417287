"""``organize_time``: the time to organize the swarm network and the retry probability against
the number of slaves (seed 000 §4.5, Fig. 22, Table 5), through ``PetSwarmEnv.reset``, which runs
the join protocol on the 802.15.4 medium. ``python -m petswarm.experiments.calibrate_organize`` sweeps the
radio parameters behind the retries with the same trials.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

import petswarm_env
from petswarm.experiments.results import Experiment, ExperimentResult, Progress, Row
from petswarm_env.config import Config

MIN_ORGANIZE_TOLERANCE_S = 0.1  # chosen: minimum organize time within ±0.1 s at each slave count
RETRY_TOLERANCE_PCT = 15.0  # chosen: retry probability within ±15 points at each count

# -- seed 000 §4.5 (Fig. 22, Table 5) ----------------------------------------------------------------
PAPER_SLAVE_COUNTS = (1, 2, 3, 4, 5)
PAPER_ORGANIZATIONS = 50  # "organizing each network 50 times"
PAPER_RETRY_PCT = {1: 0.0, 2: 6.0, 3: 30.0, 4: 67.0, 5: 80.0}  # Table 5
# Fig. 22: "the minimum required time ... increases slightly from 0.6 s to 0.8 s". The figure is
# lost from the text: only the end points (1 and 5 slaves) are the paper's. The counts in between
# have no paper figure (a line between the end points would be made up, checked against a model that
# is about linear): their row is the paper's word, that the minimum rises with the slave count.
PAPER_MIN_ORGANIZE_S = {1: 0.6, 5: 0.8}
# What was fitted to which figure. Table 5: radio.processing_jitter_s (the one free parameter of the
# collisions behind the retries) is fitted on RETRY_FIT_COUNTS only (python -m
# petswarm.experiments.calibrate_organize --fit 2,4); 1, 3 and 5 slaves are held out: 3 between the fitted
# counts, 5 beyond them, 1 (nothing to collide with) the model's structure. Fig. 22's end points:
# protocol.scan_window_s (0.5 s, most of the 0.6 s with one slave) and radio.processing_s (0.02 s,
# each slave adds a notify/ack round trip of about twice it: 0.6 -> 0.8 s) were set against them;
# that the minimum rises at 2-4 slaves is predicted (validated).
RETRY_FIT_COUNTS = (2, 4)
ORGANIZE_CALIBRATION = ("radio.processing_jitter_s to the retries at {fit} slaves (python -m petswarm.experiments.calibrate_organize --fit "
                        "{fit_arg}); protocol.scan_window_s, radio.processing_s to Fig. 22's 0.6 / 0.8 s at 1 / 5 "
                        "slaves")
# Setup of the organize experiment: every waiting robot must be able to join (seed 000 Table 1),
# so that the retries measure lost responses, not refusals. The robots stand around the grid
# formation's slots, all within 2.3 m (+ spawn jitter) of the master; the default wedge puts a
# fifth slave 3.0 m away, on the edge of the 3 m available region, where Table 1 refuses it about
# half the time (a retry that is not the paper's "simultaneous message reception").
ORGANIZE_SETUP = {"swarm.formation": "grid", "swarm.extra_robots": 0, "swarm.other_user_robots": 0,
                  "swarm.spawn": "at_slots"}  # the start radio.processing_jitter_s was calibrated on

# Trials. The paper's 50 organizations estimate a retry probability to about ±7 points (one σ),
# half the ±15-point tolerance; the full run organizes 200 times per slave count so that the
# simulated side is estimated to about ±3.5 points and the tolerance is left for the paper's own
# sampling error. --quick runs the paper's 50.
ORGANIZE_TRIALS = 200
ORGANIZE_QUICK_TRIALS = PAPER_ORGANIZATIONS


def organize_trials(cfg: Config, num_slaves: int, seeds: Iterable[int], step: Callable[[], None] | None = None) -> list[dict[str, Any]]:
    """Organize a swarm of ``num_slaves`` once per seed, through the environment's own path
    (``reset`` builds the world and runs the join protocol on the radio medium), with the robots
    placed as :data:`ORGANIZE_SETUP` says. One dict per organization: ``seed``, ``elapsed_s``,
    ``retries``, ``complete`` (all ``num_slaves`` joined), ``slaves`` (joined) and, when ``reset``
    failed, ``error`` (``elapsed_s`` is then NaN)."""
    env = petswarm_env.parallel_env(cfg, **{**ORGANIZE_SETUP, "swarm.num_slaves": num_slaves})
    out = []
    for s in seeds:
        try:
            env.reset(seed=int(s))
            r = env.truth.swarms[0].organize_result
            out.append({"seed": int(s), "elapsed_s": float(r.elapsed_s), "retries": int(r.retries),
                        "complete": bool(r.complete) and len(r.members) - 1 == num_slaves, "slaves": len(r.members) - 1})
        except RuntimeError as e:  # the swarm did not organize (reset says why)
            r = env.truth.swarms[0].organize_result if env.episode is not None else None
            out.append({"seed": int(s), "elapsed_s": math.nan, "retries": int(r.retries) if r else 0,
                        "complete": False, "slaves": 0, "error": str(e)})
        if step:
            step()
    env.close()
    return out


def organize_summary(trials: list[dict[str, Any]]) -> dict[str, Any]:
    """Fig. 22 / Table 5 figures of one slave count: min / mean / max organize time over the
    organizations that completed, and the retry probability (organizations that needed at least
    one retry, or did not complete, over all)."""
    times = np.array([t["elapsed_s"] for t in trials if t["complete"]], dtype=float)
    retried = [t["retries"] > 0 or not t["complete"] for t in trials]
    nan = math.nan
    return {
        "organizations": len(trials),
        "failed": sum(not t["complete"] for t in trials),
        "min_s": float(times.min()) if times.size else nan,
        "mean_s": float(times.mean()) if times.size else nan,
        "max_s": float(times.max()) if times.size else nan,
        "retry_pct": 100.0 * sum(retried) / len(trials) if trials else nan,
        "mean_retries": float(np.mean([t["retries"] for t in trials])) if trials else nan,
    }


def _plural(n: int) -> str:
    return f"{n} slave{'s' if n > 1 else ''}"


def organize_rows(summary: dict[int, dict[str, Any]], fit_counts: Iterable[int] = RETRY_FIT_COUNTS) -> list[Row]:
    """Rows of Fig. 22 (minimum time, and that it rises) and Table 5 (retry probability, and that it
    rises). A retry row is ``calibrated`` at a count of ``fit_counts`` (the jitter was fitted there),
    ``validated`` elsewhere; the minimum time is ``calibrated`` at the published end points (1 and 5
    slaves), and its rise over every count run is ``validated``."""
    fit = set(fit_counts)
    rows = []
    counts = sorted(summary)
    for n in counts:
        if n in PAPER_MIN_ORGANIZE_S:
            rows.append(Row.within(f"min organize time, {_plural(n)} (s)", PAPER_MIN_ORGANIZE_S[n], summary[n]["min_s"],
                                   MIN_ORGANIZE_TOLERANCE_S, basis="calibrated"))
    if len(counts) > 1:
        rows.append(_rises("min organize time", [summary[n]["min_s"] for n in counts]))
    for n in counts:
        if n in PAPER_RETRY_PCT:
            rows.append(Row.within(f"retry probability, {_plural(n)} (%)", PAPER_RETRY_PCT[n], summary[n]["retry_pct"],
                                   RETRY_TOLERANCE_PCT, basis="calibrated" if n in fit else "validated"))
    if len(counts) > 1:
        rows.append(_rises("retry probability", [summary[n]["retry_pct"] for n in counts]))
    return rows


def _rises(what: str, values: list[float]) -> Row:
    """``WHAT rises with the slave count (1 = yes)``: never falls from one count to the next and ends
    above where it started (validated: the paper says so, nothing was fitted to the shape)."""
    rising = all(b >= a for a, b in itertools.pairwise(values)) and values[-1] > values[0]
    return Row.within(f"{what} rises with the slave count (1 = yes)", 1.0, 1.0 if rising else 0.0, 0.0, basis="validated")


def calibration_text(fit_counts: Iterable[int] = RETRY_FIT_COUNTS) -> str:
    fit = sorted(fit_counts)
    return ORGANIZE_CALIBRATION.format(fit=" and ".join(map(str, fit)) or "no", fit_arg=",".join(map(str, fit)))


def organize_time(
    cfg: Config,
    seed: int,
    quick: bool,
    progress: Progress,
    *,
    slave_counts: Iterable[int] = PAPER_SLAVE_COUNTS,
    trials: int | None = None,
) -> ExperimentResult:
    """Seed 000 §4.5: 1–5 slaves, organized :data:`ORGANIZE_TRIALS` times each (the paper: 50,
    as with ``quick``), seeds ``seed, seed+1, …``. The retries come from the radio's collision
    model and the MCU processing jitter (config ``radio.*``, ``protocol.*``)."""
    counts = list(slave_counts)
    n_trials = trials or (ORGANIZE_QUICK_TRIALS if quick else ORGANIZE_TRIALS)
    total = len(counts) * n_trials
    done = 0
    progress(0, total)

    def step() -> None:
        nonlocal done
        done += 1
        progress(done, total)

    per_count, summary = {}, {}
    for n in counts:
        per_count[n] = organize_trials(cfg, n, range(seed, seed + n_trials), step)
        summary[n] = organize_summary(per_count[n])
    rows = organize_rows(summary)
    failed = sum(s["failed"] for s in summary.values())
    notes = [f"{failed} organization(s) did not complete (counted as retried)"] if failed else []
    missed = [r.metric for r in rows if r.basis == "validated" and not r.ok]
    if missed:
        notes.append("held out and outside tolerance (not re-fitted): " + ", ".join(missed))
    data = {
        "organizations_per_count": n_trials,
        "summary": {str(n): summary[n] for n in counts},
        "paper": {"min_s": {str(n): v for n, v in PAPER_MIN_ORGANIZE_S.items()},
                  "retry_pct": {str(n): PAPER_RETRY_PCT[n] for n in PAPER_SLAVE_COUNTS},
                  "retry_fit_counts": list(RETRY_FIT_COUNTS)},
        "trials": {str(n): per_count[n] for n in counts},
    }
    return ExperimentResult(rows, data, note="; ".join(notes), calibration=calibration_text())


EXPERIMENT = Experiment("organize_time", "Time to organize the swarm network vs slaves (seed 000 §4.5, Fig. 22, Table 5)", organize_time)
