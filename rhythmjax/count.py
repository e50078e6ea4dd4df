"""Counting pedestrians: the three levels of Masoud & Papanikolopoulos over a video
(`pedestrian_level.PedestrianLevel`), fragments of one walker stitched into one track, then the
rhythm classifier on every track, which removes what does not walk from the count (issue 4).

Stitching (`stitch_pieces`): a walker hidden behind another or behind a bicycle for longer than
its coasting time, or lost by its patch at a crossing (a track whose ground velocity jumps ends
there: `PedestrianLevel._velocity_jump`), comes back as a new track. At the end of the video
every track's end (its last measured frame: the EKF ground state (x, y, vx, vy) for the "3d"
dynamics, a line fit over its last `stitch_fit_s` s of measured foot points otherwise) is
compared with every later track's start (a line fit over its first `stitch_fit_s` s of
measured foot points): B continues A when B starts after A's last measured frame, within
`stitch_max_gap_s` s, and the two meet halfway: A predicted on for half the gap (on the ground
plane with its EKF state for "3d", projected through the camera; in the image otherwise) and B
taken back for half the gap at its own velocity lie within `stitch_gate_w` W across and
`stitch_gate_h` H up or down (growing by `stitch_gate_per_s` per second of gap; W, H: B's
patch), with image velocities within `stitch_max_dv_w` W/s. The gate is in the image, in units
of the patch, because the foot row's pixel noise is what limits both: a ground gate in metres
is far too tight near the camera or far too loose 20 m away. Pairs are taken cheapest first,
each track with at most one predecessor and one successor; a chain of pieces becomes one track
(the gap frames stay without rows) and is judged as one, which also lets the rhythm classifier
see N samples of a walker it saw only in pieces before.

The counting rule (`count_walkers`; PAPERS.md: the paper counted every pedestrian it tracked,
and its errors were mostly bicyclists counted twice): walkers = tracks - tracks judged
non-pedestrian - unclassified tracks too fast to walk. A track the classifier cannot judge
(unclassified: shorter than N samples, or an unusable rhythm window) is a pedestrian of the
paper's method and is counted, unless its ground speed (`track_speed`) exceeds the fastest the
walking model's test (14) accepts for any rhythm (`walking_top_speed`: pace and stride both at
+k_sigma3, 2.57 m/s with Table 1): any window of it would be judged non-pedestrian, so it is
not counted (`too_fast`: short bicycle tracks). A track judged pedestrian is counted; a
non-pedestrian verdict removes one. Tracks shorter than `min_track_frames` frames (after
stitching) are dropped from every output and count first. `CountResult.counts` holds the six
numbers (tracks, pedestrians, non_pedestrians, unclassified, too_fast, walkers), the verdicts
say per track `too_fast` and `counted`, and `COUNT_RULE` says the rule in words (written to
counts.json).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .camera_np import project_3d
from .params import Config
from .pedestrian_level import PedestrianLevel, _Ped
from .pedestrians import DYNAMICS, PEDESTRIAN_HEIGHT_M


__all__ = ["COUNT_RULE", "CountOptions", "CountResult", "PedestrianLevel", "count_frames",
           "count_walkers", "stitch_pieces"]

COUNT_RULE = ("walkers = tracks - non_pedestrians - too_fast: every confirmed track is a "
              "pedestrian of the paper's method; the rhythm classifier removes the tracks it "
              "judges non-pedestrian (bicycles); an unclassified track (too short to judge) is "
              "counted unless it moves faster than the walking model (14) can accept for any "
              "rhythm (too_fast)")


@dataclass
class CountOptions:
    """Settings of the three levels (px, grey levels, frames, patch widths W / heights H)."""

    dynamics: str = "3d"  # "2d" | "3d-shape" | "3d" (ground-plane EKF of ekf.py)
    height_m: float = PEDESTRIAN_HEIGHT_M  # average pedestrian height; width: cfg.width.mean
    max_pedestrians: int = 32  # filter slots advanced together in one jitted call
    bg_alpha: float = 0.05  # background learning rate where nothing moves
    bg_threshold: float = 20.0  # |frame - background| threshold, grey levels
    open_px: int = 1
    close_px: int = 2
    min_blob_area: int = 30  # px
    search_widths: float = 0.75  # placement search radius, W (a pedestrian alone on its blobs)
    shared_search_widths: float = 0.3  # ... when it shares a blob with others
    merge_widths: float = 0.75  # shared blob narrower than this x summed W: predict only
    min_cover: float = 0.08  # a placement must cover this fraction of its patch
    new_min_widths: float = 0.6  # unexplained blob columns needed to start a pedestrian, W
    new_min_fill: float = 0.15  # ... holding at least this fraction of a patch area in pixels
    new_min_height: float = 0.5  # ... spanning at least this many H
    new_max_lift: float = 0.25  # ... reaching down to within this many H of the blob's bottom,
    new_lifted_height: float = 0.55  # ... or, lifted higher, spanning this fraction of its H
    # (clipped at the image top) at its own foot point: a farther walker merged with a nearer one
    new_in_range: bool = True  # ... standing in the config's detection range (ground y, m)
    confirm_hits: int = 3
    tentative_misses: int = 2
    coast_s: float | None = None  # default: cfg.thresholds.predict_timeout (s)
    walker_widths: float = 1.8  # blob width of one walking pedestrian (stance foot to the
    # leading arm: ~2 W measured on synthetic walkers); a patch explains that much of a blob
    duplicate_widths: float = 0.6  # foot points closer than this many W ...
    duplicate_frames: int = 3
    crowd_fraction: float = 0.5  # one blob box covering this fraction: no detection that frame
    min_track_frames: int = 10  # shorter tracks are dropped from outputs and counts
    online_verdicts: bool = True  # with an overlay: judge each N-frame window as it completes
    # (the labels drawn); without one it is skipped (saves a compilation)
    classify: bool = True  # judge the tracks at the end (False: all unclassified, no compile)
    max_dv_mps: float = 1.5  # "3d": a track whose ground velocity changes by more than this
    dv_window_s: float = 0.5  # ... within this long lost its object: it ends before the change
    # (1.5 m/s in 0.5 s is 3 m/s^2: no walker turns or brakes that hard, while a patch moving
    # between two walkers crossing at right angles at 1.4 m/s changes by 2 m/s)
    stitch: bool = True  # join fragments of one walker (count.stitch_pieces)
    stitch_max_gap_s: float = 5.0  # from a track's last measured frame to the next one's first
    # (a walker passing behind a near one stays hidden for seconds: a 0.5 m wide walker 3 m
    # away hides 2.5 m at 15 m, 1.8 s of a 1.4 m/s crossing, longer behind a group; measured
    # on the synthetic scenes, correct links with 3-5 s gaps fit within 0.3-0.7 of the gate)
    stitch_gate_w: float = 0.9  # foot point misfit allowed at zero gap: this many W across ...
    stitch_gate_h: float = 0.45  # ... and this many H up or down ...
    stitch_gate_per_s: float = 0.5  # ... growing by this fraction per second of gap
    stitch_max_dv_w: float = 2.0  # image velocity misfit allowed, W/s
    stitch_fit_s: float = 1.0  # measured foot points fitted at a track's start (and end)

    def __post_init__(self):
        if self.dynamics not in DYNAMICS:
            raise ValueError(f"dynamics must be one of {DYNAMICS}, got {self.dynamics!r}")


# ----------------------------------------------------------------------------------------------
# the pedestrians level over frames


@dataclass
class CountResult:
    """MOT rows (frame 1-based, id, box px, conf, ground x, y m, z), the tracks format, the
    verdicts, the counts and the per-frame blob boxes; see `count_frames`."""

    mot: dict[str, np.ndarray]
    tracks: dict[str, np.ndarray]
    verdicts: dict[str, np.ndarray]
    counts: dict[str, int]
    detections: dict[str, np.ndarray]
    summary: dict[str, Any] = field(default_factory=dict)


MOT_COLUMNS = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf", "x", "y", "z")
DETECTION_COLUMNS = ("frame", "bb_left", "bb_top", "bb_width", "bb_height", "area")


def count_frames(cfg: Config, frames, *, options: CountOptions | None = None,
                 n_frames: int | None = None, overlay=None, progress: bool = False
                 ) -> CountResult:
    """Track and count the pedestrians of `frames`, items (index, t s, gray uint8 or None) as
    `video.VideoSource` yields them (None: an undecodable frame, every pedestrian predicts).

    mot: one row per track and frame from its first to its last measured frame, the box of the
    patch at the filter's estimated foot point; conf 1 measured, 0.5 predicted; x, y the ground
    estimate (m; the EKF state for "3d", the inverse perspective of the estimated foot point
    otherwise) and z = 0 (on the ground plane); x = y = z = -1 (the MOT convention for "no world
    position") where the foot point has no ground point. counts (`count_walkers`): tracks,
    pedestrians, non_pedestrians, unclassified (shorter than N or unusable), too_fast and
    walkers = tracks - non_pedestrians - too_fast (`COUNT_RULE`: unclassified tracks count
    unless too fast to walk)."""
    from .cli_video import drive_frames
    from .overlay import draw_count_frame

    opt = options or CountOptions()
    if overlay is None and opt.online_verdicts:
        opt = dataclasses.replace(opt, online_verdicts=False)
    level = PedestrianLevel(cfg, opt, defer=overlay is None)  # no snapshot drawn: defer
    drive_frames(frames, level.update, overlay,
                 lambda frame, index: draw_count_frame(frame, level.snapshot(), index),
                 n_frames=n_frames, progress=progress, desc="count")
    return level.finish()



# ----------------------------------------------------------------------------------------------
# stitching fragments of one walker


@dataclass(frozen=True)
class Piece:
    """A track for stitching: first and last measured frame (index) and time (s); its foot point
    (u, v px, du, dv px/s) at its first frame and at its last, and the patch (w, h) px at its
    first; for the "3d" dynamics also its ground state (x, y m, vx, vy m/s) at its last frame
    (the EKF's: the prediction runs on the ground plane). NaN: unknown."""

    first: int
    last: int
    t_first: float
    t_last: float
    start: tuple[float, float, float, float]
    end: tuple[float, float, float, float]
    size: tuple[float, float]
    end_ground: tuple[float, float, float, float] | None = None


def _line_fit(t: np.ndarray, uv: np.ndarray, at: float) -> tuple[float, float, float, float]:
    """(u, v, du, dv) at time `at` of a least-squares line through (t, uv); NaN with < 2
    points (velocity 0 when every t is the same)."""
    if len(t) < 2:
        return (math.nan,) * 4
    tc = t - at
    if np.ptp(tc) <= 0:
        m = uv.mean(axis=0)
        return float(m[0]), float(m[1]), 0.0, 0.0
    A = np.stack([np.ones_like(tc), tc], 1)
    coef, *_ = np.linalg.lstsq(A, uv, rcond=None)
    return float(coef[0, 0]), float(coef[0, 1]), float(coef[1, 0]), float(coef[1, 1])


def piece_of(p: _Ped, shape, dynamics: str, fit_s: float) -> Piece:
    """The `Piece` of a pedestrian's rows: a line fit over its measured foot points in its first
    `fit_s` s gives its start; its end is the EKF ground state at its last (measured) row for
    "3d" (projected, with the image velocity of its ground velocity), else the same fit over
    its last `fit_s` s."""
    from .status import TrackState

    rows = np.asarray([r[1:4] + (r[8],) for r in p.rows], np.float64).reshape(-1, 4)
    t, uv = rows[:, 0], rows[:, 1:3]
    use = (rows[:, 3] == int(TrackState.OBSERVE)) & np.all(np.isfinite(uv), axis=1)
    t0, t1 = float(t[0]), float(t[-1])
    head = use & (t <= t0 + fit_s)
    start = _line_fit(t[head], uv[head], t0)
    size = tuple(float(q) for q in shape.size(*start[:2])) if np.isfinite(start[0]) else \
        (math.nan, math.nan)
    ground = None
    if dynamics == "3d":
        ground = tuple(float(q) for q in p.ground[-1])
        x, y, vx, vy = ground
        u, v = project_3d(shape.camera, x, y, 0.0)
        u2, v2 = project_3d(shape.camera, x + 0.1 * vx, y + 0.1 * vy, 0.0)
        end = (u, v, (u2 - u) / 0.1, (v2 - v) / 0.1)
    else:
        tail = use & (t >= t1 - fit_s)
        end = _line_fit(t[tail], uv[tail], t1)
    return Piece(int(p.rows[0][0]), int(p.rows[-1][0]), t0, t1, start, end, size, ground)


def _predict(A: Piece, dt: float, camera: tuple | None) -> np.ndarray:
    """A's foot point (u, v) dt s after its end: on the ground plane (EKF state) when it has
    one, else in the image."""
    if A.end_ground is not None and camera is not None:
        x, y, vx, vy = A.end_ground
        return np.asarray(project_3d(camera, x + vx * dt, y + vy * dt, 0.0))
    e = np.asarray(A.end)
    return e[:2] + e[2:] * dt


def stitch_pieces(pieces: list[Piece], *, max_gap_s: float, gate_w: float, gate_h: float,
                  gate_per_s: float, max_dv_w: float, camera: tuple | None = None) -> list[int]:
    """Successor of each piece (index into `pieces`, -1: none); see the module docstring.

    B may follow A when B.first > A.last and B.t_first - A.t_last = gap <= max_gap_s, and they
    meet halfway: A predicted gap/2 s on (`_predict`) and B's start taken gap/2 s back at its
    own velocity differ by at most (gate_w W, gate_h H) x (1 + gate_per_s x gap) (W, H: B's
    patch at its start; an ellipse), and their image velocities by at most max_dv_w W/s.
    Cheapest pairs first (position misfit / its gate + velocity misfit / max_dv_w; charging the
    gap as well, so that A -> B -> C beats A -> C, was tried and lost: 59 -> 55 counted of 58 on
    the synthetic scenes, as a short-gap wrong piece then beats the right one); each piece has at
    most one predecessor and one successor."""
    cand = []
    for a, A in enumerate(pieces):
        ea = np.asarray(A.end, np.float64)
        if not np.all(np.isfinite(ea)):
            continue
        for b, B in enumerate(pieces):
            sb, (w, h) = np.asarray(B.start, np.float64), B.size
            gap = B.t_first - A.t_last
            if (B.first <= A.last or gap > max_gap_s or not np.all(np.isfinite(sb))
                    or not (w > 0 and h > 0)):
                continue
            mid_a = _predict(A, 0.5 * gap, camera)
            mid_b = sb[:2] - sb[2:] * 0.5 * gap
            grow = 1.0 + gate_per_s * gap
            d = float(np.hypot((mid_a[0] - mid_b[0]) / (gate_w * w),
                               (mid_a[1] - mid_b[1]) / (gate_h * h))) / grow
            dv = float(np.hypot(*(ea[2:] - sb[2:]))) / (max_dv_w * w)
            if d <= 1.0 and dv <= 1.0:
                cand.append((d + dv, a, b))
    succ, pred = [-1] * len(pieces), [-1] * len(pieces)
    for _, a, b in sorted(cand):
        if succ[a] < 0 and pred[b] < 0:
            succ[a], pred[b] = b, a
    return succ


def stitch_level(level: PedestrianLevel, peds: list[_Ped]) -> list[_Ped]:
    """Join the chains `stitch_pieces` finds among the ended tracks (`peds`, in id order) into
    one track each (the first piece's id); the rest unchanged."""
    opt = level.opt
    if not opt.stitch or len(peds) < 2:
        return peds
    pieces = [piece_of(p, level.shape, opt.dynamics, opt.stitch_fit_s) for p in peds]
    succ = stitch_pieces(pieces, max_gap_s=opt.stitch_max_gap_s, gate_w=opt.stitch_gate_w,
                         gate_h=opt.stitch_gate_h, gate_per_s=opt.stitch_gate_per_s,
                         max_dv_w=opt.stitch_max_dv_w, camera=level.shape.camera)
    has_pred = {b for b in succ if b >= 0}
    out = []
    for a, p in enumerate(peds):
        if a in has_pred:
            continue
        b = succ[a]
        while b >= 0:
            q = peds[b]
            p.rows, p.boxes, p.ground = p.rows + q.rows, p.boxes + q.boxes, p.ground + q.ground
            p.hits += q.hits
            level.stitched += 1
            b = succ[b]
        out.append(p)
    return out


def walking_top_speed(cfg: Config) -> float:
    """The fastest ground speed (m/s) the walking model's test (14) accepts for any rhythm:
    speed = pace x stride with both within k_sigma3 of the model, so at most
    (pace_mean + k_sigma3 pace_std) x (stride_mean + k_sigma3 stride_std) (2.57 m/s with the
    paper's Table 1). A window moving faster is judged non-pedestrian whatever its spectrum."""
    w, k = cfg.walking, float(cfg.thresholds.k_sigma3)
    return (float(w.pace_mean) + k * float(w.pace_std)) * \
        (float(w.stride_mean) + k * float(w.stride_std))


def track_speed(p: _Ped) -> float:
    """Least-squares ground speed (m/s) over a track's measured rows (its ground x, y: the EKF
    state for "3d"); NaN with fewer than 2 or a span under 0.5 s."""
    from .status import TrackState

    r = np.asarray([(q[1], q[6], q[7]) for q in p.rows if q[8] == int(TrackState.OBSERVE)],
                   np.float64).reshape(-1, 3)
    r = r[np.all(np.isfinite(r), axis=1)]
    if len(r) < 2 or np.ptp(r[:, 0]) < 0.5:
        return math.nan
    tc = r[:, 0] - r[:, 0].mean()
    v = tc @ (r[:, 1:] - r[:, 1:].mean(axis=0)) / float(tc @ tc)
    return float(np.hypot(*v))


def count_walkers(verdicts, too_fast=None) -> dict[str, int]:
    """The counts of a verdict list (labels as `status.Verdict`; `too_fast`: per track, faster
    than `walking_top_speed`, default none): tracks, pedestrians, non_pedestrians, unclassified,
    too_fast (unclassified and too fast) and walkers = tracks - non_pedestrians - too_fast
    (`COUNT_RULE`)."""
    v = [str(x) for x in verdicts]
    fast = [False] * len(v) if too_fast is None else [bool(f) for f in too_fast]
    n, non = len(v), v.count("non-pedestrian")
    tf = sum(f and w == "unclassified" for w, f in zip(v, fast))
    return {"tracks": n, "pedestrians": v.count("pedestrian"), "non_pedestrians": non,
            "unclassified": v.count("unclassified"), "too_fast": tf, "walkers": n - non - tf}


def counted(verdicts: dict) -> np.ndarray:
    """Per track, whether `COUNT_RULE` counts it as a walker: not judged non-pedestrian, and
    not unclassified and too fast (verdicts["too_fast"], when present)."""
    v = np.asarray([str(x) for x in verdicts["verdict"]], dtype=object)
    fast = np.asarray(verdicts.get("too_fast", np.zeros(len(v), bool)), bool)
    return (v != "non-pedestrian") & ~((v == "unclassified") & fast)


def walker_ids(verdicts: dict) -> list[int]:
    """Track ids counted as walkers (`counted`)."""
    return [int(i) for i, c in zip(verdicts["track_id"], counted(verdicts)) if c]


def _result(level: PedestrianLevel, peds: list[_Ped]) -> CountResult:
    """Outputs of the kept tracks, ids renumbered 1.. in order of appearance."""
    from .batch import classify_tracks
    from .io import Tracks, to_batch
    from .status import TrackState
    from .tracker import TRACK_COLUMNS

    cfg = level.cfg
    for k, p in enumerate(peds, 1):
        p.track_id = k
    rows = [(p.track_id, *r) for p in peds for r in p.rows]
    tracks = {c: np.asarray([r[i] for r in rows], np.int64 if i < 2 else np.float64)
              for i, c in enumerate(TRACK_COLUMNS[:-1])}
    tracks["state"] = np.asarray([TrackState(r[-1]).name.lower() for r in rows], dtype=object)
    n = cfg.thresholds.n
    if peds and level.opt.classify:
        tr = Tracks(path="<count>", track_id=tracks["track_id"].astype(str).astype(object),
                    frame=tracks["frame"], t=tracks["t"], u=tracks["u"], v=tracks["v"],
                    width_px=tracks["width_px"], intensity=tracks["intensity"],
                    line=np.arange(len(tracks["frame"])), fps=cfg.camera.fps)
        gap = max(1, round(float(cfg.thresholds.predict_timeout) * cfg.camera.fps))
        verdicts = classify_tracks(cfg, to_batch(tr, max_gap_frames=gap, min_len=n),
                                   progress=False)
        verdicts = {k: verdicts[k] for k in ("track_id", "verdict", "reason", "pace_hz",
                                              "stride_m", "ratio", "speed_mps", "n_samples")}
        verdicts["track_id"] = verdicts["track_id"].astype(np.int64)
    else:
        B, nan = len(peds), np.full(len(peds), np.nan)
        verdicts = {"track_id": np.arange(1, B + 1, dtype=np.int64),
                    "verdict": np.full(B, "unclassified", dtype=object),
                    "reason": np.full(B, "not-judged", dtype=object), "pace_hz": nan,
                    "stride_m": nan, "ratio": nan, "speed_mps": nan,
                    "n_samples": np.asarray([len(p.rows) for p in peds], np.int64)}
    rows = [(b[0] + 1, p.track_id, *b[1:6], *(b[6:8] if b[8] else (-1.0, -1.0)),
             0.0 if b[8] else -1.0) for p in peds for b in p.boxes]
    mot = {c: np.asarray([r[i] for r in rows], np.int64 if i < 2 else np.float64)
           for i, c in enumerate(MOT_COLUMNS)}
    det = {c: np.asarray([r[i] for r in level.detections], np.int64)
           for i, c in enumerate(("frame", "x0", "y0", "x1", "y1", "area"))}
    detections = {"frame": det["frame"] + 1, "bb_left": det["x0"], "bb_top": det["y0"],
                  "bb_width": det["x1"] - det["x0"], "bb_height": det["y1"] - det["y0"],
                  "area": det["area"]}
    top = walking_top_speed(cfg)
    verdicts["too_fast"] = np.asarray([track_speed(p) > top for p in peds], bool)
    verdicts["counted"] = counted(verdicts)
    counts = count_walkers(verdicts["verdict"], verdicts["too_fast"])
    summary = {"n_frames": level.n_frames, "dynamics": level.opt.dynamics,
               "count_rule": COUNT_RULE, "stitched": level.stitched,
               "crowd_frames": len(level.crowd_frames),
               "missing_frames": len(level.missing_frames), "notes": []}
    if level.crowd_frames:
        summary["notes"].append(
            f"{len(level.crowd_frames)} frame(s) had one blob covering >= "
            f"{level.opt.crowd_fraction:.0%} of the image (dense crowd or camera jump): no "
            f"detection there, pedestrians predicted (first: frame {level.crowd_frames[0]})")
    if level.full_frames:
        summary["notes"].append(f"all {level.filter.slots} pedestrian slots were in use in "
                                f"{len(set(level.full_frames))} frame(s); raise max_pedestrians")
    return CountResult(mot, tracks, verdicts, counts, detections, summary)
