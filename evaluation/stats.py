"""Small statistics for evaluations and reports: mean and 95 % confidence half-width (Student t)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

# two-sided 95 % critical values of Student's t, by degrees of freedom
_T95 = {
    1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262,
    10: 2.228, 11: 2.201, 12: 2.179, 13: 2.160, 14: 2.145, 15: 2.131, 16: 2.120, 17: 2.110,
    18: 2.101, 19: 2.093, 20: 2.086, 21: 2.080, 22: 2.074, 23: 2.069, 24: 2.064, 25: 2.060,
    26: 2.056, 27: 2.052, 28: 2.048, 29: 2.045, 30: 2.042,
}


def t_critical_95(dof: int) -> float:
    """Two-sided 95 % critical value of Student's t (table for dof ≤ 30, 1.96 beyond)."""
    if dof < 1:
        return math.nan
    return _T95.get(dof, 1.96)


def as_number(x: Any) -> float:
    """A float, or NaN for anything that is not a number (None, strings, bools, …)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return math.nan
    return float(x)


def mean_ci95(values: Iterable[Any]) -> tuple[float, float, int]:
    """(mean, half-width of the 95 % t confidence interval, n) over the finite values.
    The half-width is NaN with fewer than two values; the mean is NaN with none."""
    xs = [v for v in (as_number(x) for x in values) if math.isfinite(v)]
    n = len(xs)
    if n == 0:
        return math.nan, math.nan, 0
    mean = sum(xs) / n
    if n < 2:
        return mean, math.nan, n
    sd = math.sqrt(sum((x - mean) ** 2 for x in xs) / (n - 1))
    return mean, t_critical_95(n - 1) * sd / math.sqrt(n), n


# -- ratios of a candidate to a reference on the same seeds, with bootstrap intervals -------------
# The CIs follow Agarwal et al. 2021 ("Deep RL at the edge of the statistical precipice", the
# rliable library): percentile bootstrap intervals, stratified over cells for aggregates, the
# interquartile mean as the aggregate and the probability of improvement. rliable itself is not a
# dependency: its 1.2 release pins arch < 8, which does not import beside pandas 3; scipy does the work.
BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0  # a fixed stream: the same figures give the same intervals


def finite_pairs(a: Iterable[Any], b: Iterable[Any]) -> tuple["np.ndarray", "np.ndarray"]:
    """The seed-paired values of two runs where both are finite numbers."""
    import numpy as np

    pairs = [(x, y) for x, y in zip(map(as_number, a), map(as_number, b)) if math.isfinite(x) and math.isfinite(y)]
    return np.array([x for x, _ in pairs], dtype=float), np.array([y for _, y in pairs], dtype=float)


def _ratio_of_means(x, y, axis=-1):
    import numpy as np

    den = np.mean(y, axis=axis)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, np.mean(x, axis=axis) / np.where(den > 0, den, 1.0), np.nan)


def paired_ratio(cand: Iterable[Any], ref: Iterable[Any]) -> dict[str, Any]:
    """The candidate's mean over the reference's, on the seeds where both have a value, with a 95 %
    percentile bootstrap interval over those seeds resampled in pairs (``scipy.stats.bootstrap``):
    ``{"ratio", "ci95": [low, high], "n"}`` (NaN without a value; no interval with fewer than 2 pairs)."""
    import numpy as np
    from scipy.stats import bootstrap

    x, y = finite_pairs(cand, ref)
    ratio = float(_ratio_of_means(x, y)) if len(x) else math.nan
    lo = hi = math.nan
    if len(x) >= 2 and math.isfinite(ratio):
        res = bootstrap((x, y), _ratio_of_means, paired=True, vectorized=True, n_resamples=BOOTSTRAP_RESAMPLES,
                        confidence_level=0.95, method="percentile", random_state=np.random.default_rng(BOOTSTRAP_SEED))
        lo, hi = float(res.confidence_interval.low), float(res.confidence_interval.high)
    return {"ratio": ratio, "ci95": [lo, hi], "n": int(len(x))}


def probability_of_improvement(cand: Iterable[Any], ref: Iterable[Any]) -> float:
    """P(a candidate episode's value is below a reference episode's), ties counting half (lower is
    better): the Mann-Whitney U statistic over the finite values, as rliable's probability of
    improvement; NaN if either side has none."""
    from scipy.stats import mannwhitneyu

    x = [v for v in map(as_number, cand) if math.isfinite(v)]
    y = [v for v in map(as_number, ref) if math.isfinite(v)]
    if not x or not y:
        return math.nan
    return float(mannwhitneyu(y, x).statistic) / (len(x) * len(y))  # U(ref, cand): pairs with ref > cand


def interquartile_mean(values: Iterable[Any]) -> float:
    """The mean of the middle 50 % of the finite values (``scipy.stats.trim_mean(x, 0.25)``)."""
    from scipy.stats import trim_mean

    xs = [v for v in map(as_number, values) if math.isfinite(v)]
    return float(trim_mean(xs, 0.25)) if xs else math.nan


def stratified_ratio_aggregates(cells: list[tuple[Iterable[Any], Iterable[Any]]]) -> dict[str, Any]:
    """Over cells (each its candidate's and its reference's seed-paired values): the interquartile
    mean of the cells' ratios of means and the mean probability of improvement, each with a 95 %
    stratified bootstrap interval (every resample draws each cell's episodes with replacement
    within the cell: pairs for the ratio, each side on its own for the probability). Cells without
    a pair are left out; ``cells`` says how many count."""
    import numpy as np

    rng = np.random.default_rng(BOOTSTRAP_SEED)
    reps = BOOTSTRAP_RESAMPLES
    ratios, probs, boot_r, boot_p = [], [], [], []
    for cand, ref in cells:
        cand, ref = list(cand), list(ref)
        x, y = finite_pairs(cand, ref)
        if len(x) == 0 or not np.mean(y) > 0:
            continue
        ratios.append(float(_ratio_of_means(x, y)))
        idx = rng.integers(0, len(x), size=(reps, len(x)))
        boot_r.append(_ratio_of_means(x[idx], y[idx], axis=1))
        xc = np.array([v for v in map(as_number, cand) if math.isfinite(v)])
        yr = np.array([v for v in map(as_number, ref) if math.isfinite(v)])
        probs.append(probability_of_improvement(xc, yr))
        xs = xc[rng.integers(0, len(xc), size=(reps, len(xc)))]
        ys = yr[rng.integers(0, len(yr), size=(reps, len(yr)))]
        better = (ys[:, None, :] > xs[:, :, None]).mean(axis=(1, 2)) + 0.5 * (ys[:, None, :] == xs[:, :, None]).mean(axis=(1, 2))
        boot_p.append(better)
    if not ratios:
        return {"cells": 0, "ratio_iqm": math.nan, "ratio_iqm_ci95": [math.nan, math.nan],
                "p_improvement": math.nan, "p_improvement_ci95": [math.nan, math.nan]}
    from scipy.stats import trim_mean

    iqm_boot = trim_mean(np.nan_to_num(np.array(boot_r), nan=np.inf), 0.25, axis=0)
    p_boot = np.mean(np.array(boot_p), axis=0)
    q = lambda a: [float(np.percentile(a, 2.5)), float(np.percentile(a, 97.5))]  # noqa: E731
    return {"cells": len(ratios), "ratio_iqm": interquartile_mean(ratios), "ratio_iqm_ci95": q(iqm_boot),
            "p_improvement": float(np.mean(probs)), "p_improvement_ci95": q(p_boot)}


# -- the benchmark's aggregates (training/benchmark.py): runs x held-out episodes per task --------
# Agarwal et al. 2021 (rliable): the interquartile mean over a task's scores, a 95 % percentile
# bootstrap interval, stratified over tasks when tasks are pooled, and the probability of
# improvement. A task's scores are a (training runs x held-out episodes) array, lower is better; an
# episode without a score (the formation never built) counts as +inf, the worst, never dropped.


def _iqm_rows(values: "np.ndarray") -> "np.ndarray":
    """The interquartile mean of each row (``scipy.stats.trim_mean(…, 0.25)``); +inf kept."""
    import numpy as np

    v = np.sort(values, axis=-1)
    n = v.shape[-1]
    cut = int(0.25 * n)  # scipy's trim_mean trims int(0.25 n) values from each end
    return np.mean(v[..., cut:n - cut], axis=-1)


def worst_for_missing(values: Iterable[Any]) -> "np.ndarray":
    """The scores as floats, each one that is not a finite number (NaN, None) as +inf: the worst."""
    import numpy as np

    return np.array([v if math.isfinite(v) else math.inf for v in map(as_number, values)], dtype=float)


def resample_task(runs: "np.ndarray", rng, reps: int = BOOTSTRAP_RESAMPLES) -> "np.ndarray":
    """``reps`` bootstrap copies of a task's (runs x episodes) scores, flattened to (reps, runs x
    episodes): the runs drawn with replacement, then each drawn run's episodes with replacement (a
    two-level bootstrap: both the training seed and the held-out seed vary; with one run, the
    scripted reference or the teacher, it is the episodes' bootstrap)."""
    import numpy as np

    runs = np.atleast_2d(np.asarray(runs, dtype=float))
    r, e = runs.shape
    which = rng.integers(0, r, size=(reps, r)) if r > 1 else np.zeros((reps, 1), dtype=int)
    eps = rng.integers(0, e, size=(reps, r, e))
    return runs[which[:, :, None], eps].reshape(reps, r * e)


def _interval(boot: "np.ndarray") -> list[float]:
    """The 95 % percentile interval of bootstrap copies, by nearest rank outward (the 2.5 % quantile
    rounded down, the 97.5 % up): an interval of real copies, +inf included, never interpolated."""
    import numpy as np

    return [float(np.quantile(boot, 0.025, method="lower")), float(np.quantile(boot, 0.975, method="higher"))]


def _p_better(cand: "np.ndarray", ref: "np.ndarray") -> "np.ndarray":
    """P(a candidate score < a reference score), ties half, along the last axes: (…, n) vs (…, m)."""
    import numpy as np

    c, f = cand[..., :, None], ref[..., None, :]
    with np.errstate(invalid="ignore"):  # inf - inf: a tie, counted by ==
        return (f > c).mean(axis=(-2, -1)) + 0.5 * (f == c).mean(axis=(-2, -1))


def task_aggregates(runs: Any, reference: Any, reps: int = BOOTSTRAP_RESAMPLES, seed: int = BOOTSTRAP_SEED) -> dict[str, Any]:
    """One task: the interquartile mean of the candidate's scores (all runs' episodes pooled) with
    its 95 % bootstrap interval (:func:`resample_task`), and the probability that a candidate
    episode scores below (better than) a reference episode, with its interval (both sides resampled
    on their own). ``runs`` and ``reference``: (runs x episodes) arrays, missing scores as +inf."""
    import numpy as np

    rng = np.random.default_rng(seed)
    cand, ref = np.atleast_2d(np.asarray(runs, dtype=float)), np.atleast_2d(np.asarray(reference, dtype=float))
    bc, br = resample_task(cand, rng, reps), resample_task(ref, rng, reps)
    return {"iqm": float(_iqm_rows(cand.ravel())), "iqm_ci95": _interval(_iqm_rows(bc)),
            "p_improvement": float(_p_better(cand.ravel(), ref.ravel())), "p_improvement_ci95": _interval(_p_better(bc, br)),
            "runs": int(cand.shape[0]), "episodes": int(cand.size)}


def stratified_aggregates(tasks: list[tuple[Any, Any]], reps: int = BOOTSTRAP_RESAMPLES,
                          seed: int = BOOTSTRAP_SEED) -> dict[str, Any]:
    """Over tasks (each its candidate's and its reference's (runs x episodes) scores, already
    normalized so tasks compare, e.g. by the reference's interquartile mean): the interquartile mean
    of all the candidate's scores pooled and the mean over tasks of the probability of improvement,
    each with a 95 % stratified bootstrap interval: every resample draws within each task
    (:func:`resample_task`), so each task keeps its number of scores (rliable's StratifiedBootstrap)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    points, boots, probs, boot_p = [], [], [], []
    for runs, reference in tasks:
        cand, ref = np.atleast_2d(np.asarray(runs, dtype=float)), np.atleast_2d(np.asarray(reference, dtype=float))
        bc, br = resample_task(cand, rng, reps), resample_task(ref, rng, reps)
        points.append(cand.ravel())
        boots.append(bc)
        probs.append(_p_better(cand.ravel(), ref.ravel()))
        boot_p.append(_p_better(bc, br))
    if not points:
        return {"tasks": 0, "iqm": math.nan, "iqm_ci95": [math.nan, math.nan], "p_improvement": math.nan,
                "p_improvement_ci95": [math.nan, math.nan]}
    return {"tasks": len(points), "iqm": float(_iqm_rows(np.concatenate(points))),
            "iqm_ci95": _interval(_iqm_rows(np.concatenate(boots, axis=1))), "p_improvement": float(np.mean(probs)),
            "p_improvement_ci95": _interval(np.mean(boot_p, axis=0))}
