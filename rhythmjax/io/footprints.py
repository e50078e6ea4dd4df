"""Footprints files: image foot points (u, v px) with their ground positions (x, y m), the input
of `rhythmjax-fit camera`. Read strictly; every problem is a `BadInput` naming the file and the
line (or row) and column."""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from .errors import BadInput, PathLike
from .tables import read_table


MAX_ABS_VALUE = 1e12  # larger magnitudes are refused (as for tracks files)
TYPES = {"u": "float", "v": "float", "x": "float", "y": "float", "track_id": "id",
         "frame": "int", "t": "float", "width_px": "float", "intensity": "float"}
FOOTPRINT_COLUMNS = ("u", "v", "x", "y")
OPTIONAL_FOOTPRINT_COLUMNS = ("track_id", "frame", "t", "width_px", "intensity")


@dataclass
class Footprints:
    """Validated rows of a footprints file, in file order: image foot points u, v (px) with
    their ground positions x, y (m; NaN = missing), and the optional track_id (text), frame
    (int64) and t (s). `line` is each row's source line (CSV, header = 1) or row (Parquet),
    named by `unit`; `notes` are remarks for the user (e.g. units that look like cm)."""

    path: str
    u: np.ndarray
    v: np.ndarray
    x: np.ndarray
    y: np.ndarray
    line: np.ndarray
    unit: str = "line"
    track_id: np.ndarray | None = None
    frame: np.ndarray | None = None
    t: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return int(self.u.shape[0])


def read_footprints(path: PathLike, *, fps: float | int | None = None) -> Footprints:
    """Read a footprints table (.csv/.parquet): columns u, v (px) and x, y (m) are required;
    track_id, frame, t, width_px and intensity are optional (width_px and intensity are read
    for their checks only) and other columns are ignored. Empty cells are NaN (the fit drops
    such rows). `fps` is accepted for symmetry with `read_tracks` and unused. Raises `BadInput`
    naming the file, the line (or row) and the column of the first bad cell."""
    p = os.fspath(path)
    tab = read_table(p, (), FOOTPRINT_COLUMNS + OPTIONAL_FOOTPRINT_COLUMNS, types=TYPES)
    for pair, what in ((("x", "y"), "ground position, m"), (("u", "v"), "image foot point, px")):
        if any(c not in tab for c in pair):
            raise BadInput(p, f"footprints need columns '{pair[0]}' and '{pair[1]}' ({what}); "
                           f"columns it knows found: {', '.join(tab) or 'none'}")
    for c in FOOTPRINT_COLUMNS + ("t", "width_px", "intensity"):
        a = tab.get(c)
        i = None if a is None else _first(np.isinf(a) | (np.abs(np.nan_to_num(a)) > MAX_ABS_VALUE))
        if i is not None:
            raise tab.where(p, i, c, f"{float(a[i])!r} is not a usable value (inf or |value| > "
                            "1e12); leave the cell empty for a missing value")
    u, v, x, y = (tab[c] for c in FOOTPRINT_COLUMNS)
    meas = np.isfinite(u) & np.isfinite(v)
    if meas.sum() > 3 and np.all((u[meas] >= 0) & (u[meas] <= 1) & (v[meas] >= 0)
                                 & (v[meas] <= 1)):
        raise BadInput(p, "u, v all lie in [0, 1]: looks normalised, expected pixels")
    notes = []
    r = np.hypot(x, y)
    r = r[np.isfinite(r)]
    if r.size and float(np.median(r)) > 300.0:
        notes.append(f"{p}: x, y (median distance {float(np.median(r)):.4g}) look like "
                     "centimetres; expected metres")
    tid = tab.get("track_id")
    return Footprints(path=p, u=u, v=v, x=x, y=y, line=tab.lines, unit=tab.unit,
                      track_id=None if tid is None else np.asarray(tid, dtype=object),
                      frame=tab.get("frame"), t=tab.get("t"), notes=notes)


def _first(mask: np.ndarray) -> int | None:
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None
