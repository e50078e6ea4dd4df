"""Images and blobs levels of Masoud & Papanikolopoulos (PAPERS.md, "Multi-pedestrian paper").

Images level (`BackgroundModel`): a running-average background B (float32, grey levels) and the
difference image thresholded to 0/1, cleaned by a light morphology. Per frame I (uint8):

1. D = I - B_prev (float32); raw mask R = [|D| > threshold] (strictly greater), values 0/1.
   Optionally (`noise_k` > 0) the threshold adapts to the frame's noise, max(noise_floor,
   noise_k x sigma of D), and (`hysteresis` > 0) R keeps weaker pixels near strong ones
   (`fg_threshold`; both off by default).
2. M = close(open(R)): OpenCV MORPH_OPEN with a (2 open_px + 1)^2 square, then MORPH_CLOSE with a
   (2 close_px + 1)^2 square (0 px skips the step). M is the returned foreground mask.
3. Selective update where nothing moves (M = 0):  B <- (1 - alpha) B + alpha I,
   slow update under the foreground (M = 1):       B <- (1 - beta) B + beta I, beta = slow_alpha.
   The slow term lets a lighting change (or an object that stopped for good) be absorbed by the
   background after about 1 / beta frames instead of freezing the mask forever; beta = 0 gives
   the pure selective update. Two masked `cv2.accumulateWeighted` passes, in float32.

Blobs level (`find_blobs`): 8-connected regions of 1's with area (px), bounding box (half-open,
px), centroid (u, v) px (pixel centres at integers, u = column, v = row downwards), density =
area / box area, and perimeter = length of the blob's outer contour (`cv2.findContours`,
`CHAIN_APPROX_SIMPLE`, `cv2.arcLength`); `find_blobs` says how the work stays per box. The
contour runs through the centres of the boundary pixels, so a w x h rectangle has perimeter
2 (w - 1) + 2 (h - 1), 4 px less than the 2 (w + h) of its pixel edges; holes do not count.

Degradation: when one blob's box covers most of the frame (a dense crowd, a camera jump or a
global lighting change), `is_crowd` says so; the pedestrians level should then stop trusting
blob areas. The background keeps learning under the foreground at the slow rate, so a lighting
change clears after ~1 / slow_alpha frames. Only this module, `detect` and `video` import OpenCV.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from .fg_threshold import above, check_noise_options, hysteresis_mask, noise_sigma


CornerBox = tuple[int, int, int, int]  # x0, y0, x1, y1 px, half-open
Number = float | int
MAX_CROPS = 64  # find_blobs: above this many regions, one full-frame CC beats per-box crops
MAX_U16_LABELS = 65535  # find_blobs: more blobs than this get int32 labels


def _check_image(img: np.ndarray, name: str, dtypes: tuple[type, ...] = (np.uint8,)) -> None:
    if not isinstance(img, np.ndarray):
        raise ValueError(f"{name} must be a NumPy array, got {type(img).__name__}")
    if img.ndim != 2:
        raise ValueError(f"{name} must be a 2-D (H, W) image, got shape {img.shape}")
    if img.dtype.type not in dtypes:
        allowed = ", ".join(np.dtype(d).name for d in dtypes)
        raise ValueError(f"{name} must have dtype {allowed}, got {img.dtype}")
    if img.size == 0:
        raise ValueError(f"{name} is empty: shape {img.shape}")


def _square(px: int) -> np.ndarray | None:
    return None if px == 0 else np.ones((2 * px + 1, 2 * px + 1), np.uint8)


class BackgroundModel:
    """Running-average background with selective update (see the module docstring, steps 1-3).

    alpha: learning rate where M = 0 (per frame, in [0, 1]); slow_alpha: rate under the foreground
    (beta, in [0, 1], normally far below alpha); threshold: grey levels, foreground where
    |I - B| > threshold; open_px / close_px: half-sizes of the square structuring elements (px,
    >= 0).

    Noise-adaptive threshold (`fg_threshold`): noise_k > 0 replaces `threshold` by
    max(noise_floor, noise_k x sigma) grey levels (at most 254), sigma estimated per frame on the
    pixels the previous mask called background; hysteresis h in (0, 1) keeps pixels above h x the
    threshold within hysteresis_px px of one above it (0: off). `last_threshold` / `last_sigma`
    hold the latest frame's values (grey levels; sigma NaN when not estimated)."""

    def __init__(self, first_gray: np.ndarray, *, alpha: Number = 0.05, threshold: Number = 20,
                 open_px: int = 1, close_px: int = 2, slow_alpha: Number = 0.0025,
                 noise_k: Number = 0.0, noise_floor: Number = 6.0, hysteresis: Number = 0.0,
                 hysteresis_px: int = 2) -> None:
        _check_image(first_gray, "first_gray")
        if not 0.0 <= alpha <= 1.0:
            raise ValueError(f"alpha must lie in [0, 1], got {alpha}")
        if not 0.0 <= slow_alpha <= 1.0:
            raise ValueError(f"slow_alpha must lie in [0, 1], got {slow_alpha}")
        if not 0.0 <= threshold < 255.0:
            raise ValueError(f"threshold must lie in [0, 255), got {threshold}")
        if int(open_px) != open_px or int(close_px) != close_px or min(open_px, close_px) < 0:
            raise ValueError(f"open_px and close_px must be integers >= 0, got {open_px}, "
                             f"{close_px}")
        check_noise_options(noise_k, noise_floor, hysteresis, hysteresis_px)
        self.noise_k, self.noise_floor = float(noise_k), float(noise_floor)
        self.hysteresis, self.hysteresis_px = float(hysteresis), int(hysteresis_px)
        self.last_threshold, self.last_sigma = float(threshold), float("nan")
        self._prev_mask: np.ndarray | None = None  # for the noise estimate's background pixels
        self.alpha = float(alpha)
        self.slow_alpha = float(slow_alpha)
        self.threshold = float(threshold)
        self.open_px = int(open_px)
        self.close_px = int(close_px)
        self._bg = first_gray.astype(np.float32)
        # close(open(R)) = erode_c(dilate_{o+c}(erode_o(R))): the two middle dilations of the
        # square elements compose into one (exact, also at the borders), 3 passes instead of 4
        self._erode1 = _square(self.open_px)
        self._dilate = _square(self.open_px + self.close_px)
        self._erode2 = _square(self.close_px)
        self._scratch = np.empty_like(self._bg)
        self.n_frames = 0  # frames applied so far (the first frame only initialises B)

    @property
    def shape(self) -> tuple[int, int]:
        return self._bg.shape  # type: ignore[return-value]

    @property
    def background(self) -> np.ndarray:
        """A copy of the current background B, float32 grey levels."""
        return self._bg.copy()

    def foreground(self, gray: np.ndarray) -> np.ndarray:
        """Steps 1-2 only: the uint8 0/1 mask M of `gray` against the current B (no update)."""
        _check_image(gray, "gray")
        if gray.shape != self._bg.shape:
            raise ValueError(f"frame shape {gray.shape} differs from the background's "
                             f"{self._bg.shape}")
        cv2.subtract(gray, self._bg, dst=self._scratch, dtype=cv2.CV_32F)  # I - B, float32
        t = self.threshold
        if self.noise_k > 0.0:
            bgmask = None if self._prev_mask is None else cv2.compare(self._prev_mask, 0,
                                                                     cv2.CMP_EQ)
            self.last_sigma = noise_sigma(self._scratch, bgmask)
            t = min(254.0, max(self.noise_floor, self.noise_k * self.last_sigma))
        self.last_threshold = t
        if self.hysteresis > 0.0:
            mask = hysteresis_mask(self._scratch, t, self.hysteresis * t, self.hysteresis_px)
        else:
            mask = above(self._scratch, t)  # 1 where |D| > t
        if self._erode1 is not None:
            mask = cv2.erode(mask, self._erode1)
        if self._dilate is not None:
            mask = cv2.dilate(mask, self._dilate)
        if self._erode2 is not None:
            mask = cv2.erode(mask, self._erode2)
        return mask

    def update(self, gray: np.ndarray, mask: np.ndarray) -> None:
        """Step 3: fold `gray` into B, at alpha where mask = 0 and slow_alpha where mask != 0."""
        _check_image(mask, "mask", (np.uint8,))
        if mask.shape != self._bg.shape:
            raise ValueError(f"mask shape {mask.shape} differs from the background's "
                             f"{self._bg.shape}")
        if self.noise_k > 0.0:
            self._prev_mask = mask
        still = cv2.compare(mask, 0, cv2.CMP_EQ)
        cv2.accumulateWeighted(gray, self._bg, self.alpha, mask=still)
        if self.slow_alpha > 0.0:
            cv2.accumulateWeighted(gray, self._bg, self.slow_alpha, mask=mask)
        self.n_frames += 1

    def absorb(self, gray: np.ndarray, box: tuple[float, float, float, float]) -> None:
        """B <- I inside `box` (x0, y0, x1, y1 px, clipped to the image): a still foreground
        region (a ghost left where an object stood when B was learnt, or an object that stopped)
        becomes background at once instead of after ~1 / slow_alpha frames."""
        _check_image(gray, "gray")
        H, W = self._bg.shape
        x0, y0 = max(0, int(np.floor(box[0]))), max(0, int(np.floor(box[1])))
        x1, y1 = min(W, int(np.ceil(box[2]))), min(H, int(np.ceil(box[3])))
        if x1 > x0 and y1 > y0:
            self._bg[y0:y1, x0:x1] = gray[y0:y1, x0:x1]

    def apply(self, gray: np.ndarray) -> np.ndarray:
        """The (H, W) uint8 0/1 foreground mask of `gray` (uint8 grey); then updates B."""
        mask = self.foreground(gray)
        self.update(gray, mask)
        return mask


def median_background(grays: Sequence[np.ndarray]) -> np.ndarray:
    """The per-pixel temporal median (uint8; for an even count the mean of the two middle
    values, truncated to an integer grey level) of equally shaped uint8 frames: a background with no
    object that stood in fewer than half of them (`BackgroundModel(median_background(...))`
    starts without the ghosts of objects present in the first frame)."""
    if not grays:
        raise ValueError("median_background needs at least one frame")
    for k, g in enumerate(grays):
        _check_image(g, f"grays[{k}]")
    return np.median(np.stack(grays), axis=0).astype(np.uint8)


@dataclass(frozen=True)
class Blob:
    """A connected region of the foreground mask (all coordinates px)."""

    box: CornerBox  # x0, y0, x1, y1, half-open
    area: int  # number of pixels
    perimeter: float  # outer contour through boundary pixel centres
    centroid: tuple[float, float]  # (u, v)
    density: float  # area / box area, in (0, 1]
    label: int  # value of this blob's pixels in the labels image

    @property
    def width(self) -> int:
        return self.box[2] - self.box[0]

    @property
    def height(self) -> int:
        return self.box[3] - self.box[1]

    @property
    def bottom_center(self) -> tuple[float, float]:
        """(u, v): centre column of the box and its lowest pixel row (as detect.py's foot point)."""
        return 0.5 * (self.box[0] + self.box[2] - 1), float(self.box[3] - 1)


def _blob_of_contour(m: np.ndarray, contour: np.ndarray, rect: np.ndarray, alone: bool,
                     min_area: int) -> tuple[Blob, np.ndarray, bool] | None:
    """The blob whose outer contour is `contour` (box `rect` = x, y, w, h), from its box crop
    only; None below `min_area`. `alone`: no other region's box meets this one, so every
    non-zero pixel of the crop is the blob's; with 0/1 values, area and centroid are then plain
    sums (`cv2.reduce`, exact integers). Otherwise the blob is the 8-connected component of
    non-zero pixels of the crop holding the contour's first point (one of its pixels), found by
    `_component`. Returns the Blob (label 0 for now), its pixels in the crop, and whether they
    are the whole crop's non-zero pixels."""
    x, y, w, h = (int(v) for v in rect)
    if w * h < min_area:
        return None
    crop = m[y:y + h, x:x + w]
    if alone:
        cols = cv2.reduce(crop, 0, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel()
        area = cv2.countNonZero(crop)
        if int(cols.sum()) == area:  # 0/1 values
            if area < min_area:
                return None
            rows = cv2.reduce(crop, 1, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel()
            cu = x + float(cols @ np.arange(w)) / area
            cv = y + float(rows @ np.arange(h)) / area
            return Blob(box=(x, y, x + w, y + h), area=area,
                        perimeter=float(cv2.arcLength(contour, True)), centroid=(cu, cv),
                        density=area / (w * h), label=0), crop, True
    px, py = (int(v) for v in contour[0, 0])
    own, area = _component(crop, px - x, py - y)
    if area < min_area:
        return None
    one = own.view(np.uint8)
    xs = cv2.reduce(one, 0, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel()
    ys = cv2.reduce(one, 1, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel()
    blob = Blob(box=(x, y, x + w, y + h), area=area, perimeter=float(cv2.arcLength(contour, True)),
                centroid=(float(xs @ np.arange(w)) / area + x, float(ys @ np.arange(h)) / area + y),
                density=area / (w * h), label=0)
    return blob, own, False


def _component(crop: np.ndarray, u: int, v: int) -> tuple[np.ndarray, int]:
    """(bool mask, pixel count) of the 8-connected component of non-zero pixels of `crop`
    holding pixel (u, v) (non-zero): a flood fill over the values 1-255 (the component
    `cv2.connectedComponentsWithStats` labels there, without labelling the rest)."""
    h, w = crop.shape
    fill = np.zeros((h + 2, w + 2), np.uint8)
    seed = int(crop[v, u])
    flags = 8 | cv2.FLOODFILL_MASK_ONLY | cv2.FLOODFILL_FIXED_RANGE | (1 << 8)
    n = cv2.floodFill(crop, fill, (u, v), 0, seed - 1, 255 - seed, flags)[0]
    return fill[1:-1, 1:-1].view(bool), int(n)


def _alone(rects: np.ndarray) -> np.ndarray:
    """For (n, 4) boxes x, y, w, h: True where no other box overlaps."""
    x0, y0 = rects[:, 0], rects[:, 1]
    x1, y1 = x0 + rects[:, 2], y0 + rects[:, 3]
    meet = ((x0[:, None] < x1[None, :]) & (x0[None, :] < x1[:, None])
            & (y0[:, None] < y1[None, :]) & (y0[None, :] < y1[:, None]))
    return meet.sum(1) == 1  # itself only


def _order(b: Blob) -> tuple[int, ...]:
    return (b.box[1], b.box[0], b.area, b.box[2], b.box[3])


def _full_frame(m: np.ndarray, outer: list[np.ndarray], min_area: int
                ) -> tuple[list[Blob], np.ndarray]:
    """Blobs by one full-frame `connectedComponentsWithStats` (many regions: noise, crowds);
    labels are CC's, perimeters from the outer contours mapped by the label of their first
    point."""
    try:  # 16-bit labels are 2-3x faster in OpenCV 5.0; overflow (> 65535 regions) raises
        n, cl, st, ce = cv2.connectedComponentsWithStats(m, connectivity=8, ltype=cv2.CV_16U)
    except cv2.error:
        n, cl, st, ce = cv2.connectedComponentsWithStats(m, connectivity=8, ltype=cv2.CV_32S)
    perim = {int(cl[c[0, 0, 1], c[0, 0, 0]]): c for c in outer}
    blobs = []
    for lab in (np.flatnonzero(st[1:, cv2.CC_STAT_AREA] >= min_area) + 1).tolist():
        x, y, w, h, area = (int(v) for v in st[lab])
        blobs.append(Blob(box=(x, y, x + w, y + h), area=area,
                          perimeter=float(cv2.arcLength(perim[lab], True)),
                          centroid=(float(ce[lab, 0]), float(ce[lab, 1])),
                          density=area / (w * h), label=lab))
    return blobs, cl


def find_blobs(mask: np.ndarray, *, min_area: int = 30,
               max_crops: int = MAX_CROPS) -> tuple[list[Blob], np.ndarray]:
    """Blobs (8-connected regions of non-zero pixels with at least `min_area` px) of a uint8 or
    bool (H, W) mask, ordered by box (top, left, then area), and their labels image (uint16, or
    int32 beyond `MAX_U16_LABELS` = 65535 blobs): the k-th blob (0-based) has label k + 1;
    0 = background or a region below `min_area`.

    Full-frame work is one `cv2.findContours` (RETR_CCOMP: the outer borders of all regions,
    also those inside another's hole); then, per blob, its box crop gives the exact pixel area
    and centroid (sums when no other box meets it, else `cv2.connectedComponentsWithStats` on
    the crop) and the outer contour the perimeter. With more than `max_crops` regions (noise,
    specks) one full-frame `connectedComponentsWithStats` is cheaper and is used instead. Both
    paths give the same blobs as a full-frame `connectedComponentsWithStats`
    (tests/test_blobs.py); on a few blobs the crop path is the cheaper one, since OpenCV 5.0's
    full-frame stats pass is slow (benchmarks/bench_blobs.py)."""
    _check_image(mask, "mask", (np.uint8, np.bool_))
    if min_area < 1:
        raise ValueError(f"min_area must be >= 1, got {min_area}")
    m = mask.view(np.uint8) if mask.dtype == np.bool_ else mask
    contours, hier = cv2.findContours(m, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE)
    outer = [c for c, hc in zip(contours, hier[0] if hier is not None else []) if hc[3] == -1]
    if len(outer) > max_crops:
        found, cl = _full_frame(m, outer, min_area)
        found.sort(key=_order)
        lut = np.zeros(int(cl.max()) + 1, _label_dtype(len(found)))
        lut[[b.label for b in found]] = np.arange(1, len(found) + 1)
        labels = lut[cl]
        return [_relabel(b, k) for k, b in enumerate(found, start=1)], labels
    rects = np.array([cv2.boundingRect(c) for c in outer], np.int64).reshape(-1, 4)
    crops = [got for c, r, a in zip(outer, rects, _alone(rects).tolist())
             if (got := _blob_of_contour(m, c, r, a, min_area)) is not None]
    crops.sort(key=lambda f: _order(f[0]))
    labels = np.zeros(m.shape, _label_dtype(len(crops)))
    for k, (b, own, whole) in enumerate(crops, start=1):
        x0, y0, x1, y1 = b.box
        if whole:  # 0/1 crop, nothing else in the box
            np.multiply(own, labels.dtype.type(k), out=labels[y0:y1, x0:x1])
        else:
            labels[y0:y1, x0:x1][own] = k
    return [_relabel(b, k) for k, (b, _, _) in enumerate(crops, start=1)], labels


def _label_dtype(n: int) -> type:
    return np.uint16 if n <= MAX_U16_LABELS else np.int32


def _relabel(b: Blob, label: int) -> Blob:
    return Blob(box=b.box, area=b.area, perimeter=b.perimeter, centroid=b.centroid,
                density=b.density, label=label)


def is_crowd(blobs: Sequence[Blob], shape: tuple[int, int], *, fraction: Number = 0.5) -> bool:
    """True when one blob's box covers at least `fraction` of the (H, W) frame: a crowd, a camera
    jump or a lighting change. Blob areas then say little about how many people are inside."""
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"fraction must lie in (0, 1], got {fraction}")
    frame = float(shape[0]) * float(shape[1])
    return any(b.width * b.height >= fraction * frame for b in blobs)


def box_table(blobs: Sequence[Blob]) -> list[tuple]:
    """Per blob (x0, y0, x1, y1, half its box area px^2), for `meeting`."""
    return [(*b.box, 0.5 * float(max(0, b.box[2] - b.box[0]) * max(0, b.box[3] - b.box[1])))
            for b in blobs]


def meeting(box, table: list[tuple], frac: float) -> set[int]:
    """Indices of the blobs of `table` (`box_table`) whose box meets `box` (x0, y0, x1, y1 px,
    floats) by an intersection area above `frac` of box's area or above half their own."""
    x0, y0, x1, y1 = box
    lim = frac * float(max(0.0, x1 - x0) * max(0.0, y1 - y0))
    out = set()
    for j, (bx0, by0, bx1, by1, half) in enumerate(table):
        w = min(x1, bx1) - max(x0, bx0)
        h = min(y1, by1) - max(y0, by0)
        if w > 0 and h > 0:  # else the intersection is 0 and passes neither test
            ov = float(w * h)
            if ov > lim or ov > half:
                out.add(j)
    return out


def foreground_fraction(mask: np.ndarray) -> float:
    """Fraction of the frame's pixels that are foreground, in [0, 1]."""
    _check_image(mask, "mask", (np.uint8, np.bool_))
    return cv2.countNonZero(mask.view(np.uint8)) / mask.size
