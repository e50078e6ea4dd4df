"""`rhythmjax-fit selfcal VIDEO|TRACKS -o CONFIG`: the command around `fit.selfcal.fit_selfcal`.

It reads a tracks file (the format `rhythmjax track`, `run` and `simulate` write), or tracks a
video (by its extension, `fit.selfcal_video`: tracked, fitted and tracked again with the fitted
camera, `--rounds` times), and the start config (`-c`; its camera is the start and what it
gives of the image size, fps, principal point and roll is held), fits the camera from the people
walking in it, prints the values with their standard errors, what the data determine, the
walkers used and the camera screen, and writes the config with its camera section replaced
(atomically). Exit codes: 0 written; 1 refused (too few
walkers, a parameter the cues do not determine, a failed solve: the reason and the best point
are printed, nothing is written); 2 bad input (one line naming the file).
"""

from __future__ import annotations

import copy
import sys


CUE_HELP = ("comma-separated cues (default gait,speed,width,height): gait (stride of (12) "
            "against the walking model: the scale), speed (constant ground speed along a track: "
            "the horizon), width (ground widths independent of distance; also the scale without "
            "gait), "
            "height (foot-head heights from the tracks' top rows, column v_top, against people's "
            "1.7 +- 0.07 m: alone the classical foot-head calibration; dropped with a note when "
            "the tracks have no top rows); not by default: slant (heads over feet: the head "
            "column u_top against the vertical through the foot point; `rhythmjax count` writes "
            "it; separates the focal length from the tilt)")


def spread_m(text: str) -> float:
    """argparse type of a spread in metres: a finite number >= 0."""
    import argparse
    import math

    try:
        x = float(text)
    except ValueError:
        x = math.nan
    if not (math.isfinite(x) and x >= 0):
        raise argparse.ArgumentTypeError(f"{text!r}: a spread in m, a number >= 0")
    return x


def add_parser(sub, size_type, at_least) -> None:
    """The `selfcal` subcommand's arguments (`size_type`, `at_least`: fit.cli's parsers)."""
    from fit.selfcal import CUE_SPREADS
    from fit.selfcal_gait import STRIDE_MEAN_SD_M
    from fit.selfcal_height import HEIGHT_MEAN_SD_M
    from rhythmjax.track.options import TrackerOptions

    s = sub.add_parser("selfcal", help="fit h, tilt and focal length from people walking "
                       "(gait, constant speed, widths, heights) in a video or a tracks file")
    s.add_argument("tracks", metavar="VIDEO|TRACKS", help="a video (.avi .mp4 .mov .mkv .m4v "
                   ".mpg .webm: tracked with the start camera, then again with the fitted one), "
                   "or tracks .csv/.parquet (track_id, frame, t, u, v, width_px, intensity; "
                   "optional v_top for the height cue)")
    s.add_argument("--rounds", type=at_least(1), default=2, metavar="K",
                   help="video: track and fit K times in all, each round tracking with the "
                   "camera the previous one fitted (default 2)")
    s.add_argument("--tracks-out", metavar="T", help="video: write the last round's tracks "
                   "(.csv/.parquet)")
    s.add_argument("--max-objects", type=at_least(1), default=TrackerOptions().max_objects,
                   metavar="K", help="video: object slots tracked at once (default "
                   f"{TrackerOptions().max_objects}; 24 for a crowd such as PETS09)")
    s.add_argument("--outliers", action="store_true", help="leave out each track's foot points "
                   "far from its image path (fit.selfcal_outliers: 5 robust spreads from a "
                   "biweight quadratic of u(t), v(t)); off by default (docs/selfcal.md)")
    s.add_argument("--observed-only", action="store_true", help="use the foot points, widths "
                   "and top rows of the rows whose state (the tracks' state column) is observe "
                   "only, leaving out the detections the tracker's gates refused "
                   "(fit.selfcal_rows); off by default (docs/selfcal.md)")
    s.add_argument("--frame-union", action="store_true", help="undo the frame-difference "
                   "detector's union of two frames in the foot points, widths and top rows "
                   "(fit.selfcal_union: from each track's image velocity); off by default "
                   "(docs/selfcal.md)")
    s.add_argument("--stride-model", choices=("table1", "walk-ratio"), default="table1",
                   help="the gait cue's stride given the pace: table1, N(0.72, 0.09^2) m "
                   "whatever the pace (the walking model's), or walk-ratio, in proportion to "
                   "the pace (slow steppers take shorter steps; fit.selfcal_gait); "
                   "default table1 (docs/selfcal.md)")
    s.add_argument("--height-mean-sd", type=spread_m, default=HEIGHT_MEAN_SD_M, metavar="M",
                   help="spread (m) of the walkers' mean height about the config's (1.70 "
                   "m): the mean is estimated with the camera (fit.selfcal_height."
                   f"crowd_height); default {HEIGHT_MEAN_SD_M:g}, the spread of adult statures "
                   "between countries; 0 holds it at the config's (docs/selfcal.md)")
    s.add_argument("--stride-mean-sd", type=spread_m, default=0.0, metavar="M",
                   help="spread (m) of the walkers' mean stride about the walking model's "
                   "(0.72 m): the mean is estimated with the camera (fit.selfcal_cost."
                   f"crowd_stride), for a crowd that strolls or hurries; {STRIDE_MEAN_SD_M:g} "
                   "is the spread of crowds' mean steps between places; default 0: held at "
                   "the model's (docs/selfcal.md)")
    s.add_argument("--top-depth", type=spread_m, default=0.0, metavar="M",
                   help="how much farther (m, along the ground) the point a track's top row "
                   "images lies than its foot point: a silhouette's top is the head's far "
                   "edge, its bottom the feet's near edge (fit.selfcal_height); default 0, "
                   "the plain vertical segment; 0.23 (half a head and half a foot long, set "
                   "a priori) is measured in docs/selfcal.md")
    s.add_argument("--cue-spreads", choices=CUE_SPREADS, default="model",
                   help="the gait residuals' and the heights' spreads: model (the walking "
                   "model's stride spread and 0.07 m), data (both estimated from the walkers "
                   "after a first fit, never below the model's); default model "
                   "(docs/selfcal.md)")
    s.add_argument("--cues", default="gait,speed,width,height", help=CUE_HELP)
    s.add_argument("--image-size", type=size_type, metavar="WxH",
                   help="the image size (px; wins over the config's); needed when the config "
                   "does not give it")
    s.add_argument("--fps", type=float, help="frame rate (wins over the config's and the "
                   "tracks' own)")
    s.add_argument("--fit-roll", action="store_true", help="fit the roll too (else held at the "
                   "config's, 0 by default)")
    s.add_argument("--hold-focal", action="store_true", help="hold the focal length at the "
                   "config's (-c, camera.a_px_per_m: a known lens) and fit h and the tilt only; "
                   "where the tilt and the focal length trade off (PETS09: docs/selfcal.md)")
    s.add_argument("--fit-center", action="store_true", help="fit the principal point too "
                   "(else held at the config's, or the image centre)")
    s.add_argument("--max-steps", type=at_least(1), default=200,
                   help="Levenberg-Marquardt steps per start at most (default 200)")
    s.add_argument("--config", "-c", metavar="C", help="start config JSON (default: Table 1's "
                   "camera on the image size; for a video, the camera it is first tracked with)")
    s.add_argument("-o", "--output", required=True, metavar="C2", help="config to write")
    s.add_argument("--json", action="store_true", help="machine-readable summary on stdout")


def parse_cues(text: str) -> tuple[tuple[str, ...], list[str]]:
    """(cues, notes: an empty list to add to) of the --cues text; raises ValueError for an
    unknown name."""
    from fit.selfcal import CUES

    names = [c.strip() for c in text.split(",") if c.strip()]
    bad = [c for c in names if c not in CUES]
    if bad or not names:
        raise ValueError(f"--cues {text!r}: unknown cue(s) {bad or 'none'}; choose from "
                         f"{', '.join(CUES)}")
    return tuple(names), []


def start_config(args, d: dict, fps_tracks):
    """(start Config, the dict with image size and fps settled) from the config file's dict."""
    from rhythmjax.io import BadInput, config_or_bad_input

    d = copy.deepcopy(d)
    cam = d.setdefault("camera", {})
    cpath = args.config or args.tracks
    if not isinstance(cam, dict):
        raise BadInput(cpath, "expected an object", key="camera")
    if args.image_size is not None:
        cam["image_width_px"], cam["image_height_px"] = (int(q) for q in args.image_size)
    if "image_width_px" not in cam or "image_height_px" not in cam:
        raise BadInput(cpath, "the image size is unknown: give --image-size WxH (or "
                       "camera.image_width_px and image_height_px in the config)")
    fps = args.fps or cam.get("fps") or fps_tracks
    if fps:
        cam["fps"] = float(fps)
    cam.setdefault("uc_px", cam["image_width_px"] / 2)
    cam.setdefault("vc_px", cam["image_height_px"] / 2)
    thr = d.get("thresholds", {}) if isinstance(d.get("thresholds"), dict) else {}
    start = {**d, "thresholds": {**thr, "range_min_m": thr.get("range_min_m", 3.0),
                                 "range_max_m": thr.get("range_max_m", 20.0)}}
    return config_or_bad_input(start, cpath), d


def fit_tracks(args, tr, d: dict, source: str, notes: list[str] | None = None):
    """(fit, start Config, the settled config dict) of `rhythmjax.io.Tracks` `tr` with the
    start config dict `d` and the command's options; raises `BadInput` naming `source`.
    With `--observed-only` the rows the tracker did not observe lose their foot point, width
    and top row first (`fit.selfcal_rows.observed_rows`). Notes (the height cue dropped, the
    rows left out) go to the fit's notes and to `notes`."""
    import numpy as np

    from fit.selfcal import fit_selfcal
    from fit.selfcal_height import HEIGHT_MEAN_SD_M
    from fit.selfcal_rows import observed_rows
    from rhythmjax.io import BadInput, to_batch

    cues, more = parse_cues(args.cues)
    if "height" in cues and (tr.v_top is None or not np.isfinite(tr.v_top).any()):
        if cues == ("height",):
            raise BadInput(source, "--cues height: the tracks have no top rows (column v_top; "
                           "`rhythmjax track` and `run` write it); add gait, speed or width")
        cues = tuple(c for c in cues if c != "height")
        more.append("cue height dropped: the tracks have no top rows (column v_top)")
    if "slant" in cues and (tr.u_top is None or tr.v_top is None
                            or not np.isfinite(tr.u_top).any()):
        if cues == ("slant",):
            raise BadInput(source, "--cues slant: the tracks have no head columns (columns "
                           "v_top and u_top; `rhythmjax count` writes them)")
        cues = tuple(c for c in cues if c != "slant")
        more.append("cue slant dropped: the tracks have no head columns (column u_top)")
    dt = np.diff(tr.t)[np.diff(tr.frame) == 1] if len(tr) > 1 else np.zeros(0)
    fps_tracks = tr.fps or (1.0 / float(np.median(dt)) if dt.size and np.median(dt) > 0
                            else None)
    cfg, d = start_config(args, d, fps_tracks)
    if getattr(args, "observed_only", False):
        tr, n_left = observed_rows(tr)
        if n_left:
            more.append(f"{n_left} foot points of rows the tracker did not observe (state "
                        "predict: detections its gates refused) left out (fit.selfcal_rows)")
    batch = to_batch(tr, max_gap_frames=5, min_len=cfg.thresholds.n, fps=cfg.camera.fps)
    fit = (() if getattr(args, "hold_focal", False) else ("af",)) + ("h", "theta") + (
        ("roll",) if args.fit_roll else ()) + (
        ("uc", "vc") if args.fit_center else ())
    r = fit_selfcal(cfg, batch, cues=cues, fit=fit, max_steps=args.max_steps,
                    outliers=args.outliers, frame_union=getattr(args, "frame_union", False),
                    stride_model=getattr(args, "stride_model", "table1"),
                    height_mean_sd=getattr(args, "height_mean_sd", HEIGHT_MEAN_SD_M),
                    stride_mean_sd=getattr(args, "stride_mean_sd", 0.0),
                    top_depth_m=getattr(args, "top_depth", 0.0),
                    cue_spreads=getattr(args, "cue_spreads", "model"))
    r.notes = more + r.notes
    if notes is not None:
        notes += more
    return r, cfg, d


def fitted_dict(r, d: dict) -> dict:
    """The config dict `d` with its camera section replaced by the fit's camera (its fps and
    image size kept)."""
    from rhythmjax.model.params import Config, config_to_dict

    fitted = config_to_dict(Config(camera=r.camera))["camera"]
    return {**d, "camera": {**fitted, **{k: d["camera"][k] for k in (
        "fps", "image_width_px", "image_height_px") if k in d["camera"]}}}


def selfcal_main(args) -> int:
    """The verb: exit code as the module doc says."""
    from fit.output import write_json, write_output
    from fit.selfcal_video import is_video, video_rounds
    from rhythmjax.io import (
        BadInput,
        check_output,
        config_or_bad_input,
        dumps_json,
        read_config_dict,
        read_tracks,
        table_suffix,
    )
    from rhythmjax.model.view import camera_report, format_report

    rounds = None
    try:
        check_output(args.output, [args.config, args.tracks])
        if args.tracks_out:
            table_suffix(args.tracks_out)
            check_output(args.tracks_out, [args.config, args.tracks, args.output])
        try:
            parse_cues(args.cues)
        except ValueError as e:
            raise BadInput(args.tracks, str(e)) from None
        d = read_config_dict(args.config) if args.config else {}
        if args.hold_focal and "a_px_per_m" not in d.get("camera", {}):
            raise BadInput(args.config or args.tracks, "--hold-focal holds the config's focal "
                           "length: give a config (-c) whose camera has a_px_per_m "
                           "(`rhythmjax camera --focal-px`)")
        if is_video(args.tracks):
            if args.image_size is not None:
                raise BadInput(args.tracks, "--image-size is for a tracks file: a video gives "
                               "its own")
            r, cfg, d, rounds = video_rounds(args, d, fit_tracks, fitted_dict)
        else:
            if args.tracks_out:
                raise BadInput(args.tracks, "--tracks-out is for a video input")
            tr = read_tracks(args.tracks, fps=args.fps)
            r, cfg, d = fit_tracks(args, tr, d, args.tracks)
    except BadInput as e:
        print(f"rhythmjax-fit: {e}", file=sys.stderr)
        return 2
    bad = r.ill_determined or not r.success
    written = None if bad else fitted_dict(r, d)
    report = camera_report(r.camera, float(cfg.width.height)) if r.camera is not None else None
    if args.json:
        print(dumps_json({"command": "selfcal", "written": None if bad else args.output,
                          **r.to_dict(), "camera_report": report, "config": written,
                          **({} if rounds is None else {
                              "rounds": [q.to_dict() for q in rounds],
                              "tracks_out": args.tracks_out})}))
    else:
        print(r.summary())
        if report is not None:
            print(format_report(report))
    if bad:
        what = ("refused" if r.result == "not run" else
                f"the solver failed ({r.result})" if not r.success else "ill-determined")
        print(f"rhythmjax-fit: selfcal {what}: {'; '.join(r.reasons)}; {args.output} not "
              "written", file=sys.stderr)
        return 1

    def write():
        try:
            config_or_bad_input(written, args.output)
        except BadInput as e:  # a range the fitted camera cannot give is derived per video
            if not (e.key or "").startswith("thresholds"):
                raise
        write_json(args.output, written)

    return write_output(args.output, write, quiet=args.json)

