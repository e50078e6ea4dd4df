"""How right the counting tracker's stitching is (issue 16, counting; a study, nothing chosen).

`count.count_frames` stitches fragments of one walker into one track (`count.stitch`): a later
piece B continues an ended piece A when they meet halfway within the image gate. This records,
per clip, every candidate pair the gate lets through and every pair stitching took, each piece
labelled with the truth object its box is on (IoU >= 0.3, the majority over A's last and B's
first 8 frames: `diag_count_unjudged.frame_owners`), with the pair's misfits: position d and
image velocity dv (each over its gate, as `stitch_pieces` computes them) and the ground-velocity
misfit |v_A - v_B| m/s (`count.stitch.ground_dv_misfit`) and, when the run computes
descriptors (`--set appearance.enabled=true --set appearance.max_distance=0`: the joins of the
defaults), the pieces' appearance distance (`count.appearance`). A pair is "right" when both
pieces are on the same object, "wrong" when on two of one kind (two walkers, two cyclists),
"mixed" when one is a walker and the other is not, "unknown" when either is on none.

    python benchmarks/study_stitch_joins.py record count OUT.pkl --seed 160001,160002 \\
        [--scenes 10] [--clothing any] [--focal-px 500] [--set stitch.max_dv_mps=1.5]
    python benchmarks/study_stitch_joins.py summary OUT.pkl [OUT2.pkl ...]   # joins, misfits
    python benchmarks/study_stitch_joins.py compare OFF.pkl[,OFF2.pkl] ON.pkl[,ON2.pkl]   # in order
    python benchmarks/study_stitch_joins.py greedy OUT.pkl [...]   # the pairs re-taken offline
    python benchmarks/study_stitch_joins.py fit --train TRAIN.pkl ... --test TEST.pkl ...
    python benchmarks/study_stitch_joins.py veto --train TRAIN.pkl ... --test TEST.pkl ...

`compare`: the two runs' joins, walkers counted and per-clip count errors summed, and the paired
change in that figure with a bootstrap interval over clips (as `paired_count.py`). `greedy`
re-takes the recorded candidates cheapest first under other costs (the default d + dv; d plus
the ground misfit over 1.5 m/s; the same gated at 1.5 m/s) and counts right and wrong pairs:
what a different ranking could do on the same pieces (the verdicts and counts are not rerun).
`fit`: a logistic score of a pair being right, fitted on labelled training candidates, and the
pairs it would take on held-out records. `veto`: `appearance.veto_distance` fitted on the
training records' labelled joins (records made with descriptors), scored on held-out ones.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pickle
import sys
from collections import Counter

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def owner(truth, boxes, offset: int) -> int | None:
    """The truth id a piece's boxes (frame index, left, top, w, h) are on in most frames."""
    from diag_count_unjudged import frame_owners

    if not boxes:
        return None
    b = np.asarray(boxes, np.float64)
    hyp = {"frame": b[:, 0].astype(np.int64) + 1, "id": np.zeros(len(b), np.int64),
           "bb_left": b[:, 1], "bb_top": b[:, 2], "bb_width": b[:, 3], "bb_height": b[:, 4]}
    on = list(frame_owners(truth, hyp, offset).get(0, {}).values())
    if not on:
        return None
    v, n = np.unique(on, return_counts=True)
    return int(v[np.argmax(n)])


def pair_misfits(st, A, B, opt, camera) -> tuple[float, ...] | None:
    """(d, dv, ground misfit m/s, gap s, appearance distance) of B after A, d and dv over their
    gates as `stitch_pieces` computes them, the distance of their descriptors
    (`appearance.appearance_distance`; NaN without `appearance.enabled`); None where B cannot
    follow A (order, gap, unknowns)."""
    from rhythmjax.count.appearance import appearance_distance

    S = opt.stitch
    ea, sb, (w, h) = np.asarray(A.end, np.float64), np.asarray(B.start, np.float64), B.size
    gap = B.t_first - A.t_last
    if (B.first <= A.last or not np.all(np.isfinite(ea)) or not np.all(np.isfinite(sb))
            or not (w > 0 and h > 0) or gap > S.max_gap_s):
        return None
    d, dv = st.halfway_misfit(A, B, camera, gate_w=S.gate_w, gate_h=S.gate_h,
                              gate_per_s=S.gate_per_s, max_dv_w=S.max_dv_w)
    return d, dv, st.ground_dv_misfit(A, B), gap, appearance_distance(A.look, B.look)


def mot_figures(res, truth, kinds: dict, offset: int) -> dict:
    """eval_all's per-clip figures of a `CountResult`: non-walkers counted, MOTA, IDF1."""
    import eval_count as ec

    from rhythmjax.evaluation.motscore import score_mot

    walk = ec.walking_ids(res)
    seen = set(np.asarray(truth["id"]).tolist())
    s = score_mot(truth, res.mot, frame_offset=offset, walking_ids=walk,
                  truth_walking_ids=[t for t in seen if kinds.get(t) == "pedestrian"])
    own = ec.owner_of_tracks(truth, res.mot, offset)
    return {"others": sum(1 for h in walk if own.get(h) and kinds[own[h]] != "pedestrian"),
            "mota": float(s.mota), "idf1": float(s.idf1)}


def record(args) -> int:
    import count_dump as cd

    import rhythmjax.count.counting as counting
    import rhythmjax.count.stitch as st
    from rhythmjax.count import CountOptions, count_frames
    from rhythmjax.track.options import with_changes

    seen: list[dict] = []
    original = st.stitch_level

    def watched(level, peds):
        opt = level.opt
        if opt.stitch.enabled and len(peds) >= 2:
            pieces = [st.piece_of(p, level.shape, opt.dynamics, opt.stitch.fit_s) for p in peds]
            cands = []
            for a, A in enumerate(pieces):
                for b, B in enumerate(pieces):
                    m = pair_misfits(st, A, B, opt, level.shape.camera)
                    if m is not None and m[0] <= 1.0 and m[1] <= 1.0:
                        cands.append((a, b, *m))
            taken = st.stitch_pieces(
                pieces, max_gap_s=opt.stitch.max_gap_s, gate_w=opt.stitch.gate_w,
                gate_h=opt.stitch.gate_h, gate_per_s=opt.stitch.gate_per_s,
                max_dv_w=opt.stitch.max_dv_w, camera=level.shape.camera, reid=opt.stitch.reid,
                reid_max_dv_w=opt.stitch.reid_max_dv_w, look=opt.appearance,
                body_width_m=float(level.cfg.width.mean), max_dv_mps=opt.stitch.max_dv_mps)
            joins = [(a, b, *(pair_misfits(st, pieces[a], pieces[b], opt, level.shape.camera)
                              or (math.nan,) * 5)) for a, b in enumerate(taken) if b >= 0]
            seen.append({"cands": cands, "joins": joins, "boxes": [
                [(q.frame, q.left, q.top, q.w, q.h) for q in p.boxes] for p in peds]})
        return original(level, peds)

    counting.stitch_level = watched  # where `count_frames` looks it up
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in args.set)})
    out = []
    for seed in args.seed.split(","):
        for name, cfg, frames, truth, kinds, off, true in cd.clips_of(
                args.source, int(seed), args.scenes, args.clothing, args.focal_px):
            seen.clear()
            res = count_frames(cfg, iter(frames), n_frames=len(frames), options=opt)
            row = {"clip": name, "walkers": int(res.counts["walkers"]), "true": int(true),
                   "kinds": kinds, "cands": [], "joins": [], "own_a": [], "own_b": [],
                   **mot_figures(res, truth, kinds, off)}
            if seen:
                s = seen[0]
                row.update(cands=s["cands"], joins=s["joins"],
                           own_a=[owner(truth, bx[-8:], off) for bx in s["boxes"]],
                           own_b=[owner(truth, bx[:8], off) for bx in s["boxes"]])
            out.append(row)
            print(name, row["walkers"], "of", true, len(row["joins"]), "joins", flush=True)
    tmp = args.out + ".tmp"
    with open(tmp, "wb") as f:
        pickle.dump(out, f)
    os.replace(tmp, args.out)
    return 0


def load(paths) -> list[dict]:
    rows = []
    for p in paths:
        with open(p, "rb") as f:
            rows += pickle.load(f)
    return rows


def label(row: dict, a: int, b: int) -> str:
    oa, ob = row["own_a"][a], row["own_b"][b]
    if oa is None or ob is None:
        return "unknown"
    if oa == ob:
        return "right"
    ka, kb = row["kinds"].get(oa), row["kinds"].get(ob)
    return "mixed" if (ka == "pedestrian") != (kb == "pedestrian") else "wrong"


def tally(rows: list[dict]) -> dict:
    c = Counter(label(r, j[0], j[1]) for r in rows for j in r["joins"])
    true = sum(r["true"] for r in rows)
    err = sum(abs(r["walkers"] - r["true"]) for r in rows)
    mean = lambda k: round(float(np.mean([r[k] for r in rows])), 3) if rows and all(  # noqa: E731
        k in r for r in rows) else None
    return {"joins": sum(c.values()), "right": c["right"], "wrong": c["wrong"],
            "mixed": c["mixed"], "unknown": c["unknown"],
            "counted": sum(r["walkers"] for r in rows), "true": true,
            "err_sum_pct": round(100.0 * err / max(true, 1), 1),
            "others": sum(r.get("others", 0) for r in rows) if rows and "others" in rows[0]
            else None, "mota": mean("mota"), "idf1": mean("idf1")}


def summary(args) -> int:
    rows = load(args.paths)
    print(tally(rows))
    joins = [(label(r, j[0], j[1]), j) for r in rows for j in r["joins"]]
    for name, k, edges in (("d (position / gate)", 2, (0, 0.25, 0.5, 0.75, 1.01)),
                           ("dv (image velocity / gate)", 3, (0, 0.25, 0.5, 0.75, 1.01)),
                           ("ground misfit m/s", 4, (0, 0.5, 1, 1.5, 2, 3, 5, math.inf)),
                           ("gap s", 5, (0, 1, 2, 3, 5.01))):
        print(name)
        for lo, hi in zip(edges[:-1], edges[1:]):
            c = Counter(lab for lab, j in joins if lo <= j[k] < hi)
            print(f"  [{lo}, {hi}): right {c['right']:4d}  wrong {c['wrong']:4d}  "
                  f"mixed {c['mixed']:4d}")
    return 0


def compare(args) -> int:
    offs, ons = args.off.split(","), args.on.split(",")
    if len(offs) != len(ons):
        raise SystemExit("compare: as many OFF files as ON files, paired in order")
    a = {(i, r["clip"]): r for i, p in enumerate(offs) for r in load([p])}
    b = {(i, r["clip"]): r for i, p in enumerate(ons) for r in load([p])}
    print("OFF", tally(list(a.values())))
    print("ON ", tally(list(b.values())))
    keys = sorted(set(a) & set(b))
    true = np.asarray([a[k]["true"] for k in keys], np.float64)
    ea = np.asarray([abs(a[k]["walkers"] - a[k]["true"]) for k in keys], np.float64)
    eb = np.asarray([abs(b[k]["walkers"] - b[k]["true"]) for k in keys], np.float64)
    idx = np.random.default_rng(0).integers(0, len(keys), (10000, len(keys)))
    boot = 100.0 * (eb[idx].sum(1) - ea[idx].sum(1)) / true[idx].sum(1)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    print(f"change in per-clip errors summed over {len(keys)} clips: "
          f"{100.0 * (eb.sum() - ea.sum()) / true.sum():+.1f} points [{lo:+.1f}, {hi:+.1f}]")
    return 0


def greedy(args) -> int:
    rows = load(args.paths)
    g = lambda c: c[4] / 1.5 if math.isfinite(c[4]) else 1.0  # noqa: E731
    variants = {"default: d + dv": (lambda c: c[2] + c[3], lambda c: True),
                "d + ground / 1.5": (lambda c: c[2] + g(c), lambda c: True),
                "d + dv + ground / 1.5": (lambda c: c[2] + c[3] + g(c), lambda c: True),
                "ground <= 1.5, d + ground / 1.5": (lambda c: c[2] + g(c),
                                                    lambda c: c[4] <= 1.5)}
    print(f"{sum(len(r['cands']) for r in rows)} candidate pairs in {len(rows)} clips")
    for name, (cost, keep) in variants.items():
        print(taken_line(name, rows, cost, keep))
    d_dv = variants["default: d + dv"][0]
    for mode in ("most joins", "joins worth 2 - cost"):
        c: Counter = Counter()
        for r in rows:
            c += take_matching(r, d_dv, mode)
        print(f"  {'matching, ' + mode:34s} joins {sum(c.values()):4d}: right {c['right']:4d}, "
              f"wrong {c['wrong']:4d}, mixed {c['mixed']:4d}")
    return 0


def take_matching(row: dict, score, mode: str) -> Counter:
    """The labels of the pairs an optimal assignment takes among `row`'s candidates (each piece
    at most once before and once after; `scipy.optimize.linear_sum_assignment`): "most joins"
    takes as many pairs as any choice can, cheapest in sum among those; "joins worth 2 - cost"
    the pairs of the largest summed 2 - score (a pair's score is at most 2 inside the gate)."""
    from scipy.optimize import linear_sum_assignment

    cands = row["cands"]
    if not cands:
        return Counter()
    ends = sorted({x[0] for x in cands})
    starts = sorted({x[1] for x in cands})
    ia, ib = {a: i for i, a in enumerate(ends)}, {b: j for j, b in enumerate(starts)}
    M = np.zeros((len(ends), len(starts)))
    ok = np.zeros(M.shape, bool)
    for x in cands:
        i, j = ia[x[0]], ib[x[1]]
        v = score(x) - (100.0 if mode == "most joins" else 2.0)
        if not ok[i, j] or v < M[i, j]:
            M[i, j], ok[i, j] = v, True
    r, c = linear_sum_assignment(M)
    return Counter(label(row, ends[i], starts[j]) for i, j in zip(r, c) if ok[i, j])


def taken_line(name: str, rows: list[dict], score, keep) -> str:
    """One line: the pairs `take` takes over every row of `rows`, by label."""
    c: Counter = Counter()
    for r in rows:
        c += take(r, score, keep)
    return (f"  {name:34s} joins {sum(c.values()):4d}: right {c['right']:4d}, wrong "
            f"{c['wrong']:4d}, mixed {c['mixed']:4d}")


def take(row: dict, score, keep=lambda c: True) -> Counter:
    """The labels of the pairs taken cheapest first by `score` (lower first) among `row`'s
    candidates that `keep` keeps, each piece at most once before and once after."""
    c: Counter = Counter()
    succ: dict[int, int] = {}
    pred: dict[int, int] = {}
    for _, a, b in sorted((score(x), x[0], x[1]) for x in row["cands"] if keep(x)):
        if a not in succ and b not in pred:
            succ[a], pred[b] = b, a
            c[label(row, a, b)] += 1
    return c


def pair_features(c) -> list[float]:
    """A candidate's features for `fit`: d, dv, the ground misfit (m/s, capped at 5; 5 when
    unknown) and the gap (s)."""
    g = c[4] if math.isfinite(c[4]) else 5.0
    return [c[2], c[3], min(g, 5.0), c[5]]


def fit(args) -> int:
    """A logistic pair score fitted on the training records' labelled candidates (right 1,
    wrong or mixed 0, unknown left out; `study_count_model.fit_logistic`, l2 0.01), then pairs
    taken on the test records highest score first, all of them or those with p >= 0.5."""
    from study_count_model import fit_logistic, predict

    def xy(rows):
        x, y = [], []
        for r in rows:
            for c in r["cands"]:
                lab = label(r, c[0], c[1])
                if lab != "unknown":
                    x.append(pair_features(c))
                    y.append(1.0 if lab == "right" else 0.0)
        return np.asarray(x), np.asarray(y)

    model = fit_logistic(*xy(load(args.train)), 0.01)
    print("weights (standardised d, dv, ground, gap; intercept):", np.round(model[2], 3))
    p_of = lambda c: float(predict(model, np.asarray([pair_features(c)]))[0])  # noqa: E731
    for name, paths in (("train", args.train), ("test", args.test)):
        rows = load(paths)
        for rule, score, keep in (("default d + dv", lambda c: c[2] + c[3], lambda c: True),
                                  ("fitted, all", lambda c: -p_of(c), lambda c: True),
                                  ("fitted, p >= 0.5", lambda c: -p_of(c),
                                   lambda c: p_of(c) >= 0.5)):
            print(taken_line(f"{name}: {rule}", rows, score, keep))
    return 0


def veto(args) -> int:
    """The appearance veto's threshold fitted on the training records' taken joins: V with the
    best balanced accuracy of "distance <= V" for right joins (1) against wrong or mixed ones
    (0), over the joins with a distance; then its balanced accuracy, the AUC of -distance, and
    the joins it would refuse (before any re-pairing) on the test records."""
    def joins_of(paths):
        rows = load(paths)
        lab = [(label(r, j[0], j[1]), j[6]) for r in rows for j in r["joins"]]
        lab = [(x, dist) for x, dist in lab if x != "unknown"]
        known = [(x, dist) for x, dist in lab if math.isfinite(dist)]
        y = np.asarray([x == "right" for x, _ in known])
        return y, np.asarray([dist for _, dist in known]), len(lab) - len(known)

    def balanced(y, dist, v):
        keep = dist <= v
        return 0.5 * (keep[y].mean() + (~keep[~y]).mean())

    def auc(y, dist):
        pos, neg = -dist[y], -dist[~y]
        return float(((pos[:, None] > neg[None]) + 0.5 * (pos[:, None] == neg[None])).mean())

    y, dist, none = joins_of(args.train)
    grid = np.unique(dist)
    v = float(grid[int(np.argmax([balanced(y, dist, g) for g in grid]))])
    print(f"fitted veto_distance {v:.4f} on {len(y)} joins ({int(y.sum())} right; {none} "
          f"without a distance)")
    for name, paths in (("train", args.train), ("test", args.test)):
        y, dist, none = joins_of(paths)
        keep = dist <= v
        print(f"  {name}: balanced accuracy {balanced(y, dist, v):.3f}, AUC {auc(y, dist):.3f}; "
              f"refuses {int((~keep & y).sum())} of {int(y.sum())} right and "
              f"{int((~keep & ~y).sum())} of {int((~y).sum())} wrong joins ({none} without a "
              f"distance)")
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("source")
    r.add_argument("out")
    r.add_argument("--seed", default="160001")
    r.add_argument("--scenes", type=int, default=10)
    r.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    r.add_argument("--focal-px", type=float, default=0.0)
    r.add_argument("--set", action="append", default=[])
    for name in ("summary", "greedy"):
        s = sub.add_parser(name)
        s.add_argument("paths", nargs="+")
    for name in ("fit", "veto"):
        f = sub.add_parser(name)
        f.add_argument("--train", nargs="+", required=True)
        f.add_argument("--test", nargs="+", required=True)
    c = sub.add_parser("compare")
    c.add_argument("off")
    c.add_argument("on")
    a = p.parse_args(argv)
    return {"record": record, "summary": summary, "compare": compare, "greedy": greedy,
            "fit": fit, "veto": veto}[a.cmd](a)


if __name__ == "__main__":
    raise SystemExit(main())
