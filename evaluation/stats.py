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
