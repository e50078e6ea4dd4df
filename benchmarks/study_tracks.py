"""The tracks of the own scenes and the dev clips that the tracker studies share
(`study_false_positives.py`, `study_missed_walkers.py`, `study_max_missing.py`): every tracked
object's rows (and candidate rows) rendered and tracked as `eval_synthetic.evaluate` does (own
scenes) or as `eval_all.run_dev` does (dev clips), pickled under a cache folder so that rules on
the classification can be replayed without tracking again (the classification never feeds back
into the tracking); tracks cut post hoc at velocity jumps (`split_jumps`); the truth object
nearest each row (`nearest_per_row`); the seeds, scenes and cache of a study's command line
(`study_parser`, `scenes_of`)."""

from __future__ import annotations

import argparse
import math
import pickle
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

from eval_synthetic import scene_specs  # noqa: E402

from rhythmjax.sim.presets import synthetic_options  # noqa: E402


def slim(o) -> SimpleNamespace:
    return SimpleNamespace(track_id=o.track_id, rows=list(o.rows), result=o.result,
                           candidate_rows=None if o.candidate_rows is None
                           else list(o.candidate_rows), vel=list(o.vel),
                           mean_rows=None if getattr(o, "mean_rows", None) is None
                           else list(o.mean_rows))


def track_scene(cfg, seed: int, spec, cache: Path, options=None):
    """(tracks, verdicts, objs (slim), truth) of one own scene, from the cache when there."""
    f = cache / f"own_{seed}.pkl"
    if f.exists():
        with open(f, "rb") as fh:
            return pickle.load(fh)
    from rhythmjax.sim.scene import render_scene
    from rhythmjax.track import track_frames

    scene = render_scene(seed, spec)
    frames = ((i, i / scene.fps, g) for i, g in enumerate(scene.frames))
    tracks, verdicts, objs, _ = track_frames(cfg, frames, progress=False,
                                             options=options or synthetic_options())
    out = (tracks, verdicts, [slim(o) for o in objs], tuple(scene.truth))
    cache.mkdir(parents=True, exist_ok=True)
    with open(f, "wb") as fh:
        pickle.dump(out, fh)
    return out


def split_jumps(objs, fps: float, max_dv: float, window_s: float = 0.5) -> list:
    """The tracks cut where the filter's ground velocity changed by more than `max_dv` m/s
    within `window_s` s (`track.toolkit.velocity_jump`, the counting tracker's `life.max_dv_mps`
    rule, which the rhythm tracker lacks): the track ends k rows before the jump (k =
    window_s x fps) and its remaining rows become a new track (id + 10000 per cut), judged
    afresh. Post hoc: the new track keeps the old filter's rows (the tracker would start a
    new filter there)."""
    from rhythmjax.track.toolkit import dv_frames, velocity_jump

    k = dv_frames(window_s, fps)
    out = []
    for o in objs:
        rows, cand, vel, tid = o.rows, o.candidate_rows, o.vel, o.track_id
        while True:
            cut = None
            for r in range(2 * k + 1, len(vel) + 1):
                v = vel[:r]
                if not (math.isfinite(v[-1].vx) and math.isfinite(v[-1 - k].vx)):
                    continue
                if velocity_jump(v, k, max_dv):
                    cut = r - k
                    break
            if cut is None:
                out.append(SimpleNamespace(track_id=tid, rows=rows, candidate_rows=cand,
                                           vel=vel, result=None))
                break
            out.append(SimpleNamespace(track_id=tid, rows=rows[:cut], vel=vel[:cut],
                                       candidate_rows=None if cand is None else cand[:cut],
                                       result=None))
            rows, vel, tid = rows[cut:], vel[cut:], tid + 10000
            cand = None if cand is None else cand[cut:]
    return out


def columns_of(objs) -> dict:
    """tracks columns (track_id, frame, u, v) of the slim objects, as `score` reads them."""
    tid, fr, u, v = [], [], [], []
    for o in objs:
        for r in o.rows:
            tid.append(o.track_id)
            fr.append(r.frame)
            u.append(r.u)
            v.append(r.v)
    return {"track_id": np.asarray(tid), "frame": np.asarray(fr), "u": np.asarray(u, float),
            "v": np.asarray(v, float)}


def nearest_objects(rows, truth) -> list:
    """Per measured row of `rows` (`TrackRow`s; rows without a measurement left out), the truth
    object whose foot point is nearest the measured one (None where no object is visible)."""
    out = []
    for r in rows:
        if not math.isfinite(r.u):
            continue
        best, bd = None, math.inf
        for o in truth:
            f = int(r.frame)
            if f < len(o.u) and o.visible[f]:
                d = math.hypot(r.u - o.u[f], r.v - o.v[f])
                if d < bd:
                    best, bd = o, d
        out.append(best)
    return out


def nearest_per_row(obj, k0: int, k1: int, truth) -> str:
    """Per row k0..k1-1 of obj, the truth object whose foot point is nearest the measured one
    (`nearest_objects`): 'id x count' runs."""
    names = ["-" if o is None else f"{o.track_id}({o.kind[:3]})"
             for o in nearest_objects(obj.rows[k0:k1], truth)]
    runs = []
    for nm in names:
        if runs and runs[-1][0] == nm:
            runs[-1][1] += 1
        else:
            runs.append([nm, 1])
    return " ".join(f"{nm}x{c}" for nm, c in runs)


def study_parser(doc: str) -> argparse.ArgumentParser:
    """A study's parser: SEED[,SEED...], --scenes (10), --lateral (paths within 30 degrees of
    crossing the view) and -d CACHE; `doc`'s first paragraph its description."""
    p = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    p.add_argument("seeds")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--lateral", action="store_true", help="paths within 30 deg of crossing")
    p.add_argument("-d", "--cache", type=Path, required=True)
    return p


def scenes_of(cfg, args, options=None, cache: Path | None = None):
    """(name "seed:scene", tracks, objs (slim), truth) of every own scene of `args`
    (`study_parser`'s), tracked as `eval_synthetic.py` tracks them (`track_scene`, cached under
    `cache`, default args.cache; `options`, default the synthetic scenes')."""
    for seed in (int(s) for s in args.seeds.split(",")):
        specs = scene_specs(seed, args.scenes, camera=cfg.camera,
                            lateral_deg=30.0 if args.lateral else None)
        for i, (s, spec) in enumerate(specs):
            tracks, _, objs, truth = track_scene(cfg, s, spec,
                                                 (cache or args.cache) / str(seed), options)
            yield f"{seed}:{i}", tracks, objs, truth


def own_scenes(cfg, seed, n_scenes, cache, split_dv: float = 0.0):
    """(name, tracks, objs, truth) per own scene; split_dv > 0: the tracks cut at velocity
    jumps (`split_jumps`)."""
    out = []
    for i, (s, spec) in enumerate(scene_specs(seed, n_scenes, camera=cfg.camera)):
        tracks, verdicts, objs, truth = track_scene(cfg, s, spec, cache / str(seed))
        if split_dv > 0:
            objs = split_jumps(objs, float(cfg.camera.fps), split_dv)
            tracks = columns_of(objs)
        out.append((f"{seed}:{i}", tracks, objs, truth))
    return out


def dev_scenes(cache: Path):
    """(clip, cfg, tracks, objs, truth) of the dev clips with single objects (report only),
    tracked as `eval_all.run_dev` tracks them (the clip's camera, `TrackerOptions()`)."""
    import json

    import eval_real_video as ev
    from eval_all_score import dev_camera, dev_truth
    from eval_window_b import DEV_ROOT

    from rhythmjax.track import track_frames
    from rhythmjax.track.options import TrackerOptions
    from rhythmjax.vision.video import open_video

    out = []
    for c in json.loads((DEV_ROOT / "index.json").read_text())["clips"]:
        if c.get("count"):
            continue
        truth = json.loads((DEV_ROOT / c["truth"]).read_text())
        path = DEV_ROOT / c["video"]
        cfg = ev.video_config(dev_camera(truth), path, truth["fps"])
        f = cache / "dev" / f"{c['clip']}.pkl"
        if f.exists():
            with open(f, "rb") as fh:
                tracks, objs = pickle.load(fh)
        else:
            with open_video(str(path), fps=truth["fps"]) as src:
                tracks, _, objs, _ = track_frames(cfg, src, progress=False,
                                                  options=TrackerOptions())
            objs = [slim(o) for o in objs]
            f.parent.mkdir(parents=True, exist_ok=True)
            with open(f, "wb") as fh:
                pickle.dump((tracks, objs), fh)
        out.append((c["clip"], cfg, tracks, objs, dev_truth(truth)))
    return out
