"""Video verbs of the command line: `track`, `run` and `demo` (registered by `rhythmjax.cli`)."""

from __future__ import annotations

import contextlib
import os
import sys

import numpy as np


TRACK_ORDER = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "x_est", "y_est",
               "state"]
# The config the demo (and benchmarks/eval_synthetic.py) track synthetic scenes with: Table 1
# defaults but for the measurement noise (the motion image's foot point scatters ~4 px in u and
# v, with heavy tails, against the default 2 px) and the width spread (the motion extent holds
# the swinging legs and the displacement per frame: 0.5-1.1 m measured for a 0.5 m walker, so
# 0.12 m made gate (10) reject ~30 % of a walker's measurements).
SYNTHETIC_CONFIG = {"noise": {"r_std_px": [4.0, 4.0]}, "width": {"std_m": 0.2}}
# The tracker options for the synthetic scenes: the renderer's legs are plain polygons whose
# inside does not change, so when the feet stand still the motion's bottom is a knee or the
# torso; dropping such foot points (tracker.TrackerOptions.high_foot_widths, chosen on training
# seeds 5555 and 6666) halves the stride error there. Off by default: on PETS09 (7 fps, textured
# people seen from 7 m up) it cost coverage (71 -> 66 % of person-frames).
SYNTHETIC_OPTIONS = {"high_foot_widths": 0.25}


# The synthetic scenes of the demo and of benchmarks/eval_synthetic.py (synth.random_spec): each
# object in view 110-150 of 180 frames, bicycles at 3.0-3.2 m/s on mostly radial paths (in the
# 3-20 m range for ~75 frames, >= N = 64), all within 3.1-19.9 m.
SCENE_OPTIONS = {"min_life": 110, "max_life": 150, "bicycle_speed": (3.0, 3.2),
                 "range_m": (3.1, 19.9), "crossing_fraction": 0.95}


def synthetic_options():
    from .tracker import TrackerOptions

    return TrackerOptions(**SYNTHETIC_OPTIONS)

VERDICT_ORDER = ["track_id", "verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps",
                 "n_samples"]


def _progress(total, enabled, desc):
    if enabled and sys.stderr.isatty():
        from tqdm import tqdm

        return tqdm(total=total or None, unit="frame", desc=desc, file=sys.stderr)
    return None


def check_config_fits_image(cfg, width: int, height: int) -> None:
    """Some of the detection range must be visible: its rows (near end low in the image, far end
    higher up) must overlap the image, else every detection is refused and nothing is tracked."""
    import jax.numpy as jnp

    from .camera import project
    from .params import ConfigError

    thr = cfg.thresholds
    vs = [float(project(cfg.camera, jnp.float32(0.0), jnp.float32(float(y)))[1])
          for y in (thr.range_min, thr.range_max)]
    if not (vs[1] < height and vs[0] >= 0):
        raise ConfigError("camera", f"the detection range {float(thr.range_min):g}-"
                          f"{float(thr.range_max):g} m projects to rows {vs[0]:.0f}-{vs[1]:.0f}, "
                          f"outside the {width}x{height} image; check h_m, theta_deg, vc_px")


@contextlib.contextmanager
def overlay_writer(path, fps, size):
    """The annotated-video writer, opened before any work (a bad path fails fast), committed
    (renamed into place) when the block succeeds and removed when it fails; None for no path."""
    if path is None:
        yield None
        return
    from .video import open_writer

    writer = open_writer(path, fps, size)
    try:
        yield writer
    except BaseException:
        writer.abort()
        raise
    writer.close()


def drive_frames(frames, update, overlay, draw, *, n_frames=None, progress=True, desc=""):
    """Feed every `(index, t, frame)` item to `update(index, t, frame)`, with a progress bar on
    a terminal; when the `overlay` writer is open, write `draw(frame, index)` for each decoded
    frame (a frame that failed to decode is None: nothing is drawn)."""
    bar = _progress(n_frames, progress, desc)
    try:
        for index, t, frame in frames:
            update(index, t, frame)
            if overlay is not None and frame is not None:
                overlay.write(draw(frame, index))
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()


def track_frames(cfg, frames, *, n_frames=None, overlay=None, progress=True, options=None):
    """Run the online tracker over `(index, t, frame)` items; returns (tracks, verdicts, objs,
    tracker). Draws into the open `overlay` writer when given."""
    from .overlay import draw_frame
    from .tracker import OnlineTracker

    tracker = OnlineTracker(cfg, options)
    drive_frames(frames, tracker.update, overlay,
                 lambda frame, index: draw_frame(frame, tracker.snapshot(), index),
                 n_frames=n_frames, progress=progress, desc="track")
    tracks, verdicts, objs = tracker.finish()
    return tracks, verdicts, objs, tracker


def _open_source(args, cfg):
    from .video import open_video

    fps = args.fps if args.fps is not None else None
    src = open_video(args.video, fps=fps if fps is not None else None)
    if not np.isfinite(src.fps):
        from .io import BadInput

        raise BadInput(args.video, "no frame rate; give --fps")
    check_config_fits_image(cfg, src.width, src.height)
    return src


def _write_outputs(out_dir, cfg, tracks, verdicts, objs, *, tracks_name="tracks.parquet"):
    from .io import write_table
    from .overlay import spectrum_figure

    write_table(os.path.join(out_dir, tracks_name), tracks, TRACK_ORDER)
    write_table(os.path.join(out_dir, "verdicts.csv"), verdicts, VERDICT_ORDER)
    spectrum_figure(os.path.join(out_dir, "spectra.png"), cfg, tracks, verdicts, objs)


def _summary(tracker, verdicts, src=None) -> dict:
    v = list(verdicts["verdict"])
    s = {"n_frames": tracker.n_frames, "n_tracks": len(v),
         "verdicts": {k: v.count(k) for k in ("pedestrian", "non-pedestrian", "unclassified")},
         "glitch_frames": len(tracker.glitch_frames),
         "duplicate_frames": len(tracker.duplicate_frames)}
    if src is not None:
        s.update(bad_frames=len(src.bad_frames), notes=list(src.notes))
    return s


def _report(args, summary, verdicts) -> None:
    from .cli import _emit_json, _print_verdicts

    if args.json:
        _emit_json(summary)
        return
    _print_verdicts(verdicts)
    v = summary["verdicts"]
    print(f"{summary['n_frames']} frames, {summary['n_tracks']} tracks: {v['pedestrian']} "
          f"pedestrian, {v['non-pedestrian']} non-pedestrian, {v['unclassified']} unclassified",
          file=sys.stderr)


def cmd_track(args) -> int:
    """Track the moving objects of a video (Fig. 3 state machine, EKF + gates (10)(11)) and
    write the tracks file; classification happens as in `run` and is in the summary."""
    from .cli import _load_config
    from .io import check_writable, write_table

    check_writable(args.output)
    cfg = _load_config(args.config)
    with _open_source(args, cfg) as src, overlay_writer(
            args.overlay, src.fps, (src.width, src.height)) as overlay:
        tracks, verdicts, objs, tracker = track_frames(
            cfg, src, n_frames=src.n_frames, overlay=overlay,
            progress=not (args.quiet or args.json))
        write_table(args.output, tracks, TRACK_ORDER)
    _report(args, _summary(tracker, verdicts, src), verdicts)
    return 0


def cmd_run(args) -> int:
    """The main job: track and classify the objects of a video; writes DIR/tracks.parquet,
    DIR/verdicts.csv, DIR/spectra.png and DIR/overlay.mp4 (annotated video)."""
    from .cli import _load_config
    from .io import check_writable, make_output_dir

    make_output_dir(args.output)
    check_writable(os.path.join(args.output, "verdicts.csv"))
    cfg = _load_config(args.config)
    path = None if args.no_overlay else os.path.join(args.output, "overlay.mp4")
    with _open_source(args, cfg) as src, overlay_writer(path, src.fps,
                                                        (src.width, src.height)) as overlay:
        tracks, verdicts, objs, tracker = track_frames(
            cfg, src, n_frames=src.n_frames, overlay=overlay,
            progress=not (args.quiet or args.json))
        _write_outputs(args.output, cfg, tracks, verdicts, objs)
    _report(args, _summary(tracker, verdicts, src), verdicts)
    return 0


def cmd_demo(args) -> int:
    """The built-in default: render a synthetic scene (walkers, a bicycle, a dog; the paper's
    camera, 15 Hz, 512x512), run the whole pipeline (config: SYNTHETIC_CONFIG), print the
    verdicts beside the truth, and write tracks, verdicts, truth, an annotated video and the
    spectra to DIR."""
    from .evaluate import deciding_windows, score
    from .io import check_writable, make_output_dir, write_table
    from .params import config_from_dict
    from .synth import random_spec, render_scene, scene_to_tracks_truth

    make_output_dir(args.output)
    check_writable(os.path.join(args.output, "verdicts.csv"))
    cfg = config_from_dict(SYNTHETIC_CONFIG)
    spec = random_spec(args.seed, n_walkers=args.walkers, n_bicycles=1, n_dogs=1,
                       n_frames=args.frames, camera=cfg.camera, **SCENE_OPTIONS)
    scene = render_scene(args.seed, spec)
    truth_cols = scene_to_tracks_truth(scene)
    frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
    size = (scene.frames.shape[2], scene.frames.shape[1])
    path = None if args.no_overlay else os.path.join(args.output, "overlay.mp4")
    with overlay_writer(path, scene.fps, size) as overlay:
        tracks, verdicts, objs, tracker = track_frames(
            cfg, frames, n_frames=len(scene.frames), overlay=overlay,
            progress=not (args.quiet or args.json), options=synthetic_options())
        _write_outputs(args.output, cfg, tracks, verdicts, objs)
        write_table(os.path.join(args.output, "truth.csv"), truth_cols,
                    ["track_id", "frame", "t", "u", "v", "width_px", "label", "x", "y"])
    result = score(tracks, verdicts, scene.truth, windows=deciding_windows(objs))
    summary = {**_summary(tracker, verdicts), "output": args.output,
               **{k: v for k, v in result.items() if k != "objects"},
               "objects": result["objects"]}
    if args.json:
        from .cli import _emit_json

        _emit_json(summary)
        return 0
    print(f"{'object':>7} {'kind':>10} {'verdict':>15} {'pace':>6} {'true':>6} {'stride':>6} "
          f"{'true':>6} tracks")
    for r in result["objects"]:
        f = lambda x: "" if not np.isfinite(x) else f"{x:.2f}"
        print(f"{r['object']!s:>7} {r['kind']:>10} {r['verdict']:>15} {f(r['pace']):>6} "
              f"{f(r['pace_true']):>6} {f(r['stride']):>6} {f(r['stride_true']):>6} "
              f"{r['tracks']:>6}")
    print(f"walkers judged pedestrian: {result['walkers_pedestrian']}/{result['walkers']}; "
          f"others judged non-pedestrian: {result['others_non_pedestrian']}/"
          f"{result['others_judged']} judged of {result['others']}; pace MAE "
          f"{result['pace_mae_hz']:.3f} Hz; wrote {args.output}/", file=sys.stderr)
    return 0


def register(sub, formatter, common) -> None:
    p = sub.add_parser("demo", formatter_class=formatter, help="the built-in default: a "
                       "synthetic scene through the whole pipeline", description=cmd_demo.__doc__)
    p.add_argument("-o", "--output", default="demo_out", metavar="DIR", help="output directory")
    p.add_argument("--seed", type=int, default=4, help="scene seed (default 4: a scene where "
                   "every object is judged right; seeds 0-3 and 5 show the failure modes: a "
                   "walker tracked too briefly to judge, a walker or a dog misjudged)")
    p.add_argument("--walkers", type=int, default=4, help="walkers in the scene")
    p.add_argument("--frames", type=int, default=180, help="frames at 15 Hz")
    p.add_argument("--no-overlay", action="store_true", help="skip the annotated video")
    common(p, config=False)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("track", formatter_class=formatter, help="track the moving objects "
                       "of a video", description=cmd_track.__doc__)
    p.add_argument("video", metavar="VIDEO", help="video file, or a folder of numbered frames")
    p.add_argument("-o", "--output", required=True, metavar="TRACKS",
                   help="tracks file (.parquet or .csv)")
    p.add_argument("--overlay", metavar="OUT.mp4", help="also write an annotated video")
    p.add_argument("--fps", type=float, help="frame rate (overrides the file's; needed for "
                   "frame folders)")
    common(p)
    p.set_defaults(func=cmd_track)

    p = sub.add_parser("run", formatter_class=formatter, help="track and classify the "
                       "objects of a video", description=cmd_run.__doc__)
    p.add_argument("video", metavar="VIDEO", help="video file, or a folder of numbered frames")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output directory")
    p.add_argument("--fps", type=float, help="frame rate (overrides the file's)")
    p.add_argument("--no-overlay", action="store_true", help="skip the annotated video")
    common(p)
    p.set_defaults(func=cmd_run)
