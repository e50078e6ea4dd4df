"""No ghosts (issue 16 item 4): the background learnt from the first seconds, and pedestrians that
never move ended.

A running-average background started from the first frame keeps whatever stood there: when that
object leaves, the spot it hid differs from the background and stays foreground for ~1 /
slow_alpha frames (`vision.blobs.BackgroundModel`), and a pedestrian patch sits on it (PETS09
S2L1: a box where a man stood in frame 0, for all 794 frames). Two remedies:

1. `peek_background`: the background starts from the per-pixel temporal median
   (`blobs.median_background`) of the frames of the first `seconds` s (at most `max_frames` of
   them, evenly spaced). An object present in frame 0 that leaves within the first seconds
   (stands in fewer than half of the frames used) is not in it.
2. `is_still`: a pedestrian whose measured foot points (u, v) px stayed put for `n_rows` rows is
   a background artefact (an object that stood through the median's seconds and left, or one
   that stopped): the foot point's mean over each block of `block` rows (1 s) lies within
   `widths` W across and `heights` H up or down of every other block's (W, H: the patch at the
   foot point), with at least `min_measured` of the rows measured. A walker moves W in well
   under a second across the image; walking straight away at 1.4 m/s it moves its foot row by
   about b f h / y^2 px per m (eq. (3) differentiated, camera height h): with a 1 m high camera
   and b f = 500 px, 1.75 px = 0.08 H between blocks 4 s apart at 40 m, twice the default 0.04
   H; a ghost's blob does not move at all. The pedestrians level ends such a track and copies
   the frame into the background under its patch (`BackgroundModel.absorb`), so no new
   pedestrian starts there; a track still over its whole measured life (`never_moved`) is
   dropped from the count.
3. `duplicates`: two pedestrians within `duplicate_widths` W with the same image step (within
   0.15 W) for `duplicate_frames` frames in a row follow one object: the younger ends.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Iterator

import numpy as np

from ..vision.blobs import median_background


__all__ = ["duplicates", "is_still", "never_moved", "peek_background"]


def peek_background(frames: Iterable, seconds: float, max_frames: int
                    ) -> tuple[np.ndarray | None, Iterator]:
    """The temporal median of the decoded frames of `frames` (items (index, t s, gray or None))
    with t < t_first + `seconds` (at most `max_frames`, evenly spaced), and an iterator over
    every item again (the ones read first, then the rest). None (no median) when `seconds` <= 0
    or no frame there decodes."""
    it = iter(frames)
    if seconds <= 0:
        return None, it
    head, t0 = [], None
    for item in it:
        head.append(item)
        t0 = item[1] if t0 is None else t0
        if item[1] - t0 >= seconds:
            break
    grays = [g for _, t, g in head if g is not None and t - t0 < seconds]
    if not grays:
        return None, itertools.chain(head, it)
    pick = np.unique(np.linspace(0, len(grays) - 1, min(len(grays), max(1, max_frames)))
                     .round().astype(int))
    return median_background([grays[k] for k in pick]), itertools.chain(head, it)


def is_still(uv: np.ndarray | list, size: tuple[float, float], block: int, widths: float,
             heights: float, min_measured: float = 0.5) -> bool:
    """True when the foot points `uv` ((n, 2) px, NaN rows: predicted) stayed put (module doc):
    at least `min_measured` of the n rows measured, n >= 2 `block`, and the means of the blocks
    of `block` rows (each with a measured row) spread over at most `widths` x W across and
    `heights` x H in rows (`size` = (W, H) px of the patch there)."""
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    n, block = len(uv), max(1, int(block))
    ok = np.all(np.isfinite(uv), axis=1)
    if n < 2 * block or ok.sum() < min_measured * n or not np.all(np.isfinite(size)):
        return False
    means = [uv[k:k + block][ok[k:k + block]].mean(axis=0)
             for k in range(0, n - block + 1, block) if ok[k:k + block].any()]
    if len(means) < 2:
        return False
    spread = np.ptp(np.asarray(means), axis=0)
    return bool(spread[0] <= widths * size[0] and spread[1] <= heights * size[1])


def never_moved(uv: np.ndarray | list, size: tuple[float, float], block: int, widths: float,
                heights: float) -> bool:
    """`is_still` over a whole track's measured foot points (its predicted rows left out)."""
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    return is_still(uv[np.all(np.isfinite(uv), axis=1)], size, block, widths, heights)


def duplicates(peds: list, duplicate_widths: float, duplicate_frames: int) -> list:
    """Of `peds` (objects with est_uv, step_uv (px), size (w, h px), hits, born and a `close`
    counter, updated here), those that have been the younger of a close pair (foot points within
    `duplicate_widths` x w px, image steps within 0.15 w px) for `duplicate_frames` frames."""
    for i, a in enumerate(peds):
        for b in peds[i + 1:]:
            near = math.hypot(a.est_uv[0] - b.est_uv[0], a.est_uv[1] - b.est_uv[1]) \
                < duplicate_widths * max(1.0, a.size[0])
            same = math.hypot(a.step_uv[0] - b.step_uv[0], a.step_uv[1] - b.step_uv[1]) \
                < 0.15 * max(1.0, a.size[0])
            young = b if (b.hits, -b.born) < (a.hits, -a.born) else a
            young.close = young.close + 1 if near and same else 0
    return [p for p in peds if p.close >= duplicate_frames]
