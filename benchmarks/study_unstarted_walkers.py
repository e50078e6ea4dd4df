"""Why the counting tracker never follows some walkers of the own counting scenes or the dev
crowds (issue 16, twenty-fifth round; a study). The counting run of `count_dump.py` is
repeated with the refinement (`count.refinement.new_pedestrians`, as `count.pedestrian_level`
calls it) and the pedestrians' ends watched. For every walker no output track follows (`eval_count.
owner_of_tracks`: IoU >= 0.3 in half the track's frames) each of its truth frames gets one
cause, the first that holds:
- `tracked`: a live pedestrian's patch (tentative or confirmed) covers its box at IoU >= 0.3,
  split by what that pedestrian's output track follows in the end (another walker, nothing, a
  non-walker; directly or after stitching joined it behind an earlier track), or no output track;
- `no mask`: no foreground pixel in the lower half of its box;
- `free` (first where a run of free columns holds its centre column: with `new.cover_to_feet`
  a run can lie under a cover, below its foot row): as below;
- `covered`: its box's centre column lies in another pedestrian's cover (`new.walker_widths`
  W around that one's foot point, rows overlapping) and in no free run; split by whether the
  cover's pedestrian stands nearer (its foot row lower) or farther;
- `free`: its centre column is free but no pedestrian starts there, split by the test its run
  of free columns fails (`count.refinement.free_runs`: narrow, thin, short, lifted), or it
  passes and its pedestrians started at other columns, or it passes and no one started on it
  (its foot points out of the detection range), or no run holds it (the column has no pixel of
  a blob); for free frames also how far the run's bottom lies above the box's, in box heights;
and every pedestrian started on it (its first foot point inside the walker's box columns and
within 0.25 of its height of the box bottom) gets its fate: `tentative` (dropped before
`life.confirm_hits` measured frames, or with no ground point), `short` (confirmed, under
`verdicts.min_track_frames` rows left), `output` (an output track; it then follows someone else
or nothing). Per condition: the frames by cause, the walkers by their main cause, the starts by
fate. Nothing in the library changes; nothing is chosen here.

    python benchmarks/study_unstarted_walkers.py --seed 160001,160002 --scenes 10 \
        [--clothing any] [--focal-px 500] [--pairs 0.5] [--set KEY=JSON ...]
    RHYTHMJAX_DATA=../shared/data python benchmarks/study_unstarted_walkers.py dev_count
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections import Counter

import numpy as np

from rhythmjax.count.refinement import REFUSALS, covers, free_runs


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

BOX = ("bb_left", "bb_top", "bb_width", "bb_height")
START_ROWS = 0.25  # a start's foot row within this fraction of the box height of its bottom
TRACKS = ("another walker's track", "a track on nothing", "a track on a non-walker")
WHOSE = TRACKS + tuple("stitched into " + t for t in TRACKS) + ("no output track",)
CAUSES = (tuple("tracked: " + t for t in WHOSE)
          + ("no mask", "covered by a nearer", "covered by a farther")
          + tuple("free: " + r for r in REFUSALS + ("started elsewhere on its run",
                                                     "no start on its run (out of range)",
                                                     "no run there")))
FATES = ("tentative", "short") + tuple("output: " + t for t in WHOSE)


class Watch:
    """What the refinement saw each frame: the covers and the mask, the live patches, the
    pedestrians it started (their first foot point)."""

    def __init__(self, offset: int = -1):
        self.offset = offset  # truth frame = frame index + 1 + offset (`count_dump.clips_of`)
        self.frames: dict[int, dict] = {}
        self.starts: list[tuple[int, tuple, object]] = []  # (frame, z, Pedestrian)

    def hook(self, level, blobs, labels, inner):
        f = level.n_frames + self.offset  # the truth's frame (the clips' frames from index 0)
        cover, live = [], []
        for p, c in covers(level):
            uv = p.z if _finite(p.z) else p.next_uv
            if not _finite(uv):
                continue
            cover.append((*c, uv[1]))
            b = level.patch_at(uv)
            live.append(((b[0], b[1], b[2] - b[0], b[3] - b[1]), p))
        fg = None if labels is None else labels > 0
        runs = [] if labels is None else [(r.x0 + r.c0, r.x0 + r.c1, r.refused, r.vb)
                                          for r in free_runs(level, blobs, labels)]
        new = inner(level, blobs, labels)
        runs = [(c0, c1, refused or ("started elsewhere on its run" if any(
            c0 <= p.z[0] < c1 for p in new) else "no start on its run (out of range)"), vb)
            for c0, c1, refused, vb in runs]
        self.frames[f] = {"covers": cover, "live": live, "fg": fg, "runs": runs}
        self.starts += [(f, tuple(p.z), p) for p in new]
        return new


def _finite(uv) -> bool:
    return math.isfinite(uv[0]) and math.isfinite(uv[1])


def frame_cause(seen: dict | None, box: np.ndarray, whose, lifts: list | None = None) -> str:
    """One truth frame's cause (module doc) from what the refinement saw that frame; a frame a
    live patch covers is split by `whose(pedestrian)`: what its track follows in the end. A free
    frame's run bottom above the box bottom, in box heights, is appended to `lifts`."""
    from rhythmjax.evaluation.motscore import iou_matrix

    if seen is None or seen["fg"] is None:
        return "no mask"
    if seen["live"]:
        iou = iou_matrix(np.asarray([b for b, _ in seen["live"]], np.float64), box[None])[:, 0]
        if iou.max() >= 0.3:
            return "tracked: " + whose(seen["live"][int(np.argmax(iou))][1])
    x0, y0, w, h = box
    H, Wi = seen["fg"].shape
    r0, r1 = int(max(0, y0 + 0.5 * h)), int(min(H, y0 + h))
    c0, c1 = int(max(0, x0)), int(min(Wi, x0 + w))
    if r1 <= r0 or c1 <= c0 or not seen["fg"][r0:r1, c0:c1].any():
        return "no mask"
    uc, vb = x0 + 0.5 * w, y0 + h
    for c0, c1, refused, vb_run in seen["runs"]:  # (under a cover only with new.cover_to_feet)
        if c0 <= uc < c1:
            if lifts is not None:
                lifts.append((vb - vb_run) / h)
            return "free: " + refused
    for cx0, cy0, cx1, cy1, foot in seen["covers"]:
        if cx0 <= uc < cx1 and cy0 < y0 + h and cy1 > y0:
            return "covered by a nearer" if foot > vb else "covered by a farther"
    return "free: no run there"


def start_fate(p, min_rows: int) -> str:
    """A started pedestrian's fate (module doc; `output` also when stitching joined it)."""
    if p.track_id == 0:
        return "tentative"
    return "output" if len(p.rows) >= min_rows else "short"


def follows(p, owner: dict, kinds: dict, holder: dict) -> str:
    """What a pedestrian's output track follows in the end (`owner_of_tracks`), in words; one
    stitched behind an earlier track (`holder`: row id -> the track holding it) says so."""
    if p.track_id == 0 or p.track_id not in owner:
        into = holder.get(id(p.rows[0])) if p.rows else None
        if into is None or into is p:
            return "no output track"
        return "stitched into " + follows(into, owner, kinds, holder)
    o = owner[p.track_id]
    return ("a track on nothing" if o is None else "another walker's track"
            if kinds.get(o) == "pedestrian" else "a track on a non-walker")


def study_clip(cfg, frames, truth, kinds, opt, offset: int = -1):
    """(frame causes, walker main causes, start fates) Counters and the free frames' lifts of
    one clip (`offset`: truth frame = MOT frame + offset, as `count_dump.clips_of` gives)."""
    import eval_count as ec

    from rhythmjax.count import count_frames, pedestrian_level as pl

    watch, inner = Watch(offset), pl.new_pedestrians
    pl.new_pedestrians = lambda level, blobs, labels: watch.hook(level, blobs, labels, inner)
    try:
        res = count_frames(cfg, iter(frames), n_frames=len(frames), options=opt)
    finally:
        pl.new_pedestrians = inner
    owner = ec.owner_of_tracks(truth, res.mot, offset)
    followed = {o for o in owner.values() if o is not None}
    holder = {id(r): q for _, _, q in watch.starts if q.track_id in owner for r in q.rows}
    causes, mains, fates, lifts = Counter(), Counter(), Counter(), []
    tb = np.stack([np.asarray(truth[c], np.float64) for c in BOX], 1)
    for wid in (w for w, k in kinds.items() if k == "pedestrian" and w not in followed):
        rows = np.flatnonzero(truth["id"] == wid)
        if not rows.size:
            continue
        mine = Counter(frame_cause(watch.frames.get(int(truth["frame"][j])), tb[j],
                                   lambda q: follows(q, owner, kinds, holder), lifts)
                       for j in rows)
        causes.update(mine)
        mains[max(mine, key=mine.get)] += 1
        frame_of = {int(truth["frame"][j]): tb[j] for j in rows}
        for f, z, p in watch.starts:
            b = frame_of.get(f)
            if b is not None and b[0] <= z[0] < b[0] + b[2] and \
                    abs(z[1] - (b[1] + b[3])) <= START_ROWS * b[3]:
                fate = start_fate(p, opt.verdicts.min_track_frames)
                if fate == "output":
                    fate += ": " + follows(p, owner, kinds, holder)
                fates[fate] += 1
        fates["walkers"] += 1
    return causes, mains, fates, lifts


def main(argv=None) -> int:
    from count_dump import clips_of

    from rhythmjax.count import CountOptions
    from rhythmjax.track.options import with_changes

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("source", nargs="?", default="count", choices=("count", "dev_count"))
    p.add_argument("--seed", default="160001")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    p.add_argument("--focal-px", type=float, default=0.0)
    p.add_argument("--pairs", type=float, default=0.0)
    p.add_argument("--pair-layout", default="side", choices=("side", "file", "late"))
    p.add_argument("--set", action="append", default=[])
    a = p.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    causes, mains, fates, lifts = Counter(), Counter(), Counter(), []
    for seed in a.seed.split(",") if a.source == "count" else ["0"]:
        for _, cfg, frames, truth, kinds, off, _ in clips_of(a.source, int(seed), a.scenes,
                                                             a.clothing, a.focal_px, a.pairs,
                                                             a.pair_layout):
            c, m, f, lift = study_clip(cfg, frames, truth, kinds, opt, off)
            causes, mains, fates, lifts = causes + c, mains + m, fates + f, lifts + lift
        print(seed, dict(mains), flush=True)
    n = max(sum(causes.values()), 1)
    print(f"untracked walkers: {fates['walkers']}")
    print("frames by cause: " + ", ".join(f"{k} {causes[k]} ({100 * causes[k] / n:.0f} %)"
                                          for k in CAUSES if causes[k]))
    print("walkers by main cause: " + ", ".join(f"{k} {mains[k]}" for k in CAUSES if mains[k]))
    if lifts:
        q = np.percentile(lifts, [10, 50, 90])
        print(f"free frames: the run's bottom above the box bottom {q[1]:.2f} box heights "
              f"(10-90 %: {q[0]:.2f} to {q[2]:.2f})")
    print("starts on them by fate: " + ", ".join(f"{k} {fates[k]}" for k in FATES if fates[k]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
