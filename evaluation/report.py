"""A self-contained HTML report comparing evaluation results of slave policies.

    write_report(["runs/scripted.json", "runs/learned.json"], "report.html")

Each result file is the JSON written by an evaluation of one policy (or one mixed team) over
several scenarios and seeds: ``{"label", "config", "episodes": [...], "summary", "scenarios"}``.
The report holds a header (files, labels, config differences), a per-scenario table of
formation RMSE (mean ± 95 % t-interval computed here from the episodes, ratio to the
``scripted`` label), error-over-time and trajectory plots (PNG, base64-embedded), collision,
arbiter and communication tables, relative links to episode GIFs, and the episode replays
(:mod:`petswarm.evaluation.replay_viewer`). No external resources: the file opens from disk in any browser.

Older result files may lack fields; whatever is missing shows as "n/a".
"""

from __future__ import annotations

import json
import math
import os
import re
import urllib.parse
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from petswarm.evaluation.grid_report import grid_section, is_grid
from petswarm.evaluation.html import NA, escape, figure, now_stamp, page, table
from petswarm.evaluation.replay_viewer import replay_section
from petswarm.evaluation.report_inputs import load_result
from petswarm.evaluation.report_plots import COLORS, plot_error_over_time, plot_rmse_bars, plot_trajectories, trace_matrix
from petswarm.evaluation.stats import as_number as _num
from petswarm.evaluation.stats import mean_ci95, paired_ratio
from petswarm_env.config import flatten_dotted
from petswarm_env.files import write_text_atomic
from petswarm_env.metrics import REFILL_SETTLE_S

REFERENCE_LABEL = "scripted"
DEFAULT_DT_S = 0.1  # control period of one env step (configs/default.yaml: control_period_s)
DASH = "—"


def _sum_or_nan(values: Iterable[Any]) -> float:
    """Sum of the finite numbers; NaN if there are none."""
    xs = [v for v in (_num(x) for x in values) if math.isfinite(v)]
    return float(sum(xs)) if xs else math.nan


class _Result:
    """One loaded result file, with its display label."""

    def __init__(self, path: str, data: dict[str, Any]):
        self.path = path
        self.dir = Path(path).resolve().parent
        self.data = data
        raw = data.get("label")
        self.label = str(raw) if raw not in (None, "") else Path(path).stem
        self.config: dict[str, Any] = data["config"]
        self.episodes: list[dict[str, Any]] = data["episodes"]
        self.dt_s = _num(self.config.get("control_period_s"))
        if not (math.isfinite(self.dt_s) and self.dt_s > 0):
            self.dt_s = DEFAULT_DT_S
        default_scn = None
        user = self.config.get("user")
        if isinstance(user, dict) and user.get("scenario") not in (None, ""):
            default_scn = str(user["scenario"])
        self.default_scenario = default_scn or "default"

    def scenario_of(self, ep: dict[str, Any]) -> str:
        s = ep.get("scenario")
        return str(s) if s not in (None, "") else self.default_scenario

    def by_scenario(self) -> dict[str, list[dict[str, Any]]]:
        out: dict[str, list[dict[str, Any]]] = {}
        for ep in self.episodes:
            out.setdefault(self.scenario_of(ep), []).append(ep)
        return out


def _unique_labels(results: list[_Result]) -> None:
    """Give results with the same label distinct names (label [file name])."""
    counts: dict[str, int] = {}
    for r in results:
        counts[r.label] = counts.get(r.label, 0) + 1
    seen: dict[str, int] = {}
    for r in results:
        if counts[r.label] > 1:
            base = f"{r.label} [{Path(r.path).name}]"
            k = seen.get(base, 0)
            seen[base] = k + 1
            r.label = base if k == 0 else f"{base} #{k + 1}"


# -- formatting ----------------------------------------------------------------------------------
def _fmt(x: Any, digits: int = 3) -> str:
    v = _num(x)
    return f"{v:.{digits}f}" if math.isfinite(v) else NA


def _fmt_int(x: Any) -> str:
    v = _num(x)
    return str(round(v)) if math.isfinite(v) else NA


def _fmt_pct(num: float, den: float) -> str:
    if not (math.isfinite(num) and math.isfinite(den)) or den <= 0:
        return NA
    return f"{100.0 * num / den:.1f} %"


def _fmt_ci(mean: float, half: float, digits: int = 3) -> str:
    if not math.isfinite(mean):
        return NA
    if not math.isfinite(half):
        return f"{mean:.{digits}f} ± {NA}"
    return f"{mean:.{digits}f} ± {half:.{digits}f}"


def _cfg_value(v: Any) -> str:
    if isinstance(v, (dict, list)):
        return json.dumps(v, sort_keys=True)
    return str(v)



def _env_name(results: list[_Result]) -> str:
    for r in results:
        for key in ("env", "env_name"):
            v = r.data.get(key) or r.config.get(key)
            if isinstance(v, str) and v:
                return v
    try:
        from petswarm_env.env import ENV_NAME

        return ENV_NAME
    except ImportError:  # pragma: no cover - the report must not depend on the env importing
        return "petswarm"


_SCHEME = re.compile(r"^\s*([A-Za-z][A-Za-z0-9+.\-]*):")


def _gif_href(result: _Result, gif: str, out_dir: Path) -> tuple[str | None, bool]:
    """The href of a GIF, relative to the report's directory, and whether the file exists.
    A relative ``gif`` is taken relative to its result file; if no file is there but one is at
    that path from the current directory (a path recorded as given on the command line), that one.
    Only ``http``/``https`` URLs and paths become links: any other scheme (``javascript:``,
    ``data:``, ``file:``...) gives ``None``, shown as text, never as a link."""
    scheme = _SCHEME.match(gif)
    if scheme and len(scheme.group(1)) > 1:  # (one letter: a Windows drive, a path)
        ok = scheme.group(1).lower() in ("http", "https") and gif.strip() == gif and not any(c in gif for c in "\"\'<>`")
        return (gif, True) if ok else (None, False)
    target = Path(gif)
    if not target.is_absolute():
        beside = result.dir / target
        target = beside if beside.exists() or not target.exists() else target.resolve()
    target = Path(os.path.normpath(target))
    try:
        rel = os.path.relpath(target, out_dir)
    except ValueError:  # different drives (Windows): fall back to a file URI
        return target.as_uri(), target.exists()
    return urllib.parse.quote(Path(rel).as_posix()), target.exists()


# -- sections ----------------------------------------------------------------------------------------
def _section_header(results: list[_Result], generated: str) -> str:
    parts = [f"<h1>petswarm evaluation report</h1><p class=\"muted\">generated {escape(generated)} · environment <code>{escape(_env_name(results))}</code></p>"]
    rows = []
    for r in results:
        scns = list(r.by_scenario())
        if is_grid(r.data):
            n = f"{len(r.data['cells'])} cells × {escape(r.data.get('episodes_per_cell', NA))}"
            rows.append(([escape(r.label), f"<code>{escape(r.path)}</code>", n, "comparison grid (section below)"], ""))
            continue
        rows.append(([escape(r.label), f"<code>{escape(r.path)}</code>", str(len(r.episodes)), escape(", ".join(scns)) if scns else NA], ""))
    parts.append("<h2>1. Results compared</h2>")
    parts.append(table(["label", "file", "episodes", "scenarios"], rows, left_cols=2))
    # config differences
    flat = [flatten_dotted(r.config) for r in results]
    keys = sorted(set().union(*flat)) if flat else []
    diff = [k for k in keys if len({_cfg_value(f[k]) if k in f else "\0missing" for f in flat}) > 1]
    if len(results) < 2:
        parts.append("<p>One result only: nothing to compare configurations against.</p>")
    elif not any(flat):
        parts.append(f"<p>Configuration differences: {NA} (no configuration recorded).</p>")
    elif not diff:
        parts.append("<p>Configuration differences: none — all results share the same configuration.</p>")
    else:
        drows = [([f"<code>{escape(k)}</code>"] + [escape(_cfg_value(f[k])) if k in f else f'<span class="muted">{NA}</span>' for f in flat], "") for k in diff]
        parts.append("<p>Configuration differences between results:</p>")
        parts.append(table(["key"] + [escape(r.label) for r in results], drows))
    if any(flat):
        first = next((r for r, f in zip(results, flat) if f), results[0])
        crow = [([f"<code>{escape(k)}</code>", escape(_cfg_value(v))], "") for k, v in sorted(flatten_dotted(first.config).items())]
        parts.append(f"<details><summary>full configuration of <b>{escape(first.label)}</b></summary>{table(['key', 'value'], crow, left_cols=2)}</details>")
    return "".join(parts)


def _section_rmse(results: list[_Result], scenarios: list[str], colors: dict[str, str]) -> str:
    labels = [r.label for r in results]
    stats: dict[tuple[str, str], tuple[float, float, int]] = {}
    counts: dict[tuple[str, str], tuple[int, int]] = {}
    for r in results:
        for s, eps in r.by_scenario().items():
            stats[(s, r.label)] = mean_ci95(ep.get("formation_rmse_m") for ep in eps)
            counts[(s, r.label)] = (len(eps), stats[(s, r.label)][2])
    ref_label = REFERENCE_LABEL if REFERENCE_LABEL in labels else None
    by_label = {r.label: r for r in results}
    title = "<h2>2. Formation RMSE per scenario</h2>"
    if not scenarios:
        return title + f"<p>No episodes in any result: {NA}.</p>"
    parts = [title]
    rows = []
    for s in scenarios:
        present = [lab for lab in labels if (s, lab) in stats]
        finite = [stats[(s, lab)][0] for lab in present if math.isfinite(stats[(s, lab)][0])]
        best = min(finite) if finite else None
        ref = stats.get((s, ref_label), (math.nan, math.nan, 0))[0] if ref_label else math.nan
        for lab in present:
            m, h, n_fin = stats[(s, lab)]
            n_eps, _ = counts[(s, lab)]
            n_txt = str(n_eps) if n_fin == n_eps else f"{n_eps} ({n_eps - n_fin} without a value)"
            ratio = f"{m / ref:.2f}" if math.isfinite(m) and math.isfinite(ref) and ref > 0 else DASH
            if ratio != DASH and lab != ref_label:
                ratio += _paired_ci(by_label[lab].by_scenario().get(s, []), by_label[ref_label].by_scenario().get(s, []), "formation_rmse_m")
            is_best = best is not None and math.isfinite(m) and m == best
            cls = " ".join(c for c in ("grp" if lab == present[0] else "", "best" if is_best and len(present) > 1 else "") if c)
            rows.append(([escape(s), escape(lab) + (" ★" if is_best and len(present) > 1 else ""), _fmt_ci(m, h), n_txt, ratio], cls))
    ref_txt = f"<b>{escape(REFERENCE_LABEL)}</b>" if ref_label else f"{DASH} (no result labelled <code>{REFERENCE_LABEL}</code>)"
    parts.append(
        "<p>Formation RMSE (m) per scenario: mean over episodes ± half-width of the 95 % confidence interval "
        "(Student's t over the episodes' <code>formation_rmse_m</code>; n/a with a single episode). "
        f"Ratio: mean ÷ mean of the reference {ref_txt} on the same scenario (lower is better), with the 95 % percentile "
        "bootstrap interval of the ratio over the seeds both ran, resampled in pairs (none without two such seeds). "
        "The best (lowest mean) label per scenario is highlighted.</p>"
    )
    parts.append(table(["scenario", "label", "formation RMSE (m), mean ± 95 % CI", "episodes", f"ratio to {escape(REFERENCE_LABEL)}"], rows, left_cols=2))
    bars = plot_rmse_bars(scenarios, labels, stats, colors)
    if bars:
        parts.append(figure(bars, "formation RMSE per scenario",
                            "Formation RMSE per scenario and label; error bars: 95 % t confidence interval over episodes."))
    parts.append(_hold_table(results, scenarios, ref_label))
    return "".join(parts)


def _paired_ci(eps: list[dict[str, Any]], ref_eps: list[dict[str, Any]], key: str) -> str:
    """`` [lo, hi]``: the 95 % paired bootstrap interval of the ratio of ``key``'s means over the
    seeds both lists ran (:func:`petswarm.evaluation.stats.paired_ratio`); empty without two such seeds."""
    ref = {ep.get("seed"): ep.get(key) for ep in ref_eps if ep.get("seed") is not None}
    seeds = [ep.get("seed") for ep in eps if ep.get("seed") in ref]
    mine = {ep.get("seed"): ep.get(key) for ep in eps}
    lo, hi = paired_ratio([mine[k] for k in seeds], [ref[k] for k in seeds])["ci95"]
    return f" [{lo:.2f}, {hi:.2f}]" if math.isfinite(lo) and math.isfinite(hi) else ""


def _hold_table(results: list[_Result], scenarios: list[str], ref_label: str | None) -> str:
    """Building and holding apart (petswarm_env/metrics.py): per scenario and label the building
    time, the hold RMSE from the moment the formation was built (both over the episodes that built
    it, and how many did), its ratio to the reference, and the RMSE in the settle window after a refill."""
    rows = []
    by_label = {r.label: r for r in results}
    hold: dict[tuple[str, str], float] = {}
    for r in results:
        for s, eps in r.by_scenario().items():
            hold[(s, r.label)] = mean_ci95(ep.get("formation_hold_rmse_m") for ep in eps)[0]
    for s in scenarios:
        for r in results:
            eps = r.by_scenario().get(s)
            if not eps:
                continue
            b_m, b_h, built = mean_ci95(ep.get("building_time_s") for ep in eps)
            h_m, h_h, _ = mean_ci95(ep.get("formation_hold_rmse_m") for ep in eps)
            w_m, w_h, w_n = mean_ci95(ep.get("refill_settle_rmse_m") for ep in eps)
            ref = hold.get((s, ref_label), math.nan) if ref_label else math.nan
            ratio = f"{h_m / ref:.2f}" if math.isfinite(h_m) and math.isfinite(ref) and ref > 0 else DASH
            if ratio != DASH and r.label != ref_label:
                ratio += _paired_ci(eps, by_label[ref_label].by_scenario().get(s, []), "formation_hold_rmse_m")
            rows.append(([escape(s), escape(r.label), f"{built} of {len(eps)}", _fmt_ci(b_m, b_h, 1), _fmt_ci(h_m, h_h), ratio,
                          f"{_fmt_ci(w_m, w_h)} ({w_n})" if w_n else NA], "grp" if r is results[0] else ""))
    if not rows:
        return ""
    return ("<h3>Building and holding</h3><p>From the default scattered start most of the formation error is building: the "
            "slaves driving to their slots. <b>Building time</b> (s): from organized to every slave within 0.3 m of its "
            "reference point (<code>building_time_s</code>); <b>hold RMSE</b> (m): the formation RMSE from the step on which "
            "the formation was built (<code>formation_hold_rmse_m</code>); both mean ± 95 % CI over the episodes that built "
            "their formation (<i>built</i> says how many: an episode that never built has neither). <b>Settle after refill</b> "
            f"(m): the RMSE over the {REFILL_SETTLE_S:g} s after a dropped slave's place was refilled (<code>refill_settle_rmse_m</code>), mean ± "
            "95 % CI over the episodes with a refill (how many). Hold ratio: mean ÷ mean of the reference on the same scenario, "
            "[95 % paired bootstrap interval over the seeds where both built].</p>"
            + table(["scenario", "label", "built", "building time (s)", "hold RMSE (m)", f"hold ratio to {escape(REFERENCE_LABEL)}",
                     "settle after refill (m)"], rows, left_cols=2))


def _section_error_time(results: list[_Result], scenarios: list[str], colors: dict[str, str]) -> str:
    parts = ["<h2>3. Formation error over time</h2>"]
    for s in scenarios:
        series = []
        for r in results:
            m = trace_matrix(r.by_scenario().get(s, []))
            if m is not None:
                series.append((r.label, m, r.dt_s))
        png = plot_error_over_time(s, series, colors)
        if png is None:
            parts.append(f"<h3>{escape(s)}</h3><p>{NA}: no error traces recorded.</p>")
            continue
        dts = sorted({dt for _, _, dt in series})
        parts.append(f"<h3>{escape(s)}</h3>" + figure(
            png, f"formation error over time, {s}",
            "Mean formation error per step (m) across episodes, line = mean over episodes, shaded band = 25–75 percentile "
            f"(interquartile range) over episodes. Time axis: step index × {', '.join(f'{d:g}' for d in dts)} s, from the "
            "first step with a recorded error."))
    if not scenarios:
        parts.append(f"<p>{NA}: no episodes.</p>")
    return "".join(parts)


def _section_trajectories(results: list[_Result], scenarios: list[str]) -> str:
    parts = ["<h2>4. Trajectories</h2>"]
    if not scenarios:
        parts.append(f"<p>{NA}: no episodes.</p>")
    for s in scenarios:
        panels = []
        for r in results:
            eps = r.by_scenario().get(s, [])
            if eps:
                panels.append((r.label, eps[0]))
        png = plot_trajectories(s, panels)
        if png is None:
            parts.append(f"<h3>{escape(s)}</h3><p>{NA}: no trajectories recorded.</p>")
            continue
        parts.append(f"<h3>{escape(s)}</h3>" + figure(
            png, f"trajectories, {s}",
            "First episode of each label in this scenario: user path (black dashed, ■ start, ★ end), master robot (thick red), "
            "slave robots (thin lines), ● = final positions. Axes in metres, equal aspect."))
    return "".join(parts)


def _collision_counts(eps: list[dict[str, Any]]) -> list[float]:
    out = []
    for key in ("robot_robot", "robot_user", "robot_wall"):
        out.append(_sum_or_nan((ep.get("collisions") or {}).get(key) if isinstance(ep.get("collisions"), dict) else None for ep in eps))
    return out


def _comm_cells(eps: list[dict[str, Any]]) -> list[str]:
    def frames(key):
        return _sum_or_nan(ep["frames"].get(key) if isinstance(ep.get("frames"), dict) else None for ep in eps)

    sent, lost, coll = frames("sent"), frames("lost"), frames("collided")
    org_m, org_h, _ = mean_ci95(ep.get("organize_time_s") for ep in eps)
    built = [ep.get("building_time_s") for ep in eps if ep.get("building_time_s") is not None]
    b_m, b_h, b_n = mean_ci95(built)
    return [
        _fmt_int(sent),
        f"{_fmt_int(lost)} ({_fmt_pct(lost, sent)})" if math.isfinite(lost) else NA,
        f"{_fmt_int(coll)} ({_fmt_pct(coll, sent)})" if math.isfinite(coll) else NA,
        _fmt_int(_sum_or_nan(ep.get("join_retries") for ep in eps)),
        _fmt_int(_sum_or_nan(ep.get("token_recoveries") for ep in eps)),
        _fmt_ci(org_m, org_h, 2),
        f"{_fmt_ci(b_m, b_h, 1)} ({b_n}/{len(built)} built)" if built else NA,
    ]


def _arbiter_wins(ep: dict) -> dict | None:
    """The episode's arbiter counts (``events.arbiter_wins``; older results kept them at the top)."""
    events = ep.get("events")
    if isinstance(events, dict) and isinstance(events.get("arbiter_wins"), dict):
        return events["arbiter_wins"]
    return ep.get("arbiter_wins")


def _section_collisions_comms(results: list[_Result], scenarios: list[str]) -> str:
    title = "<h2>5. Collisions, arbiter and communication</h2>"
    if not scenarios:
        return title + f"<p>{NA}: no episodes.</p>"
    parts = [title]
    # collisions
    rows = []
    for s in scenarios:
        for r in results:
            eps = r.by_scenario().get(s)
            if eps:
                c = _collision_counts(eps)
                rows.append(([escape(s), escape(r.label), str(len(eps))] + [_fmt_int(x) for x in c] + [_fmt_int(_sum_or_nan(c))], ""))
    for r in results:
        if r.episodes:
            c = _collision_counts(r.episodes)
            rows.append((["all scenarios", escape(r.label), str(len(r.episodes))] + [_fmt_int(x) for x in c] + [_fmt_int(_sum_or_nan(c))], "total"))
    parts.append("<h3>Collisions</h3><p>Collision events summed over episodes, as counted by the environment (<code>collisions</code> of each episode).</p>")
    parts.append(table(["scenario", "label", "episodes", "robot–robot", "robot–user", "robot–wall", "total"], rows, left_cols=2))
    # arbiter
    keys: list[str] = []
    for r in results:
        for ep in r.episodes:
            if isinstance(_arbiter_wins(ep), dict):
                for k in _arbiter_wins(ep):
                    if str(k) not in keys:
                        keys.append(str(k))
    order = [k for k in ("safety", "user", "policy") if k in keys] + [k for k in keys if k not in ("safety", "user", "policy")]
    if not order:
        order = ["safety", "user", "policy"]
    arows = []
    for r in results:
        eps = [ep for ep in r.episodes if isinstance(_arbiter_wins(ep), dict)]
        if not eps:
            arows.append(([escape(r.label), "0"] + [NA] * len(order) + [NA], ""))
            continue
        wins = {k: _sum_or_nan(_arbiter_wins(ep).get(k) for ep in eps) for k in order}
        ticks = _sum_or_nan(wins.values())  # one source wins per robot and tick
        cells = [f"{_fmt_int(wins[k])} ({_fmt_pct(wins[k], ticks)})" if math.isfinite(wins[k]) else NA for k in order]
        arows.append(([escape(r.label), str(len(eps))] + cells + [_fmt_int(ticks)], ""))
    parts.append(
        "<h3>Arbiter</h3><p>Which source won the command arbitration of seed 001 (safety &gt; user &gt; policy), "
        "summed over every robot (master included) and tick of the episodes, as a share of robot-ticks. "
        f"{NA}: the result records no arbiter statistics.</p>"
    )
    parts.append(table(["label", "episodes with data"] + [escape(k) for k in order] + ["ticks"], arows))
    # communication
    crow = []
    for s in scenarios:
        for r in results:
            eps = r.by_scenario().get(s)
            if eps:
                crow.append(([escape(s), escape(r.label), str(len(eps))] + _comm_cells(eps), ""))
    for r in results:
        if r.episodes:
            crow.append((["all scenarios", escape(r.label), str(len(r.episodes))] + _comm_cells(r.episodes), "total"))
    parts.append(
        "<h3>Communication</h3><p>802.15.4 frames summed over episodes (lost and collided as a share of sent), "
        "join retries and IR token recoveries summed, organize time (s) mean ± 95 % CI over episodes; building time (s): from organized "
        "to every slave within 0.3 m of its reference (building_time_s), mean ± 95 % CI over the episodes that built their formation, "
        "and how many did (older results without it: n/a).</p>"
    )
    parts.append(table(["scenario", "label", "episodes", "frames sent", "lost", "collided", "join retries", "token recoveries", "organize time (s)", "building time (s)"], crow, left_cols=2))
    return "".join(parts)


def _section_gifs(results: list[_Result], out_dir: Path) -> str:
    parts = ["<h2>6. Episode animations</h2>"]
    items = []
    for r in results:
        for ep in r.episodes:
            gif = ep.get("gif")
            if not isinstance(gif, str) or not gif:
                continue
            href, exists = _gif_href(r, gif, out_dir)
            text = f"{r.label} — {r.scenario_of(ep)}, seed {ep.get('seed', NA)}"
            if href is None:
                items.append(f'<li>{escape(text)} <span class="warn">(not a link: <code>{escape(gif[:80])}</code> is neither a path '
                             'nor an http(s) URL)</span></li>')
                continue
            missing = "" if exists else ' <span class="warn">(file not found)</span>'
            items.append(f'<li><a href="{escape(href)}">{escape(text)}</a>{missing}</li>')
    if items:
        parts.append("<p>GIFs recorded during evaluation (links relative to this report).</p><ul class=\"gifs\">" + "".join(items) + "</ul>")
    else:
        parts.append("<p>No GIFs recorded.</p>")
    return "".join(parts)


def _render_html(results: list[_Result], out_path: str | os.PathLike, generated: str | None = None,
                 replays: str = "first") -> str:
    out_dir = Path(out_path).resolve().parent
    if generated is None:
        generated = now_stamp()
    scenarios: list[str] = []
    for r in results:
        for s in r.by_scenario():
            if s not in scenarios:
                scenarios.append(s)
    colors = {r.label: COLORS[i % len(COLORS)] for i, r in enumerate(results)}
    grids = [r for r in results if is_grid(r.data)]
    evals = [r for r in results if not is_grid(r.data)]
    body = [_section_header(results, generated)]
    if evals:  # the grid results hold no episodes: their section is the heatmap (petswarm.evaluation.grid_report)
        body += [
            _section_rmse(evals, scenarios, colors),
            _section_error_time(evals, scenarios, colors),
            _section_trajectories(evals, scenarios),
            _section_collisions_comms(evals, scenarios),
            _section_gifs(evals, out_dir),
            replay_section(evals, replays, 7),
        ]
    body += [grid_section(r.data, r.label, (8 if evals else 2) + k) for k, r in enumerate(grids)]
    return page("petswarm report: " + " vs ".join(r.label for r in results), body)


def write_report(result_paths: list[str], out_path: str, replays: str = "first") -> None:
    """Write one self-contained HTML report comparing the results in ``result_paths`` to
    ``out_path`` (atomically), with the episode replays ``replays`` chooses
    (:mod:`petswarm.evaluation.replay_viewer`). Raises ``ValueError`` naming the file on a bad result file."""
    if not result_paths:
        raise ValueError("no result files given")
    results = [_Result(str(p), load_result(p)) for p in result_paths]
    _unique_labels(results)
    out = Path(out_path)
    write_text_atomic(out, _render_html(results, out, replays=replays))
