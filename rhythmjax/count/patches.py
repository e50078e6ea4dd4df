"""Pedestrians level of Masoud & Papanikolopoulos: the patch model and its placement.

Pedestrian model (PAPERS.md, "Multi-pedestrian paper", part 3): a rectangular patch standing on
its foot point (u, v) px (bottom centre). Its size is the image of an average pedestrian
`width_m` wide (default: the config's `width.mean`, 0.5 m) and `height_m` tall (1.7 m):

    3-D shape ("3d-shape", "3d"): at the foot point's ground point (x, y) of (3) with roll,
        w = a f width_m cos(roll) / depth(y)        (the width at the feet along the rows, px)
        h = v - v_top, v_top = the row of (x, y, height_m) (`camera.upright_size_with`: (3)
            with h replaced by h - height_m; the head is nearer the image plane); with roll
            the size depends on the foot point's column as well as its row;
    2-D shape ("2d"): one fixed size, that of the average pedestrian at x = 0 and the middle
        of the detection range (range_min + range_max) / 2 ("near the middle of the scene").

Dynamics (equation (1); "2d" and "3d-shape" in the image, "3d" on the ground plane, the core's
EKF) are in `slot_filter`; `DYNAMICS` names them here, where the shape model is chosen by them.

Placement ("Calculating pedestrian positions"): `place_patch` moves the patch horizontally around
its predicted foot point to cover as many pixels of its related blobs as it can (an integral
image gives each candidate's covered count), with the foot row at the lowest related pixel under
the patch; ties go to the candidate nearest the prediction.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..model.camera import Terms, upright_size_with
from ..model.camera_np import (
    SCALAR,
    HostCamera,
    camera_tuple,
    ground_of_pixels,
    host_terms,
    project_3d,
    upright_size,
)
from ..model.params import Camera, Config, host_float


DYNAMICS = ("2d", "3d-shape", "3d")
_SCALARS = (float, int, np.float64)  # ShapeModel.size: types taken as scalars without np.ndim


# ----------------------------------------------------------------------------------------------
# shape (host float64: the camera's one set of formulas, `camera.*_with`)


def ground_point(camera: Camera | tuple, u, v):
    """Inverse of (3) with roll in NumPy float64: ground (x, y) m of the foot point (u, v) px,
    and `ok` (below the horizon, in front of the camera); x = y = 0 where not ok."""
    return ground_of_pixels(camera, u, v)


def patch_size_3d(camera: Camera | tuple, u, v, width_m: float, height_m: float):
    """3-D shape: (w, h) px of a pedestrian `width_m` wide and `height_m` tall (m; the config's
    `width.mean`, `width.height`) standing at the foot point (u, v) px, and
    `ok`; NaN where the foot point has no ground point or the head is behind the camera. w is
    the width at the feet along the rows, h = v - the head's row (`camera.upright_size_with`)."""
    return upright_size(camera, u, v, width_m, height_m)


def middle_foot_point(cfg: Config) -> tuple[float, float]:
    """Foot point (u, v) px of x = 0, y = middle of the detection range: the 2-D shape's place."""
    y = 0.5 * (float(cfg.thresholds.range_min) + float(cfg.thresholds.range_max))
    u, v = project_3d(cfg.camera, 0.0, y, 0.0)
    return float(u), float(v)


@dataclass(frozen=True)
class ShapeModel:
    """Patch size as a function of the foot point: 3-D (per place) or 2-D (fixed)."""

    camera: HostCamera  # host floats, roll included (`camera_tuple`)
    width_m: float
    height_m: float
    fixed: tuple[float, float] | None = None  # (w, h) px for the 2-D shape

    @classmethod
    def from_config(cls, cfg: Config, dynamics: str):
        """The patch model of `dynamics` for the config's camera and pedestrian size (width
        `width.mean`, height `width.height`, m)."""
        if dynamics not in DYNAMICS:
            raise ValueError(f"dynamics must be one of {DYNAMICS}, got {dynamics!r}")
        width_m, height_m = host_float(cfg.width.mean), host_float(cfg.width.height)
        fixed = None
        if dynamics == "2d":
            w, h, _ = patch_size_3d(cfg.camera, *middle_foot_point(cfg), width_m, height_m)
            fixed = (float(w), float(h))
        return cls(camera_tuple(cfg.camera), width_m, height_m, fixed)

    def size(self, u, v):
        """(w, h) px arrays (NaN where the 3-D shape has no ground point); two floats for two
        scalars (`_size_scalar`, the same arithmetic without NumPy's per-call cost)."""
        if (type(u) in _SCALARS and type(v) in _SCALARS) or (np.ndim(u) == 0 and np.ndim(v) == 0):
            return self._size_scalar(float(u), float(v))
        if self.fixed is not None:
            ones = np.ones(np.broadcast(np.asarray(u), np.asarray(v)).shape)
            return self.fixed[0] * ones, self.fixed[1] * ones
        w, h, _ = patch_size_3d(self.camera, u, v, self.width_m, self.height_m)
        return w, h

    def row_sizes(self, n_rows: int) -> tuple[np.ndarray, np.ndarray]:
        """(w, h) px of a foot point at u = Uc on each image row 0 .. n_rows - 1 (read-only
        float64). Without roll the size depends on the row only (for any finite u), so the
        table serves every integer row; with roll it also depends on u (`foot_sizes`)."""
        return _row_sizes(self, int(n_rows))

    def foot_sizes(self, u, rows, n_rows: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(w, h, finite) at the foot points (u, rows) px, rows integers in [0, n_rows); NaN as
        0: from the row table where the size depends on the row only (roll 0, or the 2-D
        shape), else computed at each foot point (`size`)."""
        if self.fixed is not None or self.camera.roll == 0.0:
            return tuple(q[rows] for q in _row_table(self, int(n_rows)))
        w, h = self.size(np.asarray(u, np.float64), np.asarray(rows, np.float64))
        fin = np.isfinite(w) & np.isfinite(h)
        return np.where(fin, w, 0.0), np.where(fin, h, 0.0), fin

    def _size_scalar(self, u: float, v: float) -> tuple[float, float]:
        """`patch_size_3d` for one foot point: the same formulas on Python floats
        (`camera_np.SCALAR`), so the same float64 values without NumPy's per-call cost (called
        several times per pedestrian and frame)."""
        if self.fixed is not None:
            return self.fixed
        memo = self._memo  # a foot point is sized several times a frame (placement, boxes)
        size = memo.get((u, v))
        if size is None:
            if len(memo) >= _MEMO_SIZE:
                memo.clear()
            w, h, _ = upright_size_with(SCALAR, self._terms, u, v, self.width_m, self.height_m)
            size = memo[u, v] = (w, h)
        return size

    @functools.cached_property
    def _terms(self) -> Terms:
        return host_terms(self.camera)  # the camera's constants, once per model

    @functools.cached_property
    def _memo(self) -> dict[tuple[float, float], tuple[float, float]]:
        return {}  # (u, v) px -> (w, h) px of `_size_scalar`, at most _MEMO_SIZE entries


_MEMO_SIZE = 4096  # foot points remembered by a ShapeModel (then forgotten at once)
_AB_ADD = np.array([[0.5], [0.5], [1.5]])  # place_patch: rounding of a0, a1 and b0


@functools.lru_cache(maxsize=8)
def _row_table(shape: ShapeModel, n_rows: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`row_sizes` with NaN as 0, and where they were finite (`foot_sizes`)."""
    w, h = _row_sizes(shape, n_rows)
    fin = np.isfinite(w) & np.isfinite(h)
    return np.where(fin, w, 0.0), np.where(fin, h, 0.0), fin


@functools.lru_cache(maxsize=8)
def _row_sizes(shape: ShapeModel, n_rows: int) -> tuple[np.ndarray, np.ndarray]:
    v = np.arange(n_rows, dtype=np.float64)
    w, h = (np.array(np.broadcast_to(q, v.shape), np.float64)
            for q in shape.size(np.full(n_rows, shape.camera.uc), v))
    w.flags.writeable = h.flags.writeable = False
    return w, h


def patch_box(u: float, v: float, w: float, h: float) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1) px of the patch standing on (u, v), w wide and h tall."""
    return u - 0.5 * w, v - h, u + 0.5 * w, v


# ----------------------------------------------------------------------------------------------
# placement (NumPy / OpenCV)


_INT_MAX = {t: int(np.iinfo(t).max) for t in (np.uint8, np.uint16, np.uint32, np.int16, np.int32,
                                              np.int64)}


def related_mask(window: np.ndarray, related) -> np.ndarray:
    """(h, w) bool: pixels of the labels `window` whose label is in `related` (labels outside
    the window's dtype range match nothing); a few labels by equality, more by a lookup table."""
    top = _INT_MAX.get(window.dtype.type, math.inf)
    labs = [q for q in np.asarray(related, np.int64).ravel().tolist() if 0 <= q <= top]
    if len(labs) <= 4:  # Python ints: comparing with an int64 scalar would cast the window
        out = window == labs[0] if labs else np.zeros(window.shape, bool)
        for lab in labs[1:]:
            out |= window == lab
        return out
    lut = np.zeros(int(window.max(initial=0)) + 1, bool)  # label -> related (np.isin: 10x slower)
    lut[[q for q in labs if q < lut.size]] = True
    return lut[window]


def lowest_rows(mask: np.ndarray) -> np.ndarray:
    """Per column of a (h, w) 0/1 (or bool) image, the row of its lowest non-zero pixel (int64);
    -1 where the column is empty."""
    rows = mask.shape[0]
    weight = np.arange(1, rows + 1, dtype=np.uint16 if rows < 65535 else np.int64)[:, None]
    return np.multiply(mask, weight, dtype=weight.dtype).max(axis=0, initial=0).astype(
        np.int64) - 1


def range_max(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, fill) -> np.ndarray:
    """max(x[lo[k]:hi[k]]) for every k (0 <= lo, hi <= len(x)); `fill` where the range is
    empty. One `np.maximum.reduceat` over the interleaved bounds."""
    lo, hi = np.asarray(lo, np.intp), np.asarray(hi, np.intp)
    if lo.size == 0:
        return np.zeros(0, x.dtype)
    ext = np.empty(len(x) + 1, x.dtype)
    ext[:-1], ext[-1] = x, fill
    idx = np.empty(2 * lo.size, np.intp)
    idx[0::2], idx[1::2] = lo, hi
    got = np.maximum.reduceat(ext, idx)[::2]
    return np.where(hi > lo, got, fill)


def _clip_int(a: np.ndarray, hi: int) -> np.ndarray:
    return np.minimum(np.maximum(a, 0), hi)  # np.clip's wrappers cost more than the work


@dataclass(frozen=True)
class Placement:
    u: float  # foot point, px
    v: float
    w: float  # patch size at the foot point, px
    h: float
    covered: int  # related pixels inside the patch


def place_patch(labels: np.ndarray, related: np.ndarray, claimed: np.ndarray | None,
                shape: ShapeModel, pred_u: float, pred_v: float, *, radius_px: float,
                band: float = 0.35, v_max: float | None = None, min_cover: float = 0.08,
                bbox: tuple[int, int, int, int] | None = None) -> Placement | None:
    """Move the patch around the predicted foot point (pred_u, pred_v) to cover as many pixels of
    its related blobs as it can: pixels of `labels` (H, W int labels image) whose label is in
    `related`, and not `claimed` (H, W bool, pixels already taken by other patches; None: none).

    Candidates: every integer column offset within `radius_px`. For each, the foot row is the
    lowest related pixel in the patch's columns from `band` patch heights above pred_v down to
    `v_max` (px; None: `band` patch heights below pred_v); the
    covered count is an integral-image sum over the patch at that foot row (sized there). The
    best count wins (ties: nearest to the prediction); None if no candidate covers at least
    `min_cover` of its patch area. `bbox` (x0, y0, x1, y1 half-open px; None: unknown): a box
    holding every related pixel (their blobs' boxes); the search window is cut to it, which
    changes no count (no related pixel lies outside) and saves the work on the rest."""
    H, W = labels.shape
    w0, h0 = (float(q) for q in shape.size(pred_u, pred_v))
    if not (math.isfinite(w0) and math.isfinite(h0)) or w0 < 1 or h0 < 1:
        return None
    r = max(1, int(math.ceil(radius_px)))
    half = 0.5 * w0
    x0 = max(0, int(math.floor(pred_u - r - half - 1)))
    x1 = min(W, int(math.ceil(pred_u + r + half + 2)))
    ylo = max(0, int(math.floor(pred_v - band * h0)))
    yhi = min(H, int(math.ceil(pred_v + band * h0 if v_max is None else v_max)) + 1)
    if x1 <= x0 or yhi <= ylo:
        return None
    ytop = max(0, int(math.floor(pred_v - (1 + 2 * band) * h0)))
    if bbox is not None:  # cut to the related pixels' box (module doc: same placement)
        x0, x1 = max(x0, int(bbox[0])), min(x1, int(bbox[2]))
        ytop, yhi = max(ytop, int(bbox[1])), min(yhi, int(bbox[3]))
        ylo = max(ylo, ytop)
        if x1 <= x0 or yhi <= ylo:
            return None
    window = labels[ytop:yhi, x0:x1]
    crop = related_mask(window, related)
    if claimed is not None:
        crop &= ~claimed[ytop:yhi, x0:x1]
    crop = crop.view(np.uint8)
    ii = cv2.integral(crop)  # (rows + 1, cols + 1), int32
    if ii[-1, -1] == 0:
        return None
    off = ylo - ytop
    bottom = lowest_rows(crop[off:]) + off  # per column; off - 1 where none
    us = pred_u + np.arange(-r, r + 1, dtype=np.float64)
    n_cols = x1 - x0
    # each candidate's columns [c0, c1) = floor(us -/+ half + 0.5) - x0 (us - -half is us + half)
    c0, c1 = _clip_int(np.floor(np.subtract(us, [[half], [-half]]) + 0.5).astype(np.intp) - x0,
                       n_cols)
    # lowest related row under each candidate's columns: the max of the column bottoms over each
    # candidate's column range (-1 where the range is empty)
    vb = range_max(bottom, c0, c1, -1)
    ok = vb >= off
    if not ok.any():
        return None
    us, vb = us[ok], vb[ok]
    v = vb + float(ytop)
    w, h, fin = shape.foot_sizes(us, vb + ytop, H)  # the size at the foot point
    hw = 0.5 * w
    # the patch's columns [a0, a1) and top row b0, in window coordinates, clipped to it
    a0, a1, b0 = np.minimum(np.maximum(
        np.floor(np.stack([us - hw, us + hw, v - h]) + _AB_ADD).astype(np.intp)
        - np.array([[x0], [x0], [ytop]]), 0), np.array([[n_cols], [n_cols], [crop.shape[0]]]))
    b1 = vb + 1
    cov = ii[b1, a1] - ii[b0, a1] - ii[b1, a0] + ii[b0, a0]
    cov = np.where(fin & (a1 > a0) & (b1 > b0), cov, -1)
    good = cov >= min_cover * w * h
    if not good.any():
        return None
    # best covered count; ties to the candidate nearest the prediction
    key = np.where(good, cov, -1) - 1e-6 * np.abs(us - pred_u) / (r + 1)
    i = int(np.argmax(key))
    return Placement(float(us[i]), float(v[i]), float(w[i]), float(h[i]), int(cov[i]))
