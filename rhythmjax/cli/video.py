"""Video verbs of the command line: `track`, `run` and `demo` (registered by `cli.main`)."""

from __future__ import annotations

import os
import sys

import numpy as np

from ..io import table_suffix, write_table
from ..model.params import ConfigError, config_from_dict, config_to_dict
from ..sim.clean import classifiable
from ..sim.evaluate import deciding_windows, match_tracks, score, window_objects
from ..sim.presets import SCENE_OPTIONS, SYNTHETIC_CONFIG, synthetic_options
from ..sim.scene import random_spec, render_scene, scene_to_tracks_truth
from ..track.columns import candidate_columns
from ..track.driver import track_frames
from ..track.options import TrackerOptions, with_changes
from .common import (
    TRACK_ORDER,
    VERDICT_ORDER,
    add_camera_check,
    add_common,
    add_strict,
    add_window_candidates,
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
from .option_changes import add_set, apply_option_changes, recorded
from .overlay import FrameSampler, TrackOverlay, in_colour
from .report import REPORT_NAME, render_report
from .spectra import write_spectra


def _drawer(overlay, cfg, sampler=None, src=None):
    """The on_frame callback that writes the tracker's snapshot drawn on each frame (colour by
    verdict, labels in words, trails, legend: `overlay.TrackOverlay`), on the video's own colour
    frame where `src` (a `VideoSource`) has one (`overlay.in_colour`); `sampler` keeps a few
    drawn frames for the report."""
    if overlay is None:
        return None
    draw = TrackOverlay("run", height_per_width=cfg.width.height_per_width())
    keep = sampler or (lambda index, img: img)
    pick = in_colour(src)
    return lambda frame, index, snapshot: overlay.write(keep(index, draw(pick(frame, index),
                                                                         index, snapshot)))


def _notes(args, notes) -> None:
    """The setup's notes (frame rate, image size), one line each, before the long run."""
    for note in notes:
        say(args, note if note.startswith("warning") else f"note: {note}")


def _options(args) -> tuple[TrackerOptions, dict]:
    """The tracker options of the flags, then --set; and the --set changes."""
    if args.max_objects < 1:
        raise ConfigError("--max-objects", f"must be >= 1, got {args.max_objects}")
    opt = TrackerOptions(max_objects=args.max_objects)
    changes = {"body.window_candidates": bool(args.window_candidates)}
    if args.no_stabilise:
        changes["motion.stabilise"] = False
    return apply_option_changes(with_changes(opt, changes), args.option_changes)


def _write_outputs(outs, out_dir, cfg, tracks, verdicts, objs, *, truth_ids=None):
    """tracks.parquet, verdicts.csv, spectra.png and spectra.pdf of `out_dir`, to the temp paths
    of `outs`; the spectra pages (PNG bytes) for the report."""
    at = lambda name: outs.path(os.path.join(out_dir, name))
    write_table(at("tracks.parquet"), tracks, [*TRACK_ORDER, "v_top",  # the head rows
                                               *candidate_columns(tracks)])
    write_table(at("verdicts.csv"), verdicts, VERDICT_ORDER)
    return write_spectra(at("spectra.png"), at("spectra.pdf"), cfg, objs, truth_ids=truth_ids)


def _write_report(outs, args, names, *, title, summary, verdicts, cfg, spectra,
                  truth_ids=None, objects=None, sampler=None) -> None:
    """DIR/report.html (unless --no-report): the summary, verdicts, spectra, overlay, config."""
    if args.no_report:
        return
    from .report import write_report

    overlay = _overlay_name(args)
    page = render_report(title=title, summary=summary, verdicts=verdicts,
                         config=config_to_dict(cfg), spectra=spectra, overlay=overlay,
                         outputs=[n for n in names if n != REPORT_NAME], truth_ids=truth_ids,
                         objects=objects, frames=None if sampler is None else sampler.frames)
    write_report(outs.path(os.path.join(args.output, REPORT_NAME)), page)


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


def size_note(verdicts) -> str | None:
    """A one-line hint when tracks judged Pedestrian by their rhythm were refused as too low
    for a walker (rule 26, `size.min_height_heights`): the height is read through the camera,
    so a wrong camera refuses people."""
    low = sum(r == "too-low" for r in verdicts["reason"])
    if not low:
        return None
    return (f"{low} track(s) with a walker's rhythm but, through the camera, less than half a "
            "walker's height were judged non-pedestrian (reason too-low, as a dog); if they are "
            "people, check the camera (f, h, theta) or give --set size.min_height_heights=0")


def _report(args, summary, verdicts, cfg=None) -> None:
    for hint in (None if cfg is None else window_note(cfg, verdicts), size_note(verdicts)):
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
    options, changes = _options(args)
    with output_set(None, (), extra=[args.output], overlay=args.overlay,
                    inputs=[args.video, args.config]) as outs:
        src, cfg, notes = open_source(args, load_config_dict(args.config))
        _notes(args, notes)
        overlay_path = outs.path(args.overlay) if args.overlay else None
        with src, overlay_writer(overlay_path, src.fps, (src.width, src.height)) as overlay:
            tracks, verdicts, objs, tracker = track_frames(
                cfg, src, n_frames=src.n_frames, on_frame=_drawer(overlay, cfg, src=src),
                progress=not (args.quiet or args.json), options=options)
            reading_check(args, src, notes)
            write_table(outs.path(args.output), tracks,
                        [*TRACK_ORDER, "v_top", *candidate_columns(tracks)])
    _report(args, {**_summary(tracker, verdicts, src),
                   **({"option_changes": recorded(changes)} if changes else {})}, verdicts, cfg)
    return 0


RUN_OUTPUTS = ("tracks.parquet", "verdicts.csv", "spectra.png", "spectra.pdf")


OVERLAY_NAMES = {"mp4": "overlay.mp4", "webm": "overlay.webm"}


def _overlay_name(args) -> str | None:
    """The overlay's file name in DIR (--overlay-format), None with --no-overlay."""
    return None if args.no_overlay else OVERLAY_NAMES[args.overlay_format]


def _names(args, extra=()) -> tuple:
    """The output set of `run` / `demo`: RUN_OUTPUTS, `extra`, the overlay and the report."""
    overlay = _overlay_name(args)
    return RUN_OUTPUTS + tuple(extra) + (() if overlay is None else (overlay,)) + \
        (() if args.no_report else (REPORT_NAME,))


def _drop(args) -> tuple:
    """Members of an older set this run does not write (removed when it succeeds): an overlay
    of the other format, or none, and the report with --no-report."""
    return tuple(n for n in OVERLAY_NAMES.values() if n != _overlay_name(args)) + \
        ((REPORT_NAME,) if args.no_report else ())


def cmd_run(args) -> int:
    """The main job: track and classify the objects of a video; writes DIR/tracks.parquet,
    DIR/verdicts.csv, DIR/spectra.pdf (every judged track's spectrum; DIR/spectra.png its first
    page), DIR/overlay.mp4 (annotated video; overlay.webm with --overlay-format webm) and
    DIR/report.html (summary, verdicts, spectra, overlay, config) as one set: they replace the
    previous set together, only when the run succeeds (an old overlay or report.html is removed
    with --no-overlay, --no-report)."""
    options, changes = _options(args)
    names = _names(args)
    with output_set(args.output, names, inputs=[args.video, args.config],
                    drop=_drop(args)) as outs:
        src, cfg, notes = open_source(args, load_config_dict(args.config))
        _notes(args, notes)
        overlay_name = _overlay_name(args)
        path = None if overlay_name is None else outs.path(os.path.join(args.output,
                                                                         overlay_name))
        sampler = FrameSampler(src.n_frames)
        with src, overlay_writer(path, src.fps, (src.width, src.height)) as overlay:
            tracks, verdicts, objs, tracker = track_frames(
                cfg, src, n_frames=src.n_frames, on_frame=_drawer(overlay, cfg, sampler, src),
                progress=not (args.quiet or args.json), options=options)
            reading_check(args, src, notes)
            spectra = _write_outputs(outs, args.output, cfg, tracks, verdicts, objs)
            summary = {"video": args.video, **_summary(tracker, verdicts, src),
                       **({"option_changes": recorded(changes)} if changes else {})}
            _write_report(outs, args, names, title=f"rhythmjax run {os.path.basename(args.video)}",
                          summary=summary, verdicts=verdicts, cfg=cfg, spectra=spectra,
                          sampler=sampler)
    del summary["video"]
    _report(args, summary, verdicts, cfg)
    return 0


def cmd_demo(args) -> int:
    """The built-in default: render a synthetic scene (walkers, a bicycle, a dog; the paper's
    camera, 15 Hz, 512x512), run the whole pipeline (config: SYNTHETIC_CONFIG), print the
    verdicts beside the truth (each object's track ids), and write tracks, verdicts, truth, an
    annotated video, the spectra and the report to DIR."""
    names = _names(args, ("truth.csv",))
    with output_set(args.output, names, drop=_drop(args)) as outs:
        cfg = config_from_dict(SYNTHETIC_CONFIG)
        spec = random_spec(args.seed, n_walkers=args.walkers, n_bicycles=1, n_dogs=1,
                           n_frames=args.frames, camera=cfg.camera, **SCENE_OPTIONS)
        scene = render_scene(args.seed, spec)
        truth_cols = scene_to_tracks_truth(scene)
        frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
        size = (scene.frames.shape[2], scene.frames.shape[1])
        overlay_name = _overlay_name(args)
        path = None if overlay_name is None else outs.path(os.path.join(args.output,
                                                                         overlay_name))
        sampler = FrameSampler(len(scene.frames))
        with overlay_writer(path, scene.fps, size) as overlay:
            tracks, verdicts, objs, tracker = track_frames(
                cfg, frames, n_frames=len(scene.frames), on_frame=_drawer(overlay, cfg, sampler),
                progress=not (args.quiet or args.json), options=synthetic_options())
            windows = deciding_windows(objs)
            result = score(tracks, verdicts, scene.truth, windows=windows,
                           classifiable=classifiable(scene, n=int(cfg.thresholds.n)))
            ids = truth_links(tracks, scene.truth, windows)
            spectra = _write_outputs(outs, args.output, cfg, tracks, verdicts, objs,
                                     truth_ids=ids)
            write_table(outs.path(os.path.join(args.output, "truth.csv")), truth_cols,
                        ["track_id", "frame", "t", "u", "v", "width_px", "label", "x", "y"])
            summary = {**_summary(tracker, verdicts), "output": args.output,
                       **{k: v for k, v in result.items() if k != "objects"},
                       "objects": result["objects"]}
            for r in result["objects"]:
                r["track_ids"] = sorted(t for t, o in ids.items() if o == r["object"])
            _write_report(outs, args, names, title=f"rhythmjax demo (seed {args.seed})",
                          summary={k: v for k, v in summary.items() if k != "output"},
                          verdicts=verdicts, cfg=cfg, spectra=spectra, truth_ids=ids,
                          objects=result["objects"], sampler=sampler)
    if args.json:
        emit_json(summary)
        return 0
    print(f"{'object':>7} {'kind':>10} {'verdict':>15} {'pace':>6} {'true':>6} {'stride':>6} "
          f"{'true':>6} tracks  track ids")
    for r in result["objects"]:
        f = lambda x: "" if not np.isfinite(x) else f"{x:.2f}"
        mark = "*" if r["verdict"] == "non-pedestrian" and np.isfinite(r["pace"]) else " "
        print(f"{r['object']!s:>7} {r['kind']:>10} {r['verdict']:>15} {f(r['pace']):>6}"
              f"{mark}{f(r['pace_true']):>6} {f(r['stride']):>6}{mark}{f(r['stride_true']):>6} "
              f"{r['tracks']:>6}  {','.join(f'#{t}' for t in r['track_ids']) or '-'}")
    if any(r["verdict"] == "non-pedestrian" and np.isfinite(r["pace"])
           for r in result["objects"]):
        print("* the spectral peak of an object judged non-pedestrian: not a gait, its pace and "
              "stride are not meaningful", file=sys.stderr)
    print(f"walkers judged pedestrian: {result['walkers_pedestrian']}/{result['walkers']} "
          f"({result['classifiable_pedestrian']}/{result['walkers_classifiable']} classifiable); "
          f"others judged non-pedestrian: {result['others_non_pedestrian']}/"
          f"{result['others_judged']} judged of {result['others']}; pace MAE "
          f"{result['pace_mae_hz']:.3f} Hz; wrote {args.output}/", file=sys.stderr)
    return 0


def truth_links(tracks, truth, windows) -> dict[int, str]:
    """{track id: the rendered object's id (ped000...)}: the object a judged track followed in
    its deciding window, else the one the whole track followed (`sim.evaluate`)."""
    links = {int(t): o.track_id for t, o in match_tracks(tracks, truth).items()}
    links.update({int(t): o.track_id for t, o in window_objects(tracks, truth, windows).items()})
    return links


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
    add_overlay_flags(p)
    add_no_report(p)
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
    add_overlay_flags(p)
    add_no_report(p)
    add_common(p)
    p.set_defaults(func=cmd_run)


FPS_HELP = ("frame rate (frames/s); the rule in every verb: --fps, else the config's camera.fps, "
            "else the file's (a note says when they disagree); needed for a frame folder "
            "without camera.fps")


def add_overlay_flags(p) -> None:
    """--no-overlay and --overlay-format, for `run` and `demo`."""
    p.add_argument("--no-overlay", action="store_true", help="skip the annotated video")
    p.add_argument("--overlay-format", choices=sorted(OVERLAY_NAMES), default="mp4",
                   help="overlay.mp4 (MPEG-4 part 2, fast to write; browsers do not play it) or "
                   "overlay.webm (VP8: report.html plays it; about 30 ms a 512x512 frame more)")


def add_no_report(p) -> None:
    """--no-report, for the verbs that write report.html."""
    p.add_argument("--no-report", action="store_true", help="skip report.html (the summary, "
                   "verdict table, spectra, overlay and config on one page)")


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
    add_window_candidates(p, TrackerOptions().body.window_candidates)
    add_set(p, "tracker (track.options.TrackerOptions)")
