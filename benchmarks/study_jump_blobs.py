"""What the counting tracker's pieces that end by the velocity jump were placed on (issue 16,
counting; a diagnostic, nothing chosen): for every placement `PedestrianLevel._place` makes,
the width of the box of the blobs it was placed on, in units of its patch width W at the
prediction, and whether that blob was shared with another pedestrian; then, for every piece
that ends by the velocity jump (`life.max_dv_mps`) on a walker (`study_track_ends.piece_owner`),
the widest such box over the `--last` frames around its end (before it and the frames the
jump rule dropped: the piece's rows stop before the jump) against all placements, and its
worst placed foot point against the walker's truth box (bottom centre) over those frames, by
the ground depth y where it ended; and what the patch stood on in the frames the jump rule
dropped (`dropped_on`: its own walker, another walker, a non-walker or nothing, by the truth box
it overlaps most, IoU >= 0.3, in most of those frames); and in those frames how far from the
walker's truth foot row the placed foot row was, against the foot row its head implies (the top
row of its blobs in the patch's columns taken as a 1.7 m walker's head: `head_foot_row`).

    python benchmarks/study_jump_blobs.py count --seed 150001 --scenes 10 \\
        [--clothing any] [--focal-px 500] [--set KEY=JSON ...] [--last 8]

SOURCE as `count_dump.py`. The placements are observed by wrapping `place_patch` and `gated`
in `count.pedestrian_level`'s namespace for the run (restored after).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from contextlib import contextmanager

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

WIDTHS = (2.0, 3.0, 4.0, 6.0)  # blob box widths reported, W
DEPTHS = ((0.0, 10.0), (10.0, 15.0), (15.0, 20.0), (20.0, 1e9))  # ground y bands, m


@contextmanager
def watched_placements(module, log: dict, speeds: dict | None = None):
    """Within the block, every placement `module` (count.pedestrian_level) gates is logged:
    log[id(pedestrian)][frame index] = (blob box width / W, shared, placed u, placed v, the
    patch's w, h px, the foot row its head implies px (`head_foot_row`; NaN: none)); with
    `speeds`, every velocity jump `module.PedestrianLevel._velocity_jump` finds too:
    speeds[id(pedestrian)] = (its ground speed k rows before, at the jump, |change of the
    velocity|) m/s."""
    place, gated = module.place_patch, module.gated
    last: dict = {}
    alive: list = []  # every pedestrian logged, kept so that no id is reused in the block

    def place_logged(labels, related, claimed, shape, u, v, *, radius_px, bbox=None, **kw):
        w0 = float(shape.size(u, v)[0])
        last["ratio"] = (bbox[2] - bbox[0]) / w0 if bbox is not None else np.nan
        last["shared"] = radius_px < 0.5 * w0  # the shared radius (0.3 W) against 0.75 W
        pl = place(labels, related, claimed, shape, u, v, radius_px=radius_px, bbox=bbox, **kw)
        last["head_v"] = (np.nan if pl is None or labels is None else
                          head_foot_row(labels, related, claimed, shape, pl))
        return pl

    def gated_logged(level, p, pl):
        if id(p) not in log:
            alive.append(p)
        log.setdefault(id(p), {})[level.n_frames - 1] = (last["ratio"], last["shared"], pl.u,
                                                          pl.v, pl.w, pl.h, last["head_v"])
        return gated(level, p, pl)

    module.place_patch, module.gated = place_logged, gated_logged
    level_class = getattr(module, "PedestrianLevel", None) if speeds is not None else None
    jump = level_class._velocity_jump if level_class is not None else None

    def jump_logged(level, p):
        k = jump(level, p)
        if k:
            alive.append(p)
            (ax, ay), (bx, by) = ((g.vx, g.vy) for g in (p.ground[-1 - k], p.ground[-1]))
            speeds[id(p)] = (float(np.hypot(ax, ay)), float(np.hypot(bx, by)),
                             float(np.hypot(bx - ax, by - ay)))
        return k

    if jump is not None:
        level_class._velocity_jump = jump_logged
    try:
        yield
    finally:
        module.place_patch, module.gated = place, gated
        if jump is not None:
            level_class._velocity_jump = jump


def head_foot_row(labels, related, claimed, shape, pl) -> float:
    """The foot row px of a walker whose head is the top row of the `related` blobs (not
    `claimed`) in the columns of the placement `pl` (`widths.measured_top`, up to
    `pedestrian_level.TOP_REACH` patch heights above its foot row), from the camera
    (`head_feet.head_foot_row`); NaN where there is no top row or no such foot row."""
    from rhythmjax.count.head_feet import head_foot_row as foot_of_head
    from rhythmjax.count.pedestrian_level import TOP_REACH
    from rhythmjax.count.widths import measured_top

    top = measured_top(labels, related, claimed, pl.u, pl.v, pl.w, TOP_REACH * pl.h)
    if not np.isfinite(top):
        return np.nan
    v = foot_of_head(shape, pl.u, top, labels.shape[0])
    return np.nan if v is None else float(v)


def truth_foot(truth, walker: int, frame: int, offset: int):
    """The walker's truth foot point (box bottom centre, px) in frame index `frame`, or None."""
    from study_track_ends import truth_frame

    k = np.flatnonzero((truth["id"] == walker) & (truth["frame"] == truth_frame(frame, offset)))
    if not len(k):
        return None
    i = k[0]
    return truth["bb_left"][i] + 0.5 * truth["bb_width"][i], truth["bb_top"][i] + truth[
        "bb_height"][i]


OFF_HEIGHTS = 0.1  # a placed foot row this many patch heights from the truth's is off (a priori)
DROPPED_ON = ("own walker", "another walker", "non-walker", "nothing", "not placed")


def dropped_on(placed: list[tuple], truth, kinds, walker: int, offset: int) -> str:
    """What the patch stood on over `placed` ((frame index, u, v, w, h) px; the frames the jump
    rule dropped): per frame the truth object whose box the patch box overlaps most (IoU >=
    0.3), then the most frequent (ties in `DROPPED_ON` order); "not placed" for no frame."""
    from study_track_ends import truth_frame

    from rhythmjax.evaluation.motscore import iou_matrix

    if not placed:
        return "not placed"
    votes = dict.fromkeys(DROPPED_ON, 0)
    for f, u, v, w, h in placed:
        k = np.flatnonzero(truth["frame"] == truth_frame(f, offset))
        tb = np.stack([np.asarray(truth[c])[k] for c in ("bb_left", "bb_top", "bb_width",
                                                          "bb_height")], 1)
        iou = iou_matrix(np.array([[u - 0.5 * w, v - h, w, h]], np.float64), tb)[0]
        if not len(k) or iou.max() < 0.3:
            votes["nothing"] += 1
            continue
        t = int(truth["id"][k[int(np.argmax(iou))]])
        votes["own walker" if t == walker else "another walker"
              if kinds.get(t) == "pedestrian" else "non-walker"] += 1
    return max(DROPPED_ON, key=lambda c: (votes[c], -DROPPED_ON.index(c)))


def jump_pieces(pieces, log, truth, kinds, offset: int, last: int, owner=None,
                speeds: dict | None = None) -> list[dict]:
    """One record per piece ended by the velocity jump on a walker: the widest blob box (W) and
    whether any placement was shared within `last` frames of its end (either side), the worst
    |du|, |dv| px of its placed foot points there against the truth, the ground y (m) where
    it ended, and what its patch stood on in the frames after its last row (`dropped_on`,
    within `last` frames); over those frames the median |dv| px of the placed foot row and of
    the foot row its head implies against the walker's truth (`dv_placed`, `dv_head`; NaN:
    no such frame), the largest placed |dv| px there (`dv_worst`), the dropped frames with a
    truth (`placed_frames`) and those whose placed foot row is more than `OFF_HEIGHTS` patch
    heights off (`off_rows`), the median |du| px of the placed column (`du_placed`), the median
    |dv| px over its own last `last` rows before the end (`dv_kept`), the frames with both a
    truth and a head row (`head_frames`) and the piece's rows (`rows`); in the dropped frames
    that are off and have a head row (`head_off_frames`) the median |dv| px of the foot row
    from the head and of the placed one (`dv_head_off`, `dv_placed_off`).
    With `speeds` (`watched_placements`): `speed_before`, `speed_at`, `dv_mps` m/s (NaN where
    not recorded). `owner(boxes, truth, offset, kinds)` -> (walker id, kind): by default
    `study_track_ends.piece_owner`."""
    from study_track_ends import piece_owner

    owner = owner or piece_owner
    out = []
    for p in pieces:
        if p.end_reason != "velocity-jump":
            continue
        walker, kind = owner(p.boxes, truth, offset, kinds)
        if kind != "pedestrian":
            continue
        end = p.boxes[-1].frame
        seen = {f: v for f, v in log.get(id(p), {}).items() if abs(f - end) <= last}
        after = [(f, *x[2:6]) for f, x in sorted(seen.items()) if f > end]
        du = dv = 0.0
        placed_du, placed_dv, head_dv, kept_dv, off_rows = [], [], [], [], 0
        head_off, placed_off = [], []  # in the dropped frames off by more than OFF_HEIGHTS
        for f, x in seen.items():
            t = truth_foot(truth, walker, f, offset)
            if t is not None:
                du, dv = max(du, abs(x[2] - t[0])), max(dv, abs(x[3] - t[1]))
                if f <= end:
                    kept_dv.append(abs(x[3] - t[1]))
                else:
                    placed_du.append(abs(x[2] - t[0]))
                    placed_dv.append(abs(x[3] - t[1]))
                    off = abs(x[3] - t[1]) > OFF_HEIGHTS * x[5]
                    off_rows += off
                    if np.isfinite(x[6]):
                        head_dv.append(abs(x[6] - t[1]))
                        if off:
                            head_off.append(abs(x[6] - t[1]))
                            placed_off.append(abs(x[3] - t[1]))
        seen = list(seen.values())
        out.append({"ratio": max((s[0] for s in seen), default=np.nan),
                    "shared": any(s[1] for s in seen), "du": du, "dv": dv,
                    "y": p.ground[-1].y,
                    "dropped_on": dropped_on(after, truth, kinds, walker, offset),
                    "dv_kept": float(np.median(kept_dv)) if kept_dv else np.nan,
                    "du_placed": float(np.median(placed_du)) if placed_du else np.nan,
                    "dv_placed": float(np.median(placed_dv)) if placed_dv else np.nan,
                    "dv_worst": float(np.max(placed_dv)) if placed_dv else np.nan,
                    "off_rows": int(off_rows),
                    "dv_head": float(np.median(head_dv)) if head_dv else np.nan,
                    "head_frames": len(head_dv), "rows": len(p.boxes),
                    "dv_head_off": float(np.median(head_off)) if head_off else np.nan,
                    "dv_placed_off": float(np.median(placed_off)) if placed_off else np.nan,
                    "head_off_frames": len(head_off),
                    "placed_frames": len(placed_dv)})
        if speeds is not None:
            out[-1].update(zip(("speed_before", "speed_at", "dv_mps"),
                               speeds.get(id(p), (np.nan,) * 3)))
    return out


def own_walker_line(jumps: list[dict]) -> str | None:
    """The summary of the jump pieces whose dropped frames stood on their own walker
    (`jump_pieces` records): their rows, the placed foot point against the truth in the dropped
    frames and the foot row in their own last rows, and the foot row from the head where there
    is one (medians over pieces; the upper quartile of the dropped frames' |dv|); None: none."""
    own = [j for j in jumps if j["dropped_on"] == "own walker"]
    if not own:
        return None
    head = [j for j in own if j["head_frames"]]
    head_off = [j for j in own if j["head_off_frames"]]

    def med(js, key):
        return float(np.nanmedian([j[key] for j in js])) if js else np.nan

    upper = float(np.nanpercentile([j["dv_placed"] for j in own], 75))
    return (f"  on its own walker ({len(own)} pieces, {med(own, 'rows'):.0f} rows): foot point "
            f"off the truth in the dropped frames by |du| {med(own, 'du_placed'):.1f}, |dv| "
            f"{med(own, 'dv_placed'):.1f} px (a quarter of the pieces over {upper:.1f}), at "
            f"worst |dv| {med(own, 'dv_worst'):.1f} px; dropped frames off by more than "
            f"{OFF_HEIGHTS:g} H: {med(own, 'off_rows'):.0f} of each piece's "
            f"{med(own, 'placed_frames'):.0f}; in "
            f"its own last rows |dv| {med(own, 'dv_kept'):.1f} px; {len(head)} pieces with a "
            f"head row in the dropped frames, the foot row it implies off by "
            f"{med(head, 'dv_head'):.1f} px (placed, in those: {med(head, 'dv_placed'):.1f}); "
            f"in the off frames ({len(head_off)} pieces with a head row there) "
            f"{med(head_off, 'dv_head_off'):.1f} px (placed {med(head_off, 'dv_placed_off'):.1f}); "
            "medians over pieces" + (
                f"; ground speed {med(own, 'speed_before'):.2f} m/s k rows before the jump, "
                f"{med(own, 'speed_at'):.2f} at it, velocity change {med(own, 'dv_mps'):.2f}"
                if "dv_mps" in own[0] else ""))


def main(argv=None) -> int:
    from count_dump import clips_of

    import rhythmjax.count.pedestrian_level as level_module
    from rhythmjax.count import CountOptions
    from rhythmjax.track.options import with_changes
    from rhythmjax.vision.frames import drive_frames

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source")
    ap.add_argument("--seed", default="150001")
    ap.add_argument("--scenes", type=int, default=10)
    ap.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    ap.add_argument("--focal-px", type=float, default=0.0)
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--last", type=int, default=8, help="frames before the end looked at")
    a = ap.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    ratios, shared, jumps = [], [], []
    for seed in a.seed.split(","):
        for _name, cfg, frames, truth, kinds, off, _ in clips_of(a.source, int(seed), a.scenes,
                                                                a.clothing, a.focal_px):
            log: dict = {}
            speeds: dict = {}
            level = level_module.PedestrianLevel(cfg, opt, defer=True)
            with watched_placements(level_module, log, speeds):
                drive_frames(iter(frames), level.update, None, n_frames=len(frames),
                             progress=False)
                pieces = level.end_all()
            ratios += [v[0] for per in log.values() for v in per.values()]
            shared += [v[1] for per in log.values() for v in per.values()]
            jumps += jump_pieces(pieces, log, truth, kinds, off, a.last, speeds=speeds)
    ratios = np.asarray(ratios, np.float64)
    widest = np.asarray([j["ratio"] for j in jumps], np.float64)
    print(f"{len(ratios)} placements ({np.mean(shared):.2f} shared); {len(jumps)} pieces ended "
          "by the velocity jump on a walker "
          f"({sum(j['shared'] for j in jumps)} with a shared placement within {a.last} frames "
          "of the end)")
    for t in WIDTHS:
        print(f"  blobs wider than {t:g} W: {np.nanmean(ratios > t):.2f} of all placements, "
              f"{np.nanmean(widest > t):.2f} of the jump pieces (within {a.last} frames of "
              "the end)")
    for lo, hi in DEPTHS:
        sel = [j for j in jumps if lo <= j["y"] < hi]
        if sel:
            print(f"  ended at y {lo:g}-{hi:g} m: {len(sel)} pieces, worst placed foot point "
                  f"off the truth by |du| {np.median([j['du'] for j in sel]):.1f}, |dv| "
                  f"{np.median([j['dv'] for j in sel]):.1f} px (medians)")
    on = {c: sum(j["dropped_on"] == c for j in jumps) for c in DROPPED_ON}
    print("  the patch in the frames the jump rule dropped stood on: "
          + ", ".join(f"{c} {n}" for c, n in on.items()))
    line = own_walker_line(jumps)
    if line:
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
