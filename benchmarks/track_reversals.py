"""Tracks of a saved counting run (`benchmarks/count_dump.py` dumps) whose ground velocity turns
back: the means of the counting EKF's (vx, vy) over consecutive 1 s blocks, both faster than
`MIN_SPEED` m/s, at an angle whose cosine is below `MAX_COS` (more than 120 degrees). For the
first such turn of a track: whether its boxes follow one walker in both blocks, two walkers
(another after the turn: a track that changed walkers), or anything else (nothing, a non-
walker), a block's object being the truth id with IoU >= 0.3 in at least half its frames.
Issue 16, twenty-fifth round (docs/rules.md). Nothing is chosen here: it measures.

    python benchmarks/track_reversals.py RUN.pkl [RUN2.pkl ...]
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
from collections import Counter

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

BOX = ("bb_left", "bb_top", "bb_width", "bb_height")
MIN_SPEED = 0.5  # m/s, both blocks
MAX_COS = -0.5  # a turn of more than 120 degrees


def first_turn(vx: np.ndarray, vy: np.ndarray, block: int) -> int | None:
    """Index of the first 1 s block (of `block` rows) after which the mean velocity turns back
    (module doc), None if it never does; a last partial block is left out."""
    v = np.stack([vx, vy], 1)
    means = [v[i:i + block].mean(0) for i in range(0, len(v) - block + 1, block)]
    for i, (a, b) in enumerate(zip(means, means[1:])):
        na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
        if na > MIN_SPEED and nb > MIN_SPEED and float(a @ b) / (na * nb) < MAX_COS:
            return i
    return None


def block_object(record: dict, rows: np.ndarray) -> int | None:
    """The truth id the MOT rows' boxes overlap (IoU >= 0.3) in at least half of them."""
    from rhythmjax.evaluation.motscore import iou_matrix

    m, tr = record["mot"], record["truth"]
    votes = Counter()
    for j in rows:
        q = np.flatnonzero(tr["frame"] == m["frame"][j] + record["offset"])
        if q.size:
            iou = iou_matrix(np.array([[m[c][j] for c in BOX]], np.float64),
                             np.stack([np.asarray(tr[c][q], np.float64) for c in BOX], 1))[0]
            if iou.max() >= 0.3:
                votes[int(tr["id"][q][int(np.argmax(iou))])] += 1
    best = votes.most_common(1)
    return best[0][0] if best and best[0][1] >= 0.5 * len(rows) else None


def reversals(record: dict) -> Counter:
    """Counts over one clip: tracks of >= 2 s, those that turn back, those counted, and the
    turns by what the track follows ("one walker", "two walkers", "other")."""
    m, kinds = record["mot"], record["kinds"]
    n = max(1, int(round(record["fps"])))
    counted = {int(t) for t, c in zip(record["verdicts"]["track_id"],
                                      record["verdicts"]["counted"]) if c}
    out = Counter()
    for t in np.unique(m["id"]):
        k = np.flatnonzero(m["id"] == t)
        if len(k) < 2 * n:
            continue
        out["tracks"] += 1
        i = first_turn(np.asarray(m["vx"])[k], np.asarray(m["vy"])[k], n)
        if i is None:
            continue
        out["turning"] += 1
        out["turning, counted"] += int(t) in counted
        a = block_object(record, k[i * n:(i + 1) * n])
        b = block_object(record, k[(i + 1) * n:(i + 2) * n])
        walker = [o is not None and kinds.get(o) == "pedestrian" for o in (a, b)]
        out["one walker" if all(walker) and a == b else "two walkers" if all(walker)
            else "other"] += 1
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+")
    a = p.parse_args(argv)
    for path in a.runs:
        with open(path, "rb") as f:
            total = sum((reversals(r) for r in pickle.load(f)), Counter())
        print(f"{path}: {dict(total)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
