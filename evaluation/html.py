"""Self-contained HTML pages: what the evaluation report (``petswarm report``) and the papers'
report (``petswarm reproduce --report``) share.

The page skeleton with its style sheet, HTML escaping, tables, and matplotlib figures as
base64-embedded PNGs (pyplot-free Agg figures, so no display and no global state). No external
resources: a page opens from disk in any browser.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import io
from typing import Any

NA = "n/a"  # what a page shows for a value that is missing

CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:1.5em auto;max-width:1100px;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:1.8em}h3{margin-bottom:.3em}
table{border-collapse:collapse;margin:.6em 0 1em;font-size:.9em}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right;vertical-align:top}
th{background:#f0f0f0}td.l,th.l{text-align:left}
tr.best td{background:#e6f4e6;font-weight:600}
tr.total td{background:#f7f7f7;font-style:italic}
tr.grp td{border-top:2px solid #999}
.meta td{text-align:left}.muted{color:#777}.warn{color:#a60}
figure{margin:.6em 0 1.4em}figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:.85em;color:#555;max-width:900px}
code{background:#f4f4f4;padding:0 .2em}details{margin:.4em 0}
ul.gifs{columns:2;font-size:.9em}
"""


def escape(x: Any) -> str:
    """``str(x)`` escaped for HTML text and attribute values."""
    return html.escape(str(x), quote=True)


def now_stamp() -> str:
    """The local time with its offset, to the second (a page's "generated" line)."""
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def page(title: str, body: list[str], extra_css: str = "") -> str:
    """A whole HTML document: ``title`` (escaped here), the shared style sheet plus ``extra_css``
    and the ``body`` parts (HTML), one per line."""
    return (
        f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{escape(title)}</title>'
        f'<meta name="viewport" content="width=device-width, initial-scale=1"><style>{CSS}{extra_css}</style></head>\n<body>\n'
        + "\n".join(body)
        + "\n</body></html>\n"
    )


def table(headers: list[str], rows: list[tuple[list[str], str]], left_cols: int = 1) -> str:
    """``rows``: (escaped cell texts, tr class). The first ``left_cols`` columns are left-aligned."""
    out = ["<table><thead><tr>"]
    out += [f'<th class="l">{h}</th>' if i < left_cols else f"<th>{h}</th>" for i, h in enumerate(headers)]
    out.append("</tr></thead><tbody>")
    for cells, cls in rows:
        out.append(f'<tr class="{cls}">' if cls else "<tr>")
        out += [f'<td class="l">{c}</td>' if i < left_cols else f"<td>{c}</td>" for i, c in enumerate(cells)]
        out.append("</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def new_figure(w: float, h: float, top_in: float = 0.35, bottom_in: float = 0.55, wspace: float = 0.2, hspace: float = 0.2):
    """A pyplot-free Agg figure with fixed margins in inches (cheaper than tight/constrained layout)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), dpi=100)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=0.75 / w, right=1 - 0.15 / w, bottom=bottom_in / h, top=1 - top_in / h, wspace=wspace, hspace=hspace)
    return fig


def png_base64(fig) -> str:
    """The figure as a PNG (90 dpi), base64 text."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def img(b64: str, alt: str) -> str:
    """An ``<img>`` of a base64 PNG (from :func:`png_base64`)."""
    return f'<img src="data:image/png;base64,{b64}" alt="{escape(alt)}">'


def figure(b64: str, alt: str, caption: str) -> str:
    """A ``<figure>`` of a base64 PNG with its ``caption`` (HTML)."""
    return f"<figure>{img(b64, alt)}<figcaption>{caption}</figcaption></figure>"
