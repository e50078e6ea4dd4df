"""The measured image width of a pedestrian's patch: the W_IMG of the rhythm paper's width gate
(10), which `rhythm.classify_track` applies to the tracks `count` writes.

The patch itself has the MODEL width (an average pedestrian, `patches.ShapeModel`), so it says
nothing about the object; what was measured is the blob under it. `measured_width` takes the
pixels of the related blobs (not claimed by an older patch) in the patch's rows, the columns that
hold any of them within `reach_px` of the patch's sides, and returns the length of the run of
such columns that overlaps the patch's own columns most: the object's horizontal extent, as the
online tracker's `detect.detect_in_window` measures it (a walker with a leg forward is wider than
the patch; two walkers merged into one blob are twice as wide, and (10) rejects the row).

`measured_top` is the same measurement upwards: the top row of those pixels in the patch's
columns (the head), the tracks format's `v_top`, which the height cue of self-calibration
(`fit.selfcal_height`) reads. Like the width it does not depend on the patch's model height,
except through how far up it looks (`reach_px`): a top on the first row searched or on the
image's first row may be cut, and is not given. `measured_lean` gives how far the head's column
lies right of the feet's: a vertical segment seen by a tilted camera slants towards the vertical
vanishing point (people off the image's centre column lean outwards), which the slant cue of
self-calibration reads (the tracks' `u_top` is the foot point's u plus the lean: the patch is an
upright rectangle, so its column is the silhouette's middle, not its feet's, and only the lean
measured within the silhouette is unbiased). A head's own pixels are few and arms and legs
swing, so the lean comes from the whole silhouette: the straight line through each row's mean
column (least squares over the rows from the top row to the feet), read at the top row less at
the feet's row.
"""

from __future__ import annotations

import math

import numpy as np

from .patches import related_mask


def column_runs(cols: np.ndarray) -> list[tuple[int, int]]:
    """(start, end exclusive) of each run of True in a 1-D bool array, in order."""
    if cols.size == 0:
        return []
    inner = (np.flatnonzero(cols[1:] != cols[:-1]) + 1).tolist()
    edges = ([0] if cols[0] else []) + inner + ([int(cols.size)] if cols[-1] else [])
    return list(zip(edges[::2], edges[1::2]))


def measured_width(labels: np.ndarray, related, claimed: np.ndarray | None, u: float, v: float,
                   w: float, h: float, reach_px: float) -> float:
    """Width px of the object under the patch standing on (u, v) px, w x h px (module doc).

    labels: (H, W) int labels image; related: the labels of the patch's blobs; claimed: (H, W)
    bool pixels taken by older patches (None: none). Rows: round(v - h) to floor(v); columns
    of the patch: [floor(u - w/2 + 0.5), floor(u + w/2 + 0.5)); columns searched: those plus
    `reach_px` on either side, inside the image. NaN when no run overlaps the patch."""
    H, W = labels.shape
    if not all(math.isfinite(q) for q in (u, v, w, h, reach_px)):
        return math.nan
    y0, y1 = max(0, int(math.floor(v - h + 0.5))), min(H, int(math.floor(v)) + 1)
    a0, a1 = int(math.floor(u - 0.5 * w + 0.5)), int(math.floor(u + 0.5 * w + 0.5))
    x0 = max(0, int(math.floor(a0 - reach_px)))
    x1 = min(W, int(math.ceil(a1 + reach_px)))
    if y1 <= y0 or x1 <= x0 or a1 <= a0:
        return math.nan
    mask = related_mask(labels[y0:y1, x0:x1], related)
    if claimed is not None:
        mask &= ~claimed[y0:y1, x0:x1]
    best, width = 0, math.nan  # the first run of the largest overlap with [a0, a1)
    for start, end in column_runs(mask.any(axis=0)):
        overlap = min(end, a1 - x0) - max(start, a0 - x0)
        if overlap > best:
            best, width = overlap, float(end - start)
    return width


def measured_top(labels: np.ndarray, related, claimed: np.ndarray | None, u: float, v: float,
                 w: float, reach_px: float) -> float:
    """Top row px of the object under the patch standing on (u, v) px, w px wide (module doc):
    `top_and_edge`'s top."""
    return top_and_edge(labels, related, claimed, u, v, w, reach_px)[0]


def top_and_edge(labels: np.ndarray, related, claimed: np.ndarray | None, u: float, v: float,
                 w: float, reach_px: float) -> tuple[float, bool]:
    """(top row px, at the edge) of the object under the patch standing on (u, v) px, w px wide
    (module doc).

    Pixels: those of the `related` labels in `labels` (H, W int), not `claimed` (H, W bool; None:
    none), in the patch's columns [floor(u - w/2 + 0.5), floor(u + w/2 + 0.5)) and the rows from
    floor(v - reach_px + 0.5) down to floor(v). The top is NaN when there is none, or when the
    topmost is the first row searched or the image's first row (the object may go on above:
    cut); at the edge is True when it is the image's first row (the object's height is at
    least the one up to that row: rule 37's lower bound, `track.twice`)."""
    H, W = labels.shape
    if not all(math.isfinite(q) for q in (u, v, w, reach_px)):
        return math.nan, False
    y0, y1 = max(0, int(math.floor(v - reach_px + 0.5))), min(H, int(math.floor(v)) + 1)
    a0 = max(0, int(math.floor(u - 0.5 * w + 0.5)))
    a1 = min(W, int(math.floor(u + 0.5 * w + 0.5)))
    if y1 <= y0 or a1 <= a0:
        return math.nan, False
    mask = related_mask(labels[y0:y1, a0:a1], related)
    if claimed is not None:
        mask &= ~claimed[y0:y1, a0:a1]
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0 or rows[0] == 0:  # none, or cut by the search or the image's top
        return math.nan, bool(rows.size and y0 == 0)
    return float(y0 + rows[0]), False


def measured_lean(labels: np.ndarray, related, claimed: np.ndarray | None, u: float, v: float,
                  w: float, v_top: float, reach_px: float) -> float:
    """Lean px (head's column less the feet's; > 0: the head lies right) of the object under the
    patch standing on (u, v) px, w px wide, whose top row is v_top px (`measured_top`; module
    doc).

    Pixels: those of the `related` labels, not `claimed`, in the rows floor(v_top) to floor(v)
    and the columns [floor(u - w/2 - reach_px + 0.5), floor(u + w/2 + reach_px + 0.5)) inside
    the image. Each row with a pixel gives its mean column (the pixel centres: column index);
    the least-squares line of those means against the row, read at v_top less at floor(v). NaN
    where v_top is not finite or fewer than a third of the rows (and 3) have a pixel."""
    H, W = labels.shape
    if not all(math.isfinite(q) for q in (u, v, w, v_top, reach_px)) or v_top > v:
        return math.nan
    y0, y1 = max(0, int(math.floor(v_top))), min(H, int(math.floor(v)) + 1)
    a0 = max(0, int(math.floor(u - 0.5 * w - reach_px + 0.5)))
    a1 = min(W, int(math.floor(u + 0.5 * w + reach_px + 0.5)))
    if y1 <= y0 or a1 <= a0:
        return math.nan
    mask = related_mask(labels[y0:y1, a0:a1], related)
    if claimed is not None:
        mask &= ~claimed[y0:y1, a0:a1]
    count = mask.sum(axis=1)
    rows = np.flatnonzero(count)
    if rows.size < max(3, (y1 - y0) / 3):
        return math.nan
    mean_col = (mask[rows] * np.arange(a0, a1)).sum(axis=1) / count[rows]
    r = (y0 + rows).astype(np.float64)
    rb = r.mean()
    slope = float(np.sum((r - rb) * (mean_col - mean_col.mean())) / np.sum((r - rb) ** 2))
    return float(slope * (v_top - (y1 - 1)))
