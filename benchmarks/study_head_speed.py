"""What a counting rule adds to the count, track by track: the tracks counted in AFTER.pkl but
not in BEFORE.pkl (two dumps of the same clips, e.g. `recount_dumps.py --rule head-speed`'s
output against its input), each put in one class: a walker no other counted track follows, a
walker already counted, a non-walker, or no one. A track follows the object its boxes overlap
(`eval_count.owner_of_tracks`, IoU >= 0.3 in half its frames) or, failing that, the walker whose
box's top 30 % holds the track's top row (`v_top`) and foot column in at least half of its rows
with a top row: a track on a walker's upper body stands its patch on the hips, too small and
too far to overlap the walker's box. Issue 16, rule 31 (docs/rules.md).

    python benchmarks/study_head_speed.py BEFORE.pkl AFTER.pkl [BEFORE2.pkl AFTER2.pkl ...]

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

HEAD_PART = 0.3  # the top fraction of a truth box that holds a walker's head
SLACK_PX = 5.0  # rows above the box's top still taken as its head (the box's rounding)


def head_owner(record: dict, tid: int) -> int | None:
    """The truth id whose box's top `HEAD_PART` holds the track's (u, v_top) in at least half
    of its rows with a top row; None if none does."""
    tr, truth = record["tracks"], record["truth"]
    k = np.asarray(tr["track_id"]) == tid
    frames = np.asarray(tr["frame"])[k]
    u, top = (np.asarray(tr[c], np.float64)[k] for c in ("u", "v_top"))
    tf = np.asarray(truth["frame"]) - record["offset"]
    left, width, btop, height = (np.asarray(truth[c], np.float64)
                                 for c in ("bb_left", "bb_width", "bb_top", "bb_height"))
    ids, votes, n = np.asarray(truth["id"]), Counter(), 0
    for f, uu, vv in zip(frames, u, top):
        if not (np.isfinite(uu) and np.isfinite(vv)):
            continue
        n += 1
        m = ((tf == f) & (left <= uu) & (uu <= left + width) & (btop - SLACK_PX <= vv)
             & (vv <= btop + HEAD_PART * height))
        votes.update(int(i) for i in ids[m])
    if not votes:
        return None
    best, count = votes.most_common(1)[0]
    return best if 2 * count >= n else None


def added_classes(before: dict, after: dict) -> Counter:
    """The classes (module doc) of the tracks counted in `after` and not in `before` (one
    clip's records)."""
    from eval_count import owner_of_tracks

    own = owner_of_tracks(before["truth"], before["mot"], before["offset"])
    ids = [int(t) for t in before["verdicts"]["track_id"]]
    was = np.asarray(before["verdicts"]["counted"], bool)
    now = np.asarray(after["verdicts"]["counted"], bool)
    out = Counter()
    for i in np.flatnonzero(now & ~was):
        tid = ids[i]
        o = own.get(tid)
        if o is None:
            o = head_owner(before, tid)
        kind = before["kinds"].get(o) if o is not None else None
        if kind is None:
            out["no one"] += 1
        elif kind != "pedestrian":
            out["non-walker"] += 1
        else:
            others = {own.get(t) for t, c in zip(ids, was) if c}
            out["walker counted already" if o in others else "walker not counted"] += 1
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="BEFORE.pkl AFTER.pkl pairs")
    a = ap.parse_args(argv)
    if len(a.runs) % 2:
        raise SystemExit("give BEFORE.pkl AFTER.pkl pairs")
    total = Counter()
    for b, f in zip(a.runs[::2], a.runs[1::2]):
        with open(b, "rb") as fb, open(f, "rb") as ff:
            before, after = pickle.load(fb), pickle.load(ff)
        got = Counter()
        for rb, ra in zip(before, after):
            if rb["clip"] != ra["clip"]:
                raise SystemExit(f"{b} and {f} hold different clips ({rb['clip']}, {ra['clip']})")
            got += added_classes(rb, ra)
        total += got
        print(f"{os.path.basename(f)}: added {sum(got.values())}: {dict(got)}")
    print(f"all: added {sum(total.values())}: {dict(total)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
