"""Undo the frame-difference union in the tracker's foot points, widths and top rows
(`fit_selfcal(..., frame_union=True)`, `rhythmjax-fit selfcal --frame-union`; off by default).

The tracker detects on the difference of successive frames, D = |I(k) - I(k-1)|
(`rhythmjax.vision.detect`), so the extent it slices is the union of the object at frame k-1 and
at frame k. With du1, dv1, dtop1 the object's displacement (px) from frame k-1 to frame k of its
foot column, foot row and head row, the row of frame k measures:

- the foot column u as the centre of the union's horizontal extent: u_k - du1 / 2;
- the foot row v as the union's lowest row: v_k + max(0, -dv1) (a receding walker, whose foot
  row decreases, keeps the previous frame's lower foot);
- the top row v_top as the union's highest row: top_k - max(0, dtop1) (an approaching walker's
  head of the previous frame is higher);
- the width as the union's: the walker's width + |du1| (the detector's own doc).

Self-calibration reads these as the walker's position at frame k; the offsets grow with the
image speed, so with the frame interval and the nearness of the walker, and differ between
receding and approaching walkers. On PETS09-S2L1 (7 fps) the tracker's foot rows lie a median
1.9 px below the annotated feet for walkers receding faster than 1.5 px per frame and 0.1-0.5 px
on approaching ones, as the union predicts (benchmarks/study_foot_bias.py; docs/selfcal.md).

The correction: per track, the image velocity of u, v and v_top (px per frame) on each row is the
slope of a least-squares line in time through the track's measured values within
`HALF_WINDOW_S` of the row (one walking cycle of about two steps at 2 Hz either side: the gait's
own bobbing averages out), times the frame interval 1 / fps; then u + du1 / 2, v + min(0, dv1),
v_top + max(0, dtop1), width - |du1| (missing where that is below `MIN_WIDTH_PX`). A row with
fewer than `MIN_POINTS` measured values in its window is left as it is. Nothing was chosen on
PETS: the model is the detector's, the window set a priori.
"""

from __future__ import annotations

import dataclasses

import numpy as np


HALF_WINDOW_S = 0.5  # s, the velocity's line is fitted over +-this around each row
MIN_POINTS = 3  # measured values in a row's window for its velocity
MIN_WIDTH_PX = 1.0  # px, a corrected width below this is made missing


def local_velocity(t: np.ndarray, y: np.ndarray, half_window_s: float = HALF_WINDOW_S
                   ) -> np.ndarray:
    """Per row, the slope (units of y per s) of the least-squares line through the finite values
    of `y` (n,) at times `t` (n,) s within `half_window_s` of the row's time; NaN where the
    window holds fewer than `MIN_POINTS` finite values or a single time."""
    t = np.asarray(t, np.float64)
    y = np.asarray(y, np.float64)
    ok = np.isfinite(y) & np.isfinite(t)
    W = (np.abs(t[:, None] - t[None, :]) <= half_window_s + 1e-9) & ok[None, :]
    n = W.sum(1)
    tt, yy = np.where(ok, t, 0.0), np.where(ok, y, 0.0)
    st, sy = W @ tt, W @ yy
    stt, sty = W @ (tt * tt), W @ (tt * yy)
    den = n * stt - st * st
    good = (n >= MIN_POINTS) & (den > 1e-12 * np.maximum(n * stt, 1e-30))
    return np.where(good, (n * sty - st * sy) / np.where(good, den, 1.0), np.nan)


def undo_union_track(t, u, v, width, top, fps: float,
                     half_window_s: float = HALF_WINDOW_S) -> tuple[np.ndarray, ...]:
    """(u, v, width, top) px of one track's rows with the union undone (module doc); `t` s,
    `fps` the video's frame rate (frames per s: the frame difference's interval). Missing
    values stay missing; rows without a velocity are left as they are."""
    dt = 1.0 / float(fps)
    vel = lambda y: local_velocity(t, y, half_window_s) * dt  # noqa: E731
    du1, dv1 = vel(u), vel(v)
    u2 = np.where(np.isfinite(du1), u + 0.5 * du1, u)
    v2 = np.where(np.isfinite(dv1), v + np.minimum(0.0, dv1), v)
    w2 = np.where(np.isfinite(du1), width - np.abs(du1), width)
    w2 = np.where(w2 >= MIN_WIDTH_PX, w2, np.where(np.isfinite(width), np.nan, width))
    top2 = top
    if top is not None:
        dt1 = vel(top)
        top2 = np.where(np.isfinite(dt1), top + np.maximum(0.0, dt1), top)
    return u2, v2, w2, top2


def undo_union(batch, fps: float, half_window_s: float = HALF_WINDOW_S):
    """(a `rhythmjax.io.TrackBatch` with every track's foot points z, widths and top rows
    corrected (`undo_union_track`, rows whose foot point is measured; the head columns u_top,
    the foot column plus the silhouette's lean, move with u), the number of rows whose foot
    point moved). The intensity and times are kept."""
    z = np.array(batch.z, np.float64)
    width = np.array(batch.width, np.float64)
    top = None if batch.v_top is None else np.array(batch.v_top, np.float64)
    head = None if batch.u_top is None else np.array(batch.u_top, np.float64)
    t = np.asarray(batch.t, np.float64)
    seen = np.asarray(batch.present) & np.all(np.isfinite(z), -1)
    moved = 0
    for b in range(z.shape[0]):
        i = np.flatnonzero(seen[b])
        if i.size < MIN_POINTS:
            continue
        u2, v2, w2, t2 = undo_union_track(t[b, i], z[b, i, 0], z[b, i, 1], width[b, i],
                                          None if top is None else top[b, i], fps,
                                          half_window_s)
        moved += int(np.sum((u2 != z[b, i, 0]) | (v2 != z[b, i, 1])))
        if head is not None:  # u_top is u plus the lean: it moves with u
            head[b, i] += u2 - z[b, i, 0]
        z[b, i, 0], z[b, i, 1], width[b, i] = u2, v2, w2
        if top is not None:
            top[b, i] = t2
    cast = lambda a, like: a.astype(np.asarray(like).dtype)  # noqa: E731
    return dataclasses.replace(
        batch, z=cast(z, batch.z), width=cast(width, batch.width),
        v_top=None if top is None else cast(top, batch.v_top),
        u_top=None if head is None else cast(head, batch.u_top)), moved
