"""Which windows rule 35b decides, and what the sum read there (issue 16; a study: nothing is
chosen here).

Rule 35b (`body.window_mean_refused`) judges a rhythm window again on I(k) per pixel where the
sum I(k) of Sec. 4.1 does not say Pedestrian. This tracks with the rule on without rule 35c's
gate (`body.mean_refused_gate` False; the defaults have it) and, per track judged
Pedestrian whose deciding window the sum alone would not have judged so (`sum_outcome`: the same
window judged again with the per-pixel rows left out, rule 37's second look included), prints the
sum's reason and strongest peaks (Hz, power), the mean's, the speed (12) of the window and of its
halves (`track.toolkit.half_speeds`, m/s), and what the window followed: on the own scenes the
truth object (`sim.evaluate.window_objects`), on a UCSD Ped2 clip the fraction of the track's rows
inside the anomaly boxes (`eval_real_video.rows_in_boxes`); on a dev clip (`--dev`) the track.

    python benchmarks/study_mean_refused.py SEED[,SEED...] [--scenes 10] -d DIR
    RHYTHMJAX_DATA=../shared/data/real python benchmarks/study_mean_refused.py --ucsd Test010 -d DIR
    RHYTHMJAX_DATA=../shared/data python benchmarks/study_mean_refused.py --dev dev_multi_01 -d DIR
"""

from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

RULE = {"body.window_mean_refused": True, "body.mean_refused_gate": False}  # rule 35b alone


def sum_outcome(cfg, obj, look=None) -> dict | None:
    """The outcome of `obj`'s deciding window (result["window"]) judged on the sum I(k) alone
    (`track.toolkit.match_window` on a copy without `mean_rows`; `look`: the tracker's second
    look, rules 37 and 45)
    where `obj` is judged Pedestrian and the sum does not say so; else None."""
    from rhythmjax.model.status import Verdict
    from rhythmjax.track.toolkit import match_window

    if (obj.result is None or "window" not in obj.result
            or int(obj.result["verdict"]) != Verdict.PEDESTRIAN):
        return None
    probe = copy.copy(obj)
    probe.mean_rows, probe.second_look = None, look
    probe.win_start, probe.result, probe.decided = int(obj.result["window"][0]), None, False
    probe.windows_done = 0
    match_window(cfg, probe)
    if probe.result is None or int(probe.result["verdict"]) == Verdict.PEDESTRIAN:
        return None
    return probe.result


def decided_by_mean(cfg, opt, objs):
    """(object, its sum outcome) for each of `objs` whose deciding window the sum alone would
    not have judged Pedestrian (`sum_outcome`, with the tracker's look for `opt`:
    `track.looks.tracker_look`, rules 37 and 45)."""
    from rhythmjax.model.camera_np import camera_tuple
    from rhythmjax.track.looks import tracker_look

    look = tracker_look(cfg, camera_tuple(cfg.camera), opt.size)
    for o in objs:
        summed = sum_outcome(cfg, o, look)
        if summed is not None:
            yield o, summed


def describe(cfg, obj, summed: dict) -> str:
    """One line: the sum's reason and peaks, the mean's (the track's result), the speeds."""
    from rhythmjax.model.status import Reason
    from rhythmjax.track.toolkit import half_speeds

    def peaks(res) -> str:
        f = np.asarray(res["peak_freq"], float).ravel()
        p = np.asarray(res["peak_power"], float).ravel()
        m = np.asarray(res["peak_mask"], bool).ravel()
        order = np.argsort(-np.where(m, p, -np.inf))[:3]
        return " ".join(f"{f[i]:.2f}:{p[i]:.1f}" for i in order if m[i])

    k0, k1 = (int(k) for k in obj.result["window"])
    first, last = half_speeds(cfg, obj.rows[k0:k1])
    return (f"sum {Reason(int(summed['reason'])).name.lower()} [{peaks(summed)}] mean pace "
            f"{float(obj.result['pace_hz']):.2f} [{peaks(obj.result)}] speed "
            f"{float(obj.result['speed_mps']):.2f} halves {first:.2f} {last:.2f}")


def own(seeds: str, scenes: int, cache: Path) -> None:
    from eval_synthetic import RECOMMENDED, scene_specs
    from study_tracks import track_scene

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.evaluate import deciding_windows, match_tracks, window_objects
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.track.options import with_changes

    opt = with_changes(synthetic_options(), RULE)
    cfg = config_from_dict(RECOMMENDED)
    for seed in (int(s) for s in seeds.split(",")):
        for i, (s, spec) in enumerate(scene_specs(seed, scenes, camera=cfg.camera)):
            tracks, _, objs, truth = track_scene(cfg, s, spec, cache / "mean_refused" / str(seed),
                                                 options=opt)
            owner = match_tracks(tracks, truth)
            followed = window_objects(tracks, truth, deciding_windows(objs))
            for o, summed in decided_by_mean(cfg, opt, objs):
                kind = getattr(followed.get(o.track_id), "kind", "none")
                scored = getattr(owner.get(o.track_id), "kind", "none")
                print(f"{seed}:{i} track {o.track_id} window {kind} (track {scored}) "
                      f"{describe(cfg, o, summed)}")


def ucsd(clip: str) -> None:
    import eval_real_video as ev
    from eval_all import apply_set

    from rhythmjax.evaluation import datasets
    from rhythmjax.track import track_frames
    from rhythmjax.track.options import TrackerOptions, with_changes
    from rhythmjax.vision.video import open_video

    folder, boxes = datasets.ucsd_clip(clip)
    cfg = ev.video_config(apply_set({"camera": ev.UCSD_CAMERA,
                                     "thresholds": {"window_s": 32 / 30}}, []), folder, 30.0)
    opt = with_changes(TrackerOptions(max_objects=ev.MAX_OBJECTS), RULE)
    tracks, _, objs, _ = track_frames(cfg, open_video(str(folder), fps=30.0), progress=False,
                                      options=opt)
    inside = ev.rows_in_boxes(tracks, boxes)
    tid, u = np.asarray(tracks["track_id"]), np.asarray(tracks["u"])
    for o, summed in decided_by_mean(cfg, opt, objs):
        rows = (tid == o.track_id) & np.isfinite(u)
        frac = float(inside[rows].mean()) if rows.any() else 0.0
        print(f"{clip} track {o.track_id} in anomaly boxes {frac:.2f} "
              f"{describe(cfg, o, summed)}")


def dev(clip: str) -> None:
    import json

    import eval_all as ea
    import eval_real_video as ev

    from rhythmjax.track import track_frames
    from rhythmjax.track.options import TrackerOptions, with_changes
    from rhythmjax.vision.video import open_video

    (entry,) = [c for c in ea._dev_index() if c["clip"] == clip]
    truth = json.loads((ea.DEV_ROOT / entry["truth"]).read_text())
    path = ea.DEV_ROOT / entry["video"]
    cfg = ev.video_config(ea.apply_set(ea.dev_camera(truth), []), path, truth["fps"])
    opt = with_changes(TrackerOptions(), RULE)
    with open_video(str(path), fps=truth["fps"]) as src:
        _, _, objs, _ = track_frames(cfg, src, progress=False, options=opt)
    for o, summed in decided_by_mean(cfg, opt, objs):
        print(f"{clip} track {o.track_id} {describe(cfg, o, summed)}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("seeds", nargs="?", default="")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--ucsd", default="", help="a UCSD Ped2 clip (Test010) instead of own seeds")
    p.add_argument("--dev", default="", help="a dev clip (dev_multi_01) instead of own seeds")
    p.add_argument("-d", "--cache", type=Path, required=True)
    a = p.parse_args(argv)
    if a.ucsd:
        ucsd(a.ucsd)
    elif a.dev:
        dev(a.dev)
    else:
        own(a.seeds, a.scenes, a.cache)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
