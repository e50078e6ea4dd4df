"""Joining a walker's fragments by appearance (`count.appearance`, `AppearanceOptions`):
run, fit, and score ON against OFF.

    python benchmarks/eval_count_appearance.py run SOURCE OUT.pkl [--seed S] [--scenes 10]
                                                   [--no-look]
    python benchmarks/eval_count_appearance.py fit TRAIN.pkl TEST.pkl [--free] [--set KEY=JSON]
    python benchmarks/eval_count_appearance.py score RUN.pkl [RUN.pkl ...] [--set KEY=JSON ...]
    python benchmarks/eval_count_appearance.py joins RUN.pkl [...] [--detail] [--set KEY=JSON ...]

`run` tracks every clip of SOURCE (`count_dump.clips_of`: pets | count (own counting scenes,
--seed) | dev_count, report only) once, with the descriptors computed (they do not change the
tracking), and saves the ended tracks before stitching with what finishing needs (a pickle),
with the tracking's frames/s. `score` finishes each clip twice, exactly as `count.finish_count`
does (stitch, drop short and never-moving tracks, judge, count): OFF (`appearance.enabled`
false) and ON (true, the `AppearanceOptions` defaults changed by --set), and prints per source
walkers counted / true, per-clip |errors| summed, counted tracks on a non-walker / on no truth
object, MOTA and IDF1 (`score_mot`, as `eval_all.count_clip`). `fit` labels the time-ordered
pairs of ended tracks (before stitching) of each clip by the truth (`eval_count.owner_of_tracks`:
same truth walker or two different walkers) among those within reach (gap <= max_gap_s, within
reach_widths + reach_speed_mps x gap; --free: only those where A has no geometric successor and
B no geometric predecessor, the pairs the rule may join), picks the appearance threshold with
the best balanced accuracy (--criterion accuracy: plain accuracy) on TRAIN and reports it, and
the ROC AUC, on TEST (held out).
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import math
import os
import pickle
import sys
import time
from types import SimpleNamespace

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def options(sets: list[str], enabled: bool):
    from rhythmjax.count import CountOptions
    from rhythmjax.track.options import with_changes

    ch = {k: json.loads(v) for k, v in (x.split("=", 1) for x in sets)}
    ch["appearance.enabled"] = enabled
    return with_changes(CountOptions(), ch)


def run(source: str, out: str, seed: int, scenes: int, look: bool = True) -> None:
    from count_dump import clips_of

    from rhythmjax.count.pedestrian_level import PedestrianLevel
    from rhythmjax.count.still import peek_background
    from rhythmjax.vision.frames import drive_frames

    opt = options([], look)
    opt = dataclasses.replace(opt, verdicts=dataclasses.replace(opt.verdicts, online=False))
    rows = []
    for name, cfg, frames, truth, kinds, off, true in clips_of(source, seed, scenes):
        t0 = time.perf_counter()
        bg, it = peek_background(iter(frames), opt.blobs.bg_init_s, opt.blobs.bg_init_frames)
        level = PedestrianLevel(cfg, opt, defer=True, background=bg)
        drive_frames(it, level.update, None, n_frames=len(frames), progress=False, desc="count")
        peds = level.end_all()
        sec = time.perf_counter() - t0
        level.filter = SimpleNamespace(slots=level.filter.slots)  # picklable: what finishing
        level.bg = level.prev = level.gray = level.bg_init = level._pending = None  # reads
        level.prev_blobs = []
        rows.append({"clip": name, "level": level, "peds": peds, "truth": truth, "kinds": kinds,
                     "offset": off, "true": true, "frames": len(frames), "seconds": sec})
        print(f"{name}: {len(peds)} tracks, {len(frames) / sec:.1f} frames/s", flush=True)
    with open(out, "wb") as f:
        pickle.dump(rows, f)


def finish(row: dict, opt):
    """`count.finish_count` on a copy of the clip's ended tracks, with `opt`."""
    from rhythmjax.count.counting import build_result, ghost
    from rhythmjax.count.stitch import stitch_level

    level, peds = copy.copy(row["level"]), copy.deepcopy(row["peds"])
    level.opt, level.stitched = opt, 0
    peds = stitch_level(level, peds)
    kept = [p for p in peds if len(p.rows) >= opt.verdicts.min_track_frames]
    level.ghosts = sum(ghost(level, p) for p in kept)
    return build_result(level, [p for p in kept if not ghost(level, p)])


def score_clip(row: dict, res) -> dict:
    import eval_count as ec

    from rhythmjax.evaluation.motscore import score_mot

    truth, kinds, off = row["truth"], row["kinds"], row["offset"]
    walk = ec.walking_ids(res)
    seen = set(np.asarray(truth["id"]).tolist())
    twalk = [t for t in seen if kinds.get(t) == "pedestrian"]
    s = score_mot(truth, res.mot, frame_offset=off, walking_ids=walk, truth_walking_ids=twalk)
    own = ec.owner_of_tracks(truth, res.mot, off)
    return {"counted": len(walk), "true": row["true"], "mota": s.mota, "idf1": s.idf1,
            "nonwalker": sum(1 for h in walk if own.get(h) and kinds[own[h]] != "pedestrian"),
            "nobody": sum(1 for h in walk if own.get(h) is None),
            "stitched": res.summary["stitched"]}


def score(paths: list[str], sets: list[str]) -> None:
    for path in paths:
        rows = pickle.load(open(path, "rb"))
        line = [os.path.basename(path)]
        for enabled in (False, True):
            opt = options(sets, enabled)
            cs = [score_clip(r, finish(r, opt)) for r in rows]
            c, t = sum(x["counted"] for x in cs), sum(x["true"] for x in cs)
            err = sum(abs(x["counted"] - x["true"]) for x in cs)
            line.append(f"{'ON' if enabled else 'OFF'} {c}/{t} ({100 * err / t:.1f} %; "
                        f"non-walkers {sum(x['nonwalker'] for x in cs)}, on nobody "
                        f"{sum(x['nobody'] for x in cs)}; MOTA "
                        f"{np.mean([x['mota'] for x in cs]):.3f}, IDF1 "
                        f"{np.mean([x['idf1'] for x in cs]):.3f}; stitched "
                        f"{sum(x['stitched'] for x in cs)})")
        fps = sum(r["frames"] for r in rows) / sum(r["seconds"] for r in rows)
        print(" | ".join(line) + f" | tracking {fps:.1f} frames/s", flush=True)


def pairs(rows: list, look, only_free: bool = False) -> list[tuple[float, bool]]:
    """(appearance distance, same walker) of the time-ordered pairs of ended tracks within reach
    (`stitch.reach_misfit` <= 1, gap <= look.max_gap_s), both on a truth walker, both with a
    descriptor; `only_free`: only those the rule may join (A without a geometric successor, B
    without a geometric predecessor)."""
    import eval_count as ec

    from rhythmjax.count.appearance import appearance_distance
    from rhythmjax.count.counting import mot_table
    from rhythmjax.count.stitch import piece_of, reach_misfit, stitch_pieces

    out = []
    for r in rows:
        level, peds = r["level"], r["peds"]
        st = level.opt.stitch
        own = ec.owner_of_tracks(r["truth"], mot_table(peds), r["offset"])
        pcs = [piece_of(p, level.shape, level.opt.dynamics, st.fit_s) for p in peds]
        geo = stitch_pieces(pcs, max_gap_s=st.max_gap_s, gate_w=st.gate_w, gate_h=st.gate_h,
                            gate_per_s=st.gate_per_s, max_dv_w=st.max_dv_w,
                            camera=level.shape.camera, reid=st.reid,
                            reid_max_dv_w=st.reid_max_dv_w)
        bw = float(level.cfg.width.mean)
        for a, A in enumerate(pcs):
            oa = own.get(peds[a].track_id)
            for b, B in enumerate(pcs):
                ob = own.get(peds[b].track_id)
                gap = B.t_first - A.t_last
                free = geo[a] < 0 and b not in geo
                if (B.first <= A.last or gap > look.max_gap_s or (only_free and not free)
                        or oa is None
                        or ob is None or r["kinds"].get(oa) != "pedestrian"
                        or r["kinds"].get(ob) != "pedestrian"):
                    continue
                if reach_misfit(A, B, level.shape.camera, look.reach_widths * bw,
                                look.reach_speed_mps) > 1.0:
                    continue
                d = appearance_distance(A.look, B.look)
                if math.isfinite(d):
                    out.append((d, oa == ob))
    return out


def joins(paths: list[str], sets: list[str], detail: bool = False) -> None:
    """Per source: the joins ON makes that OFF does not (and OFF's that ON refuses), and how
    many of them join two tracks on one truth walker (`eval_count.owner_of_tracks` of the
    tracks before stitching; "none": a track on no truth object)."""
    import eval_count as ec

    from rhythmjax.count.appearance import appearance_distance
    from rhythmjax.count.counting import mot_table
    from rhythmjax.count.stitch import piece_of, stitch_pieces

    look = options(sets, True).appearance
    for path in paths:
        made, same, none, lost = 0, 0, 0, 0
        for r in pickle.load(open(path, "rb")):
            level, peds = r["level"], r["peds"]
            st = level.opt.stitch
            own = ec.owner_of_tracks(r["truth"], mot_table(peds), r["offset"])
            pcs = [piece_of(p, level.shape, level.opt.dynamics, st.fit_s) for p in peds]
            kw = dict(max_gap_s=st.max_gap_s, gate_w=st.gate_w, gate_h=st.gate_h,
                      gate_per_s=st.gate_per_s, max_dv_w=st.max_dv_w,
                      camera=level.shape.camera, reid=st.reid, reid_max_dv_w=st.reid_max_dv_w)
            off = stitch_pieces(pcs, **kw)
            on = stitch_pieces(pcs, **kw, look=look, body_width_m=float(level.cfg.width.mean))
            for a, (b0, b1) in enumerate(zip(off, on)):
                lost += b0 >= 0 and b0 != b1
                if b1 >= 0 and b1 != b0:
                    oa, ob = own.get(peds[a].track_id), own.get(peds[b1].track_id)
                    made += 1
                    same += oa is not None and oa == ob
                    none += oa is None or ob is None
                    if detail:
                        A, B = pcs[a], pcs[b1]
                        print(f"  {r['clip']}: track {peds[a].track_id} (on {oa}) -> "
                              f"{peds[b1].track_id} (on {ob}), gap {B.t_first - A.t_last:.1f} s"
                              f", distance {appearance_distance(A.look, B.look):.3f}")
        print(f"{os.path.basename(path)}: ON joins {made} pairs OFF does not ({same} on one "
              f"truth object, {none} with a track on none, {made - same - none} on two); "
              f"{lost} of OFF's joins changed", flush=True)


def fit(train: str, test: str, sets: list[str], only_free: bool, criterion: str) -> None:
    look = options(sets, True).appearance
    tr = pairs(pickle.load(open(train, "rb")), look, only_free)
    te = pairs(pickle.load(open(test, "rb")), look, only_free)

    def bal(ps, thr):
        same = [d <= thr for d, s in ps if s]
        diff = [d > thr for d, s in ps if not s]
        return 0.5 * (np.mean(same) + np.mean(diff)) if same and diff else math.nan

    def auc(ps):
        s = np.asarray([d for d, x in ps if x])
        o = np.asarray([d for d, x in ps if not x])
        if not len(s) or not len(o):
            return math.nan
        return float(np.mean((s[:, None] < o[None, :]) + 0.5 * (s[:, None] == o[None, :])))

    def acc(ps, thr):
        return float(np.mean([(d <= thr) == s for d, s in ps])) if ps else math.nan

    cands = sorted({d for d, _ in tr})
    crit = bal if criterion == "balanced" else acc
    best = max(cands, key=lambda t: (crit(tr, t), -t))
    for name, ps in (("train " + train, tr), ("test " + test, te)):
        ns = sum(s for _, s in ps)
        print(f"{name}: {ns} same-walker pairs, {len(ps) - ns} different; AUC {auc(ps):.3f}; "
              f"at {best:.4f} ({criterion}): balanced accuracy {bal(ps, best):.3f}, accuracy "
              f"{acc(ps, best):.3f}, same-walker pairs below {sum(d <= best for d, x in ps if x)}"
              f", different {sum(d <= best for d, x in ps if not x)}")
        print("  same:", " ".join(f"{d:.3f}" for d, s in sorted(ps) if s))
        print("  diff (lowest 15):", " ".join([f"{d:.3f}" for d, s in sorted(ps) if not s][:15]))


def main(argv=None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("cmd", choices=("run", "fit", "score", "joins"))
    p.add_argument("args", nargs="+")
    p.add_argument("--seed", type=int, default=42024)
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--set", action="append", default=[])
    p.add_argument("--no-look", action="store_true",
                   help="run: without descriptors (the tracking's frames/s as OFF)")
    p.add_argument("--detail", action="store_true", help="joins: list each join")
    p.add_argument("--free", action="store_true", help="fit: only the pairs the rule may join")
    p.add_argument("--criterion", choices=("balanced", "accuracy"), default="balanced",
                   help="fit: the threshold's criterion on TRAIN (accuracy: weighted by the "
                        "pairs' own same / different ratio)")
    a = p.parse_args(argv)
    if a.cmd == "run":
        run(a.args[0], a.args[1], a.seed, a.scenes, not a.no_look)
    elif a.cmd == "fit":
        fit(a.args[0], a.args[1], a.set, a.free, a.criterion)
    elif a.cmd == "joins":
        joins(a.args, a.set, a.detail)
    else:
        score(a.args, a.set)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
