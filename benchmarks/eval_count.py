"""Measured acceptance of issue 4: counting and multi-pedestrian tracking, scored by motmetrics.

(a) synthetic: >= 10 random scenes (`synth.random_spec`, 2-8 walkers, 1-2 bicycles, no dogs,
    occlusions allowed, 180 frames at 15 fps, 512x512, the issue-3 demo config; walkers with knees
    and heel-to-toe feet, `random_spec`'s articulated, since issue 16's thirty-eighth round,
    straight legs before it: `--legs rods`). Truth boxes: the
    foot point of each visible object (as rendered, jitter included) up to the projection of its
    head (`synth.project_3d` at the actor's height, 1.7 m for walkers, 1.9 m for a bicycle with
    rider) above the body centre; width = the drawn extent (`ObjectTruth.width_px`); clipped
    to the image. Per scene:
    walkers counted vs truth, ID switches, MOTA / IDF1, bicycle tracks judged Pedestrian.
(b) PETS09-S2L1 (795 frames, 7 fps, `datasets.pets_camera()`, detection range 5-50 m): MOTA,
    IDF1, IDSW vs `datasets.pets_boxes()` (all 19 people, occluded boxes included), walkers
    counted vs 19; the SORT baseline on the same blob detections, scored by the same tool.
(c) UCSD Ped2 Test002/004/006/010: frame rate unknown, 30 fps assumed (at the usual 10 fps the
    walkers' rhythm is a third of a walking pace: `eval_real_video.py`); a guessed camera (h 10 m,
    tilt 30 deg, 400 px focal length, principal point at the image centre: a 1.7 m person at
    the centre is ~34 px tall, the median blob height of SOURCE.md). Tracks overlapping the
    anomaly boxes (cyclists, cart) and their verdicts; the walker count (no pedestrian truth).

Hypothesis track -> truth object: the object whose box it overlaps with IoU >= 0.3 in most of
its frames (synthetic), or a track box intersecting an anomaly box by >= 30 % of the smaller of
the two in >= 50 % of its frames (UCSD). Scores:
`rhythmjax.evaluation.motscore.score_mot`, IoU >= 0.5.

    python benchmarks/eval_count.py [--quick] [--parts synthetic,pets,ucsd] [--median-init]
                                    [--seed S] [--legs knees|rods] [--json OUT.json]

Writes nothing unless --json is given. Without `count.count_frames` only the SORT baseline on
`sort_baseline.blob_detections` runs.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from rhythmjax.evaluation.motscore import iou_matrix, motmetrics_version, score_mot
from rhythmjax.evaluation.sort_baseline import ASSIGNMENT_SOLVER, blob_detections, sort_track


SEED = 4_2024
PETS_PEOPLE = 19
UCSD_FPS = 30.0  # not stated; see eval_real_video.py's module doc
UCSD_CAMERA = {"f_m": 0.008, "h_m": 10.0, "theta_deg": 30.0, "a_px_per_m": 50000.0,
               "b_px_per_m": 50000.0, "uc_px": 180.0, "vc_px": 120.0, "fps": UCSD_FPS,
               "image_width_px": 360, "image_height_px": 240}
SCORE_KEYS = ("mota", "idf1", "id_switches", "precision", "recall", "mostly_tracked",
              "mostly_lost", "n_hyp_ids", "count", "count_error")


def _count_frames():
    try:
        from rhythmjax.count import count_frames
        from rhythmjax.vision.blobgraph import blob_graph  # noqa: F401  (count_frames needs it)
    except ImportError as e:
        print(f"count_frames unavailable ({e}); SORT baseline only", file=sys.stderr)
        return None
    return count_frames


def _short(s) -> dict:
    return {k: getattr(s, k) for k in SCORE_KEYS}


def walking_ids(res) -> list[int]:
    """The ids `count.COUNT_RULE` counts as walkers: every track not judged non-pedestrian."""
    from rhythmjax.count import walker_ids

    return walker_ids(res.verdicts)


def verdict_of(res) -> dict[int, str]:
    return {int(i): str(w) for i, w in zip(res.verdicts["track_id"], res.verdicts["verdict"])}


def prepare(frames: list, median_init: bool) -> tuple[list, int]:
    """(frames to feed, offset from a MOT frame number to the 0-based truth frame). With
    `median_init` the per-pixel median of up to 60 evenly spaced frames is put first, so the
    background model starts empty (no ghosts of people standing in frame 0); indices shift
    by one."""
    if not median_init:
        return frames, -1
    good = [f for _, _, f in frames if f is not None]
    med = np.median(np.stack(good[:: max(1, len(good) // 60)]), axis=0).astype(np.uint8)
    dt = frames[1][1] - frames[0][1] if len(frames) > 1 else 0.1
    return [(0, frames[0][1] - dt, med)] + [(k + 1, t, f) for k, t, f in frames], -2


def _sort_on(det, n_frames: int, truth, offset: int) -> dict:
    hyp = sort_track(det, frames=range(-offset, n_frames - offset))
    return _short(score_mot(truth, hyp, frame_offset=offset))


# ----------------------------------------------------------------------------------------------
# (a) synthetic scenes


def scene_specs(n: int, seed: int = SEED, n_frames: int = 180, camera=None,
                clothing: str = "contrasted", pairs: float = 0.0, pair_layout: str = "side",
                articulated: bool = True):
    """(scene seed, spec) of n random counting scenes; `pairs` > 0: that fraction of walkers
    joined by a partner at their shoulder, or in file with `pair_layout` "file"
    (`sim.groups.with_pairs`; 0, the scenes so far); `articulated`: walkers with knees and
    heel-to-toe feet (`random_spec`'s; False: straight legs, the scenes before issue 16's
    thirty-eighth round)."""
    from rhythmjax.sim.groups import with_pairs
    from rhythmjax.sim.scene import random_spec

    rng = np.random.default_rng(seed)
    out = []
    s = seed
    while len(out) < n:
        nw, nb = int(rng.integers(2, 9)), int(rng.integers(1, 3))
        for _ in range(20):  # a seed whose paths cannot all be placed is skipped
            s += 7919
            try:
                spec = random_spec(s, n_walkers=nw, n_bicycles=nb, n_dogs=0,
                                   n_frames=n_frames, camera=camera, occlusion=True,
                                   min_life=100, max_life=150, bicycle_speed=(3.0, 3.2),
                                   range_m=(3.1, 19.9), crossing_fraction=0.95,
                                   clothing=clothing, articulated=articulated)
                out.append((s, with_pairs(spec, s, pairs, range_m=(3.1, 19.9),
                                          layout=pair_layout)))
                break
            except RuntimeError:
                continue
    return out


def truth_boxes(scene) -> tuple[dict[str, np.ndarray], dict[int, str]]:
    """MOT truth (frame 0-based, id = actor index + 1) and the kind of each id (module doc)."""
    from rhythmjax.sim.actors import EXTENT
    from rhythmjax.sim.scene import project_3d

    cam = scene.spec.camera
    rows, kinds = [], {}
    for i, (tr, act) in enumerate(zip(scene.truth, scene.spec.actors)):
        kinds[i + 1] = tr.kind
        height = act.height_m if tr.kind == "pedestrian" else EXTENT[tr.kind][1]
        k = np.flatnonzero(tr.visible & np.isfinite(tr.width_px))
        if not k.size:
            continue
        uc, _ = project_3d(cam, tr.body_x[k], tr.body_y[k], 0.0)
        _, vh = project_3d(cam, tr.body_x[k], tr.body_y[k], height)
        uc, vh = uc + scene.jitter[k, 0], vh + scene.jitter[k, 1]
        W, H = cam.image_width, cam.image_height  # clipped to the image, as a blob box is
        x0, x1 = np.clip(uc - tr.width_px[k] / 2, 0, W), np.clip(uc + tr.width_px[k] / 2, 0, W)
        y0, y1 = np.clip(vh, 0, H), np.clip(tr.v[k] + 1, 0, H)
        for j, f in enumerate(k):
            if x1[j] > x0[j] and y1[j] > y0[j]:
                rows.append((f, i + 1, x0[j], y0[j], x1[j] - x0[j], y1[j] - y0[j]))
    a = np.asarray(rows, np.float64).reshape(-1, 6)
    return ({"frame": a[:, 0].astype(np.int64), "id": a[:, 1].astype(np.int64),
             "bb_left": a[:, 2], "bb_top": a[:, 3], "bb_width": a[:, 4], "bb_height": a[:, 5]},
            kinds)


def owner_of_tracks(truth, hyp, offset: int, min_iou: float = 0.3) -> dict[int, int | None]:
    """Per hypothesis id: the truth id it overlaps (IoU >= min_iou) in most of its frames."""
    votes: dict[int, dict[int, int]] = {}
    tb = np.stack([truth[c] for c in ("bb_left", "bb_top", "bb_width", "bb_height")], 1)
    hb = np.stack([hyp[c] for c in ("bb_left", "bb_top", "bb_width", "bb_height")], 1)
    hf = np.asarray(hyp["frame"]) + offset
    n = {}
    for f in np.unique(hf):
        kt, kh = np.flatnonzero(truth["frame"] == f), np.flatnonzero(hf == f)
        iou = iou_matrix(hb[kh], tb[kt])
        for a, h in enumerate(kh):
            hid = int(hyp["id"][h])
            n[hid] = n.get(hid, 0) + 1
            if iou.shape[1] and iou[a].max() >= min_iou:
                t = int(truth["id"][kt[int(np.argmax(iou[a]))]])
                votes.setdefault(hid, {})[t] = votes.setdefault(hid, {}).get(t, 0) + 1
    out: dict[int, int | None] = {}
    for hid, tot in n.items():
        v = votes.get(hid, {})
        best = max(v, key=v.get) if v else None
        out[hid] = best if best is not None and v[best] >= 0.5 * tot else None
    return out


def eval_synthetic(n_scenes: int, count_frames, log, median_init: bool = False,
                   seed: int = SEED, articulated: bool = True) -> dict:
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import render_scene

    cfg = config_from_dict(SYNTHETIC_CONFIG)
    rows = []
    for i, (scene_seed, spec) in enumerate(scene_specs(n_scenes, seed=seed, camera=cfg.camera,
                                                             articulated=articulated)):
        t0 = time.perf_counter()
        scene = render_scene(scene_seed, spec)
        truth, kinds = truth_boxes(scene)
        seen = set(truth["id"].tolist())
        n_walk = sum(1 for t, k in kinds.items() if k == "pedestrian" and t in seen)
        n_bike = sum(1 for t, k in kinds.items() if k == "bicycle" and t in seen)
        T = len(scene.frames)
        frames, off = prepare([(k, k / scene.fps, f) for k, f in enumerate(scene.frames)],
                              median_init)
        row = {"scene": i, "seed": scene_seed, "walkers": n_walk, "bicycles": n_bike}
        if count_frames is not None:
            res = count_frames(cfg, iter(frames), n_frames=len(frames))
            s = score_mot(truth, res.mot, frame_offset=off, walking_ids=walking_ids(res),
                          truth_walking_ids=[t for t in seen if kinds[t] == "pedestrian"])
            own, verdict = owner_of_tracks(truth, res.mot, off), verdict_of(res)
            bike_tracks = [h for h, t in own.items() if t and kinds[t] == "bicycle"]
            row.update(counted=res.counts["walkers"], tracks=res.counts["tracks"],
                       counts=res.counts, stitched=res.summary.get("stitched", 0),
                       count_error=res.counts["walkers"] - n_walk, paper=_short(s),
                       bicycle_tracks=len(bike_tracks),
                       bicycle_tracks_pedestrian=sum(verdict.get(h) == "pedestrian"
                                                     for h in bike_tracks),
                       walker_tracks=sum(1 for t in own.values() if t and
                                         kinds[t] == "pedestrian"),
                       walker_tracks_verdicts={v: sum(verdict.get(h) == v for h, t in own.items()
                                                      if t and kinds[t] == "pedestrian")
                                               for v in ("pedestrian", "non-pedestrian",
                                                         "unclassified")},
                       bicycle_tracks_verdicts={v: sum(verdict.get(h) == v for h in bike_tracks)
                                                for v in ("pedestrian", "non-pedestrian",
                                                          "unclassified")},
                       walkers_with_a_pedestrian_track=len({
                           t for h, t in own.items() if t and kinds[t] == "pedestrian"
                           and verdict.get(h) == "pedestrian"}),
                       track_frames=np.bincount(res.mot["id"]).tolist(),
                       unmatched_tracks_pedestrian=sum(verdict.get(h) == "pedestrian"
                                                       for h, t in own.items() if t is None))
            det = res.detections
        else:
            det = blob_detections(frames)
            det["frame"] = det["frame"] + 1
        row["sort"] = _sort_on(det, T, truth, off)
        row["seconds"] = time.perf_counter() - t0
        log(f"scene {i}: {json.dumps(row, default=float)}")
        rows.append(row)
    out: dict = {"scenes": rows, "n_walkers": sum(r["walkers"] for r in rows),
                 "n_bicycles": sum(r["bicycles"] for r in rows)}
    if count_frames is not None:
        nw = out["n_walkers"]
        out["counted"] = sum(r["counted"] for r in rows)
        out["total_count_error_rel"] = (out["counted"] - nw) / nw
        out["sum_abs_count_error_rel"] = sum(abs(r["count_error"]) for r in rows) / nw
        out["id_switches_per_scene"] = float(np.mean([r["paper"]["id_switches"] for r in rows]))
        out["bicycle_tracks_pedestrian"] = sum(r["bicycle_tracks_pedestrian"] for r in rows)
    out["sort_id_switches_per_scene"] = float(np.mean([r["sort"]["id_switches"] for r in rows]))
    return out


# ----------------------------------------------------------------------------------------------
# (b) PETS 2009 S2.L1 and (c) UCSD Ped2


def _config(camera, range_m=(5.0, 50.0)):
    from rhythmjax.model.params import Config, Thresholds

    return Config(camera=camera, thresholds=Thresholds(range_min=range_m[0],
                                                       range_max=range_m[1]))


def eval_pets(count_frames, max_frames: int | None, log, median_init: bool = False) -> dict:
    from rhythmjax.evaluation import datasets
    from rhythmjax.vision.video import VideoSource

    if datasets.pets_root() is None:
        return {"skipped": "PETS folder absent"}
    cfg = _config(datasets.pets_camera())
    truth = datasets.pets_boxes()
    src = VideoSource(str(datasets.pets_video()), fps=datasets.PETS_FPS)
    frames = [x for x in src if max_frames is None or x[0] < max_frames]
    T = len(frames)
    frames, off = prepare(frames, median_init)
    keep = truth["frame"] < T
    truth = {k: v[keep] for k, v in truth.items()}
    out: dict = {"frames": T, "fps": datasets.PETS_FPS, "truth_ids": int(np.unique(
        truth["id"]).size)}
    t0 = time.perf_counter()
    if count_frames is not None:
        res = count_frames(cfg, iter(frames), n_frames=len(frames))
        out["paper"] = _short(score_mot(truth, res.mot, frame_offset=off,
                                        walking_ids=walking_ids(res)))
        out["counts"] = res.counts
        out["stitched"] = res.summary.get("stitched", 0)
        out["summary_notes"] = res.summary.get("notes", [])
        det = res.detections
    else:
        det = blob_detections(frames)
        det["frame"] = det["frame"] + 1
    out["seconds_paper"] = time.perf_counter() - t0
    out["detections_per_frame"] = len(det["frame"]) / T
    out["sort"] = _sort_on(det, T, truth, off)
    out["sort_max_age_3"] = _short(score_mot(truth, sort_track(
        det, frames=range(-off, T - off), max_age=3), frame_offset=off))
    log(f"PETS: {json.dumps(out, default=float)}")
    return out


def anomaly_tracks(mot, boxes, offset: int) -> list[int]:
    """Hypothesis ids whose box meets an anomaly box (>= 30 % of the smaller box) in >= 50 % of
    the track's frames."""
    hits: dict[int, int] = {}
    n: dict[int, int] = {}
    ab = np.stack([boxes[c] for c in ("x", "y", "w", "h")], 1)
    for r in range(len(mot["frame"])):
        hid, f = int(mot["id"][r]), int(mot["frame"][r]) + offset
        n[hid] = n.get(hid, 0) + 1
        a = ab[boxes["frame"] == f]
        if not len(a):
            continue
        b = np.array([mot["bb_left"][r], mot["bb_top"][r], mot["bb_width"][r],
                      mot["bb_height"][r]])
        iw = np.minimum(a[:, 0] + a[:, 2], b[0] + b[2]) - np.maximum(a[:, 0], b[0])
        ih = np.minimum(a[:, 1] + a[:, 3], b[1] + b[3]) - np.maximum(a[:, 1], b[1])
        inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
        if np.any(inter >= 0.3 * np.minimum(a[:, 2] * a[:, 3], b[2] * b[3])):
            hits[hid] = hits.get(hid, 0) + 1
    return sorted(h for h in hits if hits[h] >= 0.5 * n[h])


def eval_ucsd(count_frames, clips, log, median_init: bool = False) -> dict:
    from rhythmjax.evaluation import datasets
    from rhythmjax.vision.video import VideoSource

    if datasets.ucsd_root() is None:
        return {"skipped": "UCSD folder absent"}
    if count_frames is None:
        return {"skipped": "count_frames unavailable"}
    from rhythmjax.model.params import config_from_dict

    cfg = _config(config_from_dict({"camera": UCSD_CAMERA}).camera)
    out: dict = {"fps_assumed": UCSD_FPS, "camera_guess": UCSD_CAMERA, "clips": []}
    for clip in clips:
        folder, boxes = datasets.ucsd_clip(clip)
        frames, off = prepare(list(VideoSource(str(folder), fps=UCSD_FPS)), median_init)
        res = count_frames(cfg, iter(frames), n_frames=len(frames))
        verdict = verdict_of(res)
        anom = anomaly_tracks(res.mot, boxes, off)
        row = {"clip": clip, "frames": len(frames) + off + 1, "counts": res.counts,
               "stitched": res.summary.get("stitched", 0),
               "anomaly_tracks": len(anom),
               "anomaly_non_pedestrian": sum(verdict.get(h) == "non-pedestrian" for h in anom),
               "anomaly_pedestrian": sum(verdict.get(h) == "pedestrian" for h in anom),
               "anomaly_unclassified": sum(verdict.get(h) == "unclassified" for h in anom)}
        log(f"UCSD {json.dumps(row, default=float)}")
        out["clips"].append(row)
    for k in ("anomaly_tracks", "anomaly_non_pedestrian", "anomaly_pedestrian"):
        out[k] = sum(r[k] for r in out["clips"])
    out["walkers"] = sum(r["counts"]["walkers"] for r in out["clips"])
    return out


# ----------------------------------------------------------------------------------------------


def _fmt(x) -> str:
    return f"{x:.3f}" if isinstance(x, float) and math.isfinite(x) else str(x)


def print_tables(out: dict) -> None:
    syn = out.get("synthetic")
    if syn:
        print("\n| scene | walkers | counted | err | bicycles (judged ped.) | IDSW | MOTA | IDF1 |"
              " SORT IDSW | SORT MOTA | SORT IDF1 |\n|" + "---|" * 11)
        for r in syn["scenes"]:
            p = r.get("paper", {})
            print(f"| {r['scene']} | {r['walkers']} | {r.get('counted', '-')} | "
                  f"{r.get('count_error', '-')} | {r['bicycles']} "
                  f"({r.get('bicycle_tracks_pedestrian', '-')}) | {p.get('id_switches', '-')} | "
                  f"{_fmt(p.get('mota', '-'))} | {_fmt(p.get('idf1', '-'))} | "
                  f"{r['sort']['id_switches']} | {_fmt(r['sort']['mota'])} | "
                  f"{_fmt(r['sort']['idf1'])} |")
        if "counted" in syn:
            print(f"\nwalkers {syn['counted']} counted / {syn['n_walkers']} true: total error "
                  f"{100 * syn['total_count_error_rel']:+.1f} %, sum |error| "
                  f"{100 * syn['sum_abs_count_error_rel']:.1f} % (target <= 5 %); IDSW/scene "
                  f"{syn['id_switches_per_scene']:.2f}; bicycle tracks judged Pedestrian "
                  f"{syn['bicycle_tracks_pedestrian']} (bicycles: {syn['n_bicycles']})")
    pets = out.get("pets")
    if pets and "skipped" not in pets:
        print(f"\nPETS09-S2L1 ({pets['frames']} frames, {pets['truth_ids']} people)\n"
              "| method | MOTA | IDF1 | IDSW | precision | recall | MT | ML | ids | walkers |"
              "\n|" + "---|" * 10)
        for name, key in (("paper (count_frames)", "paper"), ("SORT (max_age 1)", "sort"),
                          ("SORT (max_age 3)", "sort_max_age_3")):
            if key in pets:
                s = pets[key]
                walk = pets["counts"]["walkers"] if key == "paper" else "-"
                print(f"| {name} | {_fmt(s['mota'])} | {_fmt(s['idf1'])} | {s['id_switches']} |"
                      f" {_fmt(s['precision'])} | {_fmt(s['recall'])} | {s['mostly_tracked']} |"
                      f" {s['mostly_lost']} | {s['n_hyp_ids']} | {walk} |")
    ucsd = out.get("ucsd")
    if ucsd and "skipped" not in ucsd:
        print(f"\nUCSD Ped2 ({UCSD_FPS:g} fps assumed)\n| clip | tracks | walkers | anomaly "
              "tracks | non-ped. | ped. | unclassified |\n|" + "---|" * 7)
        for r in ucsd["clips"]:
            print(f"| {r['clip']} | {r['counts']['tracks']} | {r['counts']['walkers']} | "
                  f"{r['anomaly_tracks']} | {r['anomaly_non_pedestrian']} | "
                  f"{r['anomaly_pedestrian']} | {r['anomaly_unclassified']} |")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help="3 scenes, the first 200 PETS frames, one UCSD clip (a smoke run)")
    p.add_argument("--parts", default="synthetic,pets,ucsd")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--seed", type=int, default=SEED, help="seed of the synthetic scenes "
                   "(a second seed checks that a change is not tuned to the default's scenes)")
    p.add_argument("--legs", default="knees", choices=("knees", "rods"),
                   help="synthetic walkers' legs: knees and heel-to-toe feet (default) or rods")
    p.add_argument("--json", help="write the figures here (nothing is written otherwise)")
    p.add_argument("--sort-only", action="store_true", help="skip count_frames")
    p.add_argument("--median-init", action="store_true",
                   help="start the background model from a temporal median (see `prepare`)")
    p.add_argument("-q", "--quiet", action="store_true")
    a = p.parse_args(argv)
    log = (lambda s: None) if a.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
    parts = set(a.parts.split(","))
    count_frames = None if a.sort_only else _count_frames()
    out: dict = {"motmetrics": motmetrics_version(), "assignment": ASSIGNMENT_SOLVER,
                 "iou_threshold": 0.5, "quick": a.quick, "median_init": a.median_init,
                 "seed": a.seed, "legs": a.legs,
                 "paper_method": count_frames is not None}
    t0 = time.perf_counter()
    if "synthetic" in parts:
        out["synthetic"] = eval_synthetic(3 if a.quick else a.scenes, count_frames, log,
                                          a.median_init, a.seed, a.legs == "knees")
    if "pets" in parts:
        out["pets"] = eval_pets(count_frames, 200 if a.quick else None, log, a.median_init)
    if "ucsd" in parts:
        from rhythmjax.evaluation.datasets import UCSD_CLIPS

        out["ucsd"] = eval_ucsd(count_frames, UCSD_CLIPS[:1] if a.quick else UCSD_CLIPS, log,
                               a.median_init)
    out["seconds"] = time.perf_counter() - t0
    print(f"py-motmetrics {out['motmetrics']}, IoU >= 0.5, assignment {out['assignment']}")
    print_tables(out)
    if a.json:
        from rhythmjax.io import atomic_write, dumps_json

        with atomic_write(a.json, "w") as fh:
            fh.write(dumps_json(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
