"""The plots of the evaluation report (:mod:`petswarm.evaluation.report`), each a base64 PNG or ``None``
when the results hold nothing to draw: formation RMSE per scenario, formation error over time
(mean and interquartile band), and trajectories (user, master, slaves)."""

from __future__ import annotations

import math
from typing import Any

from petswarm.evaluation.html import NA, new_figure, png_base64
from petswarm.evaluation.stats import as_number

COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"]


def _as_xy(points: Any):
    """An (n, 2) float array from a list of [x, y], or None when it is not one."""
    import numpy as np

    try:
        a = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        return None
    if a.ndim != 2 or a.shape[1] < 2 or a.shape[0] == 0:
        return None
    return a[:, :2]


def trace_matrix(episodes: list[dict[str, Any]]):
    """Episodes' error traces as rows of a NaN-padded matrix (None when there are none)."""
    import numpy as np

    traces = []
    for ep in episodes:
        tr = ep.get("error_trace")
        if isinstance(tr, list) and tr:
            traces.append([as_number(x) for x in tr])
    if not traces:
        return None
    m = np.full((len(traces), max(len(t) for t in traces)), np.nan)
    for i, t in enumerate(traces):
        m[i, : len(t)] = t
    return m


def plot_rmse_bars(scenarios: list[str], labels: list[str], table: dict[tuple[str, str], tuple[float, float, int]], colors: dict[str, str]) -> str | None:
    import numpy as np

    if not any(math.isfinite(v[0]) for v in table.values()):
        return None
    fig = new_figure(max(5.0, 1.2 + 0.9 * len(scenarios) * max(1, len(labels)) * 0.5), 3.4)
    ax = fig.add_subplot(1, 1, 1)
    width = 0.8 / max(1, len(labels))
    x = np.arange(len(scenarios))
    for j, label in enumerate(labels):
        means, errs = [], []
        for s in scenarios:
            m, h, _ = table.get((s, label), (math.nan, math.nan, 0))
            means.append(m)
            errs.append(h if math.isfinite(h) else 0.0)
        ax.bar(x + (j - (len(labels) - 1) / 2) * width, means, width, yerr=errs, capsize=3, color=colors[label], label=label)
    ax.set_xticks(x)
    ax.set_xticklabels(scenarios)
    ax.set_ylabel("formation RMSE (m)")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return png_base64(fig)


def plot_error_over_time(scenario: str, series: list[tuple[str, Any, float]], colors: dict[str, str]) -> str | None:
    import warnings

    import numpy as np

    if not series:
        return None
    fig = new_figure(7.5, 3.4)
    ax = fig.add_subplot(1, 1, 1)
    for label, m, dt in series:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns
            mean = np.nanmean(m, axis=0)
            q25 = np.nanpercentile(m, 25, axis=0)
            q75 = np.nanpercentile(m, 75, axis=0)
        t = np.arange(m.shape[1]) * dt
        c = colors[label]
        ax.plot(t, mean, color=c, lw=1.5, label=f"{label} (n={m.shape[0]})")
        ax.fill_between(t, q25, q75, color=c, alpha=0.2, lw=0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("mean formation error (m)")
    ax.set_title(f"scenario {scenario}", fontsize=10)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return png_base64(fig)


_SLAVECOLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"]
_MASTER_COLOR = "#d62728"


def plot_trajectories(scenario: str, panels: list[tuple[str, dict[str, Any]]]) -> str | None:
    import numpy as np

    drawable = []
    for label, ep in panels:
        traj = ep.get("trajectory")
        if not isinstance(traj, dict):
            continue
        robots = traj.get("robots") if isinstance(traj.get("robots"), dict) else {}
        paths = {str(name): xy for name, xy in ((n, _as_xy(p)) for n, p in robots.items()) if xy is not None}
        user = _as_xy(traj.get("user"))
        if paths or user is not None:
            drawable.append((label, ep, str(traj.get("master")), paths, user))
    if not drawable:
        return None
    # panel shape from the data's overall aspect, so equal-aspect panels are not mostly blank
    pts = np.concatenate([a for _, _, _, paths, user in drawable for a in [*paths.values(), *([user] if user is not None else [])]])
    pts = pts[np.isfinite(pts).all(axis=1)]
    aspect = 1.0
    if len(pts):
        span = np.ptp(pts, axis=0)
        aspect = float((span[1] + 1.0) / (span[0] + 1.0))
    ncols = min(3, len(drawable))
    nrows = math.ceil(len(drawable) / ncols)
    panel_w = 11.0 / ncols if ncols > 1 else 6.0
    panel_h = min(max(panel_w * aspect, 2.2), 6.0)
    fig = new_figure(panel_w * ncols, panel_h * nrows + 1.2, top_in=0.55, bottom_in=0.95, wspace=0.25, hspace=0.35)
    names = sorted({n for _, _, _, paths, _ in drawable for n in paths}, key=lambda s: (len(s), s))
    slave_names = [n for n in names if all(n != m for _, _, m, _, _ in drawable)]
    colors = {n: _SLAVECOLORS[i % len(_SLAVECOLORS)] for i, n in enumerate(slave_names)}
    legend: dict[str, Any] = {}
    for k, (label, ep, master, paths, user) in enumerate(drawable):
        ax = fig.add_subplot(nrows, ncols, k + 1)
        for name in sorted(paths, key=lambda s: (s != master, len(s), s)):
            xy = paths[name]
            if name == master:
                (line,) = ax.plot(xy[:, 0], xy[:, 1], color=_MASTER_COLOR, lw=2.2, zorder=3)
                ax.plot(xy[-1, 0], xy[-1, 1], "o", color=_MASTER_COLOR, ms=6, zorder=4)
                legend.setdefault("master robot", line)
            else:
                c = colors.get(name, "#7f7f7f")
                (line,) = ax.plot(xy[:, 0], xy[:, 1], color=c, lw=0.9, alpha=0.85, zorder=2)
                ax.plot(xy[-1, 0], xy[-1, 1], "o", color=c, ms=3.5, zorder=2)
                legend.setdefault(name, line)
        if user is not None:
            (line,) = ax.plot(user[:, 0], user[:, 1], color="black", lw=1.6, ls="--", zorder=5)
            ax.plot(user[0, 0], user[0, 1], "s", color="black", ms=5, zorder=5)
            ax.plot(user[-1, 0], user[-1, 1], "*", color="black", ms=9, zorder=5)
            legend.setdefault("user", line)
        seed = ep.get("seed")
        ax.set_title(f"{label} — seed {seed if seed is not None else NA} (master {master})", fontsize=9)
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
        ax.set_xlabel("x (m)", fontsize=8)
        ax.set_ylabel("y (m)", fontsize=8)
        ax.tick_params(labelsize=7)
    order = ["user", "master robot"] + [n for n in legend if n not in ("user", "master robot")]
    order = [n for n in order if n in legend]
    fig.legend([legend[n] for n in order], order, loc="lower center", ncol=min(len(order), 8), fontsize=8, frameon=False)
    fig.suptitle(f"scenario {scenario}", fontsize=10)
    return png_base64(fig)
