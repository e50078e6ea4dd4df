"""Helpers shared by the verbs of the command line: options every verb takes, the config,
messages, JSON, the verdicts table, the video source and the overlay writer."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys

import numpy as np

from ..io import (
    BadInput,
    OutputSet,
    config_or_bad_input,
    dumps_json,
    make_output_dir,
    read_config_dict,
)
from ..model.params import Config, ConfigError
from ..track.options import SizeOptions


__all__ = ["EPILOG", "TRACK_ORDER", "VERDICT_ORDER", "Formatter", "add_camera_check",
           "add_common", "add_strict", "amount_arg", "check_config_fits_image", "count_arg",
           "emit_json", "fps_arg", "load_config", "load_config_dict", "open_source",
           "output_set", "overlay_writer", "print_verdicts", "reading_check", "say", "seed_arg"]

EPILOG = """\
exit codes: 0 success, 1 internal or I/O error, 2 bad input (the message names the file
and the line, column, key or track), 130 interrupted, 143 terminated (SIGTERM).
formats: tracks are .csv or .parquet with columns track_id, frame, t, u, v, width_px,
intensity (optional label, x, y); configs are JSON (see `rhythmjax config`)."""

TRACK_ORDER = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "x_est", "y_est",
               "state"]
VERDICT_ORDER = ["track_id", "verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps",
                 "n_samples"]


class Formatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """Help text as written, with the defaults shown."""


def add_camera_check(p: argparse.ArgumentParser) -> None:
    """--no-camera-check, for the verbs that read a video."""
    p.add_argument("--no-camera-check", action="store_true", help="skip the check of the camera "
                   "against the first 80 frames' motion (moving things outside the detection "
                   "range, or implausibly tall or small by the camera; about 5 ms a frame)")


def add_strict(p: argparse.ArgumentParser) -> None:
    """--strict, for the verbs that read a video."""
    p.add_argument("--strict", action="store_true", help="a video read short of the frames it "
                   "announces, or with frames skipped (undecodable, mis-sized), is an error "
                   "(exit 2, nothing written) instead of a warning")


def add_window_candidates(p: argparse.ArgumentParser, default: bool) -> None:
    """--window-candidates / --no-window-candidates (issue 16's candidate windows B), for the
    verbs that sum I(k) from a video; `default` the verb's options' default."""
    from ..io.files import WINDOW_CANDIDATES

    p.add_argument("--window-candidates", action=argparse.BooleanOptionalAction,
                   default=default, help="also sum I(k) in window B moved by "
                   + ", ".join(f"{o:+g} W ({c})" for c, o in WINDOW_CANDIDATES)
                   + " (negative: up), written as tracks columns, and judge each rhythm window "
                   "by the candidate whose strongest spectral peak is highest")


def add_across_candidates(p: argparse.ArgumentParser, default: bool) -> None:
    """--across-candidates / --no-across-candidates (rule 50b: window B moved across its row as
    two more candidates); `default` the verb's options' default."""
    from ..io.files import ACROSS_CANDIDATES

    p.add_argument("--across-candidates", action=argparse.BooleanOptionalAction,
                   default=default, help="also sum I(k) in window B moved by "
                   + ", ".join(f"{o:+g} W ({c})" for c, o in ACROSS_CANDIDATES)
                   + " (negative: left), written as tracks columns; they decide a rhythm window "
                   "only where they say Pedestrian at their own strongest peak")


def add_window_per_pixel(p: argparse.ArgumentParser, default: bool) -> None:
    """--window-per-pixel / --no-window-per-pixel (rule 35: I(k) as the mean of D over window
    B, grey levels per pixel, instead of its sum); `default` the verb's options' default."""
    p.add_argument("--window-per-pixel", action=argparse.BooleanOptionalAction,
                   default=default, help="I(k) as the mean of the frame difference over window "
                   "B (grey levels per pixel) instead of its sum: no trend from a walker's "
                   "image growing or shrinking as it comes nearer or goes away")


def add_height_rules(p: argparse.ArgumentParser) -> None:
    """--twice-pace-heights, --stride-peak and --min-height-heights: rules 37, 56 and 26 in the
    batch classifier, from the tracks' top rows (v_top, top_at_edge; the tracker's `size`
    options' defaults)."""
    p.add_argument("--twice-pace-heights", type=float, default=SizeOptions().twice_pace_heights,
                   metavar="H", help="judge a window read at twice a walker's pace at half "
                   "it where the object is at least H walker heights tall (rule 37; 0: off)")
    p.add_argument("--stride-peak", action=argparse.BooleanOptionalAction,
                   default=SizeOptions().stride_peak, help="judge a window read at half a "
                   "walker's pace (its stride frequency: one foot hidden) at twice it where "
                   "rule 37's height test passes (rule 56)")
    p.add_argument("--min-height-heights", type=float, default=SizeOptions().min_height_heights,
                   metavar="H", help="refuse a window judged Pedestrian where the object's "
                   "median height is below H walker heights (rule 26; 0: off)")


def height_rules(args) -> SizeOptions:
    """The `SizeOptions` of `add_height_rules`' flags; ConfigError naming the flag for a value
    below 0 or NaN."""
    for flag in ("twice_pace_heights", "min_height_heights"):
        if not getattr(args, flag) >= 0:  # NaN too
            raise ConfigError("--" + flag.replace("_", "-"), f"must be a number >= 0 (0: off), "
                              f"got {getattr(args, flag)}")
    return SizeOptions(twice_pace_heights=args.twice_pace_heights,
                       min_height_heights=args.min_height_heights, stride_peak=args.stride_peak)


def reading_check(args, src, notes=None) -> None:
    """After the video's pass: what was lost (frames read of frames announced, frames skipped
    and why) as one warning line on stderr, always; an error (`BadInput`) with --strict. Its
    notes are left out of `notes` (the list of the setup's notes shown) to say it once."""
    lost = src.shortfall()
    if lost is None:
        return
    if getattr(args, "strict", False):
        raise BadInput(args.video, f"{lost} (--strict)")
    print(f"warning: {args.video}: {lost}", file=sys.stderr)


def add_common(p: argparse.ArgumentParser, *, config: bool = True) -> None:
    """--config (unless `config` is False), --json, --quiet, --debug."""
    if config:
        p.add_argument("--config", "-c", metavar="C", help="config JSON (default: the paper's "
                       "Table 1 values; omitted keys take defaults)")
    p.add_argument("--json", action="store_true", help="print a machine-readable summary on "
                   "stdout")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar or notes")
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors")


def count_arg(text: str) -> int:
    """argparse type: a whole number >= 1 (frames, walkers in a demo, tracks per chunk...)."""
    return _int_arg(text, 1, "a whole number >= 1")


def amount_arg(text: str) -> int:
    """argparse type: a whole number >= 0 (objects of one kind in a scene...)."""
    return _int_arg(text, 0, "a whole number >= 0")


def seed_arg(text: str) -> int:
    """argparse type: a seed, a whole number >= 0 (below 2**63)."""
    return _int_arg(text, 0, "a seed: a whole number >= 0")


def _int_arg(text: str, low: int, what: str) -> int:
    try:
        if len(text) > 20:
            raise ValueError
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text[:24]!r} is not {what}") from None
    if not low <= n < 2 ** 63:
        raise argparse.ArgumentTypeError(f"{n} is not {what}")
    return n


def fps_arg(text: str) -> float:
    """argparse type: a video's frame rate, 0.1-1000 frames/s."""
    from ..vision.video import MAX_FPS

    try:
        f = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text[:24]!r} is not a frame rate") from None
    if not 0.1 <= f <= MAX_FPS:
        raise argparse.ArgumentTypeError(f"{text[:24]} frames/s is not a video's frame rate "
                                         f"(give 0.1-{MAX_FPS:g})")
    return f


def output_set(out_dir, names, *, extra=(), inputs=(), drop=(), overlay=None) -> OutputSet:
    """The outputs `names` (file names in `out_dir`; none when `out_dir` is None), the paths
    `extra` and the annotated video `overlay` (its extension checked now) as one set
    (`io.OutputSet`): `out_dir` is created now (and removed again if the run fails before
    writing), every path checked against the `inputs` and for writability before any work."""
    if overlay is not None:
        from ..vision.video_out import WRITER_FOURCC

        suffix = os.path.splitext(overlay)[1].lower()
        if suffix not in WRITER_FOURCC:
            raise BadInput(overlay, f"cannot write video: unknown extension '{suffix}' (use "
                           ".mp4 with mp4v or .avi with MJPG)")
        extra = (*extra, overlay)
    made = out_dir is not None and make_output_dir(out_dir)
    j = lambda n: os.path.join(out_dir, n)
    return OutputSet([j(n) for n in names] + list(extra), inputs=inputs,
                     drop=[j(n) for n in drop], made=out_dir if made else None)


def load_config_dict(path) -> dict:
    """The config file at `path` as written (an empty dict for None: every key defaults)."""
    return {} if path is None else read_config_dict(path)


def load_config(path) -> Config:
    """The config at `path` merged over the defaults (`model.config_setup.config_for`: the
    principal point at the image's centre, N from window_s and the fps, the range from the
    camera); the defaults for None."""
    return config_or_bad_input(load_config_dict(path), path or "config")


def say(args, msg: str) -> None:
    """A note on stderr unless --quiet."""
    if not args.quiet:
        print(msg, file=sys.stderr)


def emit_json(obj) -> None:
    """One JSON document on stdout (NaN as null)."""
    print(dumps_json(obj))


def print_verdicts(v: dict) -> None:
    """The verdicts as an aligned table on stdout."""
    print(f"{'track_id':>10} {'verdict':>15} {'reason':>16} {'pace_hz':>8} {'stride_m':>8} "
          f"{'ratio':>6} {'speed':>6}")
    for i in range(len(v["track_id"])):
        f = lambda x: "" if not np.isfinite(x) else f"{x:.3f}"
        print(f"{v['track_id'][i]!s:>10} {v['verdict'][i]:>15} {v['reason'][i]:>16} "
              f"{f(v['pace_hz'][i]):>8} {f(v['stride_m'][i]):>8} {f(v['ratio'][i]):>6} "
              f"{f(v['speed_mps'][i]):>6}")


def check_config_fits_image(cfg: Config, width: int, height: int) -> None:
    """Some of the detection range must be visible: its rows (near end low in the image, far end
    higher up) must overlap the image, else every detection is refused and nothing is tracked."""
    import jax.numpy as jnp

    from ..model.camera import project

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
    from ..vision.video_out import open_writer

    writer = open_writer(path, fps, size)
    try:
        yield writer
    except BaseException:
        writer.abort()
        raise
    writer.close()


def open_source(args, d: dict):
    """The video of `args.video` (file or frame folder) and the Config of the config dict `d`
    for it, and the notes to show. One rule for the frame rate in every verb: `--fps` > the
    config's `camera.fps` > the container's, with a note when they disagree. The image size and
    fps the config leaves out are the video's, a config image size that differs from the
    video's is replaced by it with a warning (the camera's pixels are kept as given). Checks
    that some of the detection range is in the image, then (unless --no-camera-check) the
    camera against the first frames' motion (`vision.camera_check`): its warnings are notes."""
    from ..vision.video import MAX_FPS, open_video

    if args.fps is not None and not 0.1 <= args.fps <= MAX_FPS:
        raise ConfigError("--fps", f"{args.fps!r} frames/s is not a video's frame rate (give "
                          f"0.1-{MAX_FPS:g})")
    cam = d.get("camera", {}) if isinstance(d.get("camera", {}), dict) else {}
    early = d if args.fps is None else {**d, "camera": {**cam, "fps": args.fps}}
    config_or_bad_input(early, args.config or "config")  # every key checked before the video
    conf_fps = cam.get("fps")
    fps = args.fps if args.fps is not None else conf_fps
    src = open_video(args.video, fps=fps)
    try:
        notes = []
        if args.fps is not None and conf_fps is not None and conf_fps != args.fps:
            notes.append(f"--fps {args.fps:g} overrides the config's camera.fps {conf_fps:g}")
        elif args.fps is None and conf_fps is not None:
            src.notes = [n.replace(" used;", " used (the config's camera.fps);")
                         for n in src.notes]
        if not np.isfinite(src.fps):
            raise BadInput(args.video, "no frame rate; give --fps")
        size = (src.width, src.height)
        given = (cam.get("image_width_px"), cam.get("image_height_px"))
        d = {**d, "camera": {**cam, "fps": float(src.fps)}}
        if any(g is not None for g in given) and tuple(given) != size:
            notes.append(f"warning: the config's image size {given[0]}x{given[1]} is not the "
                         f"video's {size[0]}x{size[1]}; the video's is used, the camera's "
                         "focal length and principal point as given (describe the camera for "
                         "this video with `rhythmjax camera --video`)")
            d["camera"].update(image_width_px=size[0], image_height_px=size[1])
        cfg = config_or_bad_input(d, args.config or "config", image_size=size, fps=src.fps)
        check_config_fits_image(cfg, *size)
        notes = list(src.notes) + notes
        if not getattr(args, "no_camera_check", False):
            from ..vision.camera_check import check_camera

            check = check_camera(cfg, src, video=args.video)
            notes += [f"warning: {w}" for w in check.warnings] + list(check.notes)
    except BaseException:
        src.close()
        raise
    return src, cfg, notes
