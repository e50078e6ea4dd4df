"""Moving-object detection and the rhythm signal, Sec. 2 and 4.1 of the rhythm paper (NumPy/OpenCV).

Pipeline per frame (PAPERS.md, "Sobel"):

1. D = |I(k) - I(k-1)|, the absolute difference of successive 8-bit grey frames.
2. In parallel: the thresholded difference T = [D > diff_threshold], and the vertical-edge map
   E = [|Sobel_x(D)| > edge_threshold]. The Sobel d/dx operator is applied to the DIFFERENCE image
   (moving legs are vertical edges), not to the frame.
3. The two binary maps are ADDED: motion M = T + E, values 0, 1, 2 (uint8).
4. Vertical and horizontal projections of M, sliced at a fraction of their maximum, give the bottom
   point (u_p = centre of the horizontal extent, v_p = lowest row) and the image width wid_IMG,
   inside a small window centred on the predicted foot point (`detect_in_window`), or per connected
   region for new objects elsewhere (`find_objects`). With `column_fraction` (above the slice
   fraction), where wid_IMG is wider than the predicted body box (`core`), u_p is the centre of
   the columns reaching that fraction instead, and the detection's box spans those columns: the
   body's core, which a trailing suitcase or a bag (columns with little motion) does not pull
   aside; wid_IMG and v_p stay the slice's. With `column_rows` (a fraction), the same gate
   takes u_p from the slice extent of the columns' motion over the top part of the sliced rows
   (torso and head, above a suitcase and the legs' swing).

Image coordinates are px: u = column index, v = row index (downwards), pixel centres at integers.
Biases, measured on synthetic frames (tests/test_detect.py): the extent of M is the union of the
object's two positions, so wid_IMG exceeds the object's width by its displacement per frame |du| and
u_p lags by du/2 (as in the paper). The 3x3 Sobel stencil spreads E one px beyond the thresholded
difference at a vertical boundary (with the default edge_threshold = 4 diff_threshold a step that
passes the difference threshold also fires the edge one px outside it), so wid_IMG is reported as
the extent less `SOBEL_HALO_PX` on each side; v_p may sit up to 1 px below the drawn bottom.
Window B, the rhythm signal I(k) and the walker width W are in `vision.window_b` (re-exported
here). Everything returns plain NumPy / Python values.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from .window_b import (
    walker_width_px as walker_width_px,
    window_b_intensity as window_b_intensity,
    window_b_rect as window_b_rect,
)


WindowBox = tuple[int, int, int, int]  # x0, y0, width, height px (OpenCV's convention)
Number = float | int | np.floating | np.integer  # a px coordinate or size
SOBEL_HALO_PX = 1  # the 3x3 Sobel stencil spreads E this far beyond the thresholded difference


@dataclass(frozen=True)
class Detection:
    """A detected object: foot point (u, v) px (u = centre of the horizontal extent, v = lowest
    row), image width wid_IMG px, bounding box (x0, y0, w, h) px of the sliced extent, and area (the
    number of non-zero motion pixels in the box). `top`: the top row px of the sliced extent (the
    head) where `detect_in_window` measured it; NaN where the extent reaches the window's top
    (clipped: the head may lie above it) and for `find_objects`. `top_at_edge`: the extent
    reached the image's first row there (the object goes on above the view). `u_extent`: the
    slice extent's centre px (the paper's u_p) where a column rule of `detect_in_window`
    (`column_fraction`, `column_rows`) moved u (and the box, unless `column_box` is False); NaN
    where u is it."""

    u: float
    v: float
    width: float
    box: WindowBox
    area: int
    top: float = math.nan
    top_at_edge: bool = False
    u_extent: float = math.nan

    def window_u(self, extent: bool) -> float:
        """The column px of the rhythm window B on this detection: `u_extent` where `extent`
        (rule 54, `BodyOptions.column_filter_only`) and a column rule moved u; u otherwise."""
        return self.u_extent if extent and math.isfinite(self.u_extent) else self.u


def frame_difference(prev: np.ndarray, cur: np.ndarray) -> np.ndarray:
    """|cur - prev| of two (H, W) uint8 frames, uint8."""
    if prev.shape != cur.shape:
        raise ValueError(f"frame shapes differ: {prev.shape} and {cur.shape}")
    return cv2.absdiff(prev, cur)


def motion_from_diff(absdiff: np.ndarray, *, diff_threshold: Number,
                     edge_threshold: Number | None = None) -> np.ndarray:
    """Motion image M = [D > diff_threshold] + [|Sobel_x(D)| > edge_threshold], uint8 in {0, 1, 2}.

    Sobel_x is the 3x3 d/dx kernel [[-1, 0, 1], [-2, 0, 2], [-1, 0, 1]] applied to the difference
    image D (borders reflected without repeating the edge pixel, OpenCV's BORDER_REFLECT_101).
    `edge_threshold` (grey levels of the Sobel response) defaults to 4 * diff_threshold, the
    response to a step of height diff_threshold; it must be below 255."""
    return _motion(absdiff, diff_threshold, edge_threshold)[0]


def _motion(absdiff, diff_threshold, edge_threshold):
    """(M, [D > diff_threshold]) of `motion_from_diff`."""
    te = 4.0 * diff_threshold if edge_threshold is None else float(edge_threshold)
    if not 0 <= te < 255 or not 0 <= diff_threshold < 255:
        raise ValueError(f"thresholds must lie in [0, 255): diff {diff_threshold}, edge {te}")
    # the difference, thresholded:
    _, thr = cv2.threshold(absdiff, float(diff_threshold), 1, cv2.THRESH_BINARY)
    sobel = cv2.convertScaleAbs(cv2.Sobel(absdiff, cv2.CV_16S, 1, 0, ksize=3))  # |d/dx D|, sat. 255
    _, edges = cv2.threshold(sobel, te, 1, cv2.THRESH_BINARY)  # vertical edges of the difference
    return cv2.add(thr, edges), thr  # the two maps added (Sec. 2: "in parallel", then added)


def motion_image(prev: np.ndarray, cur: np.ndarray, *, diff_threshold: Number,
                 edge_threshold: Number | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(M, D): the motion image of `motion_from_diff` and the absolute difference D (uint8), for
    two successive (H, W) uint8 grey frames. D is what `window_b_intensity` sums."""
    d = frame_difference(prev, cur)
    return motion_from_diff(d, diff_threshold=diff_threshold, edge_threshold=edge_threshold), d


def motion_image_changed(prev: np.ndarray, cur: np.ndarray, *, diff_threshold: Number
                         ) -> tuple[np.ndarray, np.ndarray, int]:
    """(M, D, n): `motion_image` and the number n of pixels with D > diff_threshold, counted
    on the thresholded map M is built from (what `is_global_change` counts, without a second
    threshold pass)."""
    d = frame_difference(prev, cur)
    m, thr = _motion(d, diff_threshold, None)
    return m, d, cv2.countNonZero(thr)


def _extent(p: np.ndarray, fraction: Number) -> tuple[int, int] | None:
    """First and last index where the projection p reaches fraction * max(p); None if p is 0."""
    m = p.max() if p.size else 0
    if m <= 0:
        return None
    idx = np.flatnonzero(p >= max(fraction * m, 1e-9))
    return int(idx[0]), int(idx[-1])


def _project(m: np.ndarray, axis: int) -> np.ndarray:
    """Sums of `m` over `axis` (0: per column, 1: per row) as integers; OpenCV's reduce for
    uint8 (exact in int32 below 8e6 rows or columns of 255), NumPy otherwise."""
    if m.dtype == np.uint8 and m.size:
        return cv2.reduce(m, axis, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel()
    return m.sum(axis=axis, dtype=np.int64)


def _bottom_point(m: np.ndarray, x0: int, y0: int, fraction: Number, min_area: int,
                  halo: int, column_fraction: Number | None = None,
                  wide_px: Number = math.inf,
                  column_rows: Number | None = None, column_box: bool = True
                  ) -> Detection | None:
    """Projections of the motion crop `m` (top-left at (x0, y0) px) sliced into a Detection;
    where wid_IMG exceeds `wide_px`, u_p is the centre of the columns reaching `column_fraction`
    of the vertical projection's maximum, or of the slice extent of the projection over the top
    `column_rows` of the sliced rows, and the box spans them where `column_box` (else it stays
    the slice extent's; None: never; module doc)."""
    cols = _project(m, 0)  # vertical projection: one value per column
    ext = _extent(cols, fraction)
    if ext is None:
        return None
    c0, c1 = ext
    rows = _project(m[:, c0:c1 + 1], 1)  # horizontal projection within the extent
    r0, r1 = _extent(rows, fraction) or (0, 0)  # never None: the extent holds motion
    box = m[r0:r1 + 1, c0:c1 + 1]
    area = cv2.countNonZero(box) if box.dtype == np.uint8 else int(np.count_nonzero(box))
    if area < min_area:
        return None
    width = float(max(c1 - c0 + 1 - 2 * halo, 1))
    u_extent = x0 + 0.5 * (c0 + c1)
    if column_fraction is not None and width > wide_px:  # something beside the body: its
        c0, c1 = _extent(cols, max(column_fraction, fraction))  # core's columns, u_p and box
    elif column_rows is not None and width > wide_px:  # ... or its upper body's columns
        upper = m[r0:r0 + max(int(column_rows * (r1 - r0 + 1)), 1), c0:c1 + 1]
        c0, c1 = (c0 + c for c in _extent(_project(upper, 0), fraction) or (0, c1 - c0))
    else:
        u_extent = math.nan
    b0, b1 = (c0, c1) if column_box or math.isnan(u_extent) else ext
    return Detection(u=x0 + 0.5 * (c0 + c1), v=float(y0 + r1), width=width,
                     box=(x0 + b0, y0 + r0, b1 - b0 + 1, r1 - r0 + 1), area=area,
                     u_extent=u_extent)


def _window(shape: tuple[int, ...], cu: float, cv: float, w: int, h: int) -> tuple[int, int, int,
                                                                                   int]:
    x0 = math.floor(cu - w / 2 + 0.5)
    y0 = math.floor(cv - h / 2 + 0.5)
    return max(x0, 0), max(y0, 0), min(x0 + w, shape[1]), min(y0 + h, shape[0])


def detect_in_window(motion: np.ndarray, center_uv: Sequence[Number] | np.ndarray,
                     window_size: Number | Sequence[Number] | np.ndarray, *,
                     fraction: Number = 0.3, min_area: int = 10, halo: int = SOBEL_HALO_PX,
                     core: WindowBox | None = None, dilate_px: int = 3,
                     body_px: Number | None = None,
                     column_fraction: Number | None = None,
                     column_rows: Number | None = None,
                     column_wide_px: Number | None = None,
                     column_box: bool = True) -> Detection | None:
    """Detect the object in a window centred on the predicted foot point `center_uv` = (u, v) px.

    `window_size` is (width, height) px or one number for a square; the window is clipped at the
    image borders. The vertical projection (column sums of M) is sliced at `fraction` of its
    maximum: the first and last columns reaching it give the horizontal extent, u_p its centre and
    wid_IMG its length. The horizontal projection (row sums within that extent), sliced the same
    way, gives v_p = its lowest row. None if the window is empty, outside the image, or holds
    fewer than `min_area` motion pixels in the sliced box (no measurement). wid_IMG is the
    extent less `halo` px on each side (see the module docstring; 0 to keep the raw extent).
    `top` is the sliced extent's top row (the head), NaN where it is the window's top row.

    `core` (x0, y0, w, h) px, the box where the object is expected (its predicted body): when
    given, only the connected regions of the window's motion (dilated by `dilate_px`, as in
    `find_objects`) that belong to the object are kept: the region with the most motion pixels
    inside `core`, and every other region at least half inside it. Another object that enters
    the window (a walker passing nearer or farther) then no longer widens the extent or moves
    the bottom point.

    `body_px` (with `core`): the object's regions may also be joined across gaps. The motion of
    a walker far away splits into separate regions (the outlines of its torso, its legs, a bag;
    its uniform inside does not change), and when the prediction is off by a fraction of the
    body width the regions on the far side lie mostly outside `core` and were dropped, so the
    detection was half a body with the foot point of the wrong part, pulling the estimate
    further off. Here the other regions with some motion inside `core` are added nearest first
    while the kept regions stay within `body_px` columns and their bottom not below `core`'s by
    more than a tenth of its height and the dilation (a nearer object's feet).

    `column_fraction` (with `core`): where wid_IMG is wider than `core`, u_p is the centre of the
    columns reaching this fraction of the vertical projection's maximum and the box spans them
    (the body without a suitcase or bag beside it; module doc, item 4); None: never.
    `column_rows` (with `core`, `column_fraction` None): the same, u_p the centre of the slice
    extent of the vertical projection over the top `column_rows` of the sliced rows (torso and
    head: a suitcase or the legs' swing lie below); None: never. `column_wide_px` (with `core`):
    the width px wid_IMG must exceed for either column rule (None: `core`'s width; 0: every
    detection, rule 54b). `column_box` False (rule 54): the box stays the slice extent's, only
    u_p moves."""
    u, v = (float(c) for c in center_uv)
    if not (math.isfinite(u) and math.isfinite(v)):
        return None
    w, h = ((int(window_size),) * 2 if np.ndim(window_size) == 0
            else (int(window_size[0]), int(window_size[1])))
    x0, y0, x1, y1 = _window(motion.shape, u, v, w, h)
    if x1 <= x0 or y1 <= y0:
        return None
    crop = motion[y0:y1, x0:x1]
    if core is not None:
        crop = _object_regions(crop, (core[0] - x0, core[1] - y0, core[2], core[3]), dilate_px,
                               body_px)
        if crop is None:
            return None
    det = _bottom_point(crop, x0, y0, fraction, min_area, halo, column_fraction,
                        math.inf if core is None else
                        core[2] if column_wide_px is None else column_wide_px, column_rows,
                        column_box)
    if det is None:
        return None
    if det.box[1] <= y0:  # the extent reaches the window's top: no top row (at the image's
        # first row: the object goes on above the view)
        return dataclasses.replace(det, top_at_edge=True) if det.box[1] <= 0 else det
    return dataclasses.replace(det, top=float(det.box[1]))


def _object_regions(crop: np.ndarray, core: WindowBox, dilate_px: int,
                    body_px: Number | None = None) -> np.ndarray | None:
    """The motion of `crop` restricted to the regions that belong to the object in `core` (crop
    coordinates): the region with the most motion pixels inside `core`, and every other region
    at least half inside it (and, with `body_px`, those joined by `_join_body`); None if no
    region touches it."""
    mask = (crop > 0).astype(np.uint8)
    if dilate_px > 0:
        mask = cv2.dilate(mask, np.ones((2 * dilate_px + 1,) * 2, np.uint8))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 2:  # one region (or none): nothing to choose
        return crop if n == 2 else None
    moving = np.where(crop > 0, labels, 0)
    total = np.bincount(moving.ravel(), minlength=n)
    cx0, cy0 = max(core[0], 0), max(core[1], 0)
    cx1, cy1 = min(core[0] + core[2], crop.shape[1]), min(core[1] + core[3], crop.shape[0])
    if cx1 <= cx0 or cy1 <= cy0:
        return None
    inside = np.bincount(moving[cy0:cy1, cx0:cx1].ravel(), minlength=n)
    inside[0] = total[0] = 0
    if inside.max() <= 0:
        return None
    keep = (2 * inside >= total) & (total > 0)
    keep[int(np.argmax(inside))] = True
    if body_px is not None:
        _join_body(keep, inside > 0, stats, dilate_px, float(body_px),
                   cy1 + 0.1 * (cy1 - cy0) + dilate_px)
    return np.where(keep[labels], crop, 0).astype(crop.dtype)


def _join_body(keep: np.ndarray, touching: np.ndarray, stats: np.ndarray, dilate_px: int,
               body_px: float, max_bottom: float) -> None:
    """Add to `keep` (in place) the other regions with motion inside the core (`touching`), the
    one that widens the kept columns least first, while the kept columns span at most `body_px`
    and the region's bottom row (stats of the dilated regions, less `dilate_px`) is above
    `max_bottom`."""
    x0 = stats[:, cv2.CC_STAT_LEFT] + dilate_px
    x1 = stats[:, cv2.CC_STAT_LEFT] + stats[:, cv2.CC_STAT_WIDTH] - 1 - dilate_px
    bottom = stats[:, cv2.CC_STAT_TOP] + stats[:, cv2.CC_STAT_HEIGHT] - 1 - dilate_px
    lo, hi = int(x0[keep].min()), int(x1[keep].max())
    if hi - lo + 1 > body_px:
        return
    rest = [k for k in np.flatnonzero(~keep & touching) if bottom[k] <= max_bottom]
    while rest:
        span = [max(hi, x1[k]) - min(lo, x0[k]) + 1 for k in rest]
        j = int(np.argmin(span))
        if span[j] > body_px:
            return
        k = rest.pop(j)
        keep[k] = True
        lo, hi = min(lo, int(x0[k])), max(hi, int(x1[k]))


def box_overlap(a: WindowBox, b: WindowBox) -> int:
    """Intersection area (px^2) of two (x0, y0, w, h) boxes."""
    ox = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    oy = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return max(ox, 0) * max(oy, 0)


def find_objects(motion: np.ndarray, *, min_area: int, exclude_boxes: Sequence[WindowBox] = (),
                 dilate_px: int = 3, fraction: Number = 0.3, max_objects: int = 64,
                 halo: int = SOBEL_HALO_PX, downscale: int = 1) -> list[Detection]:
    """New objects anywhere in M: connected regions (8-connected) of the motion mask dilated by a
    (2 dilate_px + 1)^2 square (to join legs and fragmented edges), each reduced to a Detection by
    the projections of its own motion pixels. Regions with fewer than `min_area` motion pixels are
    dropped, and so are regions whose foot point lies in a box of `exclude_boxes` (x0, y0, w, h) or
    half of whose box overlaps one (objects already tracked). At most `max_objects`, largest first
    (bounded work on a pathological frame, RELIABILITY item 16).

    `downscale` s > 1 labels the regions on an s-times smaller mask (a block is set when any of
    its pixels moves; dilated by ceil(dilate_px / s)), s^2 times less labelling work (the
    full-frame labelling was most of the tracker's per-frame cost); each region's Detection is
    still measured on the full-resolution motion pixels of its blocks."""
    if downscale > 1:
        return _find_objects_coarse(motion, min_area, exclude_boxes, dilate_px, fraction,
                                    max_objects, halo, int(downscale))
    mask = (motion > 0).astype(np.uint8)
    if dilate_px > 0:
        k = np.ones((2 * dilate_px + 1, 2 * dilate_px + 1), np.uint8)
        mask = cv2.dilate(mask, k)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    order = np.argsort(-stats[1:, cv2.CC_STAT_AREA]) + 1
    def regions():
        for k in order:
            x, y, w, h, a = (int(s) for s in stats[k])
            if a < min_area:
                return  # sorted by (dilated) area, which bounds the motion area
            crop = np.where(labels[y:y + h, x:x + w] == k, motion[y:y + h, x:x + w], 0)
            yield _bottom_point(crop, x, y, fraction, min_area, halo)

    return _keep(regions(), exclude_boxes, max_objects)


def _keep(dets, exclude_boxes, max_objects) -> list[Detection]:
    """The first `max_objects` detections not inside (or half covered by) an excluded box."""
    out: list[Detection] = []
    for det in dets:
        if det is None or any(_inside(det, b) or 2 * box_overlap(det.box, b)
                              >= det.box[2] * det.box[3] for b in exclude_boxes):
            continue
        out.append(det)
        if len(out) >= max_objects:
            break
    return out


def block_any(mask: np.ndarray, s: int) -> np.ndarray:
    """(ceil(H/s), ceil(W/s)) uint8: 1 where some pixel of the s x s block is non-zero (the last
    blocks may be partial). A dilation anchored at the block's corner, read every s pixels:
    3x cheaper than a block mean by INTER_AREA resizing (bench_pipeline)."""
    grown = cv2.dilate(mask, np.ones((s, s), np.uint8), anchor=(0, 0))  # max over [x, x + s)
    return (grown[::s, ::s] > 0).astype(np.uint8)


def _find_objects_coarse(motion, min_area, exclude_boxes, dilate_px, fraction, max_objects,
                         halo, s) -> list[Detection]:
    H, W = motion.shape
    small = block_any(motion, s)
    r = -(-dilate_px // s)
    if r > 0:
        small = cv2.dilate(small, np.ones((2 * r + 1, 2 * r + 1), np.uint8))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(small, connectivity=8)
    order = np.argsort(-stats[1:, cv2.CC_STAT_AREA]) + 1
    def regions():
        for k in order:
            x, y, w, h, a = (int(q) for q in stats[k])
            if a * s * s < min_area:
                return  # block area bounds the motion area
            x0, y0 = x * s, y * s
            x1, y1 = min((x + w) * s, W), min((y + h) * s, H)
            mine = (labels[y:y + h, x:x + w] == k).astype(np.uint8)  # block -> its s x s pixels
            lab = cv2.resize(mine, (w * s, h * s), interpolation=cv2.INTER_NEAREST_EXACT)
            crop = motion[y0:y1, x0:x1] * lab[:y1 - y0, :x1 - x0]
            yield _bottom_point(crop, x0, y0, fraction, min_area, halo)

    return _keep(regions(), exclude_boxes, max_objects)


def motion_outside(motion: np.ndarray, boxes: Sequence[WindowBox], margin: int = 0) -> int:
    """Number of motion pixels (M > 0) outside every box (x0, y0, w, h) px grown by `margin` px
    on each side, boxes clipped to the frame. A new object needs `min_area` of them (the tracker
    skips `find_objects` below)."""
    rest = motion.copy()
    H, W = motion.shape
    for x, y, w, h in boxes:
        x, y, w, h = x - margin, y - margin, w + 2 * margin, h + 2 * margin
        x0, y0 = min(max(x, 0), W), min(max(y, 0), H)
        rest[y0:min(max(y + h, y0), H), x0:min(max(x + w, x0), W)] = 0
    return cv2.countNonZero(rest)


def shared_detections(dets: dict[int, Detection], overlap: Number = 0.5) -> set[int]:
    """Keys of `dets` whose boxes overlap another's by at least `overlap` of the smaller box's
    area: one blob claimed by two tracks (two objects passing each other, or a duplicate)."""
    out, items = set(), list(dets.items())
    for i, (a, da) in enumerate(items):
        for b, db in items[i + 1:]:
            small = min(da.box[2] * da.box[3], db.box[2] * db.box[3])
            if box_overlap(da.box, db.box) >= overlap * small:
                out |= {a, b}
    return out


def _inside(det: Detection, b: WindowBox) -> bool:
    return b[0] <= det.u < b[0] + b[2] and b[1] <= det.v < b[1] + b[3]


def is_global_change(absdiff: np.ndarray, threshold: Number, fraction: Number = 0.5, *,
                     changed: int | None = None) -> bool:
    """True if more than `fraction` of the pixels have D > threshold: a corrupt frame, camera jitter
    or a sudden illumination change (RELIABILITY item 7-8). Such a frame is no measurement for
    every object (each track predicts), and must yield no detection. `changed`: that count if
    already known (`motion_image_changed`)."""
    n = changed if changed is not None else cv2.countNonZero(
        cv2.threshold(absdiff, float(threshold), 1, cv2.THRESH_BINARY)[1])
    return n > fraction * absdiff.size


def is_duplicate(absdiff: np.ndarray) -> bool:
    """True if the whole-frame difference is exactly 0: a duplicated frame (frame-rate conversion,
    RELIABILITY item 9), to be dropped with a warning rather than taken as 'no motion'."""
    return cv2.countNonZero(absdiff) == 0
