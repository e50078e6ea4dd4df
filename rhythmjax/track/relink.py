"""Re-acquisition for the online tracker: a track that timed out in PREDICT (its object hidden
behind another, or its detections refused for longer than the Fig. 3 time-out) is kept for
`relink.within_s` seconds; a new object that appears where that track's last observed ground motion
puts it continues the old track (same id, its rows, its rhythm-window position) instead of
starting a new one. The frames in between become rows with no measurement and no rhythm sample
(NaN), which the window rules of `track.toolkit.match_window` treat as missing (at most a
quarter of N).

The gate is in the image, as the detector's errors are: the lost track's last OBSERVE ground
state (x, y m; vx, vy m/s) moved on at constant velocity for the gap and projected (3) must lie
within `gate_w` W across and `gate_h` walker heights (1.7 m) up or down of the new object's
foot point, the ellipse growing by `gate_per_s` per second of gap (W: walker width in pixels at
the new foot point).

The gate reads positions only, so a bicycle that appears where a lost walker's track was heading
continues it (issue 16, fifty-seventh round: 11 of 32 bicycles judged Pedestrian on the own
scenes). Rule 57 (`relink.side_rows`, on since that round) reads each relink's two sides when the
track ends: where the observed rows next to the gap move faster on either side than any walk
(14) accepts (`fast_gap`), the relink is undone. Re-acquisition is for walkers hidden in a
group, and a side faster than any walk is not a walker's.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..model.camera_np import project_3d
from ..model.params import Config, walking_top_speed
from ..model.status import TrackState
from .rows import TrackRow, Velocity


class Anchor(NamedTuple):
    """A lost track's last observed ground state: time t s, position (x, y) m, velocity
    (vx, vy) m/s."""

    t: float
    x: float
    y: float
    vx: float
    vy: float


def last_observed(rows: list[TrackRow], vel: list[Velocity]) -> Anchor | None:
    """The `Anchor` at a track's last OBSERVE row; None without one."""
    for r, v in zip(reversed(rows), reversed(vel)):
        if r.state == int(TrackState.OBSERVE) and all(
                math.isfinite(q) for q in (r.x_est, r.y_est, v.vx, v.vy)):
            return Anchor(float(r.t), float(r.x_est), float(r.y_est), float(v.vx), float(v.vy))
    return None


def gate_distance(camera, anchor, t: float, uv, W: float, *, gate_w: float, gate_h: float,
                  gate_per_s: float, height_per_W: float) -> float:
    """Misfit (<= 1: inside the gate) between a lost track moved on to time `t` from its
    `anchor` (`last_observed`) and a new foot point `uv` (px) where the walker width is W px."""
    t0, x, y, vx, vy = anchor
    gap = t - t0
    if not (gap >= 0 and W > 0 and math.isfinite(W)):
        return math.inf
    u, v = project_3d(camera, x + vx * gap, y + vy * gap, 0.0)
    d = math.hypot((float(u) - uv[0]) / (gate_w * W),
                   (float(v) - uv[1]) / (gate_h * height_per_W * W))
    return d / (1.0 + gate_per_s * gap)


def gap_rows(last: TrackRow, index: int, t: float, xy) -> list[TrackRow]:
    """Rows for the frames strictly between `last` (a track row) and frame `index` at time t:
    no measurement, no rhythm sample, time and ground position interpolated, state NONE."""
    i0, t0, x0, y0 = int(last.frame), float(last.t), float(last.x_est), float(last.y_est)
    n = index - i0
    out = []
    for i in range(i0 + 1, index):
        a = (i - i0) / n
        out.append(TrackRow(i, t0 + a * (t - t0), math.nan, math.nan, math.nan, math.nan,
                            x0 + a * (float(xy[0]) - x0), y0 + a * (float(xy[1]) - y0),
                            int(TrackState.NONE)))
    return out


def relink_gaps(rows: list[TrackRow]) -> list[tuple[int, int]]:
    """(first, end) row indices of each run of state-NONE rows (`gap_rows`) between two rows."""
    out, start = [], None
    for k, r in enumerate(rows):
        if r.state == int(TrackState.NONE):
            start = k if start is None else start
        elif start is not None:
            if start > 0:
                out.append((start, k))
            start = None
    return out


def side_speed(rows: list[TrackRow]) -> float:
    """Ground speed (m/s) of `rows`: |(vx, vy)| of the least-squares lines through the filter's
    positions x_est(t), y_est(t) (m); NaN with fewer than two distinct times."""
    t = np.asarray([r.t for r in rows], np.float64)
    xy = np.asarray([(r.x_est, r.y_est) for r in rows], np.float64).reshape(-1, 2)
    if len(t) < 2 or np.ptp(t) <= 0:
        return math.nan
    tc = t - t.mean()
    v = tc @ (xy - xy.mean(axis=0)) / (tc @ tc)
    return float(math.hypot(v[0], v[1]))


def fast_gap(rows: list[TrackRow], m: int, top_speed: float) -> tuple[int, int] | None:
    """Rule 57: the first relink gap (`relink_gaps`) with a side faster than `top_speed` m/s
    (`side_speed`) over its m observed rows (a finite u) nearest the gap: the last m before it or
    the first m after it; a side with fewer than m // 2 observed rows is not read. None where no
    gap has such a side."""
    seen = [k for k, r in enumerate(rows) if math.isfinite(r.u)]
    for g0, g1 in relink_gaps(rows):
        before = [rows[k] for k in seen if k < g0][-m:]
        after = [rows[k] for k in seen if k >= g1][:m]
        for side in (before, after):
            if len(side) >= max(2, m // 2) and side_speed(side) > top_speed:
                return g0, g1
    return None


def cut_rows(rows: list[TrackRow], m: int, top_speed: float) -> list[slice]:
    """Rule 57: the pieces (slices of `rows`) left when every fast relink (`fast_gap`, each read
    in the rows after the one before) is undone, its gap rows dropped; [slice(0, None)] where
    none is."""
    pieces, start = [], 0
    while (gap := fast_gap(rows[start:], m, top_speed)) is not None:
        pieces.append(slice(start, start + gap[0]))
        start += gap[1]
    return pieces + [slice(start, None)]


def undo_fast_relinks(cfg: Config, finished: list, fraction: float, judge_afresh) -> int:
    """Rule 57 at the tracks' end: each object of `finished` (the tracker's `_Object`s) with a
    fast relink (`cut_rows`, m = max(2, round(`fraction` N)) rows a side, the fastest walk (14)
    `params.walking_top_speed`) is replaced by its pieces, each judged afresh by
    `judge_afresh(obj, rows, track_id)` (which appends it to `finished`; the first piece keeps
    the track's id, track_id None: a new one). Returns the number of relinks undone (0 where
    `fraction` is 0: off)."""
    if fraction <= 0:
        return 0
    m = max(2, round(fraction * int(cfg.thresholds.n)))
    top, undone = walking_top_speed(cfg), 0
    for obj in list(finished):
        pieces = cut_rows(obj.rows, m, top)
        if len(pieces) > 1:
            finished.remove(obj)
            for i, rows in enumerate(pieces):
                judge_afresh(obj, rows, None if i else obj.track_id)
            undone += len(pieces) - 1
    return undone


def best_match(anchors: list, camera, t: float, uv, W: float, **gate) -> int:
    """Index into `anchors` (`last_observed` of each lost track; None: skipped) of the track
    whose gate misfit with the new foot point is smallest and at most 1; -1 when none is."""
    best, best_d = -1, 1.0
    for i, anchor in enumerate(anchors):
        if anchor is None:
            continue
        d = gate_distance(camera, anchor, t, np.asarray(uv, np.float64), W, **gate)
        if d <= best_d:
            best, best_d = i, d
    return best
