"""The comparison grid in the HTML report (``petswarm report grid.json``): a heatmap of the
candidate / reference formation-RMSE ratios with both collision counts, one row of panels per
cell entry of the grid file, and the table of every cell (:mod:`petswarm.evaluation.grid`'s result).

How to read the heatmap: one square per cell, its colour the ratio on a log scale (green below
1, the candidate better; red above; the colour bar marks the target), its text the ratio and
``c N/M``, the candidate's and the reference's collisions over the cell's episodes (red when the
candidate collided more). A thick black frame marks a cell that meets the target (ratio at or
below it and no more collisions). An entry's product keys are its axes: the first one's values
down, the others' across.
"""

from __future__ import annotations

import math
from typing import Any

from petswarm.evaluation.html import NA, escape, figure, new_figure, png_base64, table
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


def plot_grid_heatmap(cells: list[dict[str, Any]], target: float) -> str | None:
    """The heatmap (base64 PNG), or None when no cell has a ratio."""
    import numpy as np
    from matplotlib import colormaps
    from matplotlib.colors import LogNorm
    from matplotlib.gridspec import GridSpec

    if not any(math.isfinite(as_number(c.get("ratio"))) for c in cells):
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
            r = as_number(c.get("ratio"))
            m[i, j] = min(max(r, RATIO_RANGE[0]), RATIO_RANGE[1]) if math.isfinite(r) else np.nan
        image = ax.imshow(np.ma.masked_invalid(m), cmap=cmap, norm=norm, aspect="auto")
        for (i, j), c in at.items():
            r = as_number(c.get("ratio"))
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
    bar.set_label("formation RMSE ratio, candidate / reference", fontsize=8)
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


def grid_section(data: dict[str, Any], label: str, number: int) -> str:
    """The report's section of one grid result: summary, heatmap, table of every cell."""
    cells = [c for c in data["cells"] if isinstance(c, dict)]
    target = as_number(data.get("target_ratio"))
    target = target if math.isfinite(target) else 0.8
    s = data.get("summary") if isinstance(data.get("summary"), dict) else {}
    parts = [f"<h2>{number}. Comparison grid: {escape(label)}</h2>"]
    if not data.get("complete", True):
        parts.append('<p class="warn">This grid result is incomplete (the run stopped early); its finished cells are shown.</p>')
    parts.append(
        f"<p>Grid file <code>{escape(data.get('grid', NA))}</code>: {len(cells)} cells, {escape(data.get('episodes_per_cell', NA))} "
        f"episodes per cell from seed {escape(data.get('seed', NA))}, candidate <b>{escape(data.get('candidate', NA))}</b> against the "
        f"reference <b>{escape(data.get('reference', NA))}</b> on the same seeds. Ratio ≤ {target:g}: "
        f"<b>{escape(s.get('ratio_at_or_below_target', NA))} of {escape(s.get('cells_with_ratio', NA))}</b> cells; target met "
        f"(ratio ≤ {target:g} and no more collisions): <b>{escape(s.get('meets_target', NA))} of {len(cells)}</b>; ratio median "
        f"{_fmt(s.get('ratio_median'), 2)}, worst {_fmt(s.get('ratio_max'), 2)}; collisions {escape(s.get('collisions_candidate', NA))} "
        f"(candidate) vs {escape(s.get('collisions_reference', NA))} (reference).</p>")
    png = plot_grid_heatmap(cells, target)
    if png:
        parts.append(figure(png, "comparison grid heatmap",
                            "One square per cell: colour and bold number = candidate / reference formation RMSE (log scale; green: the "
                            f"candidate is better; the bar marks the target {target:g}); <i>c N/M</i> = collisions of the candidate / of the "
                            "reference over the cell's episodes (red: the candidate collided more); a black frame = target met. Rows: "
                            "the first product key of the grid entry; columns: the others."))
    else:
        parts.append(f"<p>{NA}: no cell has a ratio.</p>")
    rows = []
    for c in cells:
        cand, ref = (c.get(side) if isinstance(c.get(side), dict) else {} for side in ("candidate", "reference"))
        rows.append(([escape(c.get("name", NA)), _team(c), _fmt(c.get("ratio"), 2), _ci(cand), _ci(ref),
                      f"{escape(cand.get('collisions', NA))} / {escape(ref.get('collisions', NA))}",
                      f"{escape(cand.get('emergencies', NA))} / {escape(ref.get('emergencies', NA))}",
                      _fmt(c.get("median_ratio"), 2), f"{escape(c.get('episodes_better', NA))} of {escape(cand.get('episodes', NA))}",
                      _fmt(c.get("mix_robots_ratio"), 2), "yes" if c.get("meets_target") else "no"],
                     "best" if c.get("meets_target") else ""))
    parts.append(table(["cell", "candidate team", "ratio", "candidate RMSE (m) ± 95 % CI", "reference RMSE (m) ± 95 % CI",
                        "collisions cand. / ref.", "emergencies cand. / ref.", "median ratio", "episodes better", "mix robots' ratio", "target met"], rows, left_cols=2))
    parts.append("<p class=\"muted\">Median ratio: the candidate's median episode RMSE over the reference's; episodes better: the "
                 "seeds on which the candidate's RMSE is lower (the mean ratio follows the one episode in which either team lost its "
                 "formation). Emergencies: the user-lost stops (seed 002 Fig. 4), whose steps the RMSE leaves out. Mix robots' ratio: in a mixed-team cell, the RMSE of the robots named in the team's mix "
                 "over the same robots' RMSE in the reference run (the team ratio mixes both policies).</p>")
    return "".join(parts)
