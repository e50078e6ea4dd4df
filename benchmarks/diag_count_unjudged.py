"""The explained-track rule (`count.explain`, `ExplainOptions`) re-applied to counting runs
saved by `benchmarks/count_dump.py`: per source, walkers counted / true, per-clip |errors| summed
over the true walkers, counted tracks on a non-walker and on no truth object, with the rule
off (the run's own `counted`) and on (settings from --set); --detail lists, per clip, every
unjudged counted track with the truth object it follows and what explains it.

    python benchmarks/diag_count_unjudged.py RUN.pkl [RUN.pkl ...] [--set explain.KEY=JSON ...]
                                             [--detail]
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from eval_count import owner_of_tracks  # noqa: E402


def apply_rule(row: dict, opt, body_width_m: float = 0.5):
    """(counted with the rule on (B,) bool, explained_by (B,) track ids (0: none),
    explained_as) for one saved clip."""
    from rhythmjax.count.explain import explain_tracks, measured_points

    v = row["verdicts"]
    ids = [int(i) for i in v["track_id"]]
    pts = measured_points(row["tracks"], ids)
    by, how = explain_tracks(pts, v["verdict"], v["counted"], row["fps"], opt, body_width_m)
    idmap = np.asarray([0] + ids, np.int64)
    return np.asarray(v["counted"], bool) & (by == 0), idmap[by], how


def score(rows: list, counted_of) -> dict:
    """Counted / true, per-clip |errors| summed, counted tracks on non-walkers / on nothing."""
    tot = {"true": 0, "counted": 0, "abs_err": 0, "nonwalker": 0, "nobody": 0}
    for r in rows:
        c = counted_of(r)
        own = owner_of_tracks(r["truth"], r["mot"], r["offset"])
        ids = [int(i) for i in r["verdicts"]["track_id"]]
        tot["true"] += r["true"]
        tot["counted"] += int(c.sum())
        tot["abs_err"] += abs(int(c.sum()) - r["true"])
        for i, ci in zip(ids, c):
            o = own.get(i)
            if ci and o is None:
                tot["nobody"] += 1
            elif ci and r["kinds"].get(o) != "pedestrian":
                tot["nonwalker"] += 1
    tot["error_pct"] = 100.0 * tot["abs_err"] / max(1, tot["true"])
    return tot


def frame_owners(truth, hyp, offset: int, min_iou: float = 0.3) -> dict[int, dict[int, int]]:
    """Per hypothesis id, {frame (MOT frame + offset): the truth id its box overlaps most, when
    IoU >= min_iou}."""
    from rhythmjax.evaluation.motscore import iou_matrix

    cols = ("bb_left", "bb_top", "bb_width", "bb_height")
    tb, hb = np.stack([truth[c] for c in cols], 1), np.stack([hyp[c] for c in cols], 1)
    hf = np.asarray(hyp["frame"]) + offset
    out: dict[int, dict[int, int]] = {}
    for f in np.unique(hf):
        kt, kh = np.flatnonzero(truth["frame"] == f), np.flatnonzero(hf == f)
        if not len(kt):
            continue
        iou = iou_matrix(hb[kh], tb[kt])
        for a, h in enumerate(kh):
            if iou[a].max() >= min_iou:
                out.setdefault(int(hyp["id"][h]), {})[int(f)] = \
                    int(truth["id"][kt[int(np.argmax(iou[a]))]])
    return out


def breakdown(row: dict, counted_now=None) -> list[str]:
    """Why a clip's count is off: per true walker counted k > 1 times, each extra counted track
    (by the frames in which each track's box is on that walker, `frame_owners`: "simultaneous"
    when both are on it in some frame, with how many; else "after gap" with the gap s from the
    earlier one's last frame on it and the ground distance between the two there); walkers
    counted by no track; counted tracks on a non-walker or on no truth object (with the
    median distance of its foot point to the nearest truth foot point, in box widths).
    Tracks: id, verdict (P, N, U), measured frames."""
    from rhythmjax.count.explain import measured_points

    v = row["verdicts"]
    ids = [int(i) for i in v["track_id"]]
    c = np.asarray(v["counted"] if counted_now is None else counted_now, bool)
    own = owner_of_tracks(row["truth"], row["mot"], row["offset"])
    fo = frame_owners(row["truth"], row["mot"], row["offset"])
    pts = dict(zip(ids, measured_points(row["tracks"], ids)))
    ver = {i: str(w)[0].upper() for i, w in zip(ids, v["verdict"])}
    kinds, fps, off = row["kinds"], row["fps"], row["offset"]
    out = []

    def on(i, t):  # frames (MOT frame + offset) in which track i's box is on walker t
        return sorted(f for f, o in fo.get(i, {}).items() if o == t)

    def ground(i, f):  # the measured ground point of track i nearest frame f (tracks: 0-based)
        fr, p = pts[i]
        return p[int(np.argmin(np.abs(fr - (f - off - 1))))] if len(fr) else np.full(2, np.nan)

    walkers = sorted({int(t) for t in np.unique(row["truth"]["id"])
                      if kinds.get(int(t)) == "pedestrian"})
    for t in walkers:
        mine = sorted((i for i, ci in zip(ids, c) if ci and own.get(i) == t and on(i, t)),
                      key=lambda i: on(i, t)[0])
        if not mine:
            out.append(f"walker {t}: missed (tracks on it: " + ", ".join(
                f"{i}{ver[i]}" for i in ids if own.get(i) == t) + ")")
        for k, b in enumerate(mine[1:], 1):
            a = mine[k - 1]
            both = set(on(a, t)) & set(on(b, t))
            if both:
                how = f"simultaneous with {a}{ver[a]} ({len(both)} fr)"
            else:
                fb = on(b, t)[0]  # a is on t before (sorted by first frame on t)
                fa = max(f for f in on(a, t) if f < fb)
                d = float(np.hypot(*(ground(b, fb) - ground(a, fa))))
                how = f"after gap {(fb - fa) / fps:.1f} s, {d:.2f} m from {a}{ver[a]}"
                if on(a, t)[-1] > fb:
                    how += " (which comes back on it later)"
            out.append(f"walker {t}: extra {b}{ver[b]} ({len(pts[b][0])} fr) {how}")
    tb = np.stack([row["truth"][k] for k in ("bb_left", "bb_top", "bb_width", "bb_height")], 1)
    for i, ci in zip(ids, c):
        o = own.get(i)
        if ci and (o is None or kinds.get(o) != "pedestrian"):
            what = "no truth object" if o is None else kinds.get(o)
            m = np.asarray(row["mot"]["id"]) == i
            dist = []
            for f, left, tp, w, h in zip(row["mot"]["frame"][m] + off, row["mot"]["bb_left"][m],
                                      row["mot"]["bb_top"][m], row["mot"]["bb_width"][m],
                                      row["mot"]["bb_height"][m]):
                k = row["truth"]["frame"] == f
                if k.any():
                    du = tb[k, 0] + tb[k, 2] / 2 - (left + w / 2)
                    dv = tb[k, 1] + tb[k, 3] - (tp + h)
                    dist.append(np.min(np.hypot(du, dv)) / w)
            near = f", nearest truth foot {np.median(dist):.1f} W" if dist else ""
            out.append(f"track {i}{ver[i]} ({len(pts[i][0])} fr) counted on {what}{near}")
    return out


def line(name: str, s: dict) -> str:
    return (f"{name}: {s['counted']}/{s['true']} ({s['error_pct']:.1f} %), non-walkers "
            f"counted {s['nonwalker']}, on nothing {s['nobody']}")


def main(argv=None) -> int:
    from rhythmjax.count.options import CountOptions
    from rhythmjax.track.options import with_changes

    p = argparse.ArgumentParser()
    p.add_argument("runs", nargs="+")
    p.add_argument("--set", action="append", default=[])
    p.add_argument("--detail", action="store_true")
    p.add_argument("--breakdown", action="store_true", help="why each clip's count is off")
    a = p.parse_args(argv)
    changes = {"explain.enabled": True}
    changes.update({k: json.loads(x) for k, x in (s.split("=", 1) for s in a.set)})
    opt = with_changes(CountOptions(), changes).explain
    for path in a.runs:
        rows = pickle.load(open(path, "rb"))
        off = score(rows, lambda r: np.asarray(r["verdicts"]["counted"], bool))
        on = score(rows, lambda r: apply_rule(r, opt)[0])
        print(line(f"{os.path.basename(path)} OFF", off))
        print(line(f"{os.path.basename(path)} ON ", on))
        if a.breakdown:
            for r in rows:
                for x in breakdown(r):
                    print(f"  {r['clip']}: {x}")
        if not a.detail:
            continue
        for r in rows:
            c, by, how = apply_rule(r, opt)
            own = owner_of_tracks(r["truth"], r["mot"], r["offset"])
            v = r["verdicts"]
            print(f"  {r['clip']}: {int(np.sum(v['counted']))} -> {int(c.sum())} of {r['true']}")
            for k, i in enumerate(v["track_id"]):
                if str(v["verdict"][k]) != "unclassified" or not v["counted"][k]:
                    continue
                o = own.get(int(i))
                print(f"    track {int(i)} own {o} ({r['kinds'].get(o, '-')}): "
                      f"{how[k] or 'counted'} {by[k] or ''} (own {own.get(int(by[k]))})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
