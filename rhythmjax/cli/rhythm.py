"""The `rhythm` verb: the rhythm classifier behind any detector and tracker (registered by
`cli.main`). Boxes in, I(k) of window B measured from the video at their feet, verdicts out."""

from __future__ import annotations

import json
import os

import numpy as np

from ..io import (
    BadInput,
    dumps_json,
    read_tracks,
    to_batch,
    write_table,
)
from ..io.files import ACROSS_CANDIDATES, ACROSS_COLUMNS, CANDIDATE_COLUMNS, WINDOW_CANDIDATES
from ..io.mot import read_mot_numbered
from ..model.batch import VERDICT_COLUMNS, classify_tracks, summarise
from ..model.params import ConfigError
from ..track.boxes import box_intensities, check_in_image, tracks_from_mot, window_widths
from ..track.looks import height_looks
from ..track.options import BodyOptions
from .common import (
    add_across_candidates,
    add_camera_check,
    add_common,
    add_height_rules,
    add_strict,
    add_window_candidates,
    add_window_per_pixel,
    fps_arg,
    height_rules,
    load_config_dict,
    open_source,
    output_set,
    print_verdicts,
    reading_check,
    say,
)


TABLE_SUFFIXES = (".csv", ".parquet")


def read_boxes(path: str, *, fps: float, frame_base: int | None, scale: float):
    """(Tracks, MOT columns or None): a tracks file (.csv/.parquet; frame = the video's 0-based
    index unless `frame_base` says otherwise; u, v, width_px times `scale`) or MOT text (any
    other name; frame 1-based unless `frame_base`)."""
    if path.lower().endswith(TABLE_SUFFIXES):
        tr = read_tracks(path, fps=fps)
        base = 0 if frame_base is None else frame_base
        tr.frame = tr.frame - base
        if len(tr.frame) and tr.frame.min() < 0:
            k = int(np.argmin(tr.frame))
            raise BadInput(path, f"frame {int(tr.frame[k]) + base} is before the video's first "
                           f"(frames are {base}-based here; see --frame-base)",
                           **({"line": int(tr.line[k])} if tr.unit == "line"
                              else {"row": int(tr.line[k])}), column="frame")
        tr.t = tr.frame / float(fps)
        tr.u, tr.v, tr.width_px = tr.u * scale, tr.v * scale, tr.width_px * scale
        tr.v_top = None if tr.v_top is None else tr.v_top * scale
        tr.u_top = None if tr.u_top is None else tr.u_top * scale
        tr.intensity = np.full(len(tr.frame), np.nan)
        return tr, None
    mot = read_mot_numbered(path)
    if not len(mot["frame"]):
        raise BadInput(path, "no boxes")
    return tracks_from_mot(mot, path, fps=fps, frame_base=1 if frame_base is None else frame_base,
                           scale=scale), mot


def cmd_rhythm(args) -> int:
    """Judge the objects of any tracker's boxes by the rhythm of their gait.

    BOXES is MOTChallenge text (frame, id, bb_left, bb_top, bb_width, bb_height, conf, x, y, z;
    ground truth or a tracker's output; frames 1-based; x, y, z ignored) or a tracks file
    (.csv/.parquet: track_id, frame, t, u, v, width_px, intensity; frames the video's 0-based
    index; t and intensity are recomputed). Each box gives the foot point (u, v) = its bottom
    centre (px) and width_px = its width; I(k) = the sum of |frame k - frame k-1| (grey levels)
    over window B, W x W/5 px with its bottom row at the foot row, W the mean walker width at
    the foot point through the camera (Sec. 4.1, as the online tracker measures it). Each box
    track is then judged as `rhythmjax classify` does (EKF with the paper's gates, MEM
    spectrum, (13)-(15)). The config is resolved for the video as `run` does.
    --window-candidates: I(k) also in window B moved by -0.2, -0.1 and +0.1 W (the tracker's
    body.window_candidates; columns intensity_up20, intensity_up10, intensity_down10), and each
    rhythm window judged by the candidate with the strongest spectral peak.
    --across-candidates: I(k) also in window B moved 0.1 W left and right (the tracker's
    body.across_candidates, rule 50b; columns intensity_left10, intensity_right10), deciding a
    rhythm window only where they say Pedestrian at their own strongest peak. Off here (on in
    the tracker, whose foot column scatters about the feet more than a box's).
    --window-per-pixel: each I(k) the mean of the difference over its window instead of the
    sum (the tracker's body.window_per_pixel, rule 35).
    --twice-pace-heights H: a window whose strongest peak is twice a walker's pace (two bursts
    a step) is judged at half that peak where the object's median height is at least H walker
    heights (rule 37, the tracker's size.twice_pace_heights; 0: off). Each box's top row gives
    its height through the camera; a box cut by the image's top edge, a lower bound of it.
    --min-height-heights H: a window judged Pedestrian whose boxes' median height is below H
    walker heights is Non-pedestrian, reason too-low (rule 26, the tracker's
    size.min_height_heights: a trotting dog; 0: off).

    Writes DIR/tracks.parquet (the tracks format with intensity) and DIR/verdicts.csv; prints
    the verdicts (or a --json summary). The two replace the previous pair together, and nothing
    is written when the input is bad or the run is interrupted."""
    if args.box_scale is None or not (np.isfinite(args.box_scale) and args.box_scale > 0):
        raise ConfigError("--box-scale", f"must be a number > 0, got {args.box_scale}")
    height_rules(args)  # a bad value fails before anything is read
    out_tracks = os.path.join(args.output, "tracks.parquet")
    out_verdicts = os.path.join(args.output, "verdicts.csv")
    with output_set(args.output, ("tracks.parquet", "verdicts.csv"),
                    inputs=[args.video, args.boxes, args.config]) as outs:
        return _rhythm(args, outs, out_tracks, out_verdicts)


def _rhythm(args, outs, out_tracks, out_verdicts) -> int:
    src, cfg, notes = open_source(args, load_config_dict(args.config))
    with src:
        tracks, mot = read_boxes(args.boxes, fps=float(src.fps), frame_base=args.frame_base,
                                 scale=args.box_scale)
        check_in_image(tracks, src.width, src.height, mot, args.box_scale)
        W = window_widths(cfg, tracks.u, tracks.v)
        offsets = tuple(off for _, off in WINDOW_CANDIDATES) if args.window_candidates else ()
        across = tuple(off for _, off in ACROSS_CANDIDATES) if args.across_candidates else ()
        sig = box_intensities(src, tracks.frame, tracks.u, tracks.v, W, offsets=offsets,
                              across=across, mean=args.window_per_pixel)
        reading_check(args, src)
    late = np.flatnonzero(tracks.frame >= sig.n_frames)
    if late.size:
        k = int(late[0])
        where = {"line": int(tracks.line[k])} if tracks.unit == "line" else \
            {"row": int(tracks.line[k])}
        raise BadInput(args.boxes, f"frame {int(tracks.frame[k])} (0-based) is past the video's "
                       f"last ({sig.n_frames - 1}; {args.video})", **where)
    tracks.intensity = sig.intensity
    tracks.candidates = sig.candidates  # None without either option (a file's are dropped)
    tracks.across, tracks.pace_window = len(across), False
    n = cfg.thresholds.n
    batch = to_batch(tracks, max_gap_frames=max(1, round(float(cfg.thresholds.predict_timeout)
                                                         * cfg.camera.fps)), min_len=n)
    verdicts = classify_tracks(cfg, batch, progress=not (args.quiet or args.json),
                               second_look=height_looks(cfg, batch, height_rules(args)))
    order = list(VERDICT_COLUMNS)
    labels = None if batch.labels is None else np.asarray(batch.labels, dtype=object)
    if labels is not None:
        verdicts["label"] = labels
        order.append("label")
    cols = {"track_id": tracks.track_id, "frame": tracks.frame, "t": tracks.t, "u": tracks.u,
            "v": tracks.v, "width_px": tracks.width_px, "intensity": tracks.intensity}
    track_order = list(cols)
    if tracks.label is not None:
        cols["label"] = tracks.label
        track_order.append("label")
    for name in ("v_top", "top_at_edge"):  # the heights rule 37 read (a file without: absent)
        if getattr(tracks, name) is not None:
            cols[name] = getattr(tracks, name)
            track_order.append(name)
    if sig.candidates is not None:
        names = (CANDIDATE_COLUMNS if offsets else ()) + (ACROSS_COLUMNS if across else ())
        cols.update({c: sig.candidates[:, j] for j, c in enumerate(names)})
        track_order += list(names)
    write_table(outs.path(out_tracks), cols, track_order)
    write_table(outs.path(out_verdicts), verdicts, order)
    sampled = int(np.sum(np.isfinite(sig.intensity)))
    notes = notes + list(tracks.notes) + [n for n in src.notes if n not in notes]
    summary = {"video": args.video, "boxes": args.boxes, "output": args.output,
               "n_rows": int(len(tracks.frame)), "rows_sampled": sampled,
               "frames_read": sig.n_frames, "glitch_frames": sig.glitch,
               "bad_frames": sig.bad, **summarise(verdicts, labels), "notes": notes}
    if args.json:
        print(json.dumps(json.loads(dumps_json(summary))))
        return 0
    print_verdicts(verdicts)
    v = summary["verdicts"]
    say(args, f"{summary['n_tracks']} box tracks: {v['pedestrian']} pedestrian, "
        f"{v['non-pedestrian']} non-pedestrian, {v['unclassified']} unclassified; I(k) sampled "
        f"in {sampled} of {summary['n_rows']} rows; wrote {args.output}/")
    lost = src.shortfall() or ""  # said once, by reading_check
    for note in notes:
        if note not in lost:
            say(args, note if note.startswith("warning") else f"note: {note}")
    return 0


def register(sub, formatter=None) -> None:
    """Add the rhythm verb to the subparsers `sub`."""
    from .common import Formatter

    formatter = formatter or Formatter
    p = sub.add_parser("rhythm", formatter_class=formatter, help="judge any tracker's boxes "
                       "by the rhythm of walking", description=cmd_rhythm.__doc__)
    p.add_argument("video", metavar="VIDEO", help="video file, or a folder of numbered frames")
    p.add_argument("--boxes", required=True, metavar="BOXES", help="MOTChallenge text (any "
                   "name but .csv/.parquet) or a tracks file (.csv/.parquet)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output directory")
    p.add_argument("--frame-base", type=int, choices=(0, 1), default=None, help="the frame "
                   "number of the video's first frame in BOXES (default: 1 for MOT text, 0 for "
                   "a tracks file)")
    p.add_argument("--box-scale", type=float, default=1.0, metavar="S", help="boxes are at S "
                   "times smaller resolution than the video: their px are multiplied by S")
    p.add_argument("--fps", type=fps_arg, help="frame rate (frames/s): --fps, else the config's "
                   "camera.fps, else the file's; needed for a frame folder without camera.fps")
    add_window_candidates(p, BodyOptions().window_candidates)
    add_across_candidates(p, False)  # off here, on in the tracker: behind the own truth boxes
    # the windows moved across read the crossing walkers' pace worse (docs/rhythm_boxes.md)
    add_window_per_pixel(p, BodyOptions().window_per_pixel)
    add_height_rules(p)
    add_camera_check(p)
    add_strict(p)
    add_common(p)
    p.set_defaults(func=cmd_rhythm)
