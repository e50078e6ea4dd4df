"""A sanity check of the camera against the video, before a long run (issue 15, item 3).

A wrong camera does not fail: the tracker runs for minutes and judges every walker a
non-pedestrian, or picks up nobody. `check_camera` looks at the first `MAX_FRAMES` frames
(seconds of work) and says, in one line each ending with the command that fixes it, when the
camera of the config cannot be right for this video:

1. The camera sees no ground (every corner of the image above the horizon: the horizon is below
   the image, or the camera looks at the sky). Judged from the config alone; no frame is read.
2. Most motion (more than `OUTSIDE_SHARE` of the moving regions) has its foot point outside the
   detection range (`thresholds.range_min/range_max`, ground distance y ahead of the camera's
   foot, m) or above the horizon: the tracker would never pick it up.
3. The moving things would be less than `HEIGHT_LIMITS_M[0]` or more than `HEIGHT_LIMITS_M[1]`
   tall (the median over the moving regions of the real height their pixel height implies at
   the ground distance of their foot point).

Moving regions: the background is the per-pixel median of up to `MEDIAN_FRAMES` frames spread
over those read (a walker crossing the view covers a pixel in few of them, so the median is the
empty scene; anything that stands still throughout is background and is not judged); each
frame's foreground is |frame - background| > `DIFF_THRESHOLD` grey levels, opened and closed
(`blobs.BackgroundModel.foreground`, the counting front end's images level), and its
8-connected blobs of at least `MIN_AREA_PX` px (`blobs.find_blobs`) are grouped into upright
objects (`stack_boxes`: a walker whose shirt matches the background splits into head and legs).
A group is a moving region when at least `MIN_CHANGED` of its pixels also differ from the frame
`FRAME_STEP` frames away (a "ghost", where something in the median background is not there in
this frame, does not change). Each region in each frame counts once. A region's foot point is
its box's bottom centre, its height the box height (px). A region touching the bottom row has no
foot point in view and is left out; one touching the top row has no head in view and is left
out of the heights. A frame whose foreground covers more than `MAX_FOREGROUND` of the image (a
lighting change, a camera jump) and a region whose box covers more than that share are left out.

Limits: a median of `MAX_FRAMES` frames holds whatever moves slowly in the image (a walker far
away walking towards the camera); such walkers leave fragments and the implied heights fall
(the demo's synthetic scenes with the right camera: medians 0.59-1.72 m over seeds 1-8). The
check is for gross errors; it does not replace the camera screen (`view.format_report`).

The thresholds, and why (none is tuned on a data set):
- `HEIGHT_LIMITS_M` = (0.5, 5.0) m: a factor of about 3 either side of a 1.7 m walker. Below,
  nothing in a street scene seen whole is that small in a median (a fragment of a walker, its
  legs, is ~0.9 m; a dog ~0.5 m); above, nothing is that tall (a lorry or a bus is 3-4.5 m; two
  walkers merged one behind the other are at most ~2.5 m). A camera whose scale (h, focal
  length) is off by a factor 3 or more is caught; a smaller error is left to the camera screen.
- `OUTSIDE_SHARE` = 0.5: "most" of the motion, so that a range that covers only part of the
  scene on purpose (a crossing, a doorway) does not warn.
- `MIN_REGIONS` = 10 region-frames before anything is judged from motion: fewer say nothing
  reliable (a leaf, a single noise speck that survived the opening).
- `MIN_AREA_PX` = 40 px: about half the silhouette of the smallest walker the derived range keeps
  (`view.MIN_PERSON_PX` = 20 px tall, ~6 px wide, two thirds filled).

Cost: one pass over at most `MAX_FRAMES` frames, the median of `MEDIAN_FRAMES` of them, and one
threshold, morphology and contour pass per frame. Measured on a shared 2-core machine: 80 decoded
frames of 720 x 576 in 0.38-0.42 s (about 5 ms a frame, a third of it the median); PETS09's first
80 frames (480 x 360) in 0.36-0.42 s, decoding (0.12 s) included. tests/test_camera_check.py's
`test_cost_is_seconds` prints it.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..model.camera import MIN_DEPTH_M
from ..model.camera_np import camera_tuple, ground_of_pixels, project_3d
from ..model.params import Camera, Config, host_float
from ..model.view import PERSON_HEIGHT_M, horizon_row
from .blobs import BackgroundModel, find_blobs, foreground_fraction
from .detect import frame_difference
from .stabilise import align_previous
from .video import to_gray_u8


MAX_FRAMES = 80  # frames read at most: 3.2 s at 25 fps, 11 s at 7 fps
MEDIAN_FRAMES = 25  # frames in the median background, spread over those read
DIFF_THRESHOLD = 20.0  # grey levels: foreground where |frame - background| exceeds this
MIN_AREA_PX = 40  # px: smallest moving region judged (module doc)
MIN_CHANGED = 0.05  # share of a region's pixels that must change over FRAME_STEP frames
FRAME_STEP = 2  # frames between the two of the change test
MAX_FOREGROUND = 0.25  # a frame (or a region's box) above this share of the image is left out
MIN_REGIONS = 10  # region-frames needed before motion is judged
OUTSIDE_SHARE = 0.5  # warn when more than this share of the motion is outside the range
HEIGHT_LIMITS_M = (0.5, 5.0)  # m: the median implied height outside these warns (module doc)
FIX = ("describe the camera with `rhythmjax camera --video {video} ...` (see README, Your own "
       "camera)")  # ends every warning; {video} is `check_camera`'s `video`


@dataclass(frozen=True)
class MovingRegions:
    """The moving regions of the frames read, one entry per region per frame: foot point
    (u, v) px (box bottom centre), box height px, whether the box touches the top or the bottom
    row; `n_frames` frames read (decoded), `n_skipped` of them left out (foreground above
    `MAX_FOREGROUND`), `shape` (H, W) px of the frames (None when none decoded)."""

    u: np.ndarray
    v: np.ndarray
    height_px: np.ndarray
    at_top: np.ndarray
    at_bottom: np.ndarray
    n_frames: int
    n_skipped: int
    shape: tuple[int, int] | None


@dataclass(frozen=True)
class CameraCheck:
    """The outcome of `check_camera`. `warnings`: one line each, ending with the command that
    fixes it (empty when the camera looks right); `notes`: what could not be judged, one line
    each. The figures (NaN when not measured): `share_outside` and `share_above_horizon` of the
    moving regions with a foot point in view; `median_height_m`, the median implied height;
    `foot_range_m`, the 10th and 90th percentiles of the foot points' ground distance y (m);
    `n_frames` read, `n_regions` judged, `seconds` spent (reading included)."""

    warnings: tuple[str, ...]
    notes: tuple[str, ...]
    share_outside: float = math.nan
    share_above_horizon: float = math.nan
    median_height_m: float = math.nan
    foot_range_m: tuple[float, float] = (math.nan, math.nan)
    n_frames: int = 0
    n_regions: int = 0
    seconds: float = 0.0

    @property
    def lines(self) -> list[str]:
        """The warnings, then the notes."""
        return [*self.warnings, *self.notes]


def sees_ground(camera: Camera, width: int, height: int) -> bool:
    """True when some of a width x height px image sees the ground: the ground's part of the
    image is a half-plane (below the horizon line, tilted by the roll), so a rectangle meets it
    exactly when one of its corners (the outer pixel edges) does."""
    u = np.array([0.0, width, 0.0, width])
    v = np.array([0.0, 0.0, height, height])
    return bool(ground_of_pixels(camera, u, v)[2].any())


def implied_height_m(camera: Camera, u, v, height_px, *, iterations: int = 60) -> np.ndarray:
    """The real height (m) of an upright object whose foot point is (u, v) px and whose image is
    `height_px` px tall (foot row minus the row of its top, as `camera_np.upright_size`), by
    bisection on the height z in [0, z_max]: the top's image moves monotonically along a line,
    up from the foot, as z grows, and leaves the image upwards as the top nears the camera's
    image plane. z_max is where the top's depth (`camera_np.depth_3d`) is 2 `MIN_DEPTH_M`,
    h + (f + y cos theta - 2 MIN_DEPTH_M) / sin theta for a camera tilted down, and at most
    1 km. NaN where the foot point is above the horizon; inf where z_max gives fewer px. The
    bracket shrinks by 2^-iterations (60: below 1e-12 m)."""
    c = camera_tuple(camera)
    u, v, hp = (np.asarray(q, np.float64) for q in np.broadcast_arrays(u, v, height_px))
    x, y, ok = ground_of_pixels(camera, u, v)
    s, co = math.sin(c.theta), math.cos(c.theta)
    z_max = np.full(u.shape, 1000.0)
    if s > 0:
        z_max = np.minimum(z_max, c.h + (c.f + y * co - 2 * MIN_DEPTH_M) / s)

    def px_at(z):
        return v - project_3d(camera, x, y, z)[1]

    lo, hi = np.zeros(u.shape), z_max.copy()
    reach = px_at(hi) >= hp
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        up = px_at(mid) < hp
        lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
    out = 0.5 * (lo + hi)
    out = np.where(reach, out, np.inf)
    return np.where(ok, out, np.nan)


def stack_boxes(boxes, *, max_boxes: int = 200) -> np.ndarray:
    """Group the boxes (x0, y0, x1, y1 px, half-open) of one frame that are parts of one upright
    object: two boxes are joined when their column extents overlap by at least half the
    narrower one's width and the rows between them number at most half the taller one's height
    (a walker whose shirt matches the background splits into head and legs; the sky behind the
    head and the ground behind the legs split it at the horizon); transitively. Returns each
    box's group, 0 .. n_groups - 1 in the order of first appearance; above `max_boxes` boxes
    (noise) each box is its own group."""
    n = len(boxes)
    if n < 2 or n > max_boxes:
        return np.arange(n)
    a = np.asarray(boxes, np.int64).reshape(n, 4)
    x0, y0, x1, y1 = a.T
    w, h = x1 - x0, y1 - y0
    overlap = np.minimum(x1[:, None], x1[None, :]) - np.maximum(x0[:, None], x0[None, :])
    gap = np.maximum(y0[:, None], y0[None, :]) - np.minimum(y1[:, None], y1[None, :])
    join = ((overlap >= 0.5 * np.minimum(w[:, None], w[None, :]))
            & (gap <= 0.5 * np.maximum(h[:, None], h[None, :])))
    group = np.arange(n)
    for i, j in zip(*np.nonzero(np.triu(join, 1))):  # union of two groups: relabel one
        gi, gj = group[i], group[j]
        if gi != gj:
            group[group == gj] = gi
    return np.unique(group, return_inverse=True)[1]


def moving_regions(frames: Iterable, *, max_frames: int = MAX_FRAMES,
                   threshold: float = DIFF_THRESHOLD, min_area: int = MIN_AREA_PX
                   ) -> MovingRegions:
    """The moving regions (module doc) of the first `max_frames` items of `frames`, an iterable
    of (index, t s, frame) with the frame grey or BGR(A), uint8 or uint16, or None (skipped),
    as `video.open_video` yields. Reads no further than `max_frames` items."""
    grays: list[np.ndarray] = []
    it = iter(frames)
    try:
        for item in itertools.islice(it, max_frames):
            frame = item[2]
            if frame is None:
                continue
            g = to_gray_u8(np.asarray(frame))
            if grays and g.shape != grays[0].shape:
                continue
            if grays:  # camera shake: onto the first frame (a fixed camera: g unchanged)
                g = align_previous(g, grays[0])[0]
            grays.append(g)
    finally:
        close = getattr(it, "close", None)
        if close is not None:
            close()
    empty = np.zeros(0)
    if len(grays) < 3:
        return MovingRegions(empty, empty, empty, empty.astype(bool), empty.astype(bool),
                             len(grays), 0, grays[0].shape if grays else None)
    pick = np.unique(np.linspace(0, len(grays) - 1, min(MEDIAN_FRAMES, len(grays))).round()
                     .astype(int))
    stack = np.stack([grays[i] for i in pick])
    bg = np.partition(stack, len(pick) // 2, axis=0)[len(pick) // 2]  # the (upper) median
    model = BackgroundModel(bg, alpha=0.0, slow_alpha=0.0, threshold=threshold)
    rows: list[np.ndarray] = []
    skipped = 0
    step = min(FRAME_STEP, len(grays) - 1)
    for k, gray in enumerate(grays):
        mask = model.foreground(gray)
        if foreground_fraction(mask) > MAX_FOREGROUND:
            skipped += 1
            continue
        j = min(k - step if k >= step else k + step, len(grays) - 1)
        other = grays[j if j != k else k - 1]
        rows.append(frame_regions(mask, frame_difference(other, gray) > threshold, min_area))
    a = np.concatenate([np.zeros((0, 4), np.int64), *rows])
    H = bg.shape[0]
    x0, y0, x1, y1 = a.T.astype(np.float64)
    return MovingRegions(0.5 * (x0 + x1 - 1), y1 - 1, y1 - y0, y0 == 0, y1 >= H, len(grays),
                         skipped, bg.shape)


def frame_regions(mask: np.ndarray, changed: np.ndarray, min_area: int) -> np.ndarray:
    """(n, 4) int64 boxes x0, y0, x1, y1 px (half-open) of one frame's moving regions: the
    blobs of the foreground `mask` with at least `min_area` px (`blobs.find_blobs`), grouped by
    `stack_boxes`, each group kept when at least `MIN_CHANGED` of its pixels are `changed`
    (bool, |frame - a frame FRAME_STEP away| above the threshold: a ghost, where the median
    background holds an object that is not there, does not change) and its box covers at most
    `MAX_FOREGROUND` of the image."""
    blobs, labels = find_blobs(mask, min_area=min_area)
    if not blobs:
        return np.zeros((0, 4), np.int64)
    n_changed = np.bincount(labels[changed], minlength=len(blobs) + 1)[1:]
    boxes = np.array([b.box for b in blobs], np.int64)
    group = stack_boxes(boxes)
    area = np.bincount(group, [b.area for b in blobs])
    moved = np.bincount(group, n_changed)
    out = np.array([[boxes[m, 0].min(), boxes[m, 1].min(), boxes[m, 2].max(), boxes[m, 3].max()]
                    for m in (group == gi for gi in range(len(area)))], np.int64)
    size = (out[:, 2] - out[:, 0]) * (out[:, 3] - out[:, 1])
    return out[(moved >= MIN_CHANGED * area) & (size <= MAX_FOREGROUND * mask.size)]


def judge_regions(cfg: Config, regions: MovingRegions, *, video: str = "VIDEO",
                  seconds: float = 0.0) -> CameraCheck:
    """Judge `regions` (`moving_regions`) against the camera and the detection range of `cfg`
    (module doc, checks 2 and 3); see `CameraCheck`."""
    fix = FIX.format(video=video)
    notes: list[str] = []
    r = regions
    if r.shape is not None and r.shape != (cfg.camera.image_height, cfg.camera.image_width):
        notes.append(f"camera check: the frames are {r.shape[1]} x {r.shape[0]} px, the "
                     f"config's camera {cfg.camera.image_width} x {cfg.camera.image_height}; "
                     "judged in the frames' pixels")
    if r.n_skipped:
        notes.append(f"camera check: {r.n_skipped} of {r.n_frames} frames left out (more than "
                     f"{MAX_FOREGROUND:.0%} of the image changed: lighting or a camera move)")
    base = dict(n_frames=r.n_frames, seconds=seconds)
    feet = ~r.at_bottom
    n = int(feet.sum())
    if n < MIN_REGIONS:
        what = "no moving regions" if n == 0 else f"only {n} moving regions"
        notes.append(f"camera check: {what} in the first {r.n_frames} frames; nothing to judge "
                     "the camera by")
        return CameraCheck((), tuple(notes), n_regions=n, **base)
    cam = cfg.camera
    _, y, ok = ground_of_pixels(cam, r.u[feet], r.v[feet])
    lo_m, hi_m = host_float(cfg.thresholds.range_min), host_float(cfg.thresholds.range_max)
    outside = ~ok | (y < lo_m) | (y > hi_m)
    share_out, share_above = float(outside.mean()), float((~ok).mean())
    foot = (tuple(float(q) for q in np.percentile(y[ok], [10, 90])) if ok.any()
            else (math.nan, math.nan))
    warnings: list[str] = []
    if share_out > OUTSIDE_SHARE:
        where = (f"feet at {foot[0]:.1f}-{foot[1]:.1f} m by this camera, 10th-90th percentile"
                 if ok.any() else "none below it")
        warnings.append(
            f"camera check: {share_out:.0%} of {n} moving regions in the first {r.n_frames} "
            f"frames have their feet outside the detection range {lo_m:.1f}-{hi_m:.1f} m "
            f"({share_above:.0%} above the horizon, row {horizon_row(cam):.0f}; {where}), so the "
            "tracker would not pick them up: the camera or thresholds.range_min_m/range_max_m "
            f"is wrong; {fix}")
    tall = feet & ~r.at_top
    z = implied_height_m(cam, r.u[tall], r.v[tall], r.height_px[tall])
    z = z[~np.isnan(z)]  # NaN: feet above the horizon
    med = float(np.median(z)) if len(z) >= MIN_REGIONS else math.nan
    if len(z) < MIN_REGIONS:
        notes.append(f"camera check: only {len(z)} moving regions wholly in view with their "
                     "feet on the ground; their height is not judged")
    elif not HEIGHT_LIMITS_M[0] <= med <= HEIGHT_LIMITS_M[1]:
        warnings.append(
            f"camera check: the moving things would be {med:.2f} m tall by this camera (median "
            f"of {len(z)} regions; a person is about {PERSON_HEIGHT_M:g} m, expected "
            f"{HEIGHT_LIMITS_M[0]:g}-{HEIGHT_LIMITS_M[1]:g} m): its height h, tilt or focal "
            f"length is wrong; {fix}")
    return CameraCheck(tuple(warnings), tuple(notes), share_outside=share_out,
                       share_above_horizon=share_above, median_height_m=med, foot_range_m=foot,
                       n_regions=n, **base)


def check_camera(cfg: Config, frames: Iterable, *, max_frames: int = MAX_FRAMES,
                 video: str = "VIDEO") -> CameraCheck:
    """Check the camera of `cfg` against the first `max_frames` items of `frames` ((index, t s,
    frame or None), as `video.open_video` yields; reads no further). `video` is the path named in
    the fix command. When the camera sees no ground (module doc, check 1) the frames are not
    read. Returns a `CameraCheck`: `warnings` empty when nothing is wrong, `notes` when there
    was nothing to judge."""
    t0 = time.perf_counter()
    cam = cfg.camera
    if not sees_ground(cam, cam.image_width, cam.image_height):
        hz = horizon_row(cam)
        where = (f"the horizon is at row {hz:.0f}, below the {cam.image_height}-row image"
                 if hz >= cam.image_height else "no corner of the image is below the horizon")
        c = camera_tuple(cam)
        warning = (f"camera check: the camera sees no ground ({where}; tilt "
                   f"{math.degrees(c.theta):.1f} deg below the horizontal, roll "
                   f"{math.degrees(c.roll):.1f} deg), so no foot point can be placed: "
                   + FIX.format(video=video))
        return CameraCheck((warning,), (), seconds=time.perf_counter() - t0)
    regions = moving_regions(frames, max_frames=max_frames)
    return judge_regions(cfg, regions, video=video, seconds=time.perf_counter() - t0)
