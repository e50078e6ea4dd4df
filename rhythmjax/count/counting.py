"""Counting pedestrians: the three levels of Masoud & Papanikolopoulos over a video
(`pedestrian_level.PedestrianLevel`), fragments of one walker stitched into one track, then the
rhythm classifier on every track, which removes what does not walk from the count (issue 4).

Stitching (`stitch_pieces`): a walker hidden behind another or behind a bicycle for longer than
its coasting time, or lost by its patch at a crossing (a track whose ground velocity jumps ends
there: `track.toolkit.velocity_jump`), comes back as a new track. At the end of the video
every track's end (its last measured frame: the EKF ground state (x, y, vx, vy) for the "3d"
dynamics, a line fit over its last `stitch.fit_s` s of measured foot points otherwise) is
compared with every later track's start (a line fit over its first `stitch.fit_s` s of
measured foot points): B continues A when B starts after A's last measured frame, within
`stitch.max_gap_s` s, and the two meet halfway: A predicted on for half the gap (on the ground
plane with its EKF state for "3d", projected through the camera; in the image otherwise) and B
taken back for half the gap at its own velocity lie within `stitch.gate_w` W across and
`stitch.gate_h` H up or down (growing by `stitch.gate_per_s` per second of gap; W, H: B's
patch), with image velocities within `stitch.max_dv_w` W/s. The gate is in the image, in units
of the patch, because the foot row's pixel noise is what limits both: a ground gate in metres
is far too tight near the camera or far too loose 20 m away. Pairs are taken cheapest first,
each track with at most one predecessor and one successor; a chain of pieces becomes one track
(the gap frames stay without rows) and is judged as one, which also lets the rhythm classifier
see N samples of a walker it saw only in pieces before. With `stitch.reid` (off: neutral on the
own seeds) a pair the halfway gate refuses is joined, after every halfway pair, when the later
track's first foot point lies where the earlier one's ground state at constant velocity puts it
(`stitch.reid_distance`: the single-object tracker's `track.relink` gate, same ellipse).
`stitch.max_dv_mps` (off; docs/rules.md) also asks a pair's ground velocities to agree.

The counting rule (`count_walkers`; PAPERS.md: the paper counted every pedestrian it tracked, and
its errors were mostly bicyclists counted twice): walkers = tracks - tracks judged non-pedestrian -
unclassified tracks too fast to walk. A track the classifier cannot judge (unclassified: shorter
than N samples, or an unusable rhythm window) is a pedestrian of the paper's method and is counted,
unless its ground speed (`track_speed`: the Theil-Sen slope, robust to a few rows placed off the
feet; least squares with `verdicts.speed_fit` "lsq") exceeds the fastest the walking model's test
(14) accepts for any rhythm (`walking_top_speed`: pace and stride both at +k_sigma3, 2.57 m/s with
Table 1): any window of it would be judged non-pedestrian, so it is not counted (`too_fast`: short
bicycle tracks). With `verdicts.head_speed` (on; rule 31) a track whose foot rows are mostly not its
feet (a walker whose legs the mask lost) is timed under its heads instead (`head_speed`,
`head_feet.head_ground_points`; verdicts `head_speed_mps`). A track judged pedestrian is counted; a
non-pedestrian verdict removes one. Tracks shorter than `verdicts.min_track_frames` frames (after
stitching) are dropped from every output and count first, and so are tracks that never moved
(`ghost`: `still.never_moved`, a ghost of the background). `CountResult.counts` holds the numbers of
`count_walkers` (tracks, pedestrians, non_pedestrians, unclassified, too_fast, unjudged_plausible,
walkers and its range walkers_low .. walkers_high: judged only .. judged + every unjudged track),
the verdicts say per track `track_speed_mps`, `too_fast`, `width_m`, `width_ok` (the unjudged
tracks' best guess by speed and size) and `counted`, and `COUNT_RULE` says the rule in words
(written to counts.json). With `explain.enabled` (off: it removed distinct walkers on the sources it
was not chosen on, docs/rules.md) a counted unclassified track that a stronger counted track
explains (a duplicate on the ground or its continuation: `explain.explain_tracks`) is not counted
either (verdicts `explained_by`, `explained_as`; counts `explained`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..io.mot import VELOCITY_COLUMNS
from ..model.params import Config, walking_top_speed
from ..track.columns import candidate_table
from ..track.rows import TrackRow
from ..vision.frames import drive_frames
from .explain import explain_tracks, measured_points
from .head_feet import head_ground_points
from .judge import judge_tracks
from .options import SPEED_FITS, CountOptions
from .patches import ShapeModel
from .pedestrian_level import END_REASONS, Pedestrian, PedestrianLevel
from .rows import BlobRow, BoxRow, GroundRow
from .still import never_moved, peek_background
from .stitch import stitch_level
from .window_candidates import align_candidates, candidates_by_row


__all__ = ["COUNT_RULE", "CountResult", "build_result", "count_frames", "finish_count",
           "count_walkers", "counted", "faster_than", "head_speed", "points_speed",
           "track_speed", "walker_ids", "walking_top_speed"]

COUNT_RULE = ("walkers = tracks - non_pedestrians - too_fast = pedestrians + "
              "unjudged_plausible: every confirmed track is a pedestrian of the paper's method; "
              "the rhythm classifier removes the tracks it judges non-pedestrian (bicycles); an "
              "unclassified track (too short to judge) is counted (unjudged_plausible) unless it "
              "moves faster than the walking model (14) can accept for any rhythm (too_fast). "
              "The unjudged tracks leave the count uncertain: walkers_low = pedestrians (judged "
              "only) to walkers_high = pedestrians + unclassified (every unjudged track a "
              "walker); per track, verdicts.csv gives the unjudged ones' guess by speed "
              "(track_speed_mps) and size (width_m: the median measured width at the foot "
              "point, width_ok: inside the width gate (10)). Walkers no track stood for "
              "(hidden in a group, lost in the foreground mask) are in neither bound")


# ----------------------------------------------------------------------------------------------
# the pedestrians level over frames


@dataclass
class CountResult:
    """MOT rows (frame 1-based, id, box px, conf, ground x, y m, z; velocities vx, vy m/s, du,
    dv px/s), the tracks format (with the same velocities), the verdicts, the counts and the
    per-frame blob boxes; see `count_frames`."""

    mot: dict[str, np.ndarray]
    tracks: dict[str, np.ndarray]
    verdicts: dict[str, np.ndarray]
    counts: dict[str, int]
    detections: dict[str, np.ndarray]
    summary: dict[str, Any] = field(default_factory=dict)


MOT_COLUMNS = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf", "x", "y", "z")
DETECTION_COLUMNS = ("frame", "bb_left", "bb_top", "bb_width", "bb_height", "area")


def count_frames(cfg: Config, frames, *, options: CountOptions | None = None,
                 n_frames: int | None = None, on_frame=None, progress: bool = False
                 ) -> CountResult:
    """Track and count the pedestrians of `frames`, items (index, t s, gray uint8 or None) as
    `vision.video.VideoSource` yields them (None: an undecodable frame, every pedestrian
    predicts). `on_frame(gray, index, snapshot)`, when given, is called after every decoded
    frame with `PedestrianLevel.snapshot()` (the command line draws its overlay there).

    mot: one row per track and frame from its first to its last measured frame, the box of the
    patch at the filter's estimated foot point; conf 1 measured, 0.5 predicted; x, y the ground
    estimate (m; the EKF state for "3d", the inverse perspective of the estimated foot point
    otherwise) and z = 0 (on the ground plane); x = y = z = -1 (the MOT convention for "no world
    position") where the foot point has no ground point; then vx, vy (ground velocity m/s, the
    EKF state for "3d", NaN otherwise) and du, dv (image velocity px/s of the estimated foot
    point; `rows.GroundRow`), which the tracks get too. tracks: width_px is the measured width
    of the blob the patch was placed on (`widths.measured_width`; NaN when predicted), the W_IMG
    of gate (10) when the tracks are judged. counts (`count_walkers`): tracks,
    pedestrians, non_pedestrians, unclassified (shorter than N or unusable), too_fast and
    walkers = tracks - non_pedestrians - too_fast (`COUNT_RULE`: unclassified tracks count
    unless too fast to walk). `verdicts.window_candidates`: the tracks also hold the candidate
    columns (`window_candidates`), verdicts["candidate"] the deciding one (0: window B)."""
    opt = options or CountOptions()
    if on_frame is None and opt.verdicts.online:
        opt = dataclasses.replace(opt, verdicts=dataclasses.replace(opt.verdicts, online=False))
    b = opt.blobs  # the background from the first seconds' median (`still.peek_background`)
    background, frames = peek_background(frames, b.bg_init_s, b.bg_init_frames)
    level = PedestrianLevel(cfg, opt, defer=on_frame is None,  # no snapshot drawn: defer
                            background=background)
    draw = None if on_frame is None else \
        (lambda frame, index: on_frame(frame, index, level.snapshot()))
    drive_frames(frames, level.update, draw, n_frames=n_frames, progress=progress,
                 desc="count")
    return finish_count(level)


def finish_count(level: PedestrianLevel) -> CountResult:
    """End every pedestrian of `level`; the `CountResult` of its tracks, stitched, those shorter
    than `verdicts.min_track_frames` and those that never moved (`ghost`) dropped, judged."""
    ended = level.end_all()
    by_row = candidates_by_row(ended)  # stitching joins rows; their candidates follow them
    peds = align_candidates(stitch_level(level, ended), by_row)
    shortest = level.opt.verdicts.min_track_frames
    kept = [p for p in peds if len(p.rows) >= shortest]
    level.ghosts = sum(ghost(level, p) for p in kept)
    return build_result(level, [p for p in kept if not ghost(level, p)])


def ghost(level: PedestrianLevel, p: Pedestrian) -> bool:
    """A track whose measured foot points stayed put over its whole life (`still.never_moved`
    with the `life.still_*` settings, W and H of the patch at their median): a ghost of the
    background or an object that never moved, no walker; False when `life.still_s` is 0."""
    lf = level.opt.life
    if lf.still_s <= 0:
        return False
    uv = np.asarray([(r.u, r.v) for r in p.rows], np.float64).reshape(-1, 2)
    uv = uv[np.all(np.isfinite(uv), axis=1)]
    if not len(uv):
        return False
    size = level.shape.size(*(float(q) for q in np.median(uv, axis=0)))
    return never_moved(uv, size, level.block, lf.still_widths, lf.still_heights)


THEIL_SEN_ROWS = 400  # `points_speed`'s Theil-Sen fit reads at most this many rows (79 800
# pairs, 1.9 MB a float64 axis); a track's speed from more rows would barely change


def track_speed(p: Pedestrian, fit: str = "theil-sen") -> float:
    """Ground speed (m/s) over a track's measured rows (its ground x, y: the EKF state for
    "3d"): `points_speed` of its OBSERVE rows (`verdicts.speed_fit`)."""
    from ..model.status import TrackState

    r = np.asarray([(q.t, q.x_est, q.y_est) for q in p.rows
                    if q.state == int(TrackState.OBSERVE)], np.float64).reshape(-1, 3)
    return points_speed(r[:, 0], r[:, 1], r[:, 2], fit)


def points_speed(t, x, y, fit: str = "theil-sen") -> float:
    """Speed (m/s) of ground points x, y (m) at times t (s), rows with a non-finite value left
    out: the norm of the least-squares slope of x and y against t (`fit` "lsq"), or of the
    Theil-Sen slope, per axis the median of (x_j - x_i) / (t_j - t_i) over all pairs i < j with
    t_j > t_i (`fit` "theil-sen", as `model.rhythm.ground_speed` does for a rhythm window; over
    `THEIL_SEN_ROWS` rows evenly spaced in the row order when there are more, so a track of
    hours costs what one of 27 s at 15 fps does); NaN with fewer than 2 rows or a span under
    0.5 s."""
    if fit not in SPEED_FITS:
        raise ValueError(f"speed fit must be one of {SPEED_FITS}, got {fit!r}")
    r = np.stack([np.asarray(a, np.float64).ravel() for a in (t, x, y)], axis=1)
    r = r[np.all(np.isfinite(r), axis=1)]
    if len(r) < 2 or np.ptp(r[:, 0]) < 0.5:
        return math.nan
    if fit == "theil-sen":
        if len(r) > THEIL_SEN_ROWS:
            r = r[np.linspace(0, len(r) - 1, THEIL_SEN_ROWS).round().astype(np.int64)]
        i, j = np.triu_indices(len(r), 1)
        dt = r[j, 0] - r[i, 0]
        ok = dt > 0  # two rows of one instant give no slope
        v = np.median((r[j, 1:][ok] - r[i, 1:][ok]) / dt[ok, None], axis=0)
        return float(np.hypot(*v))
    tc = r[:, 0] - r[:, 0].mean()
    v = tc @ (r[:, 1:] - r[:, 1:].mean(axis=0)) / float(tc @ tc)
    return float(np.hypot(*v))


def head_speed(shape: ShapeModel, rows: list[TrackRow], n_rows: int,
               fit: str = "theil-sen") -> float:
    """Ground speed (m/s) under the heads of a track's `rows` (`points_speed` of
    `head_feet.head_ground_points`, the image `n_rows` high) where its foot rows are mostly not
    its feet; NaN where they are, or too few heads for a speed."""
    pts = head_ground_points(shape, rows, n_rows)
    return math.nan if pts is None else points_speed(pts[:, 0], pts[:, 1], pts[:, 2], fit)


def faster_than(speed, head, top: float) -> np.ndarray:
    """Per track, whether it moves faster than `top` (m/s): its speed under its heads where
    there is one (`head`, finite), else its own ground speed (`speed`; NaN: not too fast)."""
    speed, head = np.asarray(speed, np.float64), np.asarray(head, np.float64)
    return np.where(np.isnan(head), speed > top, head > top)


def track_width(level: PedestrianLevel, p: Pedestrian) -> float:
    """The median over a track's measured rows of its measured width (`widths.measured_width`,
    px) in metres at its foot point: width_px / W x width.mean (W px: the patch of an average
    pedestrian, `width.mean` m wide, at that foot point; `patches.ShapeModel`); NaN without a
    measured width."""
    r = np.asarray([(q.u, q.v, q.width_px) for q in p.rows], np.float64).reshape(-1, 3)
    r = r[np.all(np.isfinite(r), axis=1)]
    if not len(r):
        return math.nan
    W = np.asarray(level.shape.size(r[:, 0], r[:, 1])[0], np.float64)
    m = np.isfinite(W) & (W > 0)
    return float(np.median(r[m, 2] / W[m]) * level.shape.width_m) if m.any() else math.nan


def count_walkers(verdicts, too_fast=None, explained=None) -> dict[str, int]:
    """The counts of a verdict list (labels as `status.Verdict`; `too_fast`: per track, faster
    than `walking_top_speed`, default none; `explained`: per track, explained by another
    counted track (`explain.explain_tracks`, `explain.enabled`), default none): tracks,
    pedestrians (judged), non_pedestrians (judged), unclassified (too short to judge), too_fast
    (unclassified and too fast), explained (unclassified, not too fast, explained),
    unjudged_plausible (unclassified, neither), walkers = tracks - non_pedestrians - too_fast -
    explained = pedestrians + unjudged_plausible (`COUNT_RULE`), and the range the unjudged
    tracks leave: walkers_low = pedestrians (judged only), walkers_high = pedestrians +
    unclassified (every unjudged track a walker)."""
    v = [str(x) for x in verdicts]
    fast = [False] * len(v) if too_fast is None else [bool(f) for f in too_fast]
    expl = [False] * len(v) if explained is None else [bool(e) for e in explained]
    n, non, ped, unc = len(v), v.count("non-pedestrian"), v.count("pedestrian"), \
        v.count("unclassified")
    tf = sum(f and w == "unclassified" for w, f in zip(v, fast))
    ex = sum(e and not f and w == "unclassified" for w, f, e in zip(v, fast, expl))
    return {"tracks": n, "pedestrians": ped, "non_pedestrians": non, "unclassified": unc,
            "too_fast": tf, "explained": ex, "unjudged_plausible": unc - tf - ex,
            "walkers": n - non - tf - ex, "walkers_low": ped, "walkers_high": ped + unc}


def counted(verdicts: dict) -> np.ndarray:
    """Per track, whether `COUNT_RULE` counts it as a walker: not judged non-pedestrian, and
    not unclassified and too fast (verdicts["too_fast"], when present), and explained by no
    other track (verdicts["explained_by"] 0, when present; `explain.enabled`)."""
    v = np.asarray([str(x) for x in verdicts["verdict"]], dtype=object)
    fast = np.asarray(verdicts.get("too_fast", np.zeros(len(v), bool)), bool)
    expl = np.asarray(verdicts.get("explained_by", np.zeros(len(v), np.int64))) != 0
    return (v != "non-pedestrian") & ~((v == "unclassified") & fast) & ~expl


def walker_ids(verdicts: dict) -> list[int]:
    """Track ids counted as walkers (`counted`)."""
    return [int(i) for i, c in zip(verdicts["track_id"], counted(verdicts)) if c]


def build_result(level: PedestrianLevel, peds: list[Pedestrian]) -> CountResult:
    """Outputs of the kept tracks, ids renumbered 1.. in order of appearance."""
    cfg = level.cfg
    for k, p in enumerate(peds, 1):
        p.track_id = k
    on = level.opt.verdicts.window_candidates  # the candidate windows B (`window_candidates`)
    tracks = tracks_table(peds, candidates=on)
    if peds and level.opt.verdicts.classify:
        vo = level.opt.verdicts
        verdicts = judge_tracks(cfg, tracks, candidates=on,
                                twice_pace_heights=vo.twice_pace_heights,
                                twice_pace_edge=vo.twice_pace_edge,
                                min_height_heights=vo.min_height_heights,
                                stride_peak=vo.stride_peak)
    else:
        B, nan = len(peds), np.full(len(peds), np.nan)
        verdicts = {"track_id": np.arange(1, B + 1, dtype=np.int64),
                    "verdict": np.full(B, "unclassified", dtype=object),
                    "reason": np.full(B, "not-judged", dtype=object), "pace_hz": nan,
                    "stride_m": nan, "ratio": nan, "speed_mps": nan,
                    "n_samples": np.asarray([len(p.rows) for p in peds], np.int64),
                    "window_frame": np.full(B, -1, np.int64)}
        if on:
            verdicts["candidate"] = np.zeros(B, np.int64)
    mot, detections = mot_table(peds), detections_table(level.detections)
    top = walking_top_speed(cfg)
    fit = level.opt.verdicts.speed_fit
    speed = np.asarray([track_speed(p, fit) for p in peds], np.float64)
    verdicts["track_speed_mps"], verdicts["too_fast"] = speed, speed > top
    if level.opt.verdicts.head_speed:  # rule 31: the speed under the heads where it stands
        n_rows = level.image_shape[0]
        head = np.asarray([head_speed(level.shape, p.rows, n_rows, fit) for p in peds],
                          np.float64)
        verdicts["head_speed_mps"] = head
        verdicts["too_fast"] = faster_than(speed, head, top)
    verdicts["width_m"] = np.asarray([track_width(level, p) for p in peds], np.float64)
    w = cfg.width
    verdicts["width_ok"] = np.abs(verdicts["width_m"] - float(w.mean)) <= \
        float(cfg.thresholds.k_sigma1) * float(w.std)
    verdicts["counted"] = counted(verdicts)
    explain_counted(level, tracks, verdicts)
    counts = count_walkers(verdicts["verdict"], verdicts["too_fast"],
                           verdicts["explained_by"] != 0)
    summary = {"n_frames": level.n_frames, "dynamics": level.opt.dynamics,
               "count_rule": COUNT_RULE, "stitched": level.stitched,
               "ghosts_dropped": level.ghosts, "rewinds": level.rewinds,
               "crowd_frames": len(level.crowd_frames),
               "missing_frames": len(level.missing_frames),
               "ends": {r: sum(q.end_reason == r for q in level.finished) for r in END_REASONS},
               "notes": []}
    if level.crowd_frames:
        summary["notes"].append(
            f"{len(level.crowd_frames)} frame(s) had one blob covering >= "
            f"{level.opt.blobs.crowd_fraction:.0%} of the image (dense crowd or camera jump): no "
            f"detection there, pedestrians predicted (first: frame {level.crowd_frames[0]})")
    if level.full_frames:
        summary["notes"].append(f"all {level.filter.slots} pedestrian slots were in use in "
                                f"{len(set(level.full_frames))} frame(s); raise max_pedestrians")
    return CountResult(mot, tracks, verdicts, counts, detections, summary)


def explain_counted(level: PedestrianLevel, tracks: dict, verdicts: dict) -> None:
    """Adds verdicts["explained_by"] (the id of the counted track that explains each track, 0:
    none) and ["explained_as"] (`explain.explain_tracks` with `explain.*`; all 0 and "" when
    off) and takes the explained tracks out of verdicts["counted"]."""
    ids = [int(i) for i in verdicts["track_id"]]
    cfg = level.cfg
    by, how = explain_tracks(measured_points(tracks, ids), verdicts["verdict"],
                             verdicts["counted"], float(cfg.camera.fps), level.opt.explain,
                             float(cfg.width.mean))
    verdicts["explained_by"] = np.asarray([0] + ids, np.int64)[by]
    verdicts["explained_as"] = how
    verdicts["counted"] = counted(verdicts)


def _columns(records: list, fields: tuple[str, ...]) -> dict[str, tuple]:
    """Per field of a NamedTuple type, the values of `records` (empty tuples when none)."""
    return dict(zip(fields, zip(*records))) if records else {f: () for f in fields}


def tracks_table(peds: list[Pedestrian], candidates: bool = False) -> dict[str, np.ndarray]:
    """The tracks format of the pedestrians' rows (`track.rows.TrackRow`), their track ids
    first; with `candidates` also the candidate windows' I(k) (`io.files.CANDIDATE_COLUMNS`,
    `track.columns.candidate_table`)."""
    from ..model.status import TrackState

    rows = [r for p in peds for r in p.rows]
    cols = _columns(rows, TrackRow._fields)
    out = {"track_id": np.asarray([p.track_id for p in peds for _ in p.rows], np.int64),
           "frame": np.asarray(cols["frame"], np.int64)}
    for name in (f for f in TrackRow._fields if f not in ("frame", "state")):
        out[name] = np.asarray(cols[name], np.float64)
    out["state"] = np.asarray([TrackState(s).name.lower() for s in cols["state"]], dtype=object)
    out.update(velocity_columns(peds))
    if candidates:
        out.update(candidate_table(peds))
    return out


def velocity_columns(peds: list[Pedestrian]) -> dict[str, np.ndarray]:
    """Per row of the pedestrians' tracks, the filter's velocities (`rows.GroundRow`): ground
    vx, vy m/s ("3d"; NaN otherwise) and image du, dv px/s (`VELOCITY_COLUMNS`)."""
    cols = _columns([g for p in peds for g in p.ground], GroundRow._fields)
    return {name: np.asarray(cols[name], np.float64) for name in VELOCITY_COLUMNS}


def mot_table(peds: list[Pedestrian]) -> dict[str, np.ndarray]:
    """MOT columns (`MOT_COLUMNS`) of the pedestrians' patches (`rows.BoxRow`): frame 1-based;
    x, y, z = ground x, y, 0 where the foot point has a ground point, else -1, -1, -1; then the
    extra `VELOCITY_COLUMNS` (`velocity_columns`)."""
    boxes = [b for p in peds for b in p.boxes]
    cols = _columns(boxes, BoxRow._fields)
    ok = np.asarray(cols["ok"], bool)
    out = {"frame": np.asarray(cols["frame"], np.int64) + 1,
           "id": np.asarray([p.track_id for p in peds for _ in p.boxes], np.int64)}
    for name, col in (("bb_left", "left"), ("bb_top", "top"), ("bb_width", "w"),
                      ("bb_height", "h"), ("conf", "conf")):
        out[name] = np.asarray(cols[col], np.float64)
    out["x"] = np.where(ok, np.asarray(cols["x"], np.float64), -1.0)
    out["y"] = np.where(ok, np.asarray(cols["y"], np.float64), -1.0)
    out["z"] = np.where(ok, 0.0, -1.0)
    out.update(velocity_columns(peds))
    return out


def detections_table(blobs: list[BlobRow]) -> dict[str, np.ndarray]:
    """Per-frame blob boxes (`rows.BlobRow`) as MOT-style columns (`DETECTION_COLUMNS`), frame
    1-based."""
    cols = {k: np.asarray(v, np.int64) for k, v in _columns(blobs, BlobRow._fields).items()}
    return {"frame": cols["frame"] + 1, "bb_left": cols["x0"], "bb_top": cols["y0"],
            "bb_width": cols["x1"] - cols["x0"], "bb_height": cols["y1"] - cols["y0"],
            "area": cols["area"]}
