"""Where a track judged Pedestrian switched onto something faster than a walk (rule 28, issue
16; `options.SwitchOptions`, off by default).

Once a rhythm window has said Pedestrian the tracker stops matching windows (Sec. 4.2), so a
track that then follows a bicycle crossing its walker (after a short PREDICT stretch, or in the
crossing) carries the walker's verdict onto the bicycle. A walker does not go faster than the
walking model (14) allows any rhythm (`params.walking_top_speed`, 2.57 m/s with Table 1); a
bicycle does. The switch is the first measured row k at which the track's measured foot
points, taken to the ground plane by inverse perspective (3), move faster than that over the
`window_s` s from k and not over the `window_s` s before k, each speed the least-squares slope
of x and y against time over at least `min_rows` measured rows (`switch_row`). The filter's own
velocity is too slow a witness: it takes about two seconds to turn round after a switch."""

from __future__ import annotations

import math

import numpy as np

from ..model.camera_np import ground_of_pixels
from ..model.params import Camera


__all__ = ["ground_track", "line_speed", "switch_row"]


def ground_track(camera: Camera | tuple, u, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y m, measured) of foot points (u, v) px through the camera's inverse perspective;
    measured is False (x = y = NaN) where a foot point is missing or not on the ground in front
    of the camera."""
    x, y, ok = ground_of_pixels(camera, np.asarray(u, np.float64), np.asarray(v, np.float64))
    ok = np.asarray(ok, bool)
    return np.where(ok, x, np.nan), np.where(ok, y, np.nan), ok


def line_speed(t, x, y) -> float:
    """The speed (m/s) of the least-squares lines of x and y (m) against t (s): |(dx/dt,
    dy/dt)|; NaN for fewer than two distinct times."""
    t, x, y = (np.asarray(q, np.float64) for q in (t, x, y))
    if t.size < 2:
        return math.nan
    tc = t - t.mean()
    s = float(tc @ tc)
    if not s > 0:
        return math.nan
    return math.hypot(float(tc @ (x - x.mean())) / s, float(tc @ (y - y.mean())) / s)


def switch_row(t, x, y, measured, top_speed: float, window_s: float, min_rows: int
               ) -> int | None:
    """The first row k (an index into the track's rows, times t s, ground points x, y m where
    `measured`) at which the measured points of [t_k, t_k + window_s) move faster than
    `top_speed` m/s and those of [t_k - window_s, t_k) do not, each with at least `min_rows`
    measured points (`line_speed`); None where there is none."""
    t = np.asarray(t, np.float64)
    m = np.asarray(measured, bool)
    idx = np.flatnonzero(m)
    tm, xm, ym = t[idx], np.asarray(x, np.float64)[idx], np.asarray(y, np.float64)[idx]
    eps = 1e-9  # s: rows on an exact grid of frames
    for j, k in enumerate(idx):
        lo = np.searchsorted(tm, tm[j] - window_s - eps, side="right")
        hi = np.searchsorted(tm, tm[j] + window_s - eps, side="left")
        if j - lo < min_rows or hi - j < min_rows:
            continue
        after = line_speed(tm[j:hi], xm[j:hi], ym[j:hi])
        if not after > top_speed:
            continue
        if line_speed(tm[lo:j], xm[lo:j], ym[lo:j]) <= top_speed:
            return int(k)
    return None
