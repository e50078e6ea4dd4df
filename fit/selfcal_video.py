"""`rhythmjax-fit selfcal VIDEO`: track a video, self-calibrate, track again with the fitted camera.

The tracker's detection window is sized by its camera (1.45 walker heights at the predicted foot
point), so the tracks depend on the camera it is given. The command tracks the video with the
library's own tracker (`rhythmjax.track.track_frames`, what `rhythmjax track` and `run` do) and
a start camera: the config's (`-c`), else a rough one of the video's image size and frame rate
(read through OpenCV, `rhythmjax.vision.video.open_video`) with Table 1's other values (f, a, b,
h, theta) and the principal point at the image centre. It then fits the camera from the tracks
(`fit.selfcal_run.fit_tracks`, the same as for a tracks file) and tracks the video again with the
fitted camera, `rounds` times in all (on PETS09-S2L1 the second round finds more walkers:
docs/selfcal.md). A round whose fit is refused ends the loop; its fit is the answer. A round
whose camera lies more than `ROUNDS_AGREE_SE` combined standard errors from the previous
round's in h, tilt or a f is refused too (`rounds_disagree`): the tracks changed with the camera
and the fit did not settle, so neither round's error bars describe its error (set a priori; on
a rendered clip a second round tracked with a camera 10 % off went from tilt 13.6 +- 1.2 to
63.5 +- 2.9 deg).
"""

from __future__ import annotations

import copy
import os
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path


VIDEO_SUFFIXES = (".avi", ".mp4", ".mov", ".mkv", ".m4v", ".mpg", ".webm")
ROUNDS_AGREE_SE = 3.0  # consecutive rounds' cameras within this many combined SEs (module doc)


def is_video(path: str) -> bool:
    """Whether the positional input is taken as a video (by its extension, any case)."""
    return os.fspath(path).lower().endswith(VIDEO_SUFFIXES)


@dataclass
class Round:
    """One round: the camera it tracked with (a f px, h m, theta deg), how many tracks the
    tracker wrote, and the fit of those tracks (`fit.selfcal_report.SelfcalFit`)."""

    index: int
    tracking: dict[str, float]
    n_tracks: int
    fit: object
    notes: list[str] = field(default_factory=list)

    def line(self, rounds: int) -> str:
        """One line: the round, the tracks and the camera found (or why none)."""
        r = self.fit
        head = f"round {self.index} of {rounds}: {self.n_tracks} tracks, {r.n_walkers} walkers"
        if r.camera is None:
            return f"{head}: no camera ({'; '.join(r.reasons)})"
        v, se = r.values, r.se
        pm = lambda k, fmt, unit: (f"{v[k]:{fmt}} +- {se[k]:{fmt}} {unit}" if k in se  # noqa: E731
                                   else f"{v[k]:{fmt}} {unit} (held)")
        flag = f" (refused: {'; '.join(r.reasons)})" if r.ill_determined else ""
        return (f"{head}: h {pm('h', '.2f', 'm')}, tilt {pm('theta', '.1f', 'deg')}, "
                f"a f {pm('af', '.0f', 'px')}{flag}")

    def to_dict(self) -> dict:
        r = self.fit
        return {"round": self.index, "tracking_camera": self.tracking,
                "n_tracks_written": self.n_tracks, "n_tracks": r.n_tracks,
                "n_walkers": r.n_walkers, "values": r.values if r.camera is not None else None,
                "se": r.se, "refused": bool(r.ill_determined or not r.success),
                "reasons": list(r.reasons), "notes": self.notes}


def rounds_disagree(prev, last, k_se: float = ROUNDS_AGREE_SE) -> str | None:
    """The reason when two consecutive rounds' fits (`SelfcalFit`) put h (m), the tilt (deg) or
    a f (px) more than `k_se` combined standard errors, sqrt(SE1^2 + SE2^2), apart; else None."""
    out = []
    for k, unit in (("h", "m"), ("theta", "deg"), ("af", "px")):
        a, b = prev.values[k], last.values[k]
        se = (prev.se.get(k, 0.0) ** 2 + last.se.get(k, 0.0) ** 2) ** 0.5
        if not abs(b - a) <= k_se * se:  # NaN SEs disagree too
            out.append(f"{k} {a:.3g} -> {b:.3g} {unit}")
    if not out:
        return None
    return (f"the rounds disagree beyond {k_se:g} combined SEs ({', '.join(out)}): the tracks "
            "changed with the camera and the fit did not settle")


def video_start(path: str, d: dict, fps: float | None) -> tuple[dict, list[str]]:
    """(the config dict for tracking `path`, notes): the video's image size and frame rate
    (`fps` > the config's camera.fps > the container's) written into `d`'s camera, the
    principal point the image centre unless given; without a camera a rough one (module doc).
    Raises `BadInput` naming the file when it is not a readable video."""
    from rhythmjax.io import BadInput
    from rhythmjax.vision.video import open_video

    d = copy.deepcopy(d)
    cam = d.setdefault("camera", {})
    if not isinstance(cam, dict):
        raise BadInput(path, "expected an object", key="camera")
    rough = not any(k in cam for k in ("h_m", "theta_deg", "a_px_per_m", "f_m"))
    with open_video(path, fps=fps or cam.get("fps")) as src:
        size, rate = (int(src.width), int(src.height)), float(src.fps)
        notes = list(src.notes)
    if rate != rate or rate <= 0:
        raise BadInput(path, "no frame rate; give --fps")
    given = (cam.get("image_width_px"), cam.get("image_height_px"))
    if any(g is not None for g in given) and tuple(given) != size:
        notes.append(f"the config's image size {given[0]}x{given[1]} is not the video's "
                     f"{size[0]}x{size[1]}; the video's is used")
    cam.update(image_width_px=size[0], image_height_px=size[1], fps=rate)
    cam.setdefault("uc_px", size[0] / 2)  # the image centre, as the fit's start (selfcal_run)
    cam.setdefault("vc_px", size[1] / 2)
    if rough:
        notes.append(f"start camera: Table 1's on the video's {size[0]}x{size[1]} at "
                     f"{rate:g} fps (no camera in the config)")
    return d, notes


def track_video(path: str, d: dict, *, max_objects: int, progress: bool):
    """(`rhythmjax.io.Tracks` read back through the tracks format, the tracker's columns, notes,
    the columns' order for writing) of the video at `path` tracked with the config dict `d` (its
    image size and fps the video's, `video_start`). Raises `BadInput` naming the file."""
    from rhythmjax.io import BadInput, config_or_bad_input, read_tracks, write_table
    from rhythmjax.track import TRACK_COLUMNS, TrackerOptions, track_frames
    from rhythmjax.vision.video import open_video

    cam = d["camera"]
    size = (int(cam["image_width_px"]), int(cam["image_height_px"]))
    cfg = config_or_bad_input(d, path, image_size=size, fps=float(cam["fps"]))
    with open_video(path, fps=cfg.camera.fps) as src:
        cols, _, _, _ = track_frames(cfg, src, n_frames=src.n_frames, progress=progress,
                                     options=TrackerOptions(max_objects=max_objects))
        lost = src.shortfall()
    notes = [f"warning: {path}: {lost}"] if lost else []
    if not len(cols["frame"]):
        raise BadInput(path, "the tracker found nothing moving in the video")
    order = [k for k in TRACK_COLUMNS if k in cols]
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "tracks.parquet"
        write_table(p, cols, order)
        tr = read_tracks(p, fps=cfg.camera.fps)
    return tr, cols, notes, order


def tracking_values(d: dict) -> dict[str, float]:
    """a f (px), h (m), theta (deg) of the camera a config dict gives (Table 1's where absent)."""
    from fit.selfcal_data import camera_values
    from rhythmjax.io import config_or_bad_input

    cam = d["camera"]
    v = camera_values(config_or_bad_input(d, "config", image_size=(
        int(cam["image_width_px"]), int(cam["image_height_px"]))).camera)
    return {k: v[k] for k in ("af", "h", "theta")}


def video_rounds(args, d: dict, fit_tracks, fitted_dict):
    """Track `args.tracks` (a video) and fit, `args.rounds` times (module doc). `fit_tracks(args,
    tracks, d, source)` returns (fit, start Config, settled dict) as for a tracks file;
    `fitted_dict(fit, d)` the config dict with the fitted camera. Returns (the last fit, its
    Config, its dict, the rounds). Writes the last round's tracks to `args.tracks_out` when
    given (atomically). Each round's line goes to stderr."""
    from rhythmjax.io import write_table

    path = args.tracks
    d, notes = video_start(path, d, args.fps)
    for n in notes:
        print(f"note: {n}", file=sys.stderr)
    rounds: list[Round] = []
    for k in range(1, args.rounds + 1):
        tracking = tracking_values(d)
        tr, cols, tnotes, order = track_video(path, d, max_objects=args.max_objects,
                                              progress=not args.json)
        r, cfg, d_fit = fit_tracks(args, tr, d, path)
        prev = rounds[-1].fit if rounds else None
        if prev is not None and r.camera is not None and (why := rounds_disagree(prev, r)):
            r.reasons.append(why)
            r.ill_determined = True
        rounds.append(Round(k, tracking, len(tr.ids), r, tnotes))
        for n in tnotes:
            print(n, file=sys.stderr)
        print(rounds[-1].line(args.rounds), file=sys.stderr)
        if r.camera is None or r.ill_determined or not r.success:
            break
        if k < args.rounds:
            d = fitted_dict(r, d_fit)
    if args.tracks_out:
        write_table(args.tracks_out, cols, order)
    return r, cfg, d_fit, rounds
