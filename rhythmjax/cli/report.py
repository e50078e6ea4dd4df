"""`report.html`: one self-contained page per run (`run`, `demo`, `count`, `classify`): the
summary, the verdict table, the spectra gallery (PNG pages as data URIs), the overlay video
(a relative link), the config used and the other outputs (relative links). Plain HTML and CSS,
no script; written atomically (the caller's `OutputSet`, or `write_report`)."""

from __future__ import annotations

import base64
import datetime
import html
import json
import math
import os

import numpy as np

from .. import __version__
from ..io import atomic_write, dumps_json


__all__ = ["MAX_ROWS", "REPORT_NAME", "read_verdicts_head", "render_report", "report_path",
           "write_report"]

REPORT_NAME = "report.html"
MAX_ROWS = 5000  # verdict rows shown (a batch of 1e6 tracks: the first ones, and a note)
COLUMNS = (("track_id", "track"), ("truth", "truth"), ("label", "label"), ("verdict", "verdict"),
           ("reason", "reason"), ("pace_hz", "pace F (Hz)"), ("stride_m", "step T (m)"),
           ("ratio", "ratio R"), ("speed_mps", "speed (m/s)"), ("n_samples", "samples"),
           ("counted", "counted"))
GAIT = ("pace_hz", "stride_m")
NO_GAIT = ("F and T are the spectral peak of a track judged not walking: not a gait, not "
           "meaningful for it")

CSS = """
body{font:14px/1.45 system-ui,sans-serif;margin:1.5em auto;max-width:1200px;color:#222;
padding:0 1em}h1{font-size:1.5em;margin-bottom:.2em}
h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}
.meta{color:#666}dl.summary{display:grid;grid-template-columns:max-content auto;gap:.2em 1em}
dl.summary dt{font-weight:600}dl.summary dd{margin:0}
table.verdicts{border-collapse:collapse;font-size:13px}
table.verdicts th,table.verdicts td{border:1px solid #ccc;padding:2px 8px;text-align:right}
table.verdicts th{background:#f2f2f2;position:sticky;top:0}
td.v-pedestrian{background:#dff3e2}td.v-non-pedestrian{background:#fbe0e0}
td.v-unclassified{background:#fdf2d0}td.nogait{color:#999;font-style:italic}
.gallery img{max-width:100%;border:1px solid #ddd;margin:.4em 0}
pre{background:#f7f7f7;padding:.8em;overflow:auto;font-size:12px}
video{max-width:100%;background:#000}.stills{display:flex;flex-wrap:wrap;gap:.5em}
.stills figure{margin:0}.stills img{width:360px;border:1px solid #ccc}
figcaption{font-size:12px;color:#666}.note{color:#8a5a00}
"""


def report_path(output: str) -> str:
    """Where `classify` writes its report: beside the verdicts, `<stem>.report.html` (a verdicts
    folder `DIR/`: `DIR.report.html`, outside the Parquet dataset)."""
    if output.endswith(("/", os.sep)) or os.path.isdir(output):
        return output.rstrip("/" + os.sep) + ".report.html"
    return os.path.splitext(output)[0] + ".report.html"


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return "" if not math.isfinite(v) else f"{v:.3f}"
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    return html.escape(str(value))


def _table(verdicts: dict, truth_ids: dict | None, max_rows: int, total: int | None) -> str:
    n = len(verdicts["track_id"]) if "track_id" in verdicts else 0
    total = n if total is None else int(total)
    cols = [(k, t) for k, t in COLUMNS
            if k in verdicts or (k == "truth" and truth_ids)]
    head = "".join(f"<th>{html.escape(t)}</th>" for _, t in cols)
    rows = []
    for i in range(min(n, max_rows)):
        verdict = str(verdicts["verdict"][i]) if "verdict" in verdicts else ""
        cells = []
        for k, _ in cols:
            if k == "truth":
                tid = verdicts["track_id"][i]
                key = int(tid) if isinstance(tid, (int, np.integer)) else tid
                cells.append(f"<td>{_cell(truth_ids.get(key, ''))}</td>")
                continue
            text = _cell(verdicts[k][i])
            if k == "verdict":
                cells.append(f'<td class="v-{html.escape(verdict)}">{text}</td>')
            elif k in GAIT and verdict == "non-pedestrian" and text:
                cells.append(f'<td class="nogait" title="{NO_GAIT}">({text})</td>')
            else:
                cells.append(f"<td>{text}</td>")
        rows.append("<tr>" + "".join(cells) + "</tr>")
    shown = len(rows)
    more = "" if total <= shown else (f'<p class="note">the first {shown} of {total} tracks '
                                      "are shown; the verdicts file holds every one</p>")
    return (f'<table class="verdicts" id="verdicts" data-rows="{shown}"><thead><tr>{head}</tr>'
            f"</thead><tbody>{''.join(rows)}</tbody></table>{more}"
            f'<p class="meta">(F), (T) in grey: {html.escape(NO_GAIT)}.</p>')


def _summary(summary: dict) -> str:
    items = []
    for k, v in summary.items():
        if k in ("notes", "objects") or v is None:
            continue
        if isinstance(v, dict):
            v = ", ".join(f"{a} {_cell(b)}" for a, b in v.items() if not isinstance(b, dict))
        elif isinstance(v, list):
            v = ", ".join(_cell(x) for x in v)
        else:
            v = _cell(v)
        items.append(f"<dt>{html.escape(k.replace('_', ' '))}</dt><dd>{v}</dd>")
    return f'<dl class="summary">{"".join(items)}</dl>'


def _objects(objects: list[dict]) -> str:
    """The demo's per-object rows: each rendered object's verdict beside its truth."""
    keys = ("object", "kind", "verdict", "pace", "pace_true", "stride", "stride_true", "tracks",
            "track_ids")
    head = "".join(f"<th>{k.replace('_', ' ')}</th>" for k in keys)
    def cell(o, k):
        v = o.get(k)
        if k == "track_ids":
            return f"<td>{', '.join(f'#{t}' for t in v or ())}</td>"
        if k in ("pace", "stride") and o.get("verdict") == "non-pedestrian" and _cell(v):
            return f'<td class="nogait" title="{NO_GAIT}">({_cell(v)})</td>'
        return f"<td>{_cell(v)}</td>"

    body = "".join("<tr>" + "".join(cell(o, k) for k in keys) + "</tr>" for o in objects)
    return (f'<table class="verdicts" id="objects"><thead><tr>{head}</tr></thead>'
            f"<tbody>{body}</tbody></table>")


def _rounded(obj):
    """Floats to 7 significant digits (the config's float32 values read as written)."""
    if isinstance(obj, float):
        return float(f"{obj:.7g}")
    if isinstance(obj, dict):
        return {k: _rounded(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_rounded(v) for v in obj]
    return obj


def render_report(*, title: str, summary: dict, verdicts: dict, config: dict | None = None,
                  spectra: list[bytes] | None = None, overlay: str | None = None,
                  outputs: list[str] = (), truth_ids: dict | None = None,
                  objects: list[dict] | None = None, max_rows: int = MAX_ROWS,
                  n_tracks: int | None = None,
                  frames: list[tuple[int, bytes]] | None = None) -> str:
    """The report page as one HTML string. `verdicts`: the verdict columns (track_id, verdict,
    reason, pace_hz, ...); `spectra`: the gallery's PNG pages (None: not made for this verb);
    `overlay`, `outputs`: paths relative to the report; `truth_ids`: {track id: the object it
    followed} (the demo); `objects`: the demo's per-object truth rows; `n_tracks`: the tracks in
    all when `verdicts` holds only the first ones (`read_verdicts_head`); `frames`: (index, JPEG
    bytes) of a few overlay frames (`overlay.FrameSampler`), shown as stills."""
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    parts = [f"<h1>{html.escape(title)}</h1>",
             f'<p class="meta">rhythmjax {__version__}, {when}</p>',
             "<h2>Summary</h2>", _summary(summary)]
    notes = summary.get("notes") or []
    if notes:
        parts.append("<ul>" + "".join(f'<li class="note">{html.escape(str(n))}</li>'
                                      for n in notes) + "</ul>")
    if objects:
        parts += ["<h2>Objects and the truth</h2>", _objects(objects)]
    parts += ["<h2>Verdicts</h2>", _table(verdicts, truth_ids, max_rows, n_tracks)]
    parts.append("<h2>Spectra</h2>")
    if spectra:
        parts.append(f'<p class="meta">every judged track: {len(spectra)} page(s); the MEM '
                     "spectrum of the window its pace came from (its deciding window, or its "
                     "strongest Pedestrian one) relative to white noise, P_thr (dotted), "
                     "the walking model's pace band (green) and the peak (dashed)</p>")
        parts.append('<div class="gallery">' + "".join(
            f'<img alt="spectra page {k + 1}" src="data:image/png;base64,'
            f'{base64.b64encode(png).decode()}">' for k, png in enumerate(spectra)) + "</div>")
    else:
        parts.append('<p class="meta">not drawn by this command (no rhythm windows kept)</p>')
    if overlay:
        href = html.escape(overlay)
        poster = "" if not frames else \
            f' poster="data:image/jpeg;base64,{base64.b64encode(frames[0][1]).decode()}"'
        parts += ["<h2>Overlay</h2>",
                  f'<video controls preload="metadata" src="{href}"{poster}></video>',
                  f'<p class="meta"><a href="{href}">{href}</a>' + (
                      "" if overlay.lower().endswith(".webm") else " (MPEG-4 part 2: most "
                      "browsers do not play it; open it in a video player, e.g. VLC or mpv, or "
                      "write overlay.webm with --overlay-format webm)") + "</p>"]
        if frames:
            parts.append('<div class="stills">' + "".join(
                f'<figure><img alt="overlay frame {i}" src="data:image/jpeg;base64,'
                f'{base64.b64encode(jpg).decode()}"><figcaption>frame {i}</figcaption></figure>'
                for i, jpg in frames) + "</div>")
    if outputs:
        parts += ["<h2>Outputs</h2>", "<ul>" + "".join(
            f'<li><a href="{html.escape(o)}">{html.escape(o)}</a></li>' for o in outputs)
                  + "</ul>"]
    if config is not None:
        text = json.dumps(_rounded(json.loads(dumps_json(config))), indent=2)
        parts += ["<h2>Config used</h2>", f"<pre>{html.escape(text)}</pre>"]
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(title)}</title><style>{CSS}</style></head><body>"
            + "\n".join(parts) + "</body></html>\n")


def read_verdicts_head(path: str, max_rows: int = MAX_ROWS) -> dict:
    """The first `max_rows` rows of a verdicts file (.csv, .parquet) or folder (a Parquet
    dataset) as columns, without reading the rest."""
    import pyarrow as pa

    if os.path.isdir(path):
        import pyarrow.dataset as ds

        tbl = ds.dataset(path, format="parquet").head(max_rows)
    else:
        if path.lower().endswith(".parquet"):
            import pyarrow.parquet as pq

            batches = pq.ParquetFile(path).iter_batches(batch_size=max_rows)
        else:
            import pyarrow.csv as pcsv

            batches = pcsv.open_csv(path)
        got, n = [], 0
        for b in batches:
            got.append(b)
            n += b.num_rows
            if n >= max_rows:
                break
        tbl = pa.Table.from_batches(got).slice(0, max_rows) if got else pa.table({})
    return {name: tbl.column(name).to_numpy(zero_copy_only=False)
            for name in tbl.column_names}


def write_report(path, page: str) -> None:
    """Write the page atomically at `path` (a temp path of an `OutputSet`, or the final one)."""
    with atomic_write(path, "w") as f:
        f.write(page)
