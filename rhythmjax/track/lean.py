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
"""

from __future__ import annotations

import math

from ..model.camera_np import ground_of_pixels, project_3d


__all__ = ["lean_px", "window_b_foot"]


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


def window_b_foot(z, est_uv, measured: bool, side_du: float, body, camera,
                  height_m: float) -> tuple[float, float]:
    """(u, v) px where the tracker puts window B on a row: the measured foot point z (the
    paper's, Sec. 4.1) when `measured` and not `body.sample_estimate`, else the filtered one
    `est_uv`. A measured one is moved across by `side_du` px (rule 16: a detection cut by the
    image's side, window B on its visible feet) and, with `body.lean_column`, back by
    `lean_px(camera, *z, height_m)` (rule 41). `body` a `track.options.BodyOptions`."""
    if not measured or body.sample_estimate:
        return float(est_uv[0]), float(est_uv[1])
    u, v = float(z[0]), float(z[1])
    lean = lean_px(camera, u, v, height_m) if body.lean_column else 0.0
    return u + side_du - lean, v
