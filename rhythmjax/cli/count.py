"""The `count` verb: track every pedestrian of a video (Masoud & Papanikolopoulos) and count only
those the rhythm classifier judges walking (registered by `cli.main`)."""

from __future__ import annotations

import json
import os
import sys

from ..count.counting import count_frames
from ..count.head_feet import TALL_HEIGHTS
from ..count.options import CountOptions, NewPedestrianOptions, VerdictOptions
from ..io import atomic_write, dumps_json, write_table
from ..io.mot import VELOCITY_COLUMNS, write_mot
from ..model.params import ConfigError, config_to_dict
from ..track.columns import candidate_columns
from .common import (
    TRACK_ORDER,
    VERDICT_ORDER,
    add_camera_check,
    add_common,
    add_strict,
    add_window_candidates,
    fps_arg,
    load_config_dict,
    open_source,
    output_set,
    overlay_writer,
    reading_check,
    say,
)
from .option_changes import add_set, apply_option_changes, recorded
from .overlay import FrameSampler, TrackOverlay, in_colour
from .report import REPORT_NAME, render_report, write_report
from .spectra import table_windows, write_spectra


COUNT_OUTPUTS = ("mot.txt", "mot_velocity.txt", "tracks.parquet", "verdicts.csv", "counts.json",
                 "spectra.png", "spectra.pdf")
GUESS_COLUMNS = ("track_speed_mps", "too_fast", "width_m", "width_ok", "counted")


def cmd_count(args) -> int:
    """Count the pedestrians of a video.

    Three levels (Masoud & Papanikolopoulos): background subtraction, blobs tracked through a
    blob graph, pedestrians as rectangular patches the size of an average pedestrian (0.5 m x
    1.7 m seen through the config's camera) with Kalman dynamics (--dynamics: 3d = the core EKF
    on the ground plane; 3d-shape or 2d = constant velocity in the image). Every track's
    window-B rhythm signal is then judged by the rhythm classifier (as `rhythmjax classify`).
    Fragments of one walker (lost behind another, at a crossing) are first stitched into one
    track when the later one starts where and as fast as the earlier one was going (ground
    plane). The walkers counted are all tracks minus those judged non-pedestrian (bicycles,
    which the paper counted twice): a track too short to judge (unclassified) still counts,
    unless it moves faster than the walking model accepts for any rhythm (too_fast: 2.6 m/s with
    the paper's Table 1; a track whose foot rows are mostly a walker's hips, its legs lost in
    the mask, is timed under its heads). So walkers = judged pedestrian + unjudged_plausible,
    within the range walkers_low (judged pedestrian only) to walkers_high (+ every unjudged
    track). The background starts from the first frame (--set blobs.bg_init_s=S: from the median
    of the first S s; off, docs/rules.md); a track whose foot point stays put for 5 s ends there
    (its patch becomes background) and one that never moved is dropped (a ghost of something
    present when the background was learnt).

    Writes DIR/mot.txt (MOTChallenge: frame (1-based), id, bb_left, bb_top, bb_width,
    bb_height, conf (1 measured, 0.5 predicted), x, y (ground, m), z (0; -1 -1 -1 where the
    foot point has no ground point); no header), DIR/mot_velocity.txt (the same ten columns,
    then each pedestrian's velocity in that frame: vx, vy on the ground (m/s; the EKF state for
    --dynamics 3d, nan otherwise) and du, dv in the image (px/s); kept apart because
    py-motmetrics misreads a MOT file with more than ten columns), DIR/tracks.parquet (the
    tracks format, which `rhythmjax classify` re-judges: width_px is the measured width of the
    blob under the patch, for the width gate (10); plus vx, vy, du, dv), DIR/verdicts.csv
    (per track also the unjudged ones' guess: track_speed_mps, too_fast, width_m (median
    measured width at the foot point), width_ok (inside the width gate (10)), counted, and
    head_speed_mps: the speed under its heads, NaN where its foot rows are its feet) and
    DIR/counts.json (counts: tracks, pedestrians, non_pedestrians, unclassified, too_fast,
    unjudged_plausible, walkers, walkers_low, walkers_high; the rule in words; the run summary
    with ghosts_dropped and ends: the tracked pieces ended, before stitching, by reason:
    timeout, velocity-jump, still, left-image, duplicate, clip-end), DIR/spectra.pdf (every
    judged track's spectrum: the window the classifier decided on; DIR/spectra.png its first
    page) and DIR/report.html (the counts, the verdict table, the spectra, the overlay and the
    config on one page; --no-report skips it). The files (and --overlay) replace the previous
    set together, only when the run succeeds. The overlay is drawn on the video's own colour
    frames where it has colour. Tracks shorter than 10 frames are dropped. A frame where one
    blob covers half the image (dense crowd, camera jump) is not used for detection
    (pedestrians predict) and the summary says how many there were."""
    if args.min_frames < 1:  # checked here, not by argparse: one line naming the option
        raise ConfigError("--min-frames", f"must be >= 1, got {args.min_frames}")
    if args.max_pedestrians < 1:
        raise ConfigError("--max-pedestrians", f"must be >= 1, got {args.max_pedestrians}")
    opt = CountOptions(dynamics=args.dynamics, max_pedestrians=args.max_pedestrians,
                       verdicts=VerdictOptions(min_track_frames=args.min_frames,
                                               window_candidates=args.window_candidates),
                       new=NewPedestrianOptions(head_feet=TALL_HEIGHTS if args.feet_from_head
                                                else 0.0))
    opt, changes = apply_option_changes(opt, args.option_changes)
    out = lambda name: os.path.join(args.output, name)
    names = COUNT_OUTPUTS + (() if args.no_report else (REPORT_NAME,))
    with output_set(args.output, names, overlay=args.overlay, inputs=[args.video, args.config],
                    drop=(REPORT_NAME,) if args.no_report else ()) as outs:
        src, cfg, setup_notes = open_source(args, load_config_dict(args.config))
        for note in setup_notes:
            say(args, note if note.startswith("warning") else f"note: {note}")
        overlay_path = outs.path(args.overlay) if args.overlay else None
        with src, overlay_writer(overlay_path, src.fps, (src.width, src.height)) as overlay:
            drawer, sampler = TrackOverlay("count"), FrameSampler(src.n_frames)
            pick = None if overlay is None else in_colour(src)  # the video's colour frame
            draw = None if overlay is None else (lambda frame, index, snapshot: overlay.write(
                sampler(index, drawer(pick(frame, index), index, snapshot))))
            res = count_frames(cfg, src, options=opt, n_frames=src.n_frames, on_frame=draw,
                               progress=not (args.quiet or args.json))
            reading_check(args, src)
            notes = setup_notes + [n for n in src.notes if n not in setup_notes] + \
                res.summary.get("notes", [])
            summary = {"video": args.video, "output": args.output, "counts": res.counts,
                       **{k: v for k, v in res.summary.items() if k != "notes"},
                       "bad_frames": len(src.bad_frames), "notes": notes,
                       **({"option_changes": recorded(changes)} if changes else {})}
            write_mot(outs.path(out("mot.txt")), res.mot)
            write_mot(outs.path(out("mot_velocity.txt")), res.mot, VELOCITY_COLUMNS)
            write_table(outs.path(out("tracks.parquet")), res.tracks,
                        TRACK_ORDER + ["v_top", "u_top", "top_at_edge", *VELOCITY_COLUMNS]
                        + candidate_columns(res.tracks))
            write_table(outs.path(out("verdicts.csv")), res.verdicts,
                        VERDICT_ORDER + list(GUESS_COLUMNS)
                        + [c for c in ("head_speed_mps", "candidate") if c in res.verdicts])
            with atomic_write(outs.path(out("counts.json")), "w") as f:
                f.write(dumps_json(summary, indent=2) + "\n")
            spectra = write_spectra(outs.path(out("spectra.png")), outs.path(out("spectra.pdf")),
                                    cfg, table_windows(res.tracks, res.verdicts,
                                                       cfg.thresholds.n, cfg.camera.fps))
            if not args.no_report:
                write_report(outs.path(out(REPORT_NAME)), render_report(
                    title=f"rhythmjax count {os.path.basename(args.video)}",
                    summary={k: v for k, v in summary.items() if k != "output"},
                    verdicts=res.verdicts, config=config_to_dict(cfg), spectra=spectra,
                    overlay=_relative(args.overlay, args.output), outputs=list(COUNT_OUTPUTS),
                    frames=sampler.frames))
    if args.json:
        print(json.dumps(json.loads(dumps_json(summary))))
        return 0
    c = res.counts
    print(f"{summary['n_frames']} frames: {c['walkers']} walkers = {c['pedestrians']} judged "
          f"pedestrian + {c['unjudged_plausible']} too short to judge and not too fast (range "
          f"{c['walkers_low']}-{c['walkers_high']}: judged only to every unjudged track; "
          f"{c['non_pedestrians']} judged non-pedestrian, {c['too_fast']} unjudged too fast, "
          f"{c['tracks']} tracks); wrote {args.output}/", file=sys.stderr)
    lost = src.shortfall() or ""  # said once, by reading_check
    for note in notes[len(setup_notes):]:  # the setup's were shown before the run
        if note not in lost:
            say(args, f"note: {note}")
    return 0


def _relative(path, out_dir) -> str | None:
    """`path` as a link from a page in `out_dir` (None stays None)."""
    return None if path is None else os.path.relpath(path, out_dir).replace(os.sep, "/")


def register(sub, formatter=None) -> None:
    """Add the count verb to the subparsers `sub`."""
    from .common import Formatter

    formatter = formatter or Formatter
    p = sub.add_parser("count", formatter_class=formatter, help="track every pedestrian of a "
                       "video and count the walkers", description=cmd_count.__doc__)
    p.add_argument("video", metavar="VIDEO", help="video file, or a folder of numbered frames")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output directory")
    p.add_argument("--overlay", metavar="OUT.mp4", help="also write an annotated video (boxes, "
                   "ids, online verdicts)")
    p.add_argument("--fps", type=fps_arg, help="frame rate (frames/s); the rule in every verb: "
                   "--fps, else the config's camera.fps, else the file's (a note says when they "
                   "disagree); needed for a frame folder without camera.fps")
    add_camera_check(p)
    add_strict(p)
    p.add_argument("--max-pedestrians", type=int, default=CountOptions().max_pedestrians,
                   metavar="K", help="pedestrian slots tracked at once (a full frame's extra "
                   "pedestrians wait, and the summary says so)")
    p.add_argument("--dynamics", choices=("3d", "3d-shape", "2d"), default="3d",
                   help="pedestrian model: 3d = 3-D shape + ground-plane EKF; 3d-shape = 3-D "
                   "shape + image constant velocity; 2d = fixed size + image constant velocity")
    p.add_argument("--min-frames", type=int, default=10, help="tracks shorter than this many "
                   "frames are dropped from the outputs and counts")
    p.add_argument("--no-report", action="store_true", help="skip report.html (the counts, "
                   "verdict table, spectra, overlay and config on one page)")
    add_window_candidates(p, VerdictOptions().window_candidates)
    p.add_argument("--feet-from-head", action="store_true", help="start a walker whose "
                   "trousers the foreground mask loses (a blob much taller than a walker "
                   "standing on its bottom) with the feet where its top row is a 1.7 m "
                   "walker's head: for low cameras and clothing of the ground's grey; off by "
                   "default (docs/rules.md, 'the feet from the head')")
    add_set(p, "counting (count.options.CountOptions)")
    add_common(p)
    p.set_defaults(func=cmd_count)
