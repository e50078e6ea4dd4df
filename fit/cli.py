"""`rhythmjax-fit`: calibrate the camera of (3) from footprints, Q and R of the EKF (4)-(9) from
tracks, or the walking and width models and thresholds from labelled tracks; write the config.

Exit codes: 0 fitted and written; 1 the solver failed or the fit is ill-determined (the result
code and the best point are printed, the output config is not written); 2 bad input (one line
naming the file).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


EPILOG = """\
exit codes: 0 fitted and written, 1 solver failure or ill-determined fit (nothing written),
2 bad input (one line naming the file)."""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rhythmjax-fit", description=__doc__.split("\n\n")[0],
                                epilog=EPILOG,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("camera", help="fit a f, b f, h, theta (and Uc, Vc) from footprints")
    c.add_argument("footprints", help="footprints .csv/.parquet: tracks columns plus x, y (m)")
    c.add_argument("--fit-center", action="store_true",
                   help="also fit Uc, Vc; b/a is then held at the config's (ground footprints "
                   "determine only five combinations)")
    c.add_argument("--fit-roll", action="store_true",
                   help="also fit the roll angle (an extension of (3): a tilted horizon); "
                   "written as camera.roll_deg")
    c.add_argument("--world", action="store_true",
                   help="x, y are in the data's own world frame: fit a planar rigid transform "
                   "(tx, ty, yaw; reported, not written) to the ground frame of (3) with the "
                   "camera; b/a is then held at the config's")
    c.add_argument("--loss", choices=("l2", "huber", "cauchy"), default="l2")
    c.add_argument("--max-steps", type=int, default=256)
    n = sub.add_parser("noise", help="fit Q and R by the EKF's innovation likelihood")
    n.add_argument("tracks", help="tracks .csv/.parquet")
    n.add_argument("--fit-init-speed", action="store_true",
                   help="also fit the initial speed spread")
    n.add_argument("--max-gap-frames", type=int, default=5)
    n.add_argument("--max-steps", type=int, default=200)
    w = sub.add_parser("walking", help="fit the walking and width models and P_thr, R_thr, "
                       "k_sigma3 from labelled tracks (balanced accuracy, held-out split)")
    w.add_argument("tracks", help="tracks .csv/.parquet with a 'label' column ('pedestrian' is "
                   "the positive class, every other label the negative one)")
    w.add_argument("--test-fraction", type=float, default=0.3,
                   help="share of each class held out for the reported accuracy (default 0.3)")
    w.add_argument("--seed", type=int, default=0, help="seed of the held-out split")
    w.add_argument("--max-gap-frames", type=int, default=5)
    w.add_argument("--max-iter", type=int, default=20,
                   help="re-centring iterations of the walking model")
    for s in (c, n, w):
        s.add_argument("--config", "-c", metavar="C", help="config JSON (default: Table 1)")
        s.add_argument("-o", "--output", required=True, metavar="C2", help="config to write")
        s.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    return p


def _camera(args, cfg):
    from fit.camera import fit_camera
    from rhythmjax.io import BadInput, read_footprints

    tr = read_footprints(args.footprints, fps=cfg.camera.fps)
    ok = np.isfinite(tr.u) & np.isfinite(tr.v) & np.isfinite(tr.x) & np.isfinite(tr.y)
    if not np.any(ok):
        raise BadInput(args.footprints, "no footprint with finite u, v, x and y")
    if args.world and args.fit_center:
        raise BadInput(args.footprints, "--world and --fit-center together are not identifiable "
                       "from ground footprints; give the principal point in the config")
    # In a world frame of its own the ground's translation trades with b f (singular Jacobian,
    # measured): b/a is held at the config's, as with --fit-center.
    fit = (("af", "h", "theta", "uc", "vc") if args.fit_center
           else ("af", "h", "theta") if args.world else ("af", "bf", "h", "theta"))
    fit += ("roll",) if args.fit_roll else ()
    try:
        r = fit_camera(tr.u[ok], tr.v[ok], tr.x[ok], tr.y[ok], cfg.camera, fit=fit,
                       loss=args.loss, max_steps=args.max_steps, world=args.world)
    except ValueError as e:
        raise BadInput(args.footprints, str(e)) from None
    return r, cfg.__class__(r.camera, cfg.noise, cfg.width, cfg.walking, cfg.thresholds)


def _noise(args, cfg):
    from fit.noise import fit_noise
    from rhythmjax.io import BadInput, read_tracks, to_batch

    tr = read_tracks(args.tracks, fps=cfg.camera.fps)
    b = to_batch(tr, max_gap_frames=args.max_gap_frames, min_len=2, fps=cfg.camera.fps)
    fit = ("log_q", "log_r_diag", "r_offdiag") + (
        ("log_init_speed_std",) if args.fit_init_speed else ())
    try:
        r = fit_noise(cfg.camera, b.z, b.width, b.dt, b.present, cfg.noise, fit=fit,
                      max_steps=args.max_steps)
    except ValueError as e:
        raise BadInput(args.tracks, str(e)) from None
    return r, cfg.__class__(cfg.camera, r.noise, cfg.width, cfg.walking, cfg.thresholds)


def _walking(args, cfg):
    from fit.walking import fit_walking
    from rhythmjax.io import BadInput, read_tracks, to_batch

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
    return r, r.config


def main(argv: list[str] | None = None) -> int:
    from rhythmjax.io import BadInput, dumps_json, read_config, write_config
    from rhythmjax.model.params import Config

    args = _parser().parse_args(argv)
    try:
        cfg = Config() if args.config is None else read_config(args.config)
        r, new = {"camera": _camera, "noise": _noise, "walking": _walking}[args.cmd](args, cfg)
    except BadInput as e:
        print(f"rhythmjax-fit: {e}", file=sys.stderr)
        return 2
    bad = r.ill_determined or not r.success
    if args.json:
        print(dumps_json({"command": args.cmd, "written": None if bad else args.output,
                          **r.to_dict()}))
    else:
        print(r.summary())
    if bad:
        print(f"rhythmjax-fit: fit failed or ill-determined ({r.result or 'successful'}); the "
              f"best point is shown above; {args.output} not written", file=sys.stderr)
        return 1
    try:
        write_config(args.output, new)
    except OSError as e:
        print(f"rhythmjax-fit: {args.output}: cannot write: {e.strerror}", file=sys.stderr)
        return 1
    if not args.json:
        print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
