"""What a track judged Pedestrian must also show (rules 26, 27; issue 16; `options.JudgedOptions`).

Rule 26, its size against a walker's.

A trotting dog whose leg cycle, aliased, falls inside the walking model (14) passes (13)-(15);
its height would refuse it. Each measured row of a track has its foot point (u, v) px and the
top row v_top px of its moving region (the head), so the row's height is that of the upright
segment standing on the foot point's ground point whose top is seen at v_top
(`camera_np.height_of_top`, (3) solved for the height). A track judged Pedestrian whose median
height, over at least `min_height_rows` such rows, is below `min_height_heights` walker heights
is Non-pedestrian with reason too-low; every other verdict stands (the paper's (13)-(15) decide
them).

Rule 27, its speed after the verdict. Once a window has said Pedestrian the rhythm is no longer
matched, and a track that then switches to a bicycle crossing its walker carries the walker's
verdict onto the bicycle. A walker never keeps up more than the fastest walk the walking model
(14) accepts (`params.walking_top_speed`, 2.57 m/s with Table 1), so a judged track whose
filter speed stays above it for `outrun_s` s ends there (`outran`)."""

from __future__ import annotations

import math

import numpy as np

from ..model.camera_np import height_of_top
from ..model.params import Camera
from ..model.status import Reason, Verdict
from .options import JudgedOptions


__all__ = ["fast_since", "median_height", "outran", "refuse_low", "too_low"]


def median_height(camera: Camera | tuple, u, v, v_top) -> tuple[float, int]:
    """(median height m, rows it is taken over) of a track's rows: foot points (u, v) px and
    top rows v_top px (NaN where not measured). Rows with a non-finite value, a foot point
    not on the ground in front of the camera or a top at or beyond the vertical vanishing
    point are left out; (NaN, 0) when none is left."""
    H, ok = height_of_top(camera, np.asarray(u, np.float64), np.asarray(v, np.float64),
                          np.asarray(v_top, np.float64))
    H = np.asarray(H)[np.asarray(ok)]
    return (float(np.median(H)) if H.size else math.nan), int(H.size)


def too_low(verdict: int, height_m: float, rows: int, walker_height_m: float,
            options: JudgedOptions) -> bool:
    """True where rule 26 turns a track's `verdict` (`status.Verdict`) to Non-pedestrian: it
    is Pedestrian, the rule is on, the median height `height_m` (m) is taken over at least
    `options.min_height_rows` rows and lies below `options.min_height_heights` walker heights
    of `walker_height_m` m."""
    return (options.min_height_heights > 0 and int(verdict) == Verdict.PEDESTRIAN
            and rows >= options.min_height_rows and math.isfinite(height_m)
            and height_m < options.min_height_heights * walker_height_m)


def refuse_low(result: dict, camera: Camera | tuple, rows: list, walker_height_m: float,
               options: JudgedOptions) -> dict:
    """`result` (a track's deciding window's outcome: `toolkit.RESULT_FIELDS`) with verdict
    Non-pedestrian and reason too-low where `too_low` says so for the track's `rows`
    (`rows.TrackRow`: u, v, v_top); `result` itself otherwise (nothing computed when off)."""
    if options.min_height_heights <= 0 or int(result["verdict"]) != Verdict.PEDESTRIAN:
        return result
    cols = np.asarray([(r.u, r.v, r.v_top) for r in rows], np.float64).reshape(-1, 3)
    height, n = median_height(camera, cols[:, 0], cols[:, 1], cols[:, 2])
    if not too_low(int(result["verdict"]), height, n, walker_height_m, options):
        return result
    return {**result, "verdict": int(Verdict.NON_PEDESTRIAN), "reason": int(Reason.TOO_LOW)}


def fast_since(since: float, t: float, speed: float, top: float) -> float:
    """The time (s) the current run of rows faster than `top` (m/s) began, after a row at time
    `t` (s) with filter speed `speed` (m/s): `since`, or `t` when this row starts the run;
    NaN when this row is not faster (or its speed is not finite)."""
    if not speed > top:
        return math.nan
    return t if math.isnan(since) else since


def outran(since: float, t: float, options: JudgedOptions) -> bool:
    """True where rule 27 ends a judged track whose run of fast rows began at `since` (s,
    `fast_since`; NaN: none) and whose last row is at `t` (s): the rule is on and the run has
    lasted `options.outrun_s` s (1e-9 s of rounding allowed)."""
    return options.outrun_s > 0 and not math.isnan(since) and t - since >= options.outrun_s - 1e-9
