"""The tracker's output tables: tracks (ARCHITECTURE.md's format plus the filter's ground
estimate, the state and, where the tracker sampled them, the candidate and pace windows' I(k)) and
verdicts, one row per track, from the tracker's objects."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..io.files import ACROSS_COLUMNS, CANDIDATE_COLUMNS, PACE_COLUMN
from ..model.status import REASON_LABELS, VERDICT_LABELS, Reason, TrackState, Verdict
from .rows import TrackRow


TRACK_COLUMNS = ["track_id", *TrackRow._fields]  # track_id, then the fields of a `TrackRow`


def candidate_columns(columns) -> list[str]:
    """The candidate-window columns (`io.files.CANDIDATE_COLUMNS`, `ACROSS_COLUMNS`, then
    `PACE_COLUMN`) that `columns` (a mapping of tracks columns) holds, in their order: what a
    writer appends to its column order."""
    return [c for c in (*CANDIDATE_COLUMNS, *ACROSS_COLUMNS, PACE_COLUMN) if c in columns]


def tracks_columns(objs: list, *, candidates: bool | None = None, pace: bool = False,
                   across: bool = False) -> dict[str, np.ndarray]:
    """The tracks format (ARCHITECTURE.md) plus the filter's ground estimate and the state, from
    objects with a track_id and rows (`TrackRow`). `candidates`: also the candidate windows'
    I(k) (grey levels; float64 columns `io.files.CANDIDATE_COLUMNS`) from each object's
    `candidate_rows` (one tuple per row, that order); None: where the objects have them.
    `across`: rule 50b's windows' I(k) too (`io.files.ACROSS_COLUMNS`, after the candidates').
    `pace`: the pace window's I(k) too (`io.files.PACE_COLUMN`, each tuple's last entry)."""
    rows = [(o.track_id, *r) for o in objs for r in o.rows]
    cols = list(zip(*rows)) if rows else [[] for _ in TRACK_COLUMNS]
    out = {k: np.asarray(c) for k, c in zip(TRACK_COLUMNS, cols)}
    out["track_id"] = out["track_id"].astype(np.int64)
    out["frame"] = out["frame"].astype(np.int64)
    out["state"] = np.asarray([TrackState(int(s)).name.lower() for s in out["state"]],
                              dtype=object)
    for k in ("t", "u", "v", "width_px", "intensity", "x_est", "y_est", "v_top", "top_at_edge"):
        out[k] = out[k].astype(np.float64)  # top_at_edge: 1/0, the tracks format's float
    if candidates is None:
        candidates = any(getattr(o, "candidate_rows", None) is not None for o in objs)
    names = (*(CANDIDATE_COLUMNS if candidates else ()), *(ACROSS_COLUMNS if across else ()),
             *((PACE_COLUMN,) if pace else ()))
    if names:
        out.update(candidate_table(objs, names))
    return out


def candidate_table(objs: list, names: Sequence[str] = CANDIDATE_COLUMNS
                    ) -> dict[str, np.ndarray]:
    """The candidate windows' I(k) (grey levels; float64 columns `names`, by default
    `io.files.CANDIDATE_COLUMNS`) of objects' rows in order, from each object's `candidate_rows`
    (one tuple per row, in that order). Raises ValueError naming the track when an object has
    none or too few."""
    for o in objs:
        if o.candidate_rows is None or len(o.candidate_rows) != len(o.rows):
            n = None if o.candidate_rows is None else len(o.candidate_rows)
            raise ValueError(f"track {o.track_id}: candidate windows' I(k) for {n} of its "
                             f"{len(o.rows)} rows")
        if any(len(c) != len(names) for c in o.candidate_rows):
            raise ValueError(f"track {o.track_id}: candidate windows' I(k) not one per column "
                             f"of {', '.join(names)}")
    values = np.asarray([c for o in objs for c in o.candidate_rows], np.float64)
    values = values.reshape(-1, len(names))
    return {name: values[:, j].copy() for j, name in enumerate(names)}


def verdict_columns(objs: list, n: int) -> dict[str, np.ndarray]:
    """One row per track, the columns of the verdicts format."""
    cols: dict[str, list] = {k: [] for k in ("track_id", "verdict", "reason", "pace_hz",
                                             "stride_m", "ratio", "speed_mps", "n_samples")}
    for o in objs:
        r = o.result
        cols["track_id"].append(o.track_id)
        cols["n_samples"].append(len(o.rows))
        if r is None:
            cols["verdict"].append(VERDICT_LABELS[Verdict.UNCLASSIFIED])
            cols["reason"].append(REASON_LABELS[Reason.TOO_SHORT])
            for k in ("pace_hz", "stride_m", "ratio", "speed_mps"):
                cols[k].append(math.nan)
            continue
        cols["verdict"].append(VERDICT_LABELS[int(r["verdict"])])
        cols["reason"].append(REASON_LABELS[int(r["reason"])])
        for k in ("pace_hz", "stride_m", "ratio", "speed_mps"):
            cols[k].append(float(r[k]))
    return {k: np.asarray(v, dtype=object if k in ("verdict", "reason") else None)
            for k, v in cols.items()}
