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
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..model.camera_np import project_3d
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
