"""`rhythmjax camera`: a config's camera section from what a user has (registered by `cli.main`).

One source: a focal length (or field of view) with height and tilt; a Tsai XML; an OpenCV
calibration; an image-ground homography. The written config is partial: the camera section
(and `thresholds.window_s` when given) over an optional base config; the detection range and
the window's N follow from the camera and the video at run time (`model.config_setup`)."""

from __future__ import annotations

import copy
import json
import math

from ..io import BadInput, atomic_write, check_output, read_config_dict
from ..io.calibration import bad_camera, read_homography, read_opencv, read_tsai
from ..model.camera_from import (
    CONVENTIONS,
    CameraError,
    CameraFrom,
    camera_from_intrinsics,
    camera_from_krt,
    camera_from_tsai,
)
from ..model.camera_homography import camera_from_homography
from ..model.config_setup import config_for
from ..model.params import ConfigError
from ..model.view import camera_report, format_report
from .common import add_common, emit_json, say


WORLD_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
FLAGS = {"focal_px": "--focal-px", "hfov_deg": "--hfov-deg", "h_m": "--height",
         "tilt_deg": "--tilt", "roll_deg": "--roll"}
EPILOG = """\
examples:
  rhythmjax camera --focal-px 1000 --height 6 --tilt 20 --video clip.avi -o cam.json
  rhythmjax camera --tsai View_001.xml --video vtest.avi --fps 7 -o pets.json
  rhythmjax camera --opencv calib.yml --image-size 1920x1080 -o cam.json
  rhythmjax camera --homography H.txt --homography-convention image-rowcol \\
      --image-size 640x480 --fps 15 -o eth.json
point pairs (u, v, x, y) are fitted, not converted: rhythmjax-fit camera PAIRS -o cam.json
exit codes: 0 success, 2 bad input (one line naming the file or option and the field)."""


def _image_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(q) for q in text.lower().split("x"))
    except ValueError:
        raise ConfigError("--image-size", f"expected WxH in px, e.g. 640x480, got {text!r}"
                          ) from None
    if w <= 0 or h <= 0:
        raise ConfigError("--image-size", f"must be positive, got {text!r}")
    return w, h


def _source(args) -> str:
    given = [n for n in ("tsai", "opencv", "homography", "points") if getattr(args, n)]
    if (args.focal_px is not None or args.hfov_deg is not None) and not args.homography:
        given.append("intrinsics")
    if len(given) != 1:
        raise ConfigError("source", "give exactly one of --focal-px / --hfov-deg (with --height "
                          "and --tilt), --tsai, --opencv, --homography; got "
                          + (", ".join(given) if given else "none"))
    src = given[0]
    if src == "points":
        raise ConfigError("--points", "point pairs (u, v, x, y) are fitted, not converted: run "
                          f"`rhythmjax-fit camera {args.points} -o CAM.json` (--world when x, y "
                          "are world coordinates)")
    wrong = [f for f, v in (("--height", args.height), ("--tilt", args.tilt),
                            ("--roll", args.roll)) if v is not None and src != "intrinsics"]
    wrong += ["--hfov-deg"] * (args.hfov_deg is not None and src == "homography")
    wrong += ["--homography-convention"] * (args.homography_convention is not None
                                            and src != "homography")
    wrong += [f for f, v in (("--world-unit", args.world_unit != "m"),
                             ("--world-z-down", args.world_z_down)) if v and src != "opencv"]
    wrong += ["--center"] * (args.center is not None and src not in ("intrinsics", "homography"))
    if wrong:
        raise ConfigError(wrong[0], f"does not apply to the {src} source")
    return src


def _video_facts(args, notes: list) -> tuple[tuple[int, int] | None, float | None]:
    size = None if args.image_size is None else _image_size(args.image_size)
    fps = args.fps
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        raise ConfigError("--fps", f"must be > 0, got {fps:g}")
    if args.video:
        from ..vision.video import open_video

        with open_video(args.video) as v:
            vsize, vfps = (v.width, v.height), v.fps_container
        if size is not None and size != vsize:
            notes.append(f"--image-size {size[0]}x{size[1]} overrides the video's "
                         f"{vsize[0]}x{vsize[1]}")
        size = size or vsize
        if fps is None:
            if not (math.isfinite(vfps) and vfps > 0):
                raise BadInput(args.video, "the video gives no frame rate; give --fps")
            fps = vfps
        elif math.isfinite(vfps) and abs(vfps - fps) > 1e-6 * fps:
            notes.append(f"--fps {fps:g} overrides the video's {vfps:g} fps")
    return size, fps


def _convert(args, src: str, size, fps, notes: list) -> tuple[CameraFrom, str]:
    """The `CameraFrom` of the source and the line naming it."""
    if src == "intrinsics":
        if size is None:
            raise ConfigError("--image-size", "give the image size (--image-size WxH or --video)")
        for flag, v in (("--height", args.height), ("--tilt", args.tilt)):
            if v is None:
                raise ConfigError(flag, "required with --focal-px / --hfov-deg")
        try:
            r = camera_from_intrinsics(focal_px=args.focal_px, hfov_deg=args.hfov_deg,
                                       h_m=args.height, tilt_deg=args.tilt,
                                       roll_deg=args.roll or 0.0, principal_point=args.center,
                                       image_size=size, fps=fps)
        except CameraError as e:
            raise ConfigError(FLAGS.get(e.key, e.key), e.message) from None
        what = "focal length" if args.focal_px is not None else "field of view"
        return r, f"{what}, height {args.height:g} m, tilt {args.tilt:g} deg"
    path = {"tsai": args.tsai, "opencv": args.opencv, "homography": args.homography}[src]
    try:
        if src == "tsai":
            cal = read_tsai(path)
            return camera_from_tsai(cal, image_size=size, fps=fps), f"Tsai calibration {path}"
        if src == "opencv":
            cal = read_opencv(path)
            notes.append("read " + ", ".join(cal.keys.values()) + f" from {path}")
            size = size or cal.image_size
            if size is None:
                raise ConfigError("--image-size", f"{path} gives no image size; give "
                                  "--image-size WxH or --video")
            r = camera_from_krt(cal.K, cal.t, R=cal.R, rvec=cal.rvec, dist=cal.dist,
                                image_size=size, calibration_size=cal.image_size, fps=fps,
                                unit_m=WORLD_UNITS[args.world_unit], z_down=args.world_z_down)
            return r, f"OpenCV calibration {path}"
        if args.homography_convention is None:
            raise ConfigError("--homography-convention", "say what H maps: image-rowcol ([row, "
                              "col, 1] to the ground, ETH's H.txt), image-uv or ground-to-image")
        if size is None:
            raise ConfigError("--image-size", "give the image size (--image-size WxH or --video)")
        H = read_homography(path)
        r = camera_from_homography(H, args.homography_convention, image_size=size,
                                   principal_point=args.center, focal_px=args.focal_px, fps=fps)
        return r, f"homography {path} ({args.homography_convention})"
    except CameraError as e:
        raise bad_camera(path, e) from None


def _config(args, r: CameraFrom, notes: list) -> dict:
    d = copy.deepcopy(read_config_dict(args.config)) if args.config else {}
    if not isinstance(d, dict):
        raise BadInput(args.config, "expected a JSON object at the top level")
    d["camera"] = dict(r.section)
    if args.window_s is not None:
        thr = d.setdefault("thresholds", {})
        if not isinstance(thr, dict):
            raise BadInput(args.config, "thresholds: expected an object", key="thresholds")
        thr.pop("n_samples", None)
        thr["window_s"] = args.window_s
    thr = d.get("thresholds", {})
    if isinstance(thr, dict) and ("range_min_m" in thr or "range_max_m" in thr):
        notes.append(f"{args.config} gives thresholds.range_*_m, kept; delete them to derive "
                     "the detection range from this camera")
    return d


def _screen(src_line: str, report: dict, r: CameraFrom, world: bool) -> str:
    lines = [f"source            {src_line}", format_report(report)]
    if r.unrepresented or r.residual_max_px > 1e-6:
        lines.append(f"nearest camera of (3): max {r.residual_max_px:.2f} px, RMS "
                     f"{r.residual_rms_px:.2f} px over the image ({', '.join(r.unrepresented)})")
    if world and r.transform is not None:
        t = r.transform
        lin = [" ".join([f"{a:.6g} x", "-" if b < 0 else "+", f"{abs(b):.6g} y", "-" if c < 0
                         else "+", f"{abs(c):.6g}"]) for a, b, c in t.matrix()]
        lines.append(f"world -> ground   x' = {lin[0]}, y' = {lin[1]} (m; the camera's foot at "
                     f"world ({t.foot_x_m:.3f}, "
                     f"{t.foot_y_m:.3f}) m, looking along {math.degrees(t.heading_rad):.1f} deg "
                     "from world x towards y" + (", world y mirrored" if t.mirror else "") + ")")
    return "\n".join(lines)


def cmd_camera(args) -> int:
    """Write a config's camera section from a focal length (or field of view), height and tilt,
    a Tsai calibration XML, an OpenCV calibration (K with R/t or rvec/tvec, YAML/XML/JSON) or an
    image-ground homography, and print the numbers to check it by. Where the source holds what
    the camera of (3) cannot (lens distortion, skew, ...), one line says how far (3) is from it
    in px over the image. The image size and fps come from --video unless given."""
    src = _source(args)
    if args.output:
        check_output(args.output, [getattr(args, k, None) for k in (
            "config", "tsai", "opencv", "homography", "points", "video")])
    if args.window_s is not None and not (math.isfinite(args.window_s) and args.window_s > 0):
        raise ConfigError("--window-s", f"must be > 0 s, got {args.window_s:g}")
    notes: list[str] = []
    size, fps = _video_facts(args, notes)
    r, src_line = _convert(args, src, size, fps, notes)
    notes += list(r.notes)
    d = _config(args, r, notes)
    size = (r.section["image_width_px"], r.section["image_height_px"])
    try:
        cfg = config_for(d, image_size=size, fps=fps)
    except ConfigError as e:
        if not e.key.startswith("thresholds.range"):
            raise
        raise ConfigError(e.key, f"{str(e).split(': ', 1)[1]}, from the ground this camera's "
                          "image sees; give thresholds.range_min_m and range_max_m in --config "
                          "BASE") from None
    report = camera_report(cfg.camera)
    if fps is None:
        notes.append("no fps given: the config leaves it to the video (--fps or --video to fix)")
    if args.output:
        with atomic_write(args.output, "w") as f:
            f.write(json.dumps(d, indent=2, allow_nan=False) + "\n")
    if args.json:
        emit_json({"output": args.output, "source": src_line, "config": d, "report": report,
                   "nearest": {"max_px": r.residual_max_px, "rms_px": r.residual_rms_px,
                               "n_points": r.n_points, "unrepresented": list(r.unrepresented)},
                   "transform": None if src == "intrinsics" or r.transform is None
                   else r.transform.as_dict(), "notes": notes})
        return 0
    print(_screen(src_line, report, r, src != "intrinsics"))
    for n in notes:
        say(args, f"note: {n}")
    say(args, f"wrote {args.output}" if args.output else "(nothing written: give -o CAM.json)")
    return 0


def register(sub, formatter) -> None:
    """Add the `camera` verb to the subparsers `sub`."""
    p = sub.add_parser("camera", formatter_class=formatter, epilog=EPILOG,
                       help="write a config's camera section from a focal length, a "
                            "calibration (Tsai, OpenCV) or a homography",
                       description=cmd_camera.__doc__)
    p.add_argument("-o", "--output", metavar="CAM", help="config JSON to write (atomically)")
    s = p.add_argument_group("source (exactly one)")
    s.add_argument("--focal-px", type=float, metavar="F", help="focal length in px (with "
                   "--homography: the focal length to start from)")
    s.add_argument("--hfov-deg", type=float, metavar="A", help="horizontal field of view (deg)")
    s.add_argument("--tsai", metavar="XML", help="Tsai calibration (PETS / ETISEO XML)")
    s.add_argument("--opencv", metavar="FILE", help="OpenCV calibration: YAML / XML / JSON "
                   "of cv2.FileStorage, or plain JSON {K, R or rvec, t, dist, image_size}")
    s.add_argument("--homography", metavar="H", help="3x3 homography text file")
    s.add_argument("--points", metavar="PAIRS", help="point pairs u, v, x, y: says how to fit "
                   "them (rhythmjax-fit camera)")
    g = p.add_argument_group("camera facts")
    g.add_argument("--height", type=float, metavar="H", help="camera height above the ground (m)")
    g.add_argument("--tilt", type=float, metavar="T", help="tilt below the horizontal (deg)")
    g.add_argument("--roll", type=float, metavar="R", help="roll (deg; + turns the picture "
                   "clockwise; default 0)")
    g.add_argument("--center", type=float, nargs=2, metavar=("U", "V"), help="principal point "
                   "(px; default the image centre)")
    g.add_argument("--homography-convention", choices=CONVENTIONS, help="what H maps: "
                   "image-rowcol: [row, col, 1] to the ground (ETH's H.txt); image-uv: [u, v, "
                   "1] to the ground; ground-to-image: [x, y, 1] to [u, v, 1]")
    g.add_argument("--world-unit", choices=tuple(WORLD_UNITS), default="m",
                   help="unit of the OpenCV calibration's world (t)")
    g.add_argument("--world-z-down", action="store_true", help="the OpenCV world's z points "
                   "down (e.g. a chessboard frame with z into the board)")
    v = p.add_argument_group("the video")
    v.add_argument("--video", metavar="V", help="image size and fps from this video")
    v.add_argument("--image-size", metavar="WxH", help="image size (px), e.g. 640x480")
    v.add_argument("--fps", type=float, help="frame rate (overrides the video's)")
    v.add_argument("--window-s", type=float, metavar="S", help="rhythm window (s): writes "
                   "thresholds.window_s (and drops the base's n_samples)")
    add_common(p)
    p.set_defaults(func=cmd_camera)
