"""Bounds on a count from the tracks a counter found, against truth boxes (issue 16, counting).

A track stands for a true walker when its box is on the walker (IoU >= 0.3, the walker its box
overlaps most: `diag_count_unjudged.frame_owners`) in at least `min_frames` frames. A maximum
matching of tracks to walkers (each track for at most one walker, each walker at most one
track) gives the most tracks that stand for distinct walkers: `distinct_walkers`. No rule that
keeps or drops tracks can count more walkers without counting one twice, so |distinct - true|
per clip, summed, is the floor of the per-clip count error any such rule reaches on these
tracks (eval_all's count rows report it beside the count). `distinct_labels` marks the tracks
of a maximum-weight matching (weight: the frames on the walker), the labels a rule learnt from
labelled tracks can aim at (`study_count_model.py --labels distinct`). A track that switched
from one walker to another can stand for either.

`row`: a dict with "truth" and "mot" (MOT tables: frame, id, bb_left, bb_top, bb_width,
bb_height), "offset" (added to the mot frames to meet the truth's) and "kinds" (truth id ->
kind; "pedestrian" for walkers), as `count_dump.py` saves per clip.
"""

from __future__ import annotations

import numpy as np
from diag_count_unjudged import frame_owners


def _cover(row: dict, ids: list[int], min_frames: int) -> tuple[np.ndarray, list[int]]:
    """(frames (len(ids), walkers) each track's box is on each walker, 0 below `min_frames`;
    the walkers' ids)."""
    fo = frame_owners(row["truth"], row["mot"], row["offset"])
    walkers = sorted({int(t) for t in np.unique(row["truth"]["id"])
                      if row["kinds"].get(int(t)) == "pedestrian"})
    n = np.zeros((len(ids), len(walkers)))
    for a, i in enumerate(ids):
        on = list(fo.get(i, {}).values())
        for b, t in enumerate(walkers):
            k = on.count(t)
            n[a, b] = k if k >= min_frames else 0.0
    return n, walkers


def distinct_labels(row: dict, ids: list[int], min_frames: int = 5) -> np.ndarray:
    """Per track of `ids`, 1 when it is in a maximum-weight matching of tracks to true walkers
    (weight: the frames its box is on the walker, IoU >= 0.3; pairs of >= `min_frames` frames
    only), else 0: tracks that stand for distinct walkers (at most `distinct_walkers` of them)."""
    from rhythmjax.evaluation.sort_baseline import assign

    lab = np.zeros(len(ids))
    n, walkers = _cover(row, ids, min_frames)
    if not ids or not walkers:
        return lab
    r, c = assign(-n)
    lab[r[n[r, c] > 0]] = 1.0
    return lab


def distinct_walkers(row: dict, ids: list[int], min_frames: int = 5) -> int:
    """The most tracks of `ids` that stand for distinct true walkers: a maximum matching of
    tracks to walkers, a track matchable to every walker its box is on (IoU >= 0.3,
    `diag_count_unjudged.frame_owners`) in at least `min_frames` frames. A track that switched
    from one walker to another can stand for either. No rule that counts tracks on distinct
    walkers can count more."""
    from rhythmjax.evaluation.sort_baseline import assign

    n, walkers = _cover(row, ids, min_frames)
    if not ids or not walkers:
        return 0
    on = (n > 0).astype(np.float64)
    r, c = assign(-on)
    return int(on[r, c].sum())
