"""Video verbs of the command line: `track`, `run` and `demo` (registered by `cli.main`)."""

from __future__ import annotations

import os
import sys

import numpy as np

from ..io import table_suffix, write_table
from ..model.params import ConfigError, config_from_dict
from ..sim.evaluate import deciding_windows, score
from ..sim.presets import SCENE_OPTIONS, SYNTHETIC_CONFIG, synthetic_options
from ..sim.scene import random_spec, render_scene, scene_to_tracks_truth
from ..track.driver import track_frames
from ..track.options import TrackerOptions, with_changes
from .common import (
    TRACK_ORDER,
    VERDICT_ORDER,
    add_camera_check,
    add_common,
    add_strict,
    count_arg,
    emit_json,
    fps_arg,
    load_config_dict,
    open_source,
    output_set,
    overlay_writer,
    print_verdicts,
    reading_check,
    say,
    seed_arg,
)
from .overlay import draw_frame, spectrum_figure


def _drawer(overlay, cfg):
    """The on_frame callback that writes the tracker's snapshot drawn on each frame."""
    if overlay is None:
        return None
    hpw = cfg.width.height_per_width()
    return lambda frame, index, snapshot: overlay.write(
        draw_frame(frame, snapshot, index, height_per_width=hpw))


def _notes(args, notes) -> None:
    """The setup's notes (frame rate, image size), one line each, before the long run."""
    for note in notes:
        say(args, note if note.startswith("warning") else f"note: {note}")


def _options(args) -> TrackerOptions:
    if args.max_objects < 1:
        raise ConfigError("--max-objects", f"must be >= 1, got {args.max_objects}")
    opt = TrackerOptions(max_objects=args.max_objects)
    return with_changes(opt, {"motion.stabilise": False}) if args.no_stabilise else opt


def _write_outputs(outs, out_dir, cfg, tracks, verdicts, objs):
    """tracks.parquet, verdicts.csv and spectra.png of `out_dir`, to the temp paths of `outs`."""
    at = lambda name: outs.path(os.path.join(out_dir, name))
    write_table(at("tracks.parquet"), tracks, TRACK_ORDER)
    write_table(at("verdicts.csv"), verdicts, VERDICT_ORDER)
    spectrum_figure(at("spectra.png"), cfg, tracks, verdicts, objs)


def _summary(tracker, verdicts, src=None) -> dict:
    v = list(verdicts["verdict"])
    s = {"n_frames": tracker.n_frames, "n_tracks": len(v),
         "verdicts": {k: v.count(k) for k in ("pedestrian", "non-pedestrian", "unclassified")},
         "glitch_frames": len(tracker.glitch_frames),
         "duplicate_frames": len(tracker.duplicate_frames)}
    if src is not None:
        s.update(bad_frames=len(src.bad_frames), notes=list(src.notes))
    return s


def window_note(cfg, verdicts) -> str | None:
    """A one-line hint when every track was too short for the rhythm window (the window is a
    duration: N = window_s x fps samples)."""
    reasons = list(verdicts["reason"])
    if not reasons or any(r != "too-short" for r in reasons):
        return None
    n, fps = cfg.thresholds.n, cfg.camera.fps
    return (f"every track is shorter than the rhythm window (N = {n} samples, {n / fps:.1f} s at "
            f"{fps:g} fps): give a shorter thresholds.window_s (s) if people are in view for "
            "less")


def _report(args, summary, verdicts, cfg=None) -> None:
    hint = None if cfg is None else window_note(cfg, verdicts)
    if hint:
        summary.setdefault("notes", []).append(hint)
        say(args, f"note: {hint}")
    if args.json:
        emit_json(summary)
        return
    print_verdicts(verdicts)
    v = summary["verdicts"]
    print(f"{summary['n_frames']} frames, {summary['n_tracks']} tracks: {v['pedestrian']} "
          f"pedestrian, {v['non-pedestrian']} non-pedestrian, {v['unclassified']} unclassified",
          file=sys.stderr)


def cmd_track(args) -> int:
    """Track the moving objects of a video (Fig. 3 state machine, EKF + gates (10)(11)) and
    write the tracks file; classification happens as in `run` and is in the summary. The tracks
    file and the overlay are replaced together, only when the run succeeds."""
    table_suffix(args.output)
    options = _options(args)
    with output_set(None, (), extra=[args.output], overlay=args.overlay,
                    inputs=[args.video, args.config]) as outs:
        src, cfg, notes = open_source(args, load_config_dict(args.config))
        _notes(args, notes)
        overlay_path = outs.path(args.overlay) if args.overlay else None
        with src, overlay_writer(overlay_path, src.fps, (src.width, src.height)) as overlay:
            tracks, verdicts, objs, tracker = track_frames(
                cfg, src, n_frames=src.n_frames, on_frame=_drawer(overlay, cfg),
                progress=not (args.quiet or args.json), options=options)
            reading_check(args, src, notes)
            write_table(outs.path(args.output), tracks, TRACK_ORDER)
    _report(args, _summary(tracker, verdicts, src), verdicts, cfg)
    return 0


RUN_OUTPUTS = ("tracks.parquet", "verdicts.csv", "spectra.png")


def cmd_run(args) -> int:
    """The main job: track and classify the objects of a video; writes DIR/tracks.parquet,
    DIR/verdicts.csv, DIR/spectra.png and DIR/overlay.mp4 (annotated video) as one set: they
    replace the previous set together, only when the run succeeds (an old overlay.mp4 is
    removed with --no-overlay)."""
    options = _options(args)
    names = RUN_OUTPUTS + (() if args.no_overlay else ("overlay.mp4",))
    with output_set(args.output, names, inputs=[args.video, args.config],
                    drop=("overlay.mp4",) if args.no_overlay else ()) as outs:
        src, cfg, notes = open_source(args, load_config_dict(args.config))
        _notes(args, notes)
        path = None if args.no_overlay else outs.path(os.path.join(args.output, "overlay.mp4"))
        with src, overlay_writer(path, src.fps, (src.width, src.height)) as overlay:
            tracks, verdicts, objs, tracker = track_frames(
                cfg, src, n_frames=src.n_frames, on_frame=_drawer(overlay, cfg),
                progress=not (args.quiet or args.json), options=options)
            reading_check(args, src, notes)
            _write_outputs(outs, args.output, cfg, tracks, verdicts, objs)
    _report(args, _summary(tracker, verdicts, src), verdicts, cfg)
    return 0


def cmd_demo(args) -> int:
    """The built-in default: render a synthetic scene (walkers, a bicycle, a dog; the paper's
    camera, 15 Hz, 512x512), run the whole pipeline (config: SYNTHETIC_CONFIG), print the
    verdicts beside the truth, and write tracks, verdicts, truth, an annotated video and the
    spectra to DIR."""
    names = RUN_OUTPUTS + ("truth.csv",) + (() if args.no_overlay else ("overlay.mp4",))
    with output_set(args.output, names, drop=("overlay.mp4",) if args.no_overlay else ()) as outs:
        cfg = config_from_dict(SYNTHETIC_CONFIG)
        spec = random_spec(args.seed, n_walkers=args.walkers, n_bicycles=1, n_dogs=1,
                           n_frames=args.frames, camera=cfg.camera, **SCENE_OPTIONS)
        scene = render_scene(args.seed, spec)
        truth_cols = scene_to_tracks_truth(scene)
        frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
        size = (scene.frames.shape[2], scene.frames.shape[1])
        path = None if args.no_overlay else outs.path(os.path.join(args.output, "overlay.mp4"))
        with overlay_writer(path, scene.fps, size) as overlay:
            tracks, verdicts, objs, tracker = track_frames(
                cfg, frames, n_frames=len(scene.frames), on_frame=_drawer(overlay, cfg),
                progress=not (args.quiet or args.json), options=synthetic_options())
            _write_outputs(outs, args.output, cfg, tracks, verdicts, objs)
            write_table(outs.path(os.path.join(args.output, "truth.csv")), truth_cols,
                        ["track_id", "frame", "t", "u", "v", "width_px", "label", "x", "y"])
    result = score(tracks, verdicts, scene.truth, windows=deciding_windows(objs))
    summary = {**_summary(tracker, verdicts), "output": args.output,
               **{k: v for k, v in result.items() if k != "objects"},
               "objects": result["objects"]}
    if args.json:
        emit_json(summary)
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


def register(sub, formatter=None) -> None:
    """Add the demo, track and run verbs to the subparsers `sub`."""
    from .common import Formatter

    formatter = formatter or Formatter
    p = sub.add_parser("demo", formatter_class=formatter, help="the built-in default: a "
                       "synthetic scene through the whole pipeline", description=cmd_demo.__doc__)
    p.add_argument("-o", "--output", default="demo_out", metavar="DIR", help="output directory")
    p.add_argument("--seed", type=seed_arg, default=4, help="scene seed (default 4: a scene where "
                   "every object is judged right; seeds 0-3 and 5 show the failure modes: a "
                   "walker tracked too briefly to judge, a walker or a dog misjudged)")
    p.add_argument("--walkers", type=count_arg, default=4, help="walkers in the scene")
    p.add_argument("--frames", type=count_arg, default=180, help="frames at 15 Hz")
    p.add_argument("--no-overlay", action="store_true", help="skip the annotated video")
    add_common(p, config=False)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("track", formatter_class=formatter, help="track the moving objects "
                       "of a video", description=cmd_track.__doc__)
    p.add_argument("video", metavar="VIDEO", help="video file, or a folder of numbered frames")
    p.add_argument("-o", "--output", required=True, metavar="TRACKS",
                   help="tracks file (.parquet or .csv)")
    p.add_argument("--overlay", metavar="OUT.mp4", help="also write an annotated video")
    _video_flags(p)
    add_common(p)
    p.set_defaults(func=cmd_track)

    p = sub.add_parser("run", formatter_class=formatter, help="track and classify the "
                       "objects of a video", description=cmd_run.__doc__)
    p.add_argument("video", metavar="VIDEO", help="video file, or a folder of numbered frames")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output directory")
    _video_flags(p)
    p.add_argument("--no-overlay", action="store_true", help="skip the annotated video")
    add_common(p)
    p.set_defaults(func=cmd_run)


FPS_HELP = ("frame rate (frames/s); the rule in every verb: --fps, else the config's camera.fps, "
            "else the file's (a note says when they disagree); needed for a frame folder "
            "without camera.fps")


def _video_flags(p) -> None:
    p.add_argument("--fps", type=fps_arg, help=FPS_HELP)
    add_strict(p)
    add_camera_check(p)
    p.add_argument("--max-objects", type=count_arg, default=TrackerOptions().max_objects,
                   metavar="K",
                   help="object slots tracked at once (more cost time per frame; 24 for a "
                   "crowd such as PETS09)")
    p.add_argument("--no-stabilise", action="store_true",
                   help="do not compensate camera shake before the frame difference (a fixed "
                   "camera's results are the same either way; this only saves ~0.2 ms a frame)")
