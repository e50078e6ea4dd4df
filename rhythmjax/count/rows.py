"""Named per-frame records of the pedestrians level (`pedestrian_level.Pedestrian` keeps one of
each per tracked frame besides its `track.rows.TrackRow`), read by `stitch` and `counting`."""

from __future__ import annotations

import math
from typing import NamedTuple


class BoxRow(NamedTuple):
    """A pedestrian's patch in one frame, a MOT row to be: frame index (0-based), box (left,
    top, w, h) px at the filter's estimated foot point, conf (1 measured, 0.5 predicted),
    ground point (x, y) m and whether it has one (`ok`)."""

    frame: int
    left: float
    top: float
    w: float
    h: float
    conf: float
    x: float
    y: float
    ok: bool


class GroundRow(NamedTuple):
    """A pedestrian's filter state in one frame: ground (x, y) m (the EKF state for "3d", the
    inverse perspective of the estimated foot point otherwise), ground velocity (vx, vy) m/s
    (the EKF state for "3d"; NaN for "2d" and "3d-shape", whose filters run in the image) and
    image velocity (du, dv) px/s of the estimated foot point (the state's own for "2d" and
    "3d-shape"; for "3d" the ground velocity through the Jacobian of (3):
    `slot_filter.image_velocity`). The tracking paper's per-pedestrian velocity output; with
    the ground velocity's posterior covariance (var vx, cov vx vy, var vy) (m/s)^2 ("3d"; NaN
    otherwise or where not given)."""

    x: float
    y: float
    vx: float
    vy: float
    du: float
    dv: float
    var_vx: float = math.nan
    cov_vxy: float = math.nan
    var_vy: float = math.nan


class BlobRow(NamedTuple):
    """A blob detected in one frame: frame index (0-based), box (x0, y0, x1, y1) px half-open,
    area px."""

    frame: int
    x0: int
    y0: int
    x1: int
    y1: int
    area: int
