"""Why the counting tracker's pedestrians end, and what the walkers do afterwards: every
confirmed piece `PedestrianLevel` ends (before stitching) with its `end_reason`, the walker
it follows (IoU >= 0.3 with the walker's truth box in at least half its frames, as
`eval_count.owner_of_tracks`), whether that walker stays in view for at least `--after` s more
and how long until another piece follows it again; for a walker's consecutive pieces, whether
the stitching joined them, why not (`walker_pairs`) and what covered the walker in between.
A diagnostic (issue 16, counting): a piece that ends on a walker who walks on is a fragment
the count must stitch or double-counts. With `--set life.jump_rewind=true` also the pieces that
went back at a velocity jump instead of ending, and how they ended (`rewind_summary`).

    python benchmarks/study_track_ends.py count --seed 150001,... --scenes 10 \\
        [--clothing any] [--focal-px 500] [--set KEY=JSON ...] [--detail]

SOURCE as `count_dump.py` (pets, count, dev_count).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections import Counter

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def piece_owner(boxes, truth, offset: int, kinds: dict, min_iou: float = 0.3):
    """The truth id a piece's boxes (BoxRow list) overlap with IoU >= min_iou in at least half
    of its frames, else None; and its kind. A box of frame index k meets the truth rows of frame
    k + 1 + offset (`truth_frame`)."""
    from eval_count import iou_matrix

    votes: Counter = Counter()
    tb = np.stack([truth[c] for c in ("bb_left", "bb_top", "bb_width", "bb_height")], 1)
    for b in boxes:
        k = np.flatnonzero(truth["frame"] == truth_frame(b.frame, offset))
        if not len(k):
            continue
        iou = iou_matrix(np.array([[b.left, b.top, b.w, b.h]]), tb[k])[0]
        if iou.max() >= min_iou:
            votes[int(truth["id"][k[int(np.argmax(iou))]])] += 1
    if not votes:
        return None, None
    best, n = votes.most_common(1)[0]
    return (best, kinds[best]) if n >= 0.5 * len(boxes) else (None, None)


def truth_frame(index: int, offset: int) -> int:
    """The truth's frame number of frame index `index`: the MOT frame (index + 1) plus the
    clip's `offset`, as `eval_count.owner_of_tracks` reads them (own scenes: offset -1, truth
    numbered from 0; dev clips: 0, from 1)."""
    return index + 1 + offset


def rewind_fate(p) -> tuple[int, int]:
    """(times the piece went back at a velocity jump (`life.jump_rewind`), its measured rows
    after the last of them); (0, 0) for a piece never rewound."""
    from rhythmjax.model.status import TrackState

    if not p.rewind_times:
        return 0, 0
    last = p.rewind_times[-1]
    return len(p.rewind_times), sum(r.t > last and r.state == TrackState.OBSERVE
                                    for r in p.rows)


def study_clip(name, cfg, frames, truth, kinds, offset, opt, after_s: float):
    """Per ended piece: [clip, id, first, last, reason, owner, kind, walker_goes_on, gap_s,
    y_m, final, counted, rewinds, measured_after]; gap_s: a piece on a walker, from its last
    frame to the first of the walker's next piece (NaN: none, or not on a walker); y_m: its
    last ground distance (the filter's); final: the output track holding it (0: none), counted:
    whether that track is counted; rewinds, measured_after: `rewind_fate`; and the
    `walker_pairs` of the clip, each with its outcome."""
    from rhythmjax.count.counting import finish_count
    from rhythmjax.count.pedestrian_level import PedestrianLevel
    from rhythmjax.count.still import peek_background
    from rhythmjax.vision.frames import drive_frames

    b = opt.blobs
    background, it = peek_background(iter(frames), b.bg_init_s, b.bg_init_frames)
    level = PedestrianLevel(cfg, opt, defer=True, background=background)
    drive_frames(it, level.update, None, n_frames=len(frames), progress=False, desc="count")
    pieces = level.end_all()
    fps = float(cfg.camera.fps)
    rows = []
    for p in pieces:
        own, kind = piece_owner(p.boxes, truth, offset, kinds)
        first, last = p.boxes[0].frame, p.boxes[-1].frame
        goes_on = False
        if own is not None:
            tf = truth["frame"][truth["id"] == own] - truth_frame(0, offset)  # as indices
            goes_on = bool(np.sum(tf > last) >= after_s * fps)
        rows.append([name, p.track_id, first, last, p.end_reason, own, kind, goes_on, np.nan,
                     round(float(p.boxes[-1].y), 1)])
    keys = [(p.boxes[0].frame, p.boxes[0].left, p.boxes[0].top) for p in pieces]
    fates = [rewind_fate(p) for p in pieces]  # before the stitching joins pieces' rows
    pairs = walker_pairs(level, pieces, rows, truth, offset)  # before stitching joins pieces
    for q in pairs:
        rows[q["a"]][8] = (rows[q["b"]][2] - rows[q["a"]][3]) / fps
    res = finish_count(level)
    final = final_tracks(res, keys)
    counted = {int(i): bool(c) for i, c in zip(res.verdicts["track_id"],
                                                res.verdicts["counted"])}
    for r, f, fate in zip(rows, final, fates):
        r += [f, counted.get(f, False), *fate]
    for q in pairs:  # each ends as one output track, or two both counted, or else
        fa, fb = final[q["a"]], final[q["b"]]
        q["outcome"] = ("joined" if fa and fa == fb else "two counted"
                        if counted.get(fa) and counted.get(fb) else "other")
    return rows, res, pairs


def walker_pairs(level, pieces, rows, truth, offset: int) -> list[dict]:
    """Each piece on a walker and that walker's next piece (by first frame): why
    `stitch.stitch_pieces` could not join them ("overlap": B starts before A ends; "gap" over
    stitch.max_gap_s; "position" / "velocity": the halfway misfit d / dv over its gate; "in gate":
    a candidate, so A or B was joined to another piece), and, over the frames between them, how
    often the walker's truth box was covered (IoU >= 0.3) by a piece on another walker, on a
    non-walker, on nothing, or not at all."""
    from eval_count import iou_matrix

    from rhythmjax.count.stitch import halfway_misfit, piece_of

    st, kinds_of = level.opt.stitch, {i: r[6] for i, r in enumerate(rows)}
    built = [piece_of(p, level.shape, level.opt.dynamics, st.fit_s) for p in pieces]
    by_frame: dict[int, list] = {}
    for j, p in enumerate(pieces):
        for b in p.boxes:
            by_frame.setdefault(b.frame, []).append((j, (b.left, b.top, b.w, b.h)))
    out = []
    for a, r in enumerate(rows):
        if r[6] != "pedestrian":
            continue
        later = [j for j, q in enumerate(rows) if q[5] == r[5] and q[2] > r[2]]
        if not later:
            continue
        b = min(later, key=lambda j: rows[j][2])
        A, B = built[a], built[b]
        gap = B.t_first - A.t_last
        if B.first <= A.last:
            why = "overlap"
        elif gap > st.max_gap_s:
            why = "gap"
        else:
            d, dv = halfway_misfit(A, B, level.shape.camera, gate_w=st.gate_w, gate_h=st.gate_h,
                                   gate_per_s=st.gate_per_s, max_dv_w=st.max_dv_w)
            why = "position" if not d <= 1 else "velocity" if not dv <= 1 else "in gate"
        cover = {"other walker": 0, "non-walker": 0, "nothing": 0, "uncovered": 0}
        for f in range(rows[a][3] + 1, rows[b][2]):
            k = np.flatnonzero((truth["id"] == r[5]) & (truth["frame"] == truth_frame(f, offset)))
            if not len(k):
                continue
            tb = np.stack([truth[c][k] for c in ("bb_left", "bb_top", "bb_width", "bb_height")],
                          1)
            on = [j for j, box in by_frame.get(f, []) if iou_matrix(np.array([box]), tb)[0, 0]
                  >= 0.3]
            kind = kinds_of[on[0]] if on else "uncovered"
            cover[{"pedestrian": "other walker", None: "nothing", "uncovered": "uncovered"}.get(
                kind, "non-walker")] += 1
        out.append({"a": a, "b": b, "gap_s": gap, "why": why, "cover": cover,
                    "goes_on": r[7]})
    return out


def final_tracks(res, keys) -> list[int]:
    """The output track id (0: dropped, too short or a ghost) holding each piece, found by its
    first box (index frame, left, top; the MOT frame is the index + 1)."""
    m = res.mot
    out = []
    for frame, left, top in keys:
        k = np.flatnonzero((m["frame"] == frame + 1) & (np.abs(m["bb_left"] - left) < 1e-3)
                           & (np.abs(m["bb_top"] - top) < 1e-3))
        out.append(int(m["id"][k[0]]) if len(k) else 0)
    return out


def rewind_summary(rows, enough: int = 15) -> str:
    """One line on the pieces that went back at a velocity jump (rows of `study_clip`): how
    many, by number of rewinds (1, 2, 3 or more), and by end reason with how many of them were
    measured in at least `enough` rows (1 s at 15 fps) after their last rewind."""
    rw = [r for r in rows if r[12] > 0]
    times = Counter(min(r[12], 3) for r in rw)
    ends = Counter(r[4] for r in rw)
    held = Counter(r[4] for r in rw if r[13] >= enough)
    return (f"rewound pieces {len(rw)} (once {times[1]}, twice {times[2]}, 3+ {times[3]}); by "
            f"end, with >= {enough} measured rows after the last rewind: " +
            ", ".join(f"{k} {ends[k]} ({held[k]})" for k in sorted(ends)))


def main(argv=None) -> int:
    from count_dump import clips_of

    from rhythmjax.count import CountOptions
    from rhythmjax.track.options import with_changes

    p = argparse.ArgumentParser()
    p.add_argument("source")
    p.add_argument("--seed", default="42024", help="one seed or a comma list")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    p.add_argument("--focal-px", type=float, default=0.0)
    p.add_argument("--set", action="append", default=[])
    p.add_argument("--after", type=float, default=1.0, help="s the walker must stay in view")
    p.add_argument("--detail", action="store_true", help="one line per piece")
    a = p.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    allrows, allpairs, counted, true = [], [], 0, 0
    for seed in a.seed.split(","):
        for name, cfg, frames, truth, kinds, off, n_true in clips_of(
                a.source, int(seed), a.scenes, a.clothing, a.focal_px):
            rows, res, pairs = study_clip(name, cfg, frames, truth, kinds, off, opt, a.after)
            allrows += rows
            allpairs += pairs
            counted, true = counted + res.counts["walkers"], true + n_true
    print(f"pieces {len(allrows)}; walkers counted {counted} of {true}")
    print(f"{'end reason':14s} {'all':>5s} {'on walker':>9s} {'walker goes on':>14s} "
          f"{'re-found':>8s} {'gap median s':>12s} {'non-walker':>10s} {'nothing':>7s}")
    for reason in sorted({r[4] for r in allrows}):
        rs = [r for r in allrows if r[4] == reason]
        wk = [r for r in rs if r[6] == "pedestrian"]
        on = [r for r in wk if r[7]]
        gaps = [r[8] for r in on if np.isfinite(r[8])]
        print(f"{reason:14s} {len(rs):5d} {len(wk):9d} {len(on):14d} {len(gaps):8d} "
              f"{np.median(gaps) if gaps else np.nan:12.2f} "
              f"{sum(r[6] not in (None, 'pedestrian') for r in rs):10d} "
              f"{sum(r[5] is None for r in rs):7d}")
    # the pieces on a walker who walks on, and the walker's next piece: joined into one output
    # track by the stitching, or two output tracks both counted (a second counted track)
    on = [q for q in allpairs if q["goes_on"]]
    joined, both = (sum(q["outcome"] == k for q in on) for k in ("joined", "two counted"))
    print(f"pieces on a walker who walks on, re-found: {len(on)}; joined by the stitching "
          f"{joined}; two counted output tracks {both}; other (a piece dropped or not counted) "
          f"{len(on) - joined - both}")
    print("a walker's consecutive pieces: stitched / left as two counted tracks / other, by why "
          "the stitching could not join them; frames between them covered by a piece on")
    for why in ("overlap", "gap", "position", "velocity", "in gate"):
        qs = [q for q in allpairs if q["why"] == why]
        two = [q for q in qs if q["outcome"] == "two counted"]
        cov = {k: sum(q["cover"][k] for q in two) for k in
               ("other walker", "non-walker", "nothing", "uncovered")}
        print(f"  {why:9s} {sum(q['outcome'] == 'joined' for q in qs):4d} / {len(two):4d} / "
              f"{sum(q['outcome'] == 'other' for q in qs):4d}   two counted: " +
              ", ".join(f"{k} {v}" for k, v in cov.items()))
    print(rewind_summary(allrows))
    if a.detail:
        for r in allrows:
            print(*r)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
