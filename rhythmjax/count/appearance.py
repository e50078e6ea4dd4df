"""An appearance descriptor per pedestrian track (`Appearance`) and its distance
(`appearance_distance`), for joining fragments of one walker across gaps (`count.stitch`).

The descriptor of one frame (`patch_histograms`): the pedestrian's patch (w x h px, foot point
(u, v) px at its bottom centre) is cut into an upper and a lower half (shirt, trousers); each
half's histogram of the grey levels (0-255, `bins` equal bins) of its foreground pixels (the
blobs the patch was placed on, pixels another pedestrian's shared placement claimed left out)
is normalised to sum 1. A half with fewer foreground pixels than `min_fill` of its area gives
no histogram that frame. The track's descriptor is the running mean of its frames' histograms,
per half (`Appearance.add`), taken only in frames where its blobs are not shared with another
pedestrian (occlusion). Two descriptors differ by the Hellinger distance
sqrt(1 - sum_i sqrt(p_i q_i)) (0: identical, 1: disjoint), averaged over the halves both have.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


__all__ = ["Appearance", "appearance_distance", "hellinger", "look_of_frame", "patch_bounds",
           "patch_histograms"]


def patch_bounds(u: float, v: float, w: float, h: float) -> tuple[int, int, int, int]:
    """Integer pixel bounds (x0, y0, x1, y1; x1, y1 exclusive) of the patch with foot point
    (u, v) px, w x h px: columns round(u - w/2) to round(u + w/2), rows
    round(v - h) to round(v + 1) (the placement's box; not clipped to the image)."""
    return (int(round(u - w / 2)), int(round(v - h)), int(round(u + w / 2)), int(round(v + 1)))


def patch_histograms(gray: np.ndarray, fg: np.ndarray, u: float, v: float, w: float, h: float,
                     bins: int = 8, min_fill: float = 0.1,
                     origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """(2, bins) float64: the normalised grey-level histograms of the foreground pixels (`fg`
    bool, the image's shape) of the patch's upper and lower halves (rows above / from
    round(v - h/2)); a half clipped away or with fewer than `min_fill` x its (unclipped) area
    foreground pixels is all NaN. `gray`: grey levels 0-255 (uint8 or float). `origin` (x, y
    px): `gray` and `fg` are the image's window from there (u, v stay image coordinates; the
    window must hold the patch's part inside the image)."""
    x0, y0, x1, y1 = patch_bounds(u, v, w, h)
    ym = int(round(v - h / 2)) - origin[1]
    x0, x1, y0, y1 = x0 - origin[0], x1 - origin[0], y0 - origin[1], y1 - origin[1]
    H, W = gray.shape
    out = np.full((2, bins), np.nan)
    for k, (r0, r1) in enumerate(((y0, ym), (ym, y1))):
        area = max(0, r1 - r0) * max(0, x1 - x0)
        a0, a1, c0, c1 = max(0, r0), min(H, r1), max(0, x0), min(W, x1)
        if area <= 0 or a1 <= a0 or c1 <= c0:
            continue
        g = np.asarray(gray[a0:a1, c0:c1], np.float64)[fg[a0:a1, c0:c1]]
        if g.size < max(1.0, min_fill * area):
            continue
        idx = np.clip((g * (bins / 256.0)).astype(np.int64), 0, bins - 1)
        out[k] = np.bincount(idx, minlength=bins) / g.size
    return out


@dataclass
class Appearance:
    """A track's descriptor: per half (upper, lower), the sum of its frames' normalised
    histograms and the number of frames summed (`add`); `mean()` the running mean."""

    bins: int = 8
    total: np.ndarray = field(default=None)  # (2, bins)
    n: np.ndarray = field(default=None)  # (2,) frames

    def __post_init__(self):
        if self.total is None:
            self.total = np.zeros((2, self.bins))
        if self.n is None:
            self.n = np.zeros(2, np.int64)

    def add(self, hist: np.ndarray) -> None:
        """Adds one frame's (2, bins) histograms (`patch_histograms`; NaN halves skipped)."""
        ok = np.all(np.isfinite(hist), axis=1)
        self.total[ok] += hist[ok]
        self.n += ok

    def merge(self, other: Appearance | None) -> None:
        """Adds another track's frames (two fragments joined into one track)."""
        if other is not None:
            self.total += other.total
            self.n += other.n

    def mean(self) -> np.ndarray:
        """(2, bins): the mean histogram per half; NaN for a half never seen."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.n[:, None] > 0, self.total / np.maximum(self.n, 1)[:, None],
                            np.nan)


def hellinger(p: np.ndarray, q: np.ndarray) -> float:
    """Hellinger distance sqrt(1 - sum sqrt(p q)) of two normalised histograms (0 to 1)."""
    bc = float(np.sum(np.sqrt(np.asarray(p, np.float64) * np.asarray(q, np.float64))))
    return math.sqrt(max(0.0, 1.0 - bc))


def appearance_distance(a: np.ndarray | None, b: np.ndarray | None) -> float:
    """Mean Hellinger distance over the halves both (2, bins) mean descriptors have (NaN
    rows: unseen); NaN when they share none or either is None."""
    if a is None or b is None:
        return math.nan
    d = [hellinger(a[k], b[k]) for k in range(len(a))
         if np.all(np.isfinite(a[k])) and np.all(np.isfinite(b[k]))]
    return float(np.mean(d)) if d else math.nan


def look_of_frame(look: Appearance | None, gray: np.ndarray, labels: np.ndarray, lab,
                  claimed: np.ndarray | None, u: float, v: float, w: float, h: float,
                  bins: int = 8, min_fill: float = 0.1) -> Appearance:
    """`look` (a new `Appearance` when None) with one frame added: `patch_histograms` of the
    patch (foot point (u, v) px, w x h px) over the pixels whose blob label is in `lab`, those
    in `claimed` (bool, taken by other pedestrians' placements) left out. Only the patch's
    window of the images is read."""
    x0, y0, x1, y1 = patch_bounds(u, v, w, h)
    x0, y0 = min(max(0, x0), labels.shape[1]), min(max(0, y0), labels.shape[0])
    x1, y1 = max(x0, x1), max(y0, y1)
    fg = np.isin(labels[y0:y1, x0:x1], lab)
    if claimed is not None:
        fg &= ~claimed[y0:y1, x0:x1]
    look = Appearance(bins) if look is None else look
    look.add(patch_histograms(gray[y0:y1, x0:x1], fg, u, v, w, h, bins, min_fill, (x0, y0)))
    return look
