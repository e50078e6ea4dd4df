"""Rule 41 (`body.lean_column`): window B's column corrected for the lean of an upright body.

A camera tilted down by theta sees an upright body off the image's centre leaning outwards: by
(3), a point z m above the ground point (x, y) has the depth f + y cos(theta) + (h - z)
sin(theta), smaller than the ground point's, so its column uc + a f x / depth lies further from
uc. The motion image's horizontal extent (`vision.detect`) spans the body from its feet to its
head, so its centre u_p, the paper's foot column, lies about the lean at half the body's height
outwards of the column of the ground point under the body, where the legs that window B reads
are. `lean_px` is that lean; the tracker puts window B (and its candidates) at u_p less it on a
measured frame (`window_b_foot`, which gives the tracker's foot point of window B on every row).
The EKF's measurement stays u_p (the paper's).

Rule 48 (`body.mass_column`): on a measured frame window B's column is instead the mean column
of the motion pixels (D > `motion.diff_threshold`) in the box u_p +- W px across and one walker
height high above the foot row (`motion_column`): the motion's centre of mass across, where
u_p is the centre of its extent, which one stray column moves (docs/window_b.md, "Window B's
column and the pace"). With `body.mass_crossing` > 0 (rule 48b) only where the track's ground
velocity crosses the camera's line of sight at an angle whose sine is at least that
(`crossing_sine`): the walkers rule 48 lost walked within 25 degrees of the line of sight.
Both are off (docs/rules.md, rules 48 and 48b).
"""

from __future__ import annotations

import math

import numpy as np

from ..model.camera_np import ground_of_pixels, project_3d


__all__ = ["crossing_sine", "lean_px", "motion_column", "window_b_foot"]


def lean_px(camera, u: float, v: float, height_m: float) -> float:
    """u(x, y, height_m / 2) - u(x, y, 0) px through (3) (`camera_np.project_3d`, with roll),
    where (x, y) m is the ground point of the foot point (u, v) px and `height_m` the body's
    height (m); 0 where (u, v) has no ground point (above the horizon, behind the camera) or is
    not finite. `camera` a `Camera` or `camera_np.camera_tuple`."""
    if not (math.isfinite(u) and math.isfinite(v)):
        return 0.0
    x, y, ok = ground_of_pixels(camera, u, v)
    if not ok:
        return 0.0
    lean = project_3d(camera, x, y, 0.5 * height_m)[0] - project_3d(camera, x, y, 0.0)[0]
    return float(lean) if math.isfinite(lean) else 0.0


def motion_column(D, u: float, v: float, W: float, height_px: float, threshold: float) -> float:
    """Rule 48: the mean column (px) of the pixels of D (grey levels) above `threshold` in the box
    of columns u - W .. u + W and rows v - height_px .. v (px, clipped at the image); NaN where
    the box holds none, D is None or an input is not finite."""
    if D is None or not all(math.isfinite(x) for x in (u, v, W, height_px)):
        return math.nan
    h, w = D.shape[:2]
    x0, x1 = max(0, math.floor(u - W)), min(w, math.floor(u + W) + 1)
    y0, y1 = max(0, math.floor(v - height_px)), min(h, math.floor(v) + 1)
    if x1 <= x0 or y1 <= y0:
        return math.nan
    counts = np.count_nonzero(D[y0:y1, x0:x1] > threshold, axis=0)
    total = int(counts.sum())
    return x0 + float(counts @ np.arange(x1 - x0)) / total if total else math.nan


def crossing_sine(camera, x: float, vx: float, y: float, vy: float) -> float:
    """Rule 48b: |sin| of the angle between the ground velocity (vx, vy) m/s at the ground point
    (x, y) m and the ground line that one image column sees there: |grad u . v| / (|grad u| |v|),
    grad u = (du/dx, du/dy) of (3) (`camera_np.project_3d`, with roll) by central differences
    over 1 cm. 1 across the view, 0 along the line of sight; NaN where undefined (v = 0)."""
    e = 0.01
    du_dx = (project_3d(camera, x + e, y, 0.0)[0] - project_3d(camera, x - e, y, 0.0)[0]) / (2 * e)
    du_dy = (project_3d(camera, x, y + e, 0.0)[0] - project_3d(camera, x, y - e, 0.0)[0]) / (2 * e)
    norm = math.hypot(float(du_dx), float(du_dy)) * math.hypot(vx, vy)
    return abs(float(du_dx) * vx + float(du_dy) * vy) / norm if norm > 0 else math.nan


def window_b_foot(z, est_uv, measured: bool, side_du: float, opt, camera, height_m: float,
                  D=None, body_px: tuple[float, float] = (math.nan, math.nan), state=None
                  ) -> tuple[float, float]:
    """(u, v) px where the tracker puts window B on a row: the measured foot point z (the
    paper's, Sec. 4.1) when `measured` and not `body.sample_estimate`, else the filtered one
    `est_uv`. A measured one is moved across by `side_du` px (rule 16: a detection cut by the
    image's side, window B on its visible feet) and, with `body.lean_column`, back by
    `lean_px(camera, *z, height_m)` (rule 41); with `body.mass_column` its column is then
    `motion_column` of the difference D around it (where it has one), body_px = (W, walker
    height) px (rule 48), with `body.mass_crossing` > 0 only where `crossing_sine` of the EKF's
    state (x, vx, y, vy) (m, m/s) reaches it (rule 48b). `opt` a `track.options.TrackerOptions`."""
    body = opt.body
    if not measured or body.sample_estimate:
        return float(est_uv[0]), float(est_uv[1])
    u, v = float(z[0]), float(z[1])
    lean = lean_px(camera, u, v, height_m) if body.lean_column else 0.0
    u = u + side_du - lean
    if body.mass_column and (body.mass_crossing <= 0 or (
            state is not None and crossing_sine(camera, *map(float, state[:4])) >=
            body.mass_crossing)):
        mass = motion_column(D, u, v, *body_px, opt.motion.diff_threshold)
        u = mass if math.isfinite(mass) else u
    return u, v
