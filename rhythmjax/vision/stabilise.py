"""Camera-shake compensation before the frame difference (issue 16 item 2, NumPy/OpenCV).

A camera that shakes by a pixel or two moves every edge of the background, so the absolute
difference D of two successive frames lights up along every edge, and the rhythm signal I(k)
(the sum of D in window B at the feet) picks up the shake instead of the legs. Here the global
translation of the current frame against the previous one is estimated and the previous frame
is shifted onto the current one before the difference, so D is in the current frame's pixel
coordinates and a static background cancels again.

The shift is the per-axis median of phase correlations (`cv2.phaseCorrelate`, Hann window) over
a grid of `tiles` x `tiles` tiles, each tile's estimate kept when its correlation peak response
is at least `min_response`: a walker covering a tile or two moves that tile's estimate, not the
median (on dev_walk_03, 2 px shake, one phase correlation over the whole 512 x 512 frame was
pulled up to 0.6 px by a near walker; the tile median stayed under 0.5 px). Shifts below
`min_shift_px` are taken as no shake and leave the previous frame untouched (the same array), so
a fixed camera gives bit-identical differences to no stabilisation. Larger shifts are refined by
Lucas-Kanade steps on the whole frame (`refine_shift`: phase correlation's sub-pixel peak leans
to whole pixels), then applied (bilinear). Cost at 512 x 512 (2 shared cores): 1.5-4 ms a
frame for the estimate, ~15 ms more on a shaken frame.

That estimate costs several times the rest of a frame's tracking (the tracker ran 2 575 frames/s
without it, 336 with it), so a video stream goes through `Stabiliser`: a screen first, one
Lucas-Kanade step per tile on frames shrunk 4 times (`screen_shift`, the per-axis median over
the tiles; ~0.2 ms a frame, each frame shrunk once), and the estimate above only where the
screen reads at least `screen_px` (0.2 px). On the own scenes (3 scenes x 179 frame pairs per
shake level; `benchmarks/eval_window_b.py`'s scenes) the screen passed 40 of 537 pairs with no
shake and all but one of the 1 487 pairs with 0.5-2 px shake whose estimate reaches 0.3 px.

Coordinates: px, u = column (right), v = row (down); a shift (du, dv) means the content of
`cur` lies (du, dv) px from where it lay in `prev`.
"""

from __future__ import annotations

import cv2
import numpy as np


__all__ = ["Stabiliser", "align_previous", "estimate_shift", "refine_shift", "screen_shift",
           "shift_image", "shrink"]

_HANN: dict[tuple[int, int], np.ndarray] = {}


def _hann(w: int, h: int) -> np.ndarray:
    key = (w, h)
    if key not in _HANN:
        _HANN[key] = cv2.createHanningWindow((w, h), cv2.CV_32F)
    return _HANN[key]


def estimate_shift(prev: np.ndarray, cur: np.ndarray, *, tiles: int = 4,
                   min_response: float = 0.1) -> tuple[float, float]:
    """(du, dv) px: the global translation of grey frame `cur` against `prev` (same shape), the
    per-axis median over the `tiles` x `tiles` tiles whose phase-correlation response (0-1) is at
    least `min_response`; (0, 0) when no tile qualifies (a blank or saturated frame)."""
    if prev.shape != cur.shape or prev.ndim != 2:
        raise ValueError(f"need two grey frames of one shape, got {prev.shape} and {cur.shape}")
    if tiles < 1:
        raise ValueError(f"tiles must be >= 1, got {tiles}")
    a, b = prev.astype(np.float32), cur.astype(np.float32)
    H, W = a.shape
    th, tw = H // tiles, W // tiles
    if th < 8 or tw < 8:
        raise ValueError(f"{tiles} x {tiles} tiles of a {W} x {H} frame are under 8 px")
    win = _hann(tw, th)
    du, dv = [], []
    for i in range(tiles):
        for k in range(tiles):
            sl = (slice(i * th, (i + 1) * th), slice(k * tw, (k + 1) * tw))
            (x, y), r = cv2.phaseCorrelate(a[sl], b[sl], win)
            if r >= min_response:
                du.append(x)
                dv.append(y)
    if not du:
        return 0.0, 0.0
    return float(np.median(du)), float(np.median(dv))


def shift_image(img: np.ndarray, du: float, dv: float) -> np.ndarray:
    """`img` moved by (du, dv) px (bilinear for fractions of a pixel; the border row or column
    repeated where the shift uncovers the edge), same shape and dtype."""
    m = np.array([[1.0, 0.0, du], [0.0, 1.0, dv]])
    return cv2.warpAffine(img, m, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE)


def refine_shift(prev: np.ndarray, cur: np.ndarray, du: float, dv: float, *, iters: int = 2,
                 max_residual: float = 20.0, border_px: int = 4) -> tuple[float, float]:
    """(du, dv) px refined by `iters` Gauss-Newton (Lucas-Kanade) steps of a global translation:
    least squares of the residual cur - prev moved by (du, dv) against cur's gradient (Sobel,
    grey levels per px), over the pixels whose |residual| is under `max_residual` grey levels
    (a moving object's pixels are left out) and `border_px` from the edge. Phase correlation's
    sub-pixel peak leans to whole pixels (1.5 px read as 1.2-1.3 px); this removes it."""
    a, b = prev.astype(np.float32), cur.astype(np.float32)
    gx = cv2.Sobel(b, cv2.CV_32F, 1, 0, ksize=3) / 8.0
    gy = cv2.Sobel(b, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    inner = (slice(border_px, -border_px or None),) * 2
    gx, gy = gx[inner], gy[inner]
    A = np.array([[np.vdot(gx, gx), np.vdot(gx, gy)], [np.vdot(gx, gy), np.vdot(gy, gy)]])
    for _ in range(iters):
        r = (b - shift_image(a, du, dv))[inner]
        ok = np.abs(r) < max_residual
        if ok.all():
            Ai = A
        else:
            x, y = gx[ok], gy[ok]
            Ai = np.array([[np.vdot(x, x), np.vdot(x, y)], [np.vdot(x, y), np.vdot(y, y)]])
        rr = np.where(ok, r, 0.0)
        rhs = -np.array([np.vdot(gx, rr), np.vdot(gy, rr)])
        if abs(np.linalg.det(Ai)) < 1e-9 * max(float(np.trace(Ai)) ** 2, 1e-30):
            break  # no texture to align on
        d = np.linalg.solve(Ai, rhs)
        du, dv = du + float(d[0]), dv + float(d[1])
    return du, dv


def align_previous(prev: np.ndarray, cur: np.ndarray, *, min_shift_px: float = 0.3,
                   tiles: int = 4) -> tuple[np.ndarray, tuple[float, float]]:
    """(prev moved onto cur, (du, dv) px applied). When the estimated shift (`estimate_shift`)
    is under `min_shift_px` on both axes, `prev` itself and (0, 0): no shake, nothing changes;
    else the shift is refined (`refine_shift`) and prev moved by it, unless that does not lower
    the summed absolute difference to cur (a wrong estimate, say a large object moving across
    most tiles, is not applied: `prev` itself and (0, 0))."""
    du, dv = estimate_shift(prev, cur, tiles=tiles)
    if abs(du) < min_shift_px and abs(dv) < min_shift_px:
        return prev, (0.0, 0.0)
    du, dv = refine_shift(prev, cur, du, dv)
    moved = shift_image(prev, du, dv)
    if cv2.norm(moved, cur, cv2.NORM_L1) >= cv2.norm(prev, cur, cv2.NORM_L1):
        return prev, (0.0, 0.0)
    return moved, (du, dv)


def shrink(img: np.ndarray, scale: int = 4) -> np.ndarray:
    """`img` (grey) `scale` times smaller by area averaging, float32."""
    h, w = img.shape
    return cv2.resize(img, (w // scale, h // scale), interpolation=cv2.INTER_AREA).astype(
        np.float32)


def screen_shift(prev_small: np.ndarray, cur_small: np.ndarray, *, scale: int = 4,
                 tiles: int = 4) -> tuple[float, float]:
    """(du, dv) px of the full frame, cheaply: one Lucas-Kanade step of a translation per tile
    on frames shrunk `scale` times (`shrink`), the per-axis median over the tiles whose normal
    matrix is well conditioned; (0, 0) when none is. Brightness constancy cur(x) = prev(x - d)
    gives, to first order, G d = -sum(grad * (cur - prev)) with G = sum(grad grad^T), the
    gradient that of the mean of the two frames (Sobel of their sum is 16 x that gradient).
    Good to ~10 % for shifts up to 2 px (0.5 px shrunk): a screen, not the estimate."""
    a, b = prev_small, cur_small
    gx = cv2.Sobel(a + b, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(a + b, cv2.CV_32F, 0, 1, ksize=3)
    it = b - a
    tile_sum = lambda x: cv2.resize(x, (tiles, tiles), interpolation=cv2.INTER_AREA).ravel()
    sxx, sxy, syy = tile_sum(gx * gx), tile_sum(gx * gy), tile_sum(gy * gy)
    sxt, syt = tile_sum(gx * it), tile_sum(gy * it)
    det = sxx * syy - sxy * sxy
    ok = det > 1e-6 * (sxx + syy) ** 2 + 1e-12
    if not ok.any():
        return 0.0, 0.0
    du = -16.0 * (syy * sxt - sxy * syt)[ok] / det[ok]
    dv = -16.0 * (sxx * syt - sxy * sxt)[ok] / det[ok]
    return float(np.median(du)) * scale, float(np.median(dv)) * scale


class Stabiliser:
    """`align_previous` over a video stream, behind the cheap screen (`screen_shift`): each frame
    is shrunk once (the current frame's copy is kept for the next call, whose `prev` it is) and
    the full estimate runs only where the screen reads at least `screen_px` px on an axis."""

    def __init__(self, *, min_shift_px: float = 0.3, screen_px: float = 0.2, scale: int = 4,
                 tiles: int = 4):
        self.min_shift_px, self.screen_px = min_shift_px, screen_px
        self.scale, self.tiles = scale, tiles
        self._frame: np.ndarray | None = None  # the last `cur` ...
        self._small: np.ndarray | None = None  # ... and its shrunk copy

    def align(self, prev: np.ndarray, cur: np.ndarray) -> np.ndarray:
        """`prev` moved onto `cur` (`align_previous`), or `prev` itself (the same array) when the
        screen or the estimate finds no shake."""
        small_prev = self._small if self._frame is prev else shrink(prev, self.scale)
        small_cur = shrink(cur, self.scale)
        self._frame, self._small = cur, small_cur
        du, dv = screen_shift(small_prev, small_cur, scale=self.scale, tiles=self.tiles)
        if abs(du) < self.screen_px and abs(dv) < self.screen_px:
            return prev
        return align_previous(prev, cur, min_shift_px=self.min_shift_px, tiles=self.tiles)[0]
