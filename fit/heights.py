"""The height thresholds of rules 26 and 37 from labelled tracks (issue 16 item 3).

A track judged Pedestrian whose median measured height is below `min_height_heights` walker
heights is refused (rule 26, `rhythmjax.track.size`); the value 0.5 was set a priori. Here it is
fitted from tracks labelled with the kind of object they follow:

1. Feature, once per track: its median height in walker heights (`track_heights`: the rows
   `size.median_height` reads, rule 36's included, over the whole track; a track with fewer
   than `min_rows` such rows has no height and is left out, as rule 26 leaves it alone). With
   `edge`, rule 37's height (`twice.twice_height`: the rows at the image's edge too, each a
   lower bound), for rule 37's threshold `size.twice_pace_heights` (a priori 0.75), fitted the
   same way: it too must keep walkers and refuse dogs, which read a walker's pace and step at
   their own trot.
2. Classes: walkers (label ``pedestrian``) are positives; objects lower than a walker (label in
   `LOWER`, the dogs) are negatives. Bicycles with their riders and cars are left out: rule 26
   is for objects shorter than a walker, and a height threshold cannot refuse a tall one.
3. The threshold maximises the balanced accuracy 0.5 (TPR + TNR) on the training tracks (a
   walker kept when its height is at least the threshold) over `GRID`; ties go to the grid
   point nearest the start (the a priori value). Reported on the training and on the held-out
   tracks: balanced accuracy, the ROC AUC of the height (Mann-Whitney; threshold-free), and the
   plateau of the training maximum (the margin the data leave around the fitted value).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fit.walking import balanced_accuracy as walking_accuracy
from rhythmjax.model.status import Verdict
from rhythmjax.track.size import median_height
from rhythmjax.track.twice import twice_height


POSITIVE = "pedestrian"
LOWER = ("dog",)  # labels of objects lower than a walker: the negatives
GRID = np.round(np.arange(0.30, 1.0001, 0.01), 2)  # walker heights


def track_heights(camera, tracks: dict, walker_height_m: float, top_inside_heights: float,
                  min_rows: int = 10, edge: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(track ids, median height in walker heights) of every track of `tracks` (columns
    track_id, u, v, v_top: a tracks table) over the rows `size.median_height` reads (rule 26's
    height); with `edge`, also the rows at the image's edge (column top_at_edge) at the height
    up to the first row, as rule 37 reads them (`twice.twice_height`). NaN where fewer than
    `min_rows` rows are read."""
    tid = np.asarray(tracks["track_id"])
    ids = np.unique(tid)
    out = np.full(len(ids), np.nan)
    for i, t in enumerate(ids):
        k = tid == t
        u, v, v_top = (np.asarray(tracks[c])[k] for c in ("u", "v", "v_top"))
        if edge:
            h, n = twice_height(camera, u, v, v_top, np.asarray(tracks["top_at_edge"])[k],
                                walker_height_m, top_inside_heights)
        else:
            h, n = median_height(camera, u, v, v_top, walker_height_m, top_inside_heights)
        if n >= min_rows:
            out[i] = h / walker_height_m
    return ids, out


def roc_auc(score: np.ndarray, positive: np.ndarray) -> float:
    """P(score of a positive > score of a negative) + 0.5 P(equal): the ROC AUC (Mann-Whitney
    U over n_pos n_neg); NaN when a class is empty."""
    pos, neg = np.asarray(score)[positive], np.asarray(score)[~positive]
    if not pos.size or not neg.size:
        return float("nan")
    greater = (pos[:, None] > neg[None, :]).sum()
    equal = (pos[:, None] == neg[None, :]).sum()
    return float((greater + 0.5 * equal) / (pos.size * neg.size))


def balanced_accuracy(height: np.ndarray, positive: np.ndarray, thresholds) -> np.ndarray:
    """0.5 (TPR + TNR) of "walker where height >= threshold" at each threshold (walker
    heights): `fit.walking.balanced_accuracy` on those verdicts; NaN where a class is empty."""
    kept = np.asarray(height)[None, :] >= np.asarray(thresholds, np.float64)[:, None]
    verdict = np.where(kept, int(Verdict.PEDESTRIAN), int(Verdict.NON_PEDESTRIAN))
    return walking_accuracy(verdict, np.asarray(positive), np.ones(kept.shape[1], bool))[0]


@dataclass
class HeightFit:
    threshold: float  # walker heights
    start: float
    plateau: tuple[float, float]  # the training maximum's range on the grid
    ba: dict = field(default_factory=dict)  # {"train": .., "test": .., "train_at_start": ..}
    auc: dict = field(default_factory=dict)  # {"train": .., "test": ..}
    counts: dict = field(default_factory=dict)  # walkers / lower objects per split


def fit_height_threshold(height: np.ndarray, labels: np.ndarray, test: np.ndarray, *,
                         start: float = 0.5, grid=GRID) -> HeightFit:
    """Fit a height rule's threshold (rule 26's or rule 37's, by the heights given; module
    doc) on the tracks not in `test` (bool) and report on both; `height` in walker heights
    (NaN: left out), `labels` the kinds. Raises ValueError when the training tracks lack a
    class."""
    height, labels = np.asarray(height, np.float64), np.asarray(labels, dtype=object)
    use = np.isfinite(height) & ((labels == POSITIVE) | np.isin(labels, LOWER))
    positive = labels == POSITIVE
    train, held = use & ~test, use & test
    if not (positive[train].any() and (~positive[train]).any()):
        raise ValueError("the training tracks need walkers and lower objects with a height")
    grid = np.asarray(grid, np.float64)
    ba = balanced_accuracy(height[train], positive[train], grid)
    best = np.flatnonzero(ba >= np.nanmax(ba) - 1e-12)
    pick = best[np.argmin(np.abs(grid[best] - start))]
    thr = float(grid[pick])
    out = HeightFit(threshold=thr, start=start,
                    plateau=(float(grid[best].min()), float(grid[best].max())))
    for name, rows in (("train", train), ("test", held)):
        out.ba[name] = float(balanced_accuracy(height[rows], positive[rows], [thr])[0])
        out.ba[f"{name}_at_start"] = float(
            balanced_accuracy(height[rows], positive[rows], [start])[0])
        out.auc[name] = roc_auc(height[rows], positive[rows])
        out.counts[name] = {"walkers": int((positive & rows).sum()),
                            "lower": int((~positive & rows).sum())}
    return out
