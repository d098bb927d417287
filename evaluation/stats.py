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
