"""MOTChallenge text files: `frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z`, no header.

frame is 1-based, id a positive integer, the box in px (left, top, width, height), conf a score,
and x, y, z the world position (here the ground point in m and z = 0; -1, -1, -1 where there is
none, the MOTChallenge convention for 2-D files). Rows are written sorted by (frame, id), comma
separated, floats with up to 6 significant decimals; the write is atomic (`io.atomic_write`).
`read_mot` also accepts 6 to 9 columns (missing conf = 1, missing x, y, z = -1) and raises
`io.BadInput` naming the file and the line for anything else.

Extra columns (`write_mot(..., extra=names)`, `read_mot(..., extra=names)`) follow the standard
ten, in the order named, non-finite values written as `nan`: `rhythmjax count` writes its
per-frame velocities (`VELOCITY_COLUMNS`: ground vx, vy m/s and image du, dv px/s) so, in a
file of its own (mot_velocity.txt). mot.txt itself keeps exactly the ten columns, as
py-motmetrics' `loadtxt` (pandas, ten names, the first two columns the index) misreads any row
with more: with an 11th field every value moves one column over, and from the 13th it raises.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence

import numpy as np

from .atomic import atomic_write
from .errors import BadInput, PathLike


MOT_COLUMNS = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf", "x", "y", "z")
VELOCITY_COLUMNS = ("vx", "vy", "du", "dv")  # count's extra columns: m/s, m/s, px/s, px/s
_DEFAULTS = {"conf": 1.0, "x": -1.0, "y": -1.0, "z": -1.0}


def _fmt(x: float) -> str:
    if not math.isfinite(x):
        raise ValueError(f"write_mot: non-finite value {x!r}")
    s = f"{x:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def write_mot(path: PathLike, cols: Mapping[str, np.ndarray], extra: Sequence[str] = ()) -> None:
    """Write MOT rows (columns `MOT_COLUMNS`; conf, x, y, z default as in `read_mot` when
    absent), then the columns named in `extra` (required; NaN written as `nan`), sorted by
    (frame, id), atomically."""
    n = len(cols["frame"])
    arr = {}
    for c in extra:
        if c in MOT_COLUMNS or c not in cols:
            raise ValueError(f"write_mot: extra column {c!r} is standard or missing")
    for c in (*MOT_COLUMNS, *extra):
        a = np.asarray(cols[c]) if c in cols else np.full(n, _DEFAULTS[c])
        if len(a) != n:
            raise ValueError(f"write_mot: column {c!r} has {len(a)} rows, frame has {n}")
        arr[c] = a
    frame, ids = arr["frame"].astype(np.int64), arr["id"].astype(np.int64)
    order = np.lexsort((ids, frame))
    with atomic_write(path, "w") as f:
        for i in order:
            vals = [str(int(frame[i])), str(int(ids[i]))]
            vals += [_fmt(float(arr[c][i])) for c in MOT_COLUMNS[2:]]
            vals += [_fmt(x) if math.isfinite(x := float(arr[c][i])) else "nan" for c in extra]
            f.write(",".join(vals) + "\n")


def read_mot(path: PathLike, extra: Sequence[str] = ()) -> dict[str, np.ndarray]:
    """Read a MOT text file into columns (frame, id int64; the rest float64), and the columns
    named in `extra` after the standard ten (NaN where a row has none). Blank lines are
    skipped; a row with fewer than 6 or more than 10 + len(extra) fields, a non-number, a
    non-integer or < 1 frame or id, a non-finite or negative box size raises `BadInput` (file
    and line)."""
    names = (*MOT_COLUMNS, *extra)
    p = os.fspath(path)
    if os.path.isdir(p):
        raise BadInput(p, "is a directory, not a MOT file")
    try:
        with open(p, encoding="utf-8") as f:
            lines = f.read().splitlines()
    except FileNotFoundError:
        raise BadInput(p, "no such file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise BadInput(p, f"cannot read: {e}") from None
    rows = []
    for k, line in enumerate(lines, 1):
        if not line.strip():
            continue
        parts = [s.strip() for s in line.replace(";", ",").split(",")]
        if not 6 <= len(parts) <= len(names):
            raise BadInput(p, f"expected 6 to {len(names)} comma-separated fields, got "
                           f"{len(parts)}", line=k)
        vals = []
        for c, s in zip(names, parts):
            try:
                x = float(s)
            except ValueError:
                raise BadInput(p, f"{s!r} is not a number", line=k, column=c) from None
            if c in ("frame", "id") and (not math.isfinite(x) or x != int(x) or x < 1):
                raise BadInput(p, f"{s!r} is not an integer >= 1", line=k, column=c)
            if c in ("bb_width", "bb_height") and not (math.isfinite(x) and x >= 0):
                raise BadInput(p, f"{s!r} is not a finite size >= 0", line=k, column=c)
            vals.append(x)
        vals += [_DEFAULTS.get(c, math.nan) for c in names[len(vals):]]
        rows.append(vals)
    a = np.asarray(rows, np.float64).reshape(-1, len(names))
    out = {c: a[:, i] for i, c in enumerate(names)}
    out["frame"] = out["frame"].astype(np.int64)
    out["id"] = out["id"].astype(np.int64)
    return out


def read_mot_numbered(path: PathLike) -> dict[str, np.ndarray]:
    """`read_mot(path)` plus `line`: each row's 1-based line number in the file (blank lines
    counted, as an editor shows them), so that a later check can name the line of a row."""
    out = read_mot(path)
    with open(os.fspath(path), encoding="utf-8") as f:
        lines = [k for k, line in enumerate(f.read().splitlines(), 1) if line.strip()]
    out["line"] = np.asarray(lines, np.int64)
    return out
