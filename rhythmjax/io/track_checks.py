"""Row checks of a tracks file (`files.validated_tracks`): per track, frames and times in order,
one label, plausible units; and the run helpers they share with `files` (rows grouped by track:
each track a run of equal keys)."""

from __future__ import annotations

import numpy as np

from .errors import BadInput


def first_true(mask: np.ndarray) -> int | None:
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def track_starts(tid: np.ndarray) -> np.ndarray:
    """Index of the first row of each track in rows grouped by track."""
    if len(tid) == 0:
        return np.zeros(0, np.int64)
    return np.flatnonzero(np.r_[True, tid[1:] != tid[:-1]])


def time_steps(tid: np.ndarray, frame: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Time per frame of each step between consecutive rows of a track (frames increasing)."""
    if len(tid) < 2:
        return np.zeros(0)
    same = (tid[1:] == tid[:-1]) & (np.diff(frame) > 0)
    return (np.diff(t)[same] / np.diff(frame)[same]).astype(np.float64)


def track_order(tid: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Stable permutation grouping rows by track (in order of first appearance), then by frame."""
    if len(tid) == 0:
        return np.zeros(0, np.int64)
    _, first, inverse = np.unique(tid.astype(str), return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return np.lexsort((frame, rank[inverse.reshape(-1)]))



def check_track_rows(p, unit, tid, key, frame, t, lines, labels, label_key) -> None:
    if len(tid) < 2:
        return
    same = key[1:] == key[:-1]
    dup = first_true(same & (frame[1:] == frame[:-1]))
    if dup is not None:
        a, b = sorted((int(lines[dup]), int(lines[dup + 1])))
        raise BadInput(p, f"frame {frame[dup]} appears twice ({unit}s {a} and {b})",
                       track_id=str(tid[dup]), line=b)
    k = first_true(same & (t[1:] <= t[:-1]))
    if k is not None:
        what = ("decreases" if t[k + 1] < t[k] else
                f"does not increase ({float(t[k])!r} s at frames {frame[k]} and {frame[k + 1]})")
        raise BadInput(p, f"t {what} at frame {frame[k + 1]} ({unit} {lines[k + 1]})",
                       track_id=str(tid[k]), line=int(lines[k + 1]), column="t")
    if labels is not None:
        k = first_true(same & (label_key[1:] != label_key[:-1]))
        if k is not None:
            raise BadInput(p, f"label changes from {labels[k]!r} to {labels[k + 1]!r} at frame "
                           f"{frame[k + 1]} ({unit} {lines[k + 1]})", track_id=str(tid[k]),
                           line=int(lines[k + 1]), column="label")


def check_track_units(p, unit, tid, key, col, lines, fps, notes) -> None:
    frame, t = col["frame"], col["t"]
    if len(t) >= 2:
        step = time_steps(key, frame, t)
        if step.size:
            med = float(np.median(step))
            ms = 300.0 < med * fps < 3000.0 if fps else med > 1.0
            if ms:
                expect = f"; at {fps:g} fps expect {1 / fps:.4g} s" if fps else ""
                raise BadInput(p, f"column 't' looks like milliseconds (median step {med:.4g} "
                               f"per frame{expect}); give seconds", column="t")
            if fps and not 0.5 < med * fps < 2.0:
                notes.append(f"{p}: median time step {med:.4g} s per frame disagrees with "
                             f"{fps:g} fps (expected {1 / fps:.4g} s)")
    starts = track_starts(key)
    if len(starts):
        u, v = col["u"], col["v"]
        meas = np.isfinite(u) & np.isfinite(v)
        unit01 = meas & (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1)
        n_meas = np.add.reduceat(meas.astype(np.int64), starts)
        n01 = np.add.reduceat(unit01.astype(np.int64), starts)
        b = first_true((n_meas > 3) & (n01 == n_meas))
        if b is not None:
            s = starts[b]
            raise BadInput(p, f"u, v all lie in [0, 1]: looks normalised, expected pixels "
                           f"({unit} {lines[s]})", track_id=str(tid[s]), line=int(lines[s]))
    if "x" in col and "y" in col:
        r = np.hypot(col["x"], col["y"])
        r = r[np.isfinite(r)]
        if r.size and float(np.median(r)) > 300.0:
            notes.append(f"{p}: x, y (median distance {float(np.median(r)):.4g}) look like "
                         "centimetres; expected metres")
