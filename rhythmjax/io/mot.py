"""MOTChallenge text files: `frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z`, no header.

frame is 1-based, id a positive integer, the box in px (left, top, width, height), conf a score,
and x, y, z the world position (here the ground point in m and z = 0; -1, -1, -1 where there is
none, the MOTChallenge convention for 2-D files). Rows are written sorted by (frame, id), comma
separated, floats with up to 6 significant decimals; the write is atomic (`io.atomic_write`).
`read_mot` also accepts 6 to 9 columns (missing conf = 1, missing x, y, z = -1) and raises
`io.BadInput` naming the file and the line for anything else.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping

import numpy as np

from .atomic import atomic_write
from .errors import BadInput, PathLike


MOT_COLUMNS = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf", "x", "y", "z")
_DEFAULTS = {"conf": 1.0, "x": -1.0, "y": -1.0, "z": -1.0}


def _fmt(x: float) -> str:
    if not math.isfinite(x):
        raise ValueError(f"write_mot: non-finite value {x!r}")
    s = f"{x:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def write_mot(path: PathLike, cols: Mapping[str, np.ndarray]) -> None:
    """Write MOT rows (columns `MOT_COLUMNS`; conf, x, y, z default as in `read_mot` when
    absent) sorted by (frame, id), atomically."""
    n = len(cols["frame"])
    arr = {}
    for c in MOT_COLUMNS:
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
            f.write(",".join(vals) + "\n")


def read_mot(path: PathLike) -> dict[str, np.ndarray]:
    """Read a MOT text file into columns (frame, id int64; the rest float64). Blank lines are
    skipped; a row with fewer than 6 or more than 10 fields, a non-number, a non-integer or
    < 1 frame or id, a non-finite or negative box size raises `BadInput` (file and line)."""
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
        if not 6 <= len(parts) <= 10:
            raise BadInput(p, f"expected 6 to 10 comma-separated fields, got {len(parts)}",
                           line=k)
        vals = []
        for c, s in zip(MOT_COLUMNS, parts):
            try:
                x = float(s)
            except ValueError:
                raise BadInput(p, f"{s!r} is not a number", line=k, column=c) from None
            if c in ("frame", "id") and (not math.isfinite(x) or x != int(x) or x < 1):
                raise BadInput(p, f"{s!r} is not an integer >= 1", line=k, column=c)
            if c in ("bb_width", "bb_height") and not (math.isfinite(x) and x >= 0):
                raise BadInput(p, f"{s!r} is not a finite size >= 0", line=k, column=c)
            vals.append(x)
        vals += [_DEFAULTS[c] for c in MOT_COLUMNS[len(vals):]]
        rows.append(vals)
    a = np.asarray(rows, np.float64).reshape(-1, len(MOT_COLUMNS))
    out = {c: a[:, i] for i, c in enumerate(MOT_COLUMNS)}
    out["frame"] = out["frame"].astype(np.int64)
    out["id"] = out["id"].astype(np.int64)
    return out
