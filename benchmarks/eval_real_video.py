"""Real clips through the single-object pipeline of the rhythm paper (issue 3, Measured acceptance).

CASIA-B (`casia_b_090/`, 25 fps, side view, not calibrated: CASIA_CONFIG): every clip tracked;
the longest track's length, verdict and pace per clip, and the pace spread of subject 001's six
normal walks.

PETS09-S2L1 (`../shared/data/real/pets2009_s2l1/`, 480x360, dt = 1/7 s, the camera of (3) nearest
to the Tsai calibration as `rhythmjax camera --tsai` writes it, the rest of the config Table 1's,
24 object slots, i.e. `rhythmjax run VIDEO -c pets.json --max-objects 24`): the online tracker's
measured foot points are matched per frame to the annotated boxes' bottom centres (greedy
nearest pairs within max(GATE_PX, 0.5 box width)); each track is assigned to the person it
matched most often. Reports the median px distance over matched track-frames, the annotated
people tracked, the fraction of annotated person-frames covered, and each person's verdict (its
longest classified track). All 19 people walk.

UCSD Ped2 (`ucsd_ped2/`, 360x240 frames, camera GUESSED, see UCSD_CAMERA; the frame rate is not
stated: 30 fps by default, because at the 10 fps the literature usually quotes the walkers'
rhythm comes out at a third of a walking pace (measured with an earlier config: 1 of the 57
judged tracks off the anomaly boxes is Pedestrian at 10 fps, 31 of 47 at 30 fps; `--ucsd-fps`)):
a track
overlaps the anomaly boxes (cyclists, the cart) when its foot point lies in a box (grown by
BOX_MARGIN_PX) on at least OVERLAP_FRACTION of its measured frames; those should be judged
Non-pedestrian, the others Pedestrian. Prints the confusion counts per clip and in total.

    python benchmarks/eval_real_video.py [--only casia|pets|ucsd] [-o eval_real_video.json]
        [--overlay DIR]  (annotated videos, to look at)
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

from rhythmjax.evaluation import datasets
from rhythmjax.model.params import Config


GATE_PX = 12.0  # PETS: a track's foot point and a box bottom centre this close (or 0.5 W) match
BOX_MARGIN_PX = 6.0  # UCSD: anomaly boxes grown by this on each side
OVERLAP_FRACTION = 0.3  # UCSD: of a track's measured frames inside an anomaly box
# Every config here is what a user gives the command line: a partial config dict, resolved for
# the video by `model.config_setup.config_for` exactly as `rhythmjax run -c CONFIG` does
# (image size and fps from the video, principal point at the centre, N = window_s x fps, the
# detection range from the camera). The rest of the config is Table 1's.

# UCSD Ped2 gives no calibration. A guess that puts a 1.7 m walker ~33 px tall on the walkway
# (measured blob heights 31-39 px): camera 8 m up, 25 deg down, focal 400 px.
UCSD_CAMERA = {"f_m": 0.01, "h_m": 8.0, "theta_deg": 25.0, "a_px_per_m": 40000.0,
               "b_px_per_m": 40000.0}
# CASIA-B side view (README, "Your own camera"): not calibrated; `rhythmjax camera --focal-px 400
# --height 0.85 --tilt 2 --window-s 1.92` (a walker is in view for 63-86 frames at 25 fps: the
# window is N = 48 samples).
CASIA_CONFIG = {"camera": {"f_m": 0.008, "a_px_per_m": 50000.0, "b_px_per_m": 50000.0,
                           "h_m": 0.85, "theta_deg": 2.0},
                "thresholds": {"window_s": 1.92}}


def video_config(d: dict, path, fps: float) -> Config:
    """`d` resolved for the video at `path` played at `fps`, as the command line does."""
    from rhythmjax.model.config_setup import config_for
    from rhythmjax.vision.video import open_video

    with open_video(str(path), fps=fps) as src:
        return config_for(d, image_size=(src.width, src.height), fps=src.fps)


def pets_config_dict(window_s: float | None = None) -> dict:
    """PETS: the camera section `rhythmjax camera --tsai View_001.xml --video VIDEO --fps 7`
    writes (the Tsai calibration's nearest camera of (3) at 480 x 360, 7 fps)."""
    from rhythmjax.io.calibration import read_tsai
    from rhythmjax.model.camera_from import camera_from_tsai

    xml = datasets.pets_root() / "calibration" / "View_001.xml"
    section = camera_from_tsai(read_tsai(xml), image_size=datasets.PETS_SIZE,
                               fps=datasets.PETS_FPS).section
    return {"camera": section, **({"thresholds": {"window_s": window_s}} if window_s else {})}


MAX_OBJECTS = 24  # object slots (TrackerOptions default 8): up to ~20 people in view at once


def track(cfg, path, fps, overlay=None, max_objects=MAX_OBJECTS):
    from rhythmjax.cli.common import overlay_writer
    from rhythmjax.cli.overlay import draw_frame
    from rhythmjax.track import track_frames
    from rhythmjax.track.tracker import TrackerOptions
    from rhythmjax.vision.video import open_video

    src = open_video(str(path), fps=fps)
    with overlay_writer(overlay, fps, (src.width, src.height)) as w:
        hpw = cfg.width.height_per_width()
        draw = None if w is None else (lambda f, i, snap: w.write(
            draw_frame(f, snap, i, height_per_width=hpw)))
        tracks, verdicts, _, _ = track_frames(cfg, src, on_frame=draw, progress=False,
                                              options=TrackerOptions(max_objects=max_objects))
    return tracks, verdicts


def _verdict_of(verdicts, tids):
    """The verdict of the longest classified track among `tids` (else the longest's)."""
    vid = [int(t) for t in verdicts["track_id"]]
    order = sorted(tids, key=lambda t: -int(verdicts["n_samples"][vid.index(t)]))
    for t in order:
        v = str(verdicts["verdict"][vid.index(t)])
        if v != "unclassified":
            return v, t
    return ("unclassified", order[0]) if order else ("missed", None)


def score_pets(tracks, verdicts, boxes) -> dict:
    fr_t, tid = np.asarray(tracks["frame"]), np.asarray(tracks["track_id"])
    u, v = np.asarray(tracks["u"]), np.asarray(tracks["v"])
    by_frame: dict[int, list[int]] = {}
    for i, f in enumerate(boxes["frame"]):
        by_frame.setdefault(int(f), []).append(i)
    pairs = []  # (track id, person id, distance px)
    for f in np.unique(fr_t):
        rows = np.flatnonzero((fr_t == f) & np.isfinite(u))
        cand = by_frame.get(int(f), [])
        if not len(rows) or not cand:
            continue
        d = np.hypot(u[rows, None] - boxes["foot_u"][cand][None],
                     v[rows, None] - boxes["foot_v"][cand][None])
        lim = np.maximum(GATE_PX, 0.5 * boxes["bb_width"][cand])[None]
        used_r, used_c = set(), set()
        for k in np.argsort(d, axis=None):
            r, c = np.unravel_index(k, d.shape)
            if d[r, c] > lim[0, c]:
                break
            if r in used_r or c in used_c:
                continue
            used_r.add(r)
            used_c.add(c)
            pairs.append((int(tid[rows[r]]), int(boxes["id"][cand[c]]), float(d[r, c])))
    dist = np.asarray([p[2] for p in pairs])
    people = np.unique(boxes["id"])
    owner: dict[int, int] = {}  # track -> the person it matched most often
    for t in np.unique(tid):
        mine = [p[1] for p in pairs if p[0] == t]
        if mine:
            ids, cnt = np.unique(mine, return_counts=True)
            owner[int(t)] = int(ids[np.argmax(cnt)])
    per_person = {}
    for p in people:
        tids = [t for t, o in owner.items() if o == p]
        verdict, _ = _verdict_of(verdicts, tids)
        frames = int(np.sum(boxes["id"] == p))
        per_person[int(p)] = {"tracks": len(tids), "verdict": verdict, "frames": frames,
                              "matched_frames": sum(1 for q in pairs if q[1] == p)}
    verd = [r["verdict"] for r in per_person.values()]
    return {
        "n_tracks": int(len(np.unique(tid))), "n_people": int(len(people)),
        "median_px": float(np.median(dist)) if len(dist) else math.nan,
        "p90_px": float(np.percentile(dist, 90)) if len(dist) else math.nan,
        "matched_track_frames": int(len(dist)),
        "measured_track_frames": int(np.sum(np.isfinite(u))),
        "people_tracked": int(sum(r["tracks"] > 0 for r in per_person.values())),
        "person_frames_covered": float(sum(r["matched_frames"] for r in per_person.values())
                                       / len(boxes["frame"])),
        "verdicts": {k: verd.count(k) for k in ("pedestrian", "non-pedestrian", "unclassified",
                                                 "missed")},
        "track_verdicts": {k: int(np.sum(np.asarray(verdicts["verdict"]) == k))
                           for k in ("pedestrian", "non-pedestrian", "unclassified")},
        "paces_hz": [float(p) for p in verdicts["pace_hz"] if math.isfinite(p)],
        "people": per_person,
    }


def rows_in_boxes(tracks, boxes) -> np.ndarray:
    """Per track row: its foot point within `BOX_MARGIN_PX` of an annotated box of its frame."""
    fr_t = np.asarray(tracks["frame"])
    u, v = np.asarray(tracks["u"]), np.asarray(tracks["v"])
    m = BOX_MARGIN_PX
    inside = np.zeros(len(fr_t), bool)
    for i in np.flatnonzero(np.isfinite(u)):
        sel = boxes["frame"] == fr_t[i]
        x, y, w, h = (boxes[k][sel] for k in ("x", "y", "w", "h"))
        inside[i] = np.any((u[i] >= x - m) & (u[i] <= x + w + m) & (v[i] >= y - m)
                           & (v[i] <= y + h + m))
    return inside


def score_ucsd(tracks, verdicts, boxes) -> dict:
    tid, u = np.asarray(tracks["track_id"]), np.asarray(tracks["u"])
    inside = rows_in_boxes(tracks, boxes)
    out = {"anomaly": {}, "other": {}}
    vid = [int(t) for t in verdicts["track_id"]]
    for t in np.unique(tid):
        rows = (tid == t) & np.isfinite(u)
        frac = inside[rows].mean() if rows.any() else 0.0
        group = "anomaly" if frac >= OVERLAP_FRACTION else "other"
        verdict = str(verdicts["verdict"][vid.index(int(t))])
        out[group][verdict] = out[group].get(verdict, 0) + 1
    return out


def run_pets(window_s: float | None, overlay_dir=None) -> dict:
    cfg = video_config(pets_config_dict(window_s), datasets.pets_video(), datasets.PETS_FPS)
    t0 = time.perf_counter()
    tracks, verdicts = track(cfg, datasets.pets_video(), datasets.PETS_FPS,
                             overlay_dir and os.path.join(overlay_dir, "pets.mp4"))
    res = score_pets(tracks, verdicts, datasets.pets_boxes())
    res["seconds"] = time.perf_counter() - t0
    res["n_samples"] = cfg.thresholds.n
    res["range_m"] = [float(cfg.thresholds.range_min), float(cfg.thresholds.range_max)]
    return res


def score_pets_run(out_dir) -> dict:
    """Score the output folder of `rhythmjax run` on the PETS video (tracks.parquet,
    verdicts.csv) as `run_pets` scores its own run: the two-command check of issue 15."""
    import pandas as pd

    tracks = {k: v.to_numpy() for k, v in pd.read_parquet(
        os.path.join(out_dir, "tracks.parquet")).items()}
    verdicts = {k: v.to_numpy() for k, v in pd.read_csv(
        os.path.join(out_dir, "verdicts.csv")).items()}
    verdicts["verdict"] = verdicts["verdict"].astype(str)
    return score_pets(tracks, verdicts, datasets.pets_boxes())


def run_casia(overlay_dir=None) -> dict:
    """Every clip of casia_b_090/: tracks, the longest track's frames, its verdict and pace."""
    out = {}
    for path in sorted((datasets.DATA_ROOT / "casia_b_090").glob("*.avi")):
        cfg = video_config(CASIA_CONFIG, path, 25.0)
        video = overlay_dir and os.path.join(overlay_dir, f"casia_{path.stem}.mp4")
        tracks, verdicts = track(cfg, path, 25.0, video, max_objects=8)
        tid = np.asarray(tracks["track_id"])
        ids, frames = np.unique(tid, return_counts=True) if tid.size else ([], [])
        row = {"tracks": int(len(ids)), "frames": 0, "verdict": "none", "pace_hz": math.nan}
        if len(ids):
            best = int(ids[int(np.argmax(frames))])
            k = [int(t) for t in verdicts["track_id"]].index(best)
            row.update(frames=int(np.max(frames)), verdict=str(verdicts["verdict"][k]),
                       pace_hz=float(verdicts["pace_hz"][k]))
        out[path.stem] = row
    return out


def run_ucsd(window_s: float, fps: float, overlay_dir=None) -> dict:
    d = {"camera": UCSD_CAMERA, "thresholds": {"window_s": window_s}}
    out, total = {}, {"anomaly": {}, "other": {}}
    for clip in datasets.UCSD_CLIPS:
        folder, boxes = datasets.ucsd_clip(clip)
        cfg = video_config(d, folder, fps)
        tracks, verdicts = track(cfg, folder, fps,
                                 overlay_dir and os.path.join(overlay_dir, f"ucsd_{clip}.mp4"))
        out[clip] = score_ucsd(tracks, verdicts, boxes)
        for g in total:
            for k, c in out[clip][g].items():
                total[g][k] = total[g].get(k, 0) + c
    out["total"] = total
    out["n_samples"], out["fps"] = cfg.thresholds.n, fps
    out["range_m"] = [float(cfg.thresholds.range_min), float(cfg.thresholds.range_max)]
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", choices=("casia", "pets", "ucsd"))
    p.add_argument("-o", "--output", default="eval_real_video.json")
    p.add_argument("--overlay", help="folder for annotated videos")
    p.add_argument("--window-pets", type=float, help="rhythm window (s) for PETS (default: "
                   "Table 1's 64/15 s, N = 30 at 7 fps)")
    p.add_argument("--window-ucsd", type=float, default=32 / 30, help="rhythm window (s) for "
                   "UCSD (N = 32 at 30 fps; walkers cross the small view in a few seconds)")
    p.add_argument("--pets-run", metavar="DIR", help="score this `rhythmjax run` output folder "
                   "on PETS instead of running the tracker")
    p.add_argument("--ucsd-fps", type=float, default=30.0,
                   help="UCSD frame rate (not stated; 10 is the usual claim, but the "
                   "walkers' rhythm is a walking pace only at 30 fps: see the module doc)")
    a = p.parse_args(argv)
    if a.overlay:
        os.makedirs(a.overlay, exist_ok=True)
    out = {}
    if a.only in (None, "casia"):
        if not (datasets.DATA_ROOT / "casia_b_090").is_dir():
            print("CASIA-B absent: skipped", file=sys.stderr)
        else:
            r = out["casia"] = run_casia(a.overlay)
            for clip, row in r.items():
                print(f"CASIA {clip}: {row['tracks']} track(s), longest {row['frames']} frames, "
                      f"{row['verdict']}, pace {row['pace_hz']:.3f} Hz")
            nm = [row["pace_hz"] for clip, row in r.items() if clip.startswith("001-nm")]
            if len(nm) > 1:
                print(f"CASIA 001 normal walks: pace mean {np.mean(nm):.3f} Hz, sd "
                      f"{np.std(nm, ddof=1):.3f} Hz over {len(nm)} walks")
    if a.only in (None, "pets"):
        if datasets.pets_root() is None:
            print("PETS09-S2L1 absent: skipped", file=sys.stderr)
        else:
            if a.pets_run:
                r = out["pets"] = score_pets_run(a.pets_run)
                r.update(n_samples=math.nan, range_m=[math.nan, math.nan], seconds=math.nan)
            else:
                r = out["pets"] = run_pets(a.window_pets, a.overlay)
            print(f"PETS09-S2L1 (N = {r['n_samples']}, range {r['range_m'][0]:.1f}-"
                  f"{r['range_m'][1]:.1f} m): {r['n_tracks']} tracks; foot point vs box "
                  f"bottom centre median {r['median_px']:.1f} px (90 % {r['p90_px']:.1f} px) "
                  f"over {r['matched_track_frames']} of {r['measured_track_frames']} measured "
                  f"track-frames; people tracked {r['people_tracked']}/{r['n_people']}, "
                  f"person-frames covered {100 * r['person_frames_covered']:.0f} %; people's "
                  f"verdicts {r['verdicts']}; all tracks {r['track_verdicts']}; "
                  f"{r['seconds']:.0f} s")
    if a.only in (None, "ucsd"):
        if datasets.ucsd_root() is None:
            print("UCSD Ped2 absent: skipped", file=sys.stderr)
        else:
            r = out["ucsd"] = run_ucsd(a.window_ucsd, a.ucsd_fps, a.overlay)
            for clip in (*datasets.UCSD_CLIPS, "total"):
                print(f"UCSD {clip} (N = {r['n_samples']}, {a.ucsd_fps:g} fps, range "
                      f"{r['range_m'][0]:.1f}-{r['range_m'][1]:.1f} m): tracks on anomaly boxes "
                      f"{r[clip]['anomaly']}; other tracks {r[clip]['other']}")
    with open(a.output, "w") as fh:
        json.dump(out, fh, indent=1, default=float)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
