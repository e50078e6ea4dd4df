"""Window B and the rhythm signal I(k), Sec. 4.1 of the rhythm paper, and the walker width W
(px) of (3) that sizes it; split from `vision.detect` (which re-exports them).

Image coordinates are px: u = column index, v = row index (downwards), pixel centres at
integers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import jax
import numpy as np

from ..model.camera import ground_from_image, image_width
from ..model.params import Camera, WidthModel


Number = float | int | np.floating | np.integer  # a px coordinate or size


def window_b_rect(shape: tuple[int, ...], u_p: Number, v_p: Number, W: Number
                  ) -> tuple[int, int, int, int]:
    """Window B as (x0, y0, x1, y1) px, half-open and clipped to an image of `shape` (H, W).

    Wb = max(1, round(W)) columns centred on u_p: x0 = floor(u_p - Wb / 2 + 0.5), x1 = x0 + Wb.
    Hb = max(1, round(W / 5)) rows ending AT the foot row v_p (included), i.e. just above and
    including the object's bottom: y1 = floor(v_p + 0.5) + 1, y0 = y1 - Hb.
    Here round(x) = floor(x + 0.5)."""
    wb = max(1, math.floor(W + 0.5))
    hb = max(1, math.floor(W / 5 + 0.5))
    x0 = math.floor(u_p - wb / 2 + 0.5)
    y1 = math.floor(v_p + 0.5) + 1
    return max(x0, 0), max(y1 - hb, 0), min(x0 + wb, shape[1]), min(y1, shape[0])


def window_b_intensity(absdiff: np.ndarray, u_p: Number, v_p: Number, W: Number, *,
                       mean: bool = False) -> float:
    """The rhythm signal I(k) (Sec. 4.1): the sum of the absolute difference D (grey levels) over
    window B (`window_b_rect`: W px wide, W/5 px high, bottom row at the foot row v_p), clipped at
    the image borders. `mean=True` divides by the number of pixels of the clipped window (grey
    levels per pixel). NaN if u_p, v_p or W is not finite or W <= 0; 0 if B lies outside the
    image."""
    if not (math.isfinite(u_p) and math.isfinite(v_p) and math.isfinite(W)) or W <= 0:
        return math.nan
    x0, y0, x1, y1 = window_b_rect(absdiff.shape, u_p, v_p, W)
    if x1 <= x0 or y1 <= y0:
        return 0.0
    s = float(cv2.sumElems(absdiff[y0:y1, x0:x1])[0])
    return s / ((x1 - x0) * (y1 - y0)) if mean else s


def window_b_candidates(absdiff: np.ndarray, u_p: Number, v_p: Number, W: Number,
                        offsets: Sequence[float], *, mean: bool = False) -> tuple[float, ...]:
    """The rhythm signal I(k) (grey levels) of window B moved vertically, once per offset:
    `window_b_intensity(absdiff, u_p, v_p + offset * W, W)`, i.e. the same W x W/5 px window
    with its bottom row `offset` walker widths W (px) below the foot row v_p (negative: above;
    -0.1 moves it up by W/10 px), u_p and W unchanged. Used for the candidate windows B of
    issue 16 (`io.files.WINDOW_CANDIDATES`). The NaN rules of `window_b_intensity`: every value
    NaN if u_p, v_p or W is not finite or W <= 0; 0 for a moved window outside the image.
    `mean`: each the mean over its clipped window (grey levels per pixel), as there."""
    return tuple(window_b_intensity(absdiff, u_p, v_p + float(off) * W, W, mean=mean)
                 for off in offsets)


def window_b_across(absdiff: np.ndarray, u_p: Number, v_p: Number, W: Number,
                    offsets: Sequence[float], *, mean: bool = False) -> tuple[float, ...]:
    """Rule 50b's candidates: window B moved across its row, once per offset,
    `window_b_intensity(absdiff, u_p + offset * W, v_p, W)` (offset in walker widths W px,
    negative: left; `io.files.ACROSS_CANDIDATES`). NaN rules and `mean` as there."""
    return tuple(window_b_intensity(absdiff, u_p + float(off) * W, v_p, W, mean=mean)
                 for off in offsets)


def window_b_extras(absdiff: np.ndarray, u_p: Number, v_p: Number, W: Number,
                    offsets: Sequence[float], pace_scale: float, *,
                    mean: bool = False, across: Sequence[float] = ()) -> tuple[float, ...]:
    """The tracker's extra I(k) samples of a row (grey levels): the candidate windows B
    (`window_b_candidates` at `offsets`), then those moved across (`window_b_across` at
    `across`, rule 50b), then, where `pace_scale` > 0, the pace window of rule 34
    (`io.files.PACE_COLUMN`): window B scaled by `pace_scale` about the foot point, i.e.
    `pace_scale` W px wide and `pace_scale` W/5 px high with its bottom row at v_p
    (`window_b_intensity(absdiff, u_p, v_p, pace_scale * W)`). NaN rules as there; `mean`: per
    pixel, as there."""
    moved = window_b_candidates(absdiff, u_p, v_p, W, offsets, mean=mean) + \
        window_b_across(absdiff, u_p, v_p, W, across, mean=mean)
    if pace_scale <= 0:
        return moved
    return moved + (window_b_intensity(absdiff, u_p, v_p, pace_scale * W, mean=mean),)


def window_b_means(absdiff: np.ndarray | None, u_p: Number, v_p: Number, W: Number,
                   offsets: Sequence[float], pace_scale: float, sampled: bool = True,
                   across: Sequence[float] = ()) -> tuple[float, ...]:
    """Rule 35b's per-pixel samples of a tracked row (grey levels per pixel): window B's I(k)
    (`window_b_intensity(..., mean=True)`), then its extras' (`window_b_extras(..., mean=True)`:
    the candidate windows at `offsets`, those across at `across`, the pace window where
    `pace_scale` > 0). Every value NaN where not `sampled` (the row's I(k) is NaN) or `absdiff`
    is None, so that each is NaN exactly where I(k) is; else the NaN rules of
    `window_b_intensity`."""
    if absdiff is None or not sampled:
        return (math.nan,) * (1 + len(offsets) + len(across) + (pace_scale > 0))
    return ((window_b_intensity(absdiff, u_p, v_p, W, mean=True),)
            + window_b_extras(absdiff, u_p, v_p, W, offsets, pace_scale, mean=True,
                              across=across))


@jax.jit
def _walker_width(camera: Camera, width_m, u, v):
    _, y, ok = ground_from_image(camera, u, v)
    return image_width(camera, width_m, y), ok


def walker_width_px(camera: Camera, width_model: WidthModel, u: Number | np.ndarray,
                    v: Number | np.ndarray) -> float | np.ndarray:
    """W (px): the image width of the mean walker width `width_model.mean` (m) at the ground
    distance of the foot point (u, v) px, from the camera model (3). NaN on or above the horizon.
    Scalars give a float; arrays (one call for all objects of a frame) a float64 array."""
    uu, vv = np.asarray(u, np.float32), np.asarray(v, np.float32)
    w, ok = _walker_width(camera, width_model.mean, uu, vv)
    out = np.where(np.asarray(ok), np.asarray(w, np.float64), np.nan)
    return float(out) if out.ndim == 0 else out
