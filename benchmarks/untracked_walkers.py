"""Where a saved counting run's per-clip errors come from (`benchmarks/count_dump.py` dumps): the
counted tracks split by what they follow (a walker's first counted track, judged Pedestrian "P"
or unjudged "U"; a second track on the same walker; a non-walker; no truth object), the walkers
no counted track follows split into those some track follows and those none does, and for the
untracked ones how often another walker's box stands beside theirs (columns overlapping by at
least `BESIDE` of their box width, in the same frame), how far apart in depth the two stand
(their foot rows, in walker heights; which is the farther) and how often some track's box
covers theirs (IoU >= 0.3) though that track follows someone else. A track follows the walker
its boxes overlap with IoU >= 0.3 in at least half its frames (`eval_count.owner_of_tracks`).
Issue 16, twenty-fourth round (docs/rules.md).

    python benchmarks/untracked_walkers.py RUN.pkl [RUN2.pkl ...]

Nothing is chosen here: it measures.
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
from collections import Counter

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

BESIDE = 0.3  # column overlap, fraction of the walker's box width
BOX = ("bb_left", "bb_top", "bb_width", "bb_height")


def decompose(record: dict, own: dict) -> Counter:
    """Counts over one clip: counted tracks by kind ("first_P", "first_U", "second",
    "non_walker", "nothing"), "missed_tracked" and "missed_untracked" walkers, "true"."""
    v, kinds = record["verdicts"], record["kinds"]
    c, seen = Counter(true=int(record["true"])), set()
    for t, verdict, counted in zip(v["track_id"], v["verdict"], v["counted"]):
        if not counted:
            continue
        o = own.get(int(t))
        if o is None:
            c["nothing"] += 1
        elif kinds[o] != "pedestrian":
            c["non_walker"] += 1
        elif o in seen:
            c["second"] += 1
        else:
            seen.add(o)
            c["first_P" if verdict == "pedestrian" else "first_U"] += 1
    tracked = {o for o in own.values() if o is not None}
    for w in (w for w, k in kinds.items() if k == "pedestrian" and w not in seen):
        c["missed_tracked" if w in tracked else "missed_untracked"] += 1
    return c


def beside_and_covered(record: dict, walker: int) -> tuple[float, float, float, float]:
    """Over the walker's truth frames: the fraction with another truth walker's box beside its
    own (`BESIDE`; the most overlapping one is "the other"), the fraction with some track's box
    covering it at IoU >= 0.3, and over the frames with another beside: the median |foot row
    difference| to the other in walker heights (box heights) and the fraction of them in which
    the walker is the farther (its box bottom higher in the image). NaN without such frames."""
    from eval_count import iou_matrix

    tr, kinds = record["truth"], record["kinds"]
    mot, off = record["mot"], record["offset"]
    left, width = np.asarray(tr["bb_left"], np.float64), np.asarray(tr["bb_width"], np.float64)
    bottom = np.asarray(tr["bb_top"], np.float64) + np.asarray(tr["bb_height"], np.float64)
    hb = np.stack([np.asarray(mot[c], np.float64) for c in BOX], 1)
    hf = np.asarray(mot["frame"]) + off
    rows = np.flatnonzero(tr["id"] == walker)
    covered, depth = 0, []
    for j in rows:
        box = np.asarray([[tr[c][j] for c in BOX]], np.float64)
        o = np.flatnonzero((tr["frame"] == tr["frame"][j]) & (tr["id"] != walker))
        o = o[[kinds.get(int(tr["id"][i])) == "pedestrian" for i in o]] if o.size else o
        if o.size:
            overlap = np.minimum(left[j] + width[j], left[o] + width[o]) - np.maximum(left[j],
                                                                                     left[o])
            if overlap.max() >= BESIDE * width[j]:
                i = o[int(np.argmax(overlap))]
                depth.append((abs(bottom[j] - bottom[i]) / box[0, 3], bottom[j] < bottom[i]))
        k = np.flatnonzero(hf == tr["frame"][j])
        covered += bool(k.size and iou_matrix(hb[k], box).max() >= 0.3)
    n = max(len(rows), 1)
    d = np.asarray(depth, np.float64).reshape(-1, 2)
    return (len(d) / n, covered / n, float(np.median(d[:, 0])) if len(d) else np.nan,
            float(np.mean(d[:, 1])) if len(d) else np.nan)


def main(argv=None) -> int:
    from eval_count import owner_of_tracks

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+")
    a = ap.parse_args(argv)
    for path in a.runs:
        with open(path, "rb") as f:
            records = pickle.load(f)
        total, fr, fr_tracked = Counter(), [], []
        for r in records:
            own = owner_of_tracks(r["truth"], r["mot"], r["offset"])
            total += decompose(r, own)
            tracked = {o for o in own.values() if o is not None}
            for w, k in r["kinds"].items():
                if k == "pedestrian":
                    (fr_tracked if w in tracked else fr).append(beside_and_covered(r, w))
        f, g = (np.asarray(x, np.float64).reshape(-1, 4) for x in (fr, fr_tracked))
        fb, gb = f[f[:, 0] > 0.5], g[g[:, 0] > 0.5]  # beside another in over half their frames
        print(f"{path}: {dict(total)}; untracked walkers {len(f)}: another walker beside in over "
              f"half their frames {len(fb)}, a track's box on them in over half "
              f"{int(np.sum(f[:, 1] > 0.5))}; of those beside, foot rows apart by a median "
              f"{np.median(fb[:, 2]) if len(fb) else np.nan:.2f} H, the farther in "
              f"{np.median(fb[:, 3]) if len(fb) else np.nan:.0%} of those frames (tracked "
              f"walkers: {len(gb)} of {len(g)} beside another, "
              f"{np.median(gb[:, 2]) if len(gb) else np.nan:.2f} H, "
              f"{np.median(gb[:, 3]) if len(gb) else np.nan:.0%})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
