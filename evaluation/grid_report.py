"""The comparison grid in the HTML report (``petswarm report grid.json``): a heatmap of the
candidate / reference formation-RMSE ratios with both collision counts, one row of panels per
cell entry of the grid file, and the table of every cell (:mod:`petswarm.evaluation.grid`'s result).

How to read the heatmap: one square per cell, its colour the scored ratio (the grid's ``metric``,
by default the hold RMSE from the moment the formation is built; in a mixed cell the candidate
robots' own) on a log scale (green below 1, the candidate better; red above; the colour bar marks
the target), its text the ratio and ``c N/M``, the candidate's and the reference's collisions over
the cell's episodes (red when the candidate collided more). A thick black frame marks a cell that
meets the target (:mod:`petswarm.evaluation.grid`). An entry's product keys are its axes: the first one's
values down, the others' across. Results written before the scored ratio existed show ``ratio``.
"""

from __future__ import annotations

import math
from typing import Any

from petswarm.evaluation.html import NA, escape, figure, new_figure, png_base64, table

DASH = "—"
from petswarm.evaluation.stats import as_number

RATIO_RANGE = (0.25, 4.0)  # the colour scale's ends (ratios beyond are drawn at the end colour)


def is_grid(data: dict[str, Any]) -> bool:
    """Whether a loaded result file is a grid result (``petswarm eval --grid``)."""
    return data.get("kind") == "grid" and isinstance(data.get("cells"), list)


def _text(value: Any) -> str:
    return value if isinstance(value, str) else repr(value) if isinstance(value, float) else str(value)


def group_layout(cells: list[dict[str, Any]]) -> list[tuple[str, list[str], list[str], dict[tuple[int, int], dict[str, Any]]]]:
    """Per group (cell entry, in order of first appearance): its row labels, column labels and
    the cells by (row, column). The first product key gives the rows, the others the columns;
    an entry without a product is one square."""
    groups: dict[str, list[dict[str, Any]]] = {}
    for c in cells:
        groups.setdefault(str(c.get("group", c.get("name", "?"))), []).append(c)
    out = []
    for name, members in groups.items():
        rows: list[str] = []
        cols: list[str] = []
        at: dict[tuple[int, int], dict[str, Any]] = {}
        for c in members:
            axes = c.get("axes") if isinstance(c.get("axes"), dict) else {}
            items = list(axes.items())
            row = f"{items[0][0].rsplit('.', 1)[-1]}={_text(items[0][1])}" if items else ""
            col = " ".join(f"{k.rsplit('.', 1)[-1]}={_text(v)}" for k, v in items[1:])
            if len(items) == 1:
                row, col = "", row
            for labels, lab in ((rows, row), (cols, col)):
                if lab not in labels:
                    labels.append(lab)
            at[(rows.index(row), cols.index(col))] = c
        out.append((name, rows, cols, at))
    return out


def scored(c: dict[str, Any]) -> float:
    """The ratio a cell is judged on (``score_ratio``; ``ratio`` in older results)."""
    return as_number(c.get("score_ratio", c.get("ratio")))


def plot_grid_heatmap(cells: list[dict[str, Any]], target: float, what: str = "formation RMSE ratio") -> str | None:
    """The heatmap (base64 PNG), or None when no cell has a ratio."""
    import numpy as np
    from matplotlib import colormaps
    from matplotlib.colors import LogNorm
    from matplotlib.gridspec import GridSpec

    if not any(math.isfinite(scored(c)) for c in cells):
        return None
    layout = group_layout(cells)
    ncols = max(len(cols) for _, _, cols, _ in layout)
    heights = [len(rows) + 0.9 for _, rows, _, _ in layout]
    w = min(2.2 + 1.25 * ncols, 14.0)
    h = 0.9 + 0.62 * sum(heights)
    fw = w + 1.4
    fig = new_figure(fw, h, top_in=0.3, bottom_in=0.3)
    gs = GridSpec(len(layout), 2, figure=fig, height_ratios=heights, width_ratios=[w, 0.25], hspace=0.9,
                  left=1.9 / fw, right=1 - 1.05 / fw, top=1 - 0.3 / h, bottom=0.3 / h, wspace=0.05)
    norm = LogNorm(*RATIO_RANGE)
    cmap = colormaps["RdYlGn_r"]
    image = None
    for k, (name, rows, cols, at) in enumerate(layout):
        ax = fig.add_subplot(gs[k, 0])
        m = np.full((len(rows), len(cols)), np.nan)
        for (i, j), c in at.items():
            r = scored(c)
            m[i, j] = min(max(r, RATIO_RANGE[0]), RATIO_RANGE[1]) if math.isfinite(r) else np.nan
        image = ax.imshow(np.ma.masked_invalid(m), cmap=cmap, norm=norm, aspect="auto")
        for (i, j), c in at.items():
            r = scored(c)
            cand, ref = (c.get(side) or {} for side in ("candidate", "reference"))
            nc, nr = as_number(cand.get("collisions")), as_number(ref.get("collisions"))
            more = math.isfinite(nc) and math.isfinite(nr) and nc > nr
            dark = math.isfinite(r) and not 0.45 <= r <= 2.2  # the scale's dark ends: white numbers
            ax.text(j, i - 0.14, f"{r:.2f}" if math.isfinite(r) else NA, ha="center", va="center", fontsize=9, weight="bold",
                    color="white" if dark else "black")
            ax.text(j, i + 0.24, f"c {_count(nc)}/{_count(nr)}", ha="center", va="center", fontsize=7,
                    color="#b00000" if more else "#222222", weight="bold" if more else "normal",
                    bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none", "alpha": 0.85})
            if c.get("meets_target"):
                ax.add_patch(_frame(j, i))
        ax.set_xticks(range(len(cols)))
        ax.set_xticklabels(cols, fontsize=7)
        ax.set_yticks(range(len(rows)))
        ax.set_yticklabels(rows, fontsize=7)
        ax.set_xlim(-0.5, ncols - 0.5)  # every square the same size; a short entry leaves the right blank
        for spine in ax.spines.values():
            spine.set_visible(False)
        ax.set_title(name, fontsize=9, loc="left")
        ax.tick_params(length=0)
    cax = fig.add_subplot(gs[:, 1])
    bar = fig.colorbar(image, cax=cax)
    bar.ax.minorticks_off()
    bar.set_ticks([0.25, 0.5, target, 1.0, 2.0, 4.0])
    bar.set_ticklabels(["≤0.25", "0.5", f"{target:g} target", "1", "2", "≥4"], fontsize=7)
    bar.ax.axhline(target, color="black", lw=1.5)
    bar.set_label(f"{what}, candidate / reference", fontsize=8)
    return png_base64(fig)


def _count(x: float) -> str:
    return str(int(x)) if math.isfinite(x) else NA


def _frame(x: float, y: float):
    from matplotlib.patches import Rectangle

    return Rectangle((x - 0.47, y - 0.47), 0.94, 0.94, fill=False, lw=2.2, edgecolor="black")


def _fmt(x: Any, digits: int = 3) -> str:
    v = as_number(x)
    return f"{v:.{digits}f}" if math.isfinite(v) else NA


def _ci(run: dict[str, Any]) -> str:
    m, h = as_number(run.get("formation_rmse_m")), as_number(run.get("formation_rmse_ci95"))
    if not math.isfinite(m):
        return NA
    return f"{m:.3f} ± {h:.3f}" if math.isfinite(h) else f"{m:.3f} ± {NA}"


def _team(c: dict[str, Any]) -> str:
    team = c.get("team") if isinstance(c.get("team"), dict) else {}
    mix = team.get("mix") if isinstance(team.get("mix"), dict) else {}
    return escape(str(team.get("policy", NA)) + "".join(f", {r}={p}" for r, p in sorted(mix.items())))


def _ratio_ci(c: dict[str, Any], name: str) -> str:
    """``1.23 [1.05, 1.40]``: a cell's ratio and its 95 % CI (n/a where missing)."""
    r = as_number(c.get(f"{name}_ratio"))
    ci = c.get(f"{name}_ratio_ci95")
    lo, hi = (as_number(x) for x in ci) if isinstance(ci, list) and len(ci) == 2 else (math.nan, math.nan)
    if not math.isfinite(r):
        return NA
    return f"{r:.2f} [{_fmt(lo, 2)}, {_fmt(hi, 2)}]" if math.isfinite(lo) else f"{r:.2f}"


def _pair(cand: dict[str, Any], ref: dict[str, Any], key: str, digits: int) -> str:
    return f"{_fmt(cand.get(key), digits)} / {_fmt(ref.get(key), digits)}"


def _ci_pair(ci: Any) -> str:
    lo, hi = (as_number(x) for x in ci) if isinstance(ci, list) and len(ci) == 2 else (math.nan, math.nan)
    return f"[{_fmt(lo, 2)}, {_fmt(hi, 2)}]"


def _lost(s: dict[str, Any]) -> str:
    """The summary's lost-robot episodes (petswarm_env/metrics.py), where the grid result has them."""
    lost = s.get("lost_episodes")
    if not isinstance(lost, list) or len(lost) != 2:
        return ""
    return (f"; lost-robot episodes {escape(lost[0])} vs {escape(lost[1])} ({escape(s.get('lost_only_candidate', NA))} on seeds "
            "where the reference lost none)")


def grid_section(data: dict[str, Any], label: str, number: int) -> str:
    """The report's section of one grid result: summary, heatmap, table of every cell."""
    cells = [c for c in data["cells"] if isinstance(c, dict)]
    target = as_number(data.get("target_ratio"))
    target = target if math.isfinite(target) else 0.8
    s = data.get("summary") if isinstance(data.get("summary"), dict) else {}
    metric = str(data.get("metric", "formation_rmse_m"))
    what = "hold RMSE ratio" if metric == "formation_hold_rmse_m" else "formation RMSE ratio"
    scored_summary = "score_ratio_median" in s
    parts = [f"<h2>{number}. Comparison grid: {escape(label)}</h2>"]
    if not data.get("complete", True):
        parts.append('<p class="warn">This grid result is incomplete (the run stopped early); its finished cells are shown.</p>')
    head = (f"<p>Grid file <code>{escape(data.get('grid', NA))}</code>: {len(cells)} cells, {escape(data.get('episodes_per_cell', NA))} "
            f"episodes per cell from seed {escape(data.get('seed', NA))}, candidate <b>{escape(data.get('candidate', NA))}</b> against the "
            f"reference <b>{escape(data.get('reference', NA))}</b> on the same seeds. ")
    if scored_summary:
        head += (f"Judged on <code>{escape(metric)}</code> (in mixed cells the candidate robots' own error; the other robots "
                 f"may hold at most {1 + as_number(data.get('others_tolerance', 0)):.2f}× worse): ratio ≤ {target:g} in "
                 f"<b>{escape(s.get('score_at_or_below_target', NA))} of {escape(s.get('cells_with_score', NA))}</b> cells, ≤ 1 in "
                 f"{escape(s.get('score_at_or_below_1', NA))}; target met (and no more collisions, no fewer formations built, no new "
                 f"lost-robot episode): "
                 f"<b>{escape(s.get('meets_target', NA))} of {len(cells)}</b>; ratio median {_fmt(s.get('score_ratio_median'), 2)}, "
                 f"worst {_fmt(s.get('score_ratio_max'), 2)}; interquartile mean {_fmt(s.get('score_ratio_iqm'), 2)} "
                 f"{_ci_pair(s.get('score_ratio_iqm_ci95'))}, probability of improvement {_fmt(s.get('p_improvement'), 2)} "
                 f"{_ci_pair(s.get('p_improvement_ci95'))} (95 % stratified bootstrap over the cells' episodes). Whole-episode "
                 f"RMSE ratio median {_fmt(s.get('ratio_median'), 2)}; building time {_fmt(s.get('building_time_candidate_s'), 1)} s "
                 f"(candidate) vs {_fmt(s.get('building_time_reference_s'), 1)} s; collisions "
                 f"{escape(s.get('collisions_candidate', NA))} vs {escape(s.get('collisions_reference', NA))}{_lost(s)}.</p>")
    else:
        head += (f"Ratio ≤ {target:g}: <b>{escape(s.get('ratio_at_or_below_target', NA))} of {escape(s.get('cells_with_ratio', NA))}</b> "
                 f"cells; target met (ratio ≤ {target:g} and no more collisions): <b>{escape(s.get('meets_target', NA))} of "
                 f"{len(cells)}</b>; ratio median {_fmt(s.get('ratio_median'), 2)}, worst {_fmt(s.get('ratio_max'), 2)}; collisions "
                 f"{escape(s.get('collisions_candidate', NA))} (candidate) vs {escape(s.get('collisions_reference', NA))} (reference).</p>")
    parts.append(head)
    png = plot_grid_heatmap(cells, target, what if scored_summary else "formation RMSE ratio")
    if png:
        parts.append(figure(png, "comparison grid heatmap",
                            f"One square per cell: colour and bold number = candidate / reference {what if scored_summary else 'formation RMSE ratio'} "
                            "(in a mixed cell the candidate robots' own; log scale; green: the candidate is better; the bar marks the "
                            f"target {target:g}); <i>c N/M</i> = collisions of the candidate / of the reference over the cell's episodes "
                            "(red: the candidate collided more); a black frame = target met. Rows: the first product key of the grid "
                            "entry; columns: the others."))
    else:
        parts.append(f"<p>{NA}: no cell has a ratio.</p>")
    rows = []
    for c in cells:
        cand, ref = (c.get(side) if isinstance(c.get(side), dict) else {} for side in ("candidate", "reference"))
        mixed = bool((c.get("team") or {}).get("mix")) if isinstance(c.get("team"), dict) else False
        guard = c.get("others_no_worse")
        rows.append(([escape(c.get("name", NA)), _team(c), _ratio_ci(c, "score") if "score_ratio" in c else _fmt(c.get("ratio"), 2),
                      _fmt(c.get("p_improvement"), 2),
                      _ratio_ci(c, "hold"), _pair(cand, ref, "formation_hold_rmse_m", 3),
                      _pair(cand, ref, "building_time_s", 1) + (f" ({_ratio_ci(c, 'building')})" if "building_ratio" in c else ""),
                      f"{escape(cand.get('formations_built', NA))} / {escape(ref.get('formations_built', NA))}",
                      f"{_fmt(c.get('ratio'), 2)}" + (f" {_ci_pair(c.get('ratio_ci95'))}" if "ratio_ci95" in c else ""),
                      _ci(cand), _ci(ref), _ratio_ci(c, "settle"),
                      f"{escape(cand.get('collisions', NA))} / {escape(ref.get('collisions', NA))}",
                      f"{escape(cand.get('emergencies', NA))} / {escape(ref.get('emergencies', NA))}",
                      _fmt(c.get("median_ratio"), 2), f"{escape(c.get('episodes_better', NA))} of {escape(cand.get('episodes', NA))}",
                      (_ratio_ci(c, "others_hold") + (" ok" if guard else " worse")) if mixed and guard is not None else DASH,
                      "yes" if c.get("meets_target") else "no"],
                     "best" if c.get("meets_target") else ""))
    parts.append(table(["cell", "candidate team", "scored ratio [95 % CI]", "P(improvement)", "hold ratio [95 % CI]",
                        "hold RMSE (m) cand. / ref.", "building time (s) cand. / ref. (ratio [95 % CI])", "built cand. / ref.",
                        "whole-episode ratio [95 % CI]", "candidate RMSE (m) ± 95 % CI", "reference RMSE (m) ± 95 % CI",
                        "settle-after-refill ratio [95 % CI]", "collisions cand. / ref.", "emergencies cand. / ref.",
                        "median ratio", "episodes better", "others' hold ratio (mixed)", "target met"], rows, left_cols=2))
    settle_s = as_number(data.get("refill_settle_s"))
    parts.append("<p class=\"muted\">Scored ratio: the ratio the cell is judged on (the grid's metric; in a mixed cell the "
                 "candidate robots' own error over the same robots' error in the reference run). Every ratio is the candidate's mean "
                 "over the reference's on the seeds where both have the figure, with a 95 % percentile bootstrap interval over those "
                 "seeds resampled in pairs. P(improvement): the probability that a candidate episode scores below a reference "
                 "episode (ties half). Hold RMSE: from the moment the formation is built, mean over the episodes that built it "
                 "(built: how many); building time likewise. Settle after refill: the RMSE over the "
                 f"{_fmt(settle_s, 0) if math.isfinite(settle_s) else NA} s after a dropped slave's place was refilled. Median ratio, "
                 "episodes better: on the whole-episode RMSE (the mean ratio follows the one episode in which either team lost its "
                 "formation). Emergencies: the user-lost stops (seed 002 Fig. 4), whose steps the RMSE leaves out. Others' hold "
                 "ratio: in a mixed cell the other robots' hold RMSE over theirs in the reference run, and whether it stays within "
                 "the tolerance.</p>")
    return "".join(parts)
