"""Per-walker diagnostics of the walker count on the synthetic scenes of `eval_count.py`.

For every true walker: its visible frames, the ground range it walks, the fraction of its frames
in which at least half its box's columns are covered by no other object's box (`free`: where a
blob detector can see it apart), and the tracks that own it (`eval_count.owner_of_tracks`: IoU
>= 0.3 in most of the track's frames) with their verdicts, their first and last frames, and
whether `count.COUNT_RULE` counts them; then the counted tracks owned by no walker (a bicycle,
two walkers merged, nothing). The count error of a scene is (walkers with k counted tracks:
k - 1 each) - (walkers with none) + (counted tracks owned by no walker).

    python benchmarks/diag_count.py [--seed S] [--scenes 10] [--only 0,3] [--set KEY=JSON ...]
                                    [--clothing any] [--focal-px 500]

--set overrides a `count.CountOptions` field, dotted (e.g. `--set new.lifted_height=2.0`,
repeatable; `track.options.with_changes`).
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from eval_count import SEED, owner_of_tracks, scene_specs, truth_boxes  # noqa: E402


def free_fraction(truth, t: int, min_free: float = 0.5) -> float:
    """Fraction of walker t's truth frames in which at least `min_free` of its box's columns
    are covered by no other object's box (a blob detector can see it apart there)."""
    fr, ids = truth["frame"], truth["id"]
    x0, x1 = truth["bb_left"], truth["bb_left"] + truth["bb_width"]
    k = np.flatnonzero(ids == t)
    n = 0
    for r in k:
        o = np.flatnonzero((fr == fr[r]) & (ids != t))
        cols = np.arange(int(x0[r]), int(np.ceil(x1[r])))
        if not cols.size:
            continue
        hid = np.zeros(cols.size, bool)
        for q in o:
            hid |= (cols >= x0[q]) & (cols < x1[q])
        n += (1 - hid.mean()) >= min_free
    return n / max(1, k.size)


def diagnose(scene, res, off: int = -1) -> dict:
    truth, kinds = truth_boxes(scene)
    own = owner_of_tracks(truth, res.mot, off)
    v = res.verdicts
    info = {int(i): (str(w), bool(c), bool(f), str(r)) for i, w, c, f, r in
            zip(v["track_id"], v["verdict"], v["counted"], v["too_fast"], v["reason"])}
    nfr = np.bincount(res.mot["id"])
    span = {int(h): (int(res.mot["frame"][res.mot["id"] == h].min()) + off,
                     int(res.mot["frame"][res.mot["id"] == h].max()) + off) for h in own}
    walkers, extra = [], []
    seen = set(truth["id"].tolist())
    for t, k in kinds.items():
        if k != "pedestrian" or t not in seen:
            continue
        tr = scene.truth[t - 1]
        vis = np.flatnonzero(tr.visible)
        tracks = [(h, int(nfr[h]), *info[h], span[h]) for h, o in own.items() if o == t]
        top = truth["bb_top"][truth["id"] == t]
        walkers.append({"id": t, "visible": int(vis.size), "frames": (int(vis[0]), int(vis[-1])),
                        "y_m": (float(np.nanmin(tr.y)), float(np.nanmax(tr.y))),
                        "head_clipped": float(np.mean(top <= 0)),
                        "free": free_fraction(truth, t),
                        "tracks": tracks, "counted": sum(x[3] for x in tracks)})
    reasons: dict = {}
    for h, o in own.items():
        key = f"{'none' if o is None else kinds[o]}:{info[h][0]}:{info[h][3]}"
        reasons[key] = reasons.get(key, 0) + 1
        if info[h][1] and (o is None or kinds[o] != "pedestrian"):
            extra.append((h, int(nfr[h]), None if o is None else kinds[o], *info[h]))
    return {"walkers": walkers, "extra": extra, "reasons": reasons}


def main(argv=None) -> int:
    from rhythmjax.count import CountOptions, count_frames
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import render_scene
    from rhythmjax.track.options import with_changes

    p = argparse.ArgumentParser()
    p.add_argument("--seed", type=int, default=SEED)
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--only", default="")
    p.add_argument("--set", action="append", default=[], metavar="KEY=JSON",
                   help="a CountOptions field, e.g. new.lifted_height=2.0 (repeatable)")
    p.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    p.add_argument("--focal-px", type=float, default=0.0,
                   help="the camera's a f = b f (px; default the paper's 800)")
    a = p.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    only = {int(x) for x in a.only.split(",") if x}
    d = copy.deepcopy(SYNTHETIC_CONFIG)
    if a.focal_px > 0:  # as eval_count_options.count_seed
        d["camera"] = {"a_px_per_m": a.focal_px / 0.008, "b_px_per_m": a.focal_px / 0.008}
    cfg = config_from_dict(d)
    tot = {"true": 0, "counted": 0, "missed": 0, "over": 0, "extra": 0}
    reasons: dict = {}
    for i, (s, spec) in enumerate(scene_specs(a.scenes, seed=a.seed, camera=cfg.camera,
                                                       clothing=a.clothing)):
        if only and i not in only:
            continue
        scene = render_scene(s, spec)
        res = count_frames(cfg, iter([(k, k / scene.fps, f) for k, f in
                                      enumerate(scene.frames)]), n_frames=len(scene.frames),
                           options=opt)
        d = diagnose(scene, res)
        missed = sum(w["counted"] == 0 for w in d["walkers"])
        over = sum(max(0, w["counted"] - 1) for w in d["walkers"])
        tot["missed"] += missed
        tot["true"] += len(d["walkers"])
        tot["counted"] += res.counts["walkers"]
        tot["over"] += over
        tot["extra"] += len(d["extra"])
        for k, n in d["reasons"].items():
            reasons[k] = reasons.get(k, 0) + n
        print(f"scene {i} (seed {s}): walkers {len(d['walkers'])} counted "
              f"{res.counts['walkers']}: missed {missed}, over {over}, extra {len(d['extra'])}")
        for w in d["walkers"]:
            flag = "MISSED" if w["counted"] == 0 else ("OVER" if w["counted"] > 1 else "")
            print(f"  walker {w['id']}: vis {w['visible']} {w['frames']} y {w['y_m'][0]:.1f}-"
                  f"{w['y_m'][1]:.1f} m head-clipped {w['head_clipped']:.2f} "
                  f"free {w['free']:.2f} {flag}")
            for t in w["tracks"]:
                print(f"      track {t[0]} frames {t[1]} {t[6]} {t[2]} counted={t[3]} fast={t[4]} "
                      f"{t[5]}")
        for e in d["extra"]:
            print(f"  extra counted track {e[0]} frames {e[1]} owner {e[2]} {e[3]} {e[6]}")
    print("tracks by owner:verdict:reason: " + ", ".join(f"{k} {n}" for k, n in
                                                       sorted(reasons.items())))
    print(f"total: {tot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
