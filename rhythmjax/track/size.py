"""A judged track's size against a walker's (rule 26, issue 16; `options.SizeOptions`, on by
default since the thirty-first round).

A trotting dog whose leg cycle, aliased, falls inside the walking model (14) passes (13)-(15);
its height would refuse it. Each measured row of a track has its foot point (u, v) px and the
top row v_top px of its moving region (the head), so the row's height is that of the upright
segment standing on the foot point's ground point whose top is seen at v_top
(`camera_np.height_of_top`, (3) solved for the height). Only rows where a walker's head would
be inside the image count (`median_height`). A track judged Pedestrian whose median height, over
at least `min_height_rows` such rows, is below `min_height_heights` walker heights is
Non-pedestrian with reason too-low; every other verdict stands (the paper's (13)-(15) decide
them). The rows read are those of the deciding rhythm window (rule 26c, `min_height_scope`
"window"): a track that re-acquisition or a crossing carried onto another object after its
verdict keeps the height of the object the verdict was judged on. With "window-or-track" (rule
26f, off) a window with too few readable rows is read over the whole track instead (a far dog
whose window rows are those where a walker's head would leave the image). With rule 36
(`top_inside_heights` > 0, on since the thirty-eighth round) such a row also counts where the
measured top lies inside the image by that many walker heights: the object's own top is seen
there, and a walker's would be the image's edge (a dog near the top of the view, whose rows rule
26 cannot read)."""

from __future__ import annotations

import math

import numpy as np

from ..model.camera_np import camera_tuple, height_of_top, upright_size
from ..model.params import Camera, Config, host_float
from ..model.status import Reason, Verdict
from .options import SizeOptions


__all__ = ["batch_size_look", "median_height", "refuse_low", "row_heights", "rows_height",
           "too_low"]


def median_height(camera: Camera | tuple, u, v, v_top, walker_height_m: float,
                  top_inside_heights: float = 0.0) -> tuple[float, int]:
    """(median height m, rows it is taken over) of a track's rows: foot points (u, v) px and
    top rows v_top px (NaN where not measured). Only rows where a walker `walker_height_m` m
    tall standing on the foot point would have its top inside the image (row >= 0, through
    the camera: `camera_np.upright_size`) count: elsewhere a walker's measured top is the
    image's edge or a part below its head, too low, and a height is read for nothing. Rows
    with a non-finite value, a foot point not on the ground in front of the camera or a top
    at or beyond the vertical vanishing point are left out too; (NaN, 0) when none is left.
    `top_inside_heights` > 0 (rule 36): a row where the walker's head would leave the image
    counts too when its top row v_top >= `top_inside_heights` x the walker's height in px
    there (its height then reads below a walker's: v - v_top < v < the walker's px)."""
    H, read = row_heights(camera, u, v, v_top, walker_height_m, top_inside_heights)
    H = H[read]
    return (float(np.median(H)) if H.size else math.nan), int(H.size)


def row_heights(camera: Camera | tuple, u, v, v_top, walker_height_m: float,
                top_inside_heights: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Per row, (height m, read): the height of `median_height` and whether that reads it
    (its rows: the same arguments and rules)."""
    u, v, v_top = (np.asarray(q, np.float64) for q in (u, v, v_top))
    _, walker_px, seen = upright_size(camera, u, v, 1.0, walker_height_m)
    with np.errstate(invalid="ignore"):
        head_in = v - walker_px >= 0
        if top_inside_heights > 0:
            head_in = head_in | (v_top >= top_inside_heights * walker_px)
        seen = seen & head_in
    H, ok = height_of_top(camera, u, v, v_top)
    return np.asarray(H, np.float64), np.asarray(ok) & seen


def too_low(verdict: int, height_m: float, rows: int, walker_height_m: float,
            options: SizeOptions) -> bool:
    """True where rule 26 turns a track's `verdict` (`status.Verdict`) to Non-pedestrian: it
    is Pedestrian, the rule is on, the median height `height_m` (m) is taken over at least
    `options.min_height_rows` rows and lies below `options.min_height_heights` walker heights
    of `walker_height_m` m."""
    return (options.min_height_heights > 0 and int(verdict) == Verdict.PEDESTRIAN
            and rows >= options.min_height_rows and math.isfinite(height_m)
            and height_m < options.min_height_heights * walker_height_m)


def rows_height(camera: Camera | tuple, rows: list, walker_height_m: float,
                top_inside: float) -> tuple[float, int]:
    """`median_height` of `rows` (`rows.TrackRow`: u, v, v_top), rule 36's `top_inside`."""
    cols = np.asarray([(r.u, r.v, r.v_top) for r in rows], np.float64).reshape(-1, 3)
    return median_height(camera, cols[:, 0], cols[:, 1], cols[:, 2], walker_height_m,
                         top_inside)


def refuse_low(result: dict, camera: Camera | tuple, rows: list, walker_height_m: float,
               options: SizeOptions) -> dict:
    """`result` (a track's deciding window's outcome: `toolkit.RESULT_FIELDS`, with its
    "window" (first, end) row indices) with verdict Non-pedestrian and reason too-low where
    `too_low` says so for the track's `rows` (`rows.TrackRow`: u, v, v_top): those of the
    deciding window with `options.min_height_scope` "window" (every row when the result names
    none), all of them with "track", the window's and where fewer than
    `options.min_height_rows` of them are readable every row with "window-or-track" (rule 26f);
    `result` itself otherwise (nothing computed when off)."""
    if options.min_height_heights <= 0 or int(result["verdict"]) != Verdict.PEDESTRIAN:
        return result
    top = options.top_inside_heights
    if options.min_height_scope != "track" and "window" in result:
        first, end = result["window"]
        height, n = rows_height(camera, rows[first:end], walker_height_m, top)
        if options.min_height_scope == "window-or-track" and n < options.min_height_rows:
            height, n = rows_height(camera, rows, walker_height_m, top)  # rule 26f: the track's
    else:
        height, n = rows_height(camera, rows, walker_height_m, top)
    if not too_low(int(result["verdict"]), height, n, walker_height_m, options):
        return result
    return {**result, "verdict": int(Verdict.NON_PEDESTRIAN), "reason": int(Reason.TOO_LOW)}


def batch_size_look(cfg: Config, batch, options: SizeOptions, then=None):
    """`model.batch.classify_tracks`' `second_look` that applies rule 26 to every window it
    classifies (`batch`: a `TrackBatch` with top rows `v_top`; window w holds rows start[w] ..
    start[w] + N - 1 of track track[w]): after `then` (another look, e.g. rule 37's
    `twice.batch_second_look`, or None), a window judged Pedestrian whose rows' `median_height`
    (rule 36's rows with `options.top_inside_heights`) is below `options.min_height_heights`
    walker heights over at least `options.min_height_rows` rows is Non-pedestrian, reason
    too-low. Each window is read on its own rows (the tracker's scope "window", rule 26c, for
    each window rather than the deciding one only; `twice` False, rule 50b's windows moved
    across, is handed to `then`). `then` itself when rule 26 is off
    (`min_height_heights` 0) or the batch has no `v_top`."""
    if options.min_height_heights <= 0 or getattr(batch, "v_top", None) is None:
        return then
    camera = camera_tuple(cfg.camera)
    walker_m = host_float(cfg.width.height)
    n = int(cfg.thresholds.n)

    def look(res: dict, track: np.ndarray, start: np.ndarray, twice: bool = True) -> dict:
        if then is not None:
            res = then(res, track, start, twice=twice)
        verdict = np.atleast_1d(np.asarray(res["verdict"]))
        ped = np.flatnonzero(verdict == Verdict.PEDESTRIAN)
        if not ped.size:
            return res
        tr = np.asarray(track)[ped, None]
        rows = np.asarray(start)[ped, None] + np.arange(n)  # (windows, N) batch rows
        H, read = row_heights(camera, batch.z[tr, rows, 0], batch.z[tr, rows, 1],
                              batch.v_top[tr, rows], walker_m, options.top_inside_heights)
        count = read.sum(axis=1)
        height = np.full(len(ped), np.nan)  # a window with no row read: never too low
        some = count > 0
        height[some] = np.nanmedian(np.where(read[some], H[some], np.nan), axis=1)
        low = np.zeros(len(verdict), bool)
        low[ped] = (count >= options.min_height_rows) & np.isfinite(height) & \
            (height < options.min_height_heights * walker_m)  # `too_low` on each window
        if not low.any():
            return res
        out = dict(res)
        for key, value in (("verdict", int(Verdict.NON_PEDESTRIAN)),
                           ("reason", int(Reason.TOO_LOW))):
            old = np.asarray(res[key])
            out[key] = np.where(low, value, np.atleast_1d(old)).astype(old.dtype) \
                .reshape(old.shape)
        return out

    return look
