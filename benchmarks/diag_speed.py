"""Per-track ground speed diagnostics of `count_frames` (issue 16): for every track, the
counting rule's speed (`count.track_speed`), alternative estimates, and its owner's true speed
and ground path.

    python benchmarks/diag_speed.py --seed 42024 [--scenes 10] [-o out.json]
    python benchmarks/diag_speed.py --dev     (dev crowd clips: LOOK only, never tune on them)
    python benchmarks/diag_speed.py --pets

Estimates per track: ls_ekf (the counting rule's default, `count.track_speed` "lsq"), ts_ekf
(Theil-Sen of the same EKF positions: `verdicts.speed_fit` "theil-sen"), ts_meas / ls_meas (of
the measured foot points taken to the ground), ekf_med(_settled) (median EKF speed, after its
first 1 s); owner (`eval_count.owner_of_tracks`), its true speed and the track's ground distance
from it (median, max). Tracks too fast or off their owner's speed by > 0.8 m/s get `detail`.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def theil_sen(t, xy):
    i, j = np.triu_indices(len(t), 1)
    dt = t[j] - t[i]
    ok = dt > 0
    if not ok.any():
        return np.nan
    v = np.median((xy[j][ok] - xy[i][ok]) / dt[ok, None], axis=0)
    return float(np.hypot(*v))


def ls(t, xy):
    tc = t - t.mean()
    v = tc @ (xy - xy.mean(axis=0)) / float(tc @ tc)
    return float(np.hypot(*v))


def per_track(cfg, res, own, truth_xy, truth_speed, off):
    from rhythmjax.model.camera_np import ground_of_pixels

    tr, v = res.tracks, res.verdicts
    out = []
    for k, h in enumerate(v["track_id"]):
        m = tr["track_id"] == h
        obs = m & (tr["state"] == "observe")
        t = tr["t"][obs]
        xy = np.stack([tr["x_est"][obs], tr["y_est"][obs]], 1)
        fin = np.all(np.isfinite(xy), 1)
        u, vv = tr["u"][obs], tr["v"][obs]
        gx, gy, ok = ground_of_pixels(cfg.camera, np.nan_to_num(u), np.nan_to_num(vv))
        okm = np.asarray(ok, bool) & np.isfinite(u) & np.isfinite(vv)
        gxy = np.stack([gx, gy], 1)[okm]
        spd = np.hypot(tr["vx"][obs], tr["vy"][obs])
        settle = t >= t.min() + 1.0 if len(t) else t
        o = own.get(int(h))
        fr = tr["frame"][obs]
        rec = {"id": int(h), "verdict": str(v["verdict"][k]), "counted": bool(v["counted"][k]),
               "too_fast": bool(v["too_fast"][k]), "n_obs": int(obs.sum()),
               "span_s": float(np.ptp(t)) if len(t) else 0.0,
               "ls_ekf": float(v["track_speed_mps"][k]),
               "ts_ekf": theil_sen(t[fin], xy[fin]) if fin.sum() > 1 else np.nan,
               "ts_meas": theil_sen(t[okm], gxy) if okm.sum() > 1 else np.nan,
               "ls_meas": ls(t[okm], gxy) if okm.sum() > 1 else np.nan,
               "ekf_med_settled": float(np.nanmedian(spd[settle])) if settle.any() else np.nan,
               "ekf_med": float(np.nanmedian(spd)) if len(spd) else np.nan,
               "owner": o, "owner_speed": truth_speed.get(o) if o else None}
        if o is not None and o in truth_xy:
            T = truth_xy[o]  # frame -> (x, y)
            d = [np.hypot(*(xy[q] - T[int(f) + off])) for q, f in enumerate(fr)
                 if int(f) + off in T and fin[q]]
            rec["dist_owner_med"] = float(np.median(d)) if d else None
            rec["dist_owner_max"] = float(np.max(d)) if d else None
            rec["y_range"] = [float(np.nanmin(xy[:, 1])), float(np.nanmax(xy[:, 1]))] \
                if fin.any() else None
        off_speed = rec["owner_speed"] and abs(rec["ls_ekf"] - rec["owner_speed"]) > 0.8
        if rec["too_fast"] or off_speed:  # per measured row: frame t x y u v vx vy, truth x y
            T = truth_xy.get(o, {}) if o is not None else {}
            vx, vy = tr["vx"][obs], tr["vy"][obs]
            rec["detail"] = [
                [int(f), round(float(t[q]), 3),
                 *(round(float(z), 2) for z in (xy[q, 0], xy[q, 1], u[q], vv[q], vx[q], vy[q])),
                 *(round(float(z), 2) for z in T.get(int(f) + off, (np.nan, np.nan)))]
                for q, f in enumerate(fr)]
        out.append(rec)
    return out


def own_seed(seed, n, only):
    import eval_count as ec

    from rhythmjax.count import count_frames
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import render_scene

    cfg = config_from_dict(SYNTHETIC_CONFIG)
    clips = []
    for i, (s, spec) in enumerate(ec.scene_specs(n, seed=seed, camera=cfg.camera)):
        if only and i not in only:
            continue
        scene = render_scene(s, spec)
        truth, kinds = ec.truth_boxes(scene)
        res = count_frames(cfg, iter([(k, k / scene.fps, f) for k, f in
                                      enumerate(scene.frames)]), n_frames=len(scene.frames))
        own = ec.owner_of_tracks(truth, res.mot, -1)
        txy = {q + 1: {f: (tr.x[f], tr.y[f]) for f in range(len(tr.x))
                       if np.isfinite(tr.x[f])} for q, tr in enumerate(scene.truth)}
        tsp = {q + 1: float(tr.speed_mps) for q, tr in enumerate(scene.truth)}
        rows = per_track(cfg, res, own, txy, tsp, 0)
        for r in rows:
            r["owner_kind"] = kinds.get(r["owner"]) if r["owner"] else None
        clips.append({"scene": i, "seed": s, "counts": res.counts, "tracks": rows,
                      "true_walkers": sum(1 for t in set(truth["id"].tolist())
                                          if kinds[t] == "pedestrian")})
        print(f"scene {i}: {res.counts['walkers']}/{clips[-1]['true_walkers']}", flush=True)
    return clips


def dev():
    import eval_count as ec
    import eval_real_video as ev
    from eval_all import DEV_ROOT, _dev_index
    from eval_all_score import dev_camera, read_gt

    from rhythmjax.count import count_frames
    from rhythmjax.vision.video import VideoSource

    clips = []
    for c in _dev_index():
        if not c.get("count"):
            continue
        truth = json.loads((DEV_ROOT / c["truth"]).read_text())
        path = DEV_ROOT / c["video"]
        cfg = ev.video_config(dev_camera(truth), path, truth["fps"])
        gt, kinds = read_gt(DEV_ROOT / c["mot_gt"])
        frames = list(VideoSource(str(path), fps=truth["fps"]))
        res = count_frames(cfg, iter(frames), n_frames=len(frames))
        own = ec.owner_of_tracks(gt, res.mot, 0)
        txy, tsp = {}, {}
        for o in truth["objects"]:
            gid = int(o["id"]) + 1 if min(kinds) == 1 else int(o["id"])
            tk = o["track"]
            txy[gid] = {int(f): (x, y) for f, x, y in zip(tk["frame"], tk["x"], tk["y"])}
            tsp[gid] = float(o["speed_mps"])
        rows = per_track(cfg, res, own, txy, tsp, 0)
        for r in rows:
            r["owner_kind"] = kinds.get(r["owner"]) if r["owner"] else None
        clips.append({"clip": c["clip"], "counts": res.counts, "tracks": rows})
        print(c["clip"], res.counts, flush=True)
    return clips


def pets():
    import eval_count as ec
    import eval_real_video as ev

    from rhythmjax.count import count_frames
    from rhythmjax.evaluation import datasets
    from rhythmjax.vision.video import VideoSource

    cfg = ev.video_config(ev.pets_config_dict(), datasets.pets_video(), datasets.PETS_FPS)
    frames = list(VideoSource(str(datasets.pets_video()), fps=datasets.PETS_FPS))
    truth = datasets.pets_boxes()
    res = count_frames(cfg, iter(frames), n_frames=len(frames))
    own = ec.owner_of_tracks(truth, res.mot, -1)
    rows = per_track(cfg, res, own, {}, {}, 0)
    for r in rows:
        r["owner_kind"] = "pedestrian" if r["owner"] else None
    print("pets", res.counts, flush=True)
    return [{"clip": "pets", "counts": res.counts, "tracks": rows,
             "true_walkers": len(np.unique(truth["id"]))}]


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--seed", type=int, default=42024)
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--only", default="")
    p.add_argument("--dev", action="store_true")
    p.add_argument("--pets", action="store_true")
    p.add_argument("-o", "--output", default="diag_speed.json")
    a = p.parse_args(argv)
    only = {int(x) for x in a.only.split(",") if x}
    clips = dev() if a.dev else pets() if a.pets else own_seed(a.seed, a.scenes, only)
    with open(a.output, "w") as fh:
        json.dump(clips, fh, indent=1, default=float)
    for c in clips:
        for r in c["tracks"]:
            r = {k: x for k, x in r.items() if k != "detail"}
            print(c.get("clip", c.get("scene")), {k: (round(x, 2) if isinstance(x, float) else x)
                                                  for k, x in r.items()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
