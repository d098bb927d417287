"""The report's episode replays: which episodes, and the viewer embedded in the page.

``petswarm report A.json B.json --replays SPEC`` embeds the replay files that ``petswarm eval
--replay-dir`` recorded (each episode of a result names its file in ``"replay"``, relative to the
result file). Episodes of the same scenario and seed — from different result files, e.g. the
scripted reference and a learned policy — play side by side in one panel, in step, from one slider.
``SPEC`` chooses the panels:

* ``first`` (default): per scenario, the first seed that has a replay;
* ``all``: every scenario and seed that has one;
* ``none``: no replays;
* ``SCENARIO:SEED,...``: those (e.g. ``zigzag:0,u_turn:3``).

Each replay is embedded gzipped and base64-encoded in a ``<script type="application/octet-stream">``
and unpacked by the browser (``DecompressionStream``); the viewer (``replay_viewer.js``, package
data) is inlined: the page stays one file that needs no network.
"""

from __future__ import annotations

import base64
import gzip
import json
from importlib import resources
from pathlib import Path
from typing import Any

from petswarm.evaluation.html import escape
from petswarm.evaluation.replay import load_replay

CSS = """
div.rp{border:1px solid #ddd;padding:.5em;margin:.8em 0 1.6em;background:#fff}
div.rp-controls{display:flex;gap:.6em;align-items:center;margin-bottom:.4em;font-size:.9em}
div.rp-controls input[type=range]{flex:1}
div.rp-row{display:flex;gap:12px;flex-wrap:wrap}
div.rp-ep canvas{display:block;border:1px solid #eee;margin-bottom:3px}
div.rp-title{font-weight:600;margin-bottom:.2em}
div.rp-info{font-size:.8em}table.rp-table{font-size:1em;margin:.2em 0}table.rp-table td,table.rp-table th{padding:.05em .4em}
"""


def parse_spec(spec: str) -> str | list[tuple[str, int]]:
    """``first``, ``all``, ``none`` or a list of (scenario, seed); a bad item is a ``ValueError``."""
    spec = spec.strip()
    if spec in ("first", "all", "none"):
        return spec
    out = []
    for item in (s.strip() for s in spec.split(",")):
        scenario, sep, seed = item.rpartition(":")
        if not sep or not scenario or not seed.isdigit():
            raise ValueError(f"--replays '{item}': expected first, all, none or SCENARIO:SEED[,...], e.g. zigzag:0")
        out.append((scenario, int(seed)))
    return out


def _replay_path(result_dir: Path, replay: str) -> Path:
    """A replay's path: relative to its result file (as ``petswarm eval --json`` writes it), or, if no
    file is there but one is at the path as given, that one."""
    p = Path(replay)
    if p.is_absolute():
        return p
    beside = result_dir / p
    return beside if beside.exists() or not p.exists() else p


def choose(results: list, spec: str) -> list[tuple[tuple[str, int], list[tuple[str, Path]]]]:
    """The panels: ((scenario, seed), [(result label, replay path), ...]) in the order of the
    results' episodes. ``results`` are the report's loaded results (label, dir, episodes, scenario_of)."""
    chosen = parse_spec(spec)
    groups: dict[tuple[str, int], list[tuple[str, Path]]] = {}
    for r in results:
        for ep in r.episodes:
            replay = ep.get("replay")
            if not isinstance(replay, str) or not replay or not isinstance(ep.get("seed"), int):
                continue
            groups.setdefault((r.scenario_of(ep), ep["seed"]), []).append((r.label, _replay_path(r.dir, replay)))
    if chosen == "none":
        return []
    if chosen == "all":
        return list(groups.items())
    if chosen == "first":
        seen: set[str] = set()
        out = []
        for key, items in groups.items():
            if key[0] not in seen:
                seen.add(key[0])
                out.append((key, items))
        return out
    missing = [f"{s}:{n}" for s, n in chosen if (s, n) not in groups]
    if missing:
        raise ValueError(f"--replays {', '.join(missing)}: no replay recorded for it (record with petswarm eval --replay-dir DIR)")
    return [((s, n), groups[(s, n)]) for s, n in chosen]


def embed(data: dict[str, Any]) -> str:
    """One replay as the page carries it: compact JSON, gzipped (no timestamp: the same replay gives
    the same bytes), base64."""
    raw = json.dumps(data, separators=(",", ":"), allow_nan=False).encode("utf-8")
    return base64.b64encode(gzip.compress(raw, 9, mtime=0)).decode("ascii")


def viewer_js() -> str:
    return resources.files("petswarm.evaluation").joinpath("replay_viewer.js").read_text(encoding="utf-8")


def _panel(key: tuple[str, int], items: list[tuple[str, Path]]) -> str:
    scenario, seed = key
    blobs, problems = [], []
    for label, path in items:
        if not path.exists():
            problems.append(f"{escape(label)}: replay file not found (<code>{escape(path)}</code>)")
            continue
        data = load_replay(path)
        data["label"] = label  # the report's (unique) label
        blobs.append(f'<script type="application/octet-stream" class="rp-data">{embed(data)}</script>')
    head = f"<h3>{escape(scenario)}, seed {seed}</h3>"
    warn = "".join(f'<p class="warn">{p}</p>' for p in problems)
    if not blobs:
        return head + warn
    controls = ('<div class="rp-controls"><button class="rp-play" type="button">▶ play</button>'
                '<input class="rp-slider" type="range" min="0" max="0" value="0" aria-label="replay step">'
                '<span class="rp-time"></span><select class="rp-speed" aria-label="speed"><option value="1">1×</option>'
                '<option value="2">2×</option><option value="5">5×</option><option value="10">10×</option></select></div>')
    return f'{head}{warn}<div class="rp">{controls}<div class="rp-row"></div>{"".join(blobs)}</div>'


def replay_section(results: list, spec: str, number: int) -> str:
    """The report's replay section (``<h2>``, explanation, one panel per chosen scenario and seed, the viewer)."""
    title = f"<h2>{number}. Episode replays</h2>"
    panels = choose(results, spec)
    if not panels:
        why = "none chosen (--replays none)" if spec.strip() == "none" else \
            "no episode has a replay (record them with <code>petswarm eval --replay-dir DIR</code>)"
        return title + f"<p>No replays: {why}.</p>"
    intro = (
        "<p>Episodes of the same scenario and seed side by side, in step, from one slider (chosen with "
        f"<code>--replays {escape(spec)}</code>). Keys: <b>space</b> play/pause, <b>←/→</b> one step (with shift: ten), "
        "Home/End; a click in a chart jumps there. Arena: the view follows the user (orange, dashed path); robots "
        "coloured by role (master red, slave blue, waiting grey, other user's purple), a yellow halo on the IR token "
        "holder, crosses at the reference points with the error to them dotted, grey formation links. Below: the mean "
        "formation error, the radio per frame type (sent, lost, collided per step; the first column is the reset: "
        "pairing and organize), the user's activity, robot state and commands, and each robot's arbiter winner "
        "(policy green, user blue, safety red); the table gives each robot's type, role, state and error at the cursor.</p>"
    )
    body = "".join(_panel(key, items) for key, items in panels)
    return f"{title}{intro}<style>{CSS}</style>{body}<script>{viewer_js()}</script>"
