"""`rhythmjax-fit`: calibrate the camera of (3) from footprints, Q and R of the EKF (4)-(9) from
tracks, or the walking and width models and thresholds from labelled tracks; write the config.
`rhythmjax-fit footprints` makes the footprints file from boxes + world positions or from image
points + an image-to-ground homography.

Exit codes: 0 fitted and written; 1 the solver failed or the fit is ill-determined (the result
code and the best point are printed, the output config is not written); 2 bad input (one line
naming the file; an unusable output is refused before the fit); 130 interrupted (Ctrl-C), 143
terminated (SIGTERM), nothing written.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from fit.calibrate import UNITS, fit_footprints
from fit.selfcal_run import add_parser as add_selfcal_parser


EPILOG = """\
exit codes: 0 fitted and written, 1 solver failure or ill-determined fit (nothing written),
2 bad input (one line naming the file), 130 interrupted, 143 terminated."""


def _at_least(low: int):
    """argparse type: a whole number >= `low`."""
    def parse(text: str) -> int:
        try:
            n = int(text) if len(text) <= 20 else None
        except ValueError:
            n = None
        if n is None or n < low:
            raise argparse.ArgumentTypeError(f"{text[:24]!r} is not a whole number >= {low}")
        return n
    return parse


def _fraction(text: str) -> float:
    try:
        f = float(text)
    except ValueError:
        f = math.nan
    if not 0.0 < f < 1.0:
        raise argparse.ArgumentTypeError(f"{text[:24]!r} is not a fraction between 0 and 1")
    return f


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(s) for s in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not WxH (e.g. 640x480)") from None
    if w <= 0 or h <= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: width and height must be > 0")
    return w, h


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rhythmjax-fit", description=__doc__.split("\n\n")[0],
                                epilog=EPILOG,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("camera", help="fit a f, b f, h, theta (and Uc, Vc, roll) from footprints")
    c.add_argument("footprints", help="footprints .csv/.parquet: columns u, v (px), x, y (m); "
                   "track_id, frame optional")
    c.add_argument("--image-size", type=_size, metavar="WxH",
                   help="the image size (px; wins over the config's): needed when the config "
                   "does not give the principal point, whose start is the image centre")
    c.add_argument("--fit-center", action="store_true",
                   help="fit Uc, Vc even when the config gives them (they are fitted anyway "
                   "when it does not); b/a is then held at the config's")
    c.add_argument("--image-center", action="store_true",
                   help="hold the principal point at the image centre when the config does not "
                   "give it (instead of fitting it; needed with --world)")
    c.add_argument("--fit-roll", action="store_true",
                   help="fit the roll angle even when the config gives camera.roll_deg (it is "
                   "fitted anyway when the config does not)")
    c.add_argument("--world", action="store_true",
                   help="x, y are in the data's own world frame: fit a planar rigid transform "
                   "(tx, ty, yaw; reported, not written) to the ground frame of (3) with the "
                   "camera; b/a is then held at the config's")
    c.add_argument("--units", choices=tuple(UNITS), default="m",
                   help="units of x, y in the file (scaled to metres on reading)")
    c.add_argument("--loss", choices=("l2", "huber", "cauchy"), default="l2")
    c.add_argument("--max-steps", type=_at_least(1), default=256)
    n = sub.add_parser("noise", help="fit Q and R by the EKF's innovation likelihood")
    n.add_argument("tracks", help="tracks .csv/.parquet")
    n.add_argument("--fit-init-speed", action="store_true",
                   help="also fit the initial speed spread")
    n.add_argument("--max-gap-frames", type=_at_least(1), default=5)
    n.add_argument("--max-steps", type=_at_least(1), default=200)
    w = sub.add_parser("walking", help="fit the walking and width models and P_thr, R_thr, "
                       "k_sigma3 from labelled tracks (balanced accuracy, held-out split)")
    w.add_argument("tracks", help="tracks .csv/.parquet with a 'label' column ('pedestrian' is "
                   "the positive class, every other label the negative one)")
    w.add_argument("--test-fraction", type=_fraction, default=0.3,
                   help="share of each class held out for the reported accuracy (default 0.3)")
    w.add_argument("--seed", type=_at_least(0), default=0, help="seed of the held-out split")
    w.add_argument("--max-gap-frames", type=_at_least(1), default=5)
    w.add_argument("--max-iter", type=_at_least(1), default=20,
                   help="re-centring iterations of the walking model")
    for s in (c, n, w):
        s.add_argument("--config", "-c", metavar="C", help="config JSON (default: Table 1)")
        s.add_argument("-o", "--output", required=True, metavar="C2", help="config to write")
        s.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    _footprints_parser(sub)
    add_selfcal_parser(sub, _size, _at_least)
    return p


def _footprints_parser(sub) -> None:
    f = sub.add_parser("footprints", help="make a footprints file (u, v, x, y, track_id, frame) "
                       "from boxes + world positions, or image points + a homography",
                       description="Sources: --boxes with --positions (or a MOT file whose "
                       "x, y columns hold the world position); --boxes, --points or --grid with "
                       "--homography.")
    f.add_argument("--boxes", metavar="B", help="boxes: MOTChallenge text (frame, id, left, "
                   "top, width, height, ...) or CVML .xml (PETS); foot point = bottom centre")
    f.add_argument("--points", metavar="P", help="image foot points: .csv/.parquet with u, v "
                   "(px) [, track_id, frame], or a MOT file")
    f.add_argument("--grid", type=int, metavar="N", help="image points on an N x N grid over "
                   "the image (with --image-size and --homography)")
    f.add_argument("--image-size", type=_size, metavar="WxH", help="image size for --grid")
    f.add_argument("--positions", metavar="W", help="world positions per frame and id, the "
                   "TrajNet layout: 'frame id x y' per line")
    f.add_argument("--homography", metavar="H", help="3x3 image-to-ground homography (one row "
                   "per line), to metres (or --units)")
    f.add_argument("--homography-convention", choices=("image-rowcol", "image-uv"),
                   default="image-rowcol", help="H maps the image's [row, col, 1] (ETH's H.txt) "
                   "or [u, v, 1] to the ground (as in `rhythmjax camera`)")
    f.add_argument("--box-scale", type=float, default=1.0, help="multiply box and point "
                   "coordinates (boxes at another resolution: 0.625 for PETS' 768x576 boxes on "
                   "its 480x360 video)")
    f.add_argument("--frame-offset", type=int, default=0, help="world frame = box frame + K "
                   "(1-based MOT frames against 0-based TrajNet frames: -1)")
    f.add_argument("--match", choices=("auto", "id", "geometry"), default="auto",
                   help="pair boxes and positions by id and frame, or by geometry (RANSAC "
                   "homography, then per frame the nearest within --gate-px); auto: id when "
                   "half the positions find a box of their id")
    f.add_argument("--gate-px", type=float, default=12.0, help="largest distance (px) of a "
                   "geometric match")
    f.add_argument("--depth-ratio", type=float, default=10.0, help="--grid keeps points up to "
                   "this many times as deep as the nearest")
    f.add_argument("--units", choices=tuple(UNITS), default="m",
                   help="units of the positions or of the homography's ground (scaled to m)")
    f.add_argument("-o", "--output", required=True, metavar="F", help=".csv or .parquet to write")
    f.add_argument("--json", action="store_true", help="machine-readable summary on stdout")


# ----------------------------------------------------------------------------------------------
# the verbs

def _camera(args):
    from rhythmjax.io import BadInput, read_config_dict, read_footprints

    fp = read_footprints(args.footprints)
    ok = np.isfinite(fp.u) & np.isfinite(fp.v) & np.isfinite(fp.x) & np.isfinite(fp.y)
    if not np.any(ok):
        raise BadInput(args.footprints, "no footprint with finite u, v, x and y")
    scale = UNITS[args.units]
    x, y = fp.x[ok] * scale, fp.y[ok] * scale
    if not args.world and np.any(y <= 0):
        i = int(np.flatnonzero(ok)[np.flatnonzero(y <= 0)[0]])
        raise BadInput(args.footprints, f"ground y {fp.y[i]:.6g} <= 0: x, y must be in the "
                       "camera's ground frame (y > 0 ahead of its foot); for x, y in a world "
                       "frame of their own, add --world", column="y",
                       **{fp.unit: int(fp.line[i])})
    d = read_config_dict(args.config) if args.config else {}
    run = fit_footprints(fp.u[ok], fp.v[ok], x, y, d, path=args.footprints,
                         config_path=args.config, image_size=args.image_size,
                         fit_center=args.fit_center, image_center=args.image_center,
                         fit_roll=args.fit_roll, world=args.world, loss=args.loss,
                         max_steps=args.max_steps)
    return run.fit, run.config, run


def _noise(args):
    from fit.noise import fit_noise
    from rhythmjax.io import BadInput, read_tracks, to_batch

    cfg = _config(args)
    tr = read_tracks(args.tracks, fps=cfg.camera.fps)
    b = to_batch(tr, max_gap_frames=args.max_gap_frames, min_len=2, fps=cfg.camera.fps)
    fit = ("log_q", "log_r_diag", "r_offdiag") + (
        ("log_init_speed_std",) if args.fit_init_speed else ())
    try:
        r = fit_noise(cfg.camera, b.z, b.width, b.dt, b.present, cfg.noise, fit=fit,
                      max_steps=args.max_steps)
    except ValueError as e:
        raise BadInput(args.tracks, str(e)) from None
    return r, cfg.__class__(cfg.camera, r.noise, cfg.width, cfg.walking, cfg.thresholds), None


def _walking(args):
    from fit.walking import fit_walking
    from rhythmjax.io import BadInput, read_tracks, to_batch

    cfg = _config(args)
    tr = read_tracks(args.tracks, fps=cfg.camera.fps)
    if tr.label is None:
        raise BadInput(args.tracks, "no 'label' column: the walking fit needs labelled tracks")
    b = to_batch(tr, max_gap_frames=args.max_gap_frames, min_len=cfg.thresholds.n,
                 fps=cfg.camera.fps)
    try:
        r = fit_walking(cfg, b, test_fraction=args.test_fraction, seed=args.seed,
                        max_iter=args.max_iter)
    except ValueError as e:
        raise BadInput(args.tracks, str(e)) from None
    return r, r.config, None


def _config(args):
    from rhythmjax.io import read_config
    from rhythmjax.model.params import Config

    return Config() if args.config is None else read_config(args.config)


# ----------------------------------------------------------------------------------------------
# footprints

def make_footprints(args):
    """`rhythmjax-fit footprints`: the `fit.footprints.Made` table of the arguments."""
    from fit import footprints as F
    from rhythmjax.io import BadInput

    sources = [k for k in ("boxes", "points", "grid") if getattr(args, k) is not None]
    if len(sources) != 1:
        raise BadInput("footprints", "give one image source: --boxes, --points or --grid")
    if args.homography is None and sources != ["boxes"]:
        raise BadInput("footprints", f"--{sources[0]} needs --homography")
    if args.positions is not None and args.homography is not None:
        raise BadInput("footprints", "give --positions or --homography, not both")
    if not (args.box_scale > 0 and math.isfinite(args.box_scale)):
        raise BadInput("footprints", f"--box-scale {args.box_scale} must be > 0")
    scale = UNITS[args.units]
    if args.homography is not None:
        H = F.read_homography(args.homography)
        H = np.diag([scale, scale, 1.0]) @ H
        order = args.homography_convention.removeprefix("image-")  # "rowcol" or "uv"
        if args.grid is not None:
            if args.image_size is None or args.grid < 2:
                raise BadInput("footprints", "--grid N (N >= 2) needs --image-size WxH")
            u, v = F.grid_points(H, args.image_size, args.grid, order, args.depth_ratio)
            src = f"a {args.grid}x{args.grid} grid over the image through {args.homography}"
            return F.through_homography({"u": u, "v": v}, H, order, source=src)
        path = args.boxes or args.points
        pts = F.read_points(path, scale=args.box_scale)
        return F.through_homography(pts, H, order, source=path)
    boxes = F.read_boxes(args.boxes, scale=args.box_scale)
    boxes["x"], boxes["y"] = boxes["x"] * scale, boxes["y"] * scale
    pos = None
    if args.positions is not None:
        pos = F.read_positions(args.positions)
        pos["x"], pos["y"] = pos["x"] * scale, pos["y"] * scale
    return F.from_boxes(boxes, pos, match=args.match, frame_offset=args.frame_offset,
                        gate_px=args.gate_px, source=args.boxes)


def _footprints_main(args) -> int:
    from fit.footprints import write_footprints
    from rhythmjax.io import BadInput, check_output, dumps_json

    try:
        check_output(args.output, _inputs(args))
        made = make_footprints(args)
        write_footprints(args.output, made)
    except BadInput as e:
        print(f"rhythmjax-fit: {e}", file=sys.stderr)
        return 2
    print(dumps_json({"command": "footprints", "written": args.output, **made.to_dict()})
          if args.json else made.summary() + f"\nwrote {args.output}")
    return 0


# ----------------------------------------------------------------------------------------------

def _inputs(args) -> list:
    return [getattr(args, k, None) for k in ("config", "footprints", "tracks", "boxes", "points",
                                              "positions", "homography")]


def failure(r) -> str:
    """What failed, in words: the solver (its result code) or the checks of an ill-determined fit
    (their reasons, with the numbers), never both contradicting each other."""
    if not r.success:
        what = f"the solver failed ({r.result or 'no result code'})"
        return what + ("; also " + "; ".join(r.reasons) if r.reasons else "")
    if r.reasons:
        return "the solver converged but the fit is ill-determined: " + "; ".join(r.reasons)
    return "the fit gave no config"


def main(argv: list[str] | None = None) -> int:
    from rhythmjax.io import Terminated, raise_on_sigterm

    args = _parser().parse_args(argv)
    raise_on_sigterm()  # SIGTERM cleans up as Ctrl-C does
    try:
        if args.cmd == "selfcal":
            from fit.selfcal_run import selfcal_main

            return selfcal_main(args)
        return _footprints_main(args) if args.cmd == "footprints" else _fit_main(args)
    except Terminated:
        print("rhythmjax-fit: terminated (SIGTERM); nothing written", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("rhythmjax-fit: interrupted; nothing written", file=sys.stderr)
        return 130


def _fit_main(args) -> int:
    from fit.output import write_json, write_output
    from rhythmjax.io import BadInput, check_output, dumps_json, write_config
    from rhythmjax.model.view import format_report

    try:
        check_output(args.output, _inputs(args))  # before the fit
        r, new, run = {"camera": _camera, "noise": _noise, "walking": _walking}[args.cmd](args)
    except BadInput as e:
        print(f"rhythmjax-fit: {e}", file=sys.stderr)
        return 2
    bad = r.ill_determined or not r.success or (new is None and run is None)
    if args.json:
        print(dumps_json({"command": args.cmd, "written": None if bad else args.output,
                          **(run.to_dict() if run is not None else r.to_dict())}))
    else:
        print(r.summary())
        if run is not None:
            print("\n".join(run.notes + [f"held {k}: {why}" for k, why in run.held.items()]))
            print(format_report(run.report))
    for w in run.warnings if run is not None else ():
        print(f"rhythmjax-fit: warning: {w}", file=sys.stderr)
    if bad:
        print(f"rhythmjax-fit: {failure(r)}; the best point is shown above; {args.output} not "
              "written", file=sys.stderr)
        return 1
    if run is not None:  # the config as given, with the fitted camera
        return write_output(args.output, lambda: write_json(args.output, run.config_dict),
                            quiet=args.json)
    return write_output(args.output, lambda: write_config(args.output, new), quiet=args.json)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
