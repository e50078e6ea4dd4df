"""A new walker's foot point from its head where the mask lost its legs (`new.head_feet`).

Trousers close to the ground's grey leave only the head and torso in the foreground mask: the
blob's bottom is the hips, not the feet. With a camera near hip height (1 m: the dev clips and
the library's default camera) the hips project onto the horizon, so the patch standing on the
blob's bottom has no ground point or a tiny one, no pedestrian starts there, and a track that
holds one reads its foot point tens of metres away. A blob part taller than `tall` patch
heights of a walker standing on its bottom (or with no ground point under its bottom) cannot be
a walker standing there; its top row is then taken as the head, and the foot row is where a
walker of the height prior (`width.height`, m) has its head on that row (`head_foot_row`: the
row v with v - h(v) = v_top, h the patch height of `patches.ShapeModel`).

That row is well determined only where the head's row moves with the distance: its slope
d(v - h(v))/dv tends to (camera height - walker height) / camera height far away, -0.7 for a
1 m camera (-0.76 at 10 m) and 0.76 for PETS09's 7 m one, and 0 for a camera at head height.
Below `MIN_SLOPE` in magnitude (a 1 px error of the head row more than 4 px at the feet) no foot
row is given; nor where the part's top is the image's first row (a head cut by the border: the
default camera cuts those of walkers nearer than about 15 m).

Only where a pedestrian starts (`refinement.new_pedestrians`): its patch then stands on its
feet, and the blobs it overlaps there (the shoes, where they show) are related to it, so the
paper's placement (the lowest related pixel, `patches.place_patch`) follows the feet from the
next frame on. Placing every frame from the head where `place_patch` finds no foot row was
measured too and not kept (docs/rules.md).

The same reading serves the counting rule's too-fast test (`verdicts.head_speed`,
`head_ground_points`): a track whose foot rows are mostly a walker's hips reads its walker 2-4
times too far away and so too fast; under its heads its ground points are the walker's.
Units: px, m, s; rows grow downwards.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.status import TrackState
from ..track.rows import TrackRow
from .patches import ShapeModel, ground_point


__all__ = ["MIN_SLOPE", "TALL_HEIGHTS", "head_foot_row", "head_ground_points", "too_tall"]

MIN_SLOPE = 0.25  # |d(head row)/d(foot row)| below this: no foot row from the head (module doc)
TALL_HEIGHTS = 1.25  # the option's value when on: a part 25 % taller than the height prior's
# walker (2.1 m for 1.7 m, taller than any adult) is not standing on its bottom; set a priori


def head_foot_row(shape: ShapeModel, u: float, v_top: float, n_rows: int,
                  min_slope: float = MIN_SLOPE) -> float | None:
    """The foot row (px, float) of a walker at column `u` whose patch top (head) is on row
    `v_top`: the one crossing of v - h(v) = v_top over the image rows 0..n_rows-1, linear
    between rows; None where there is no crossing, more than one, or the slope there is below
    `min_slope` in magnitude (module doc), or `v_top` on the image's first row (a part cut by
    the border has no head row)."""
    if not float(v_top) >= 0.5:
        return None
    rows = np.arange(int(n_rows))
    # the patch heights of every row: the shape's cached row table where the size depends on
    # the row only (no roll), else computed at (u, row)
    _, h, fin = shape.foot_sizes(np.full(rows.size, float(u)), rows, int(n_rows))
    top = rows - h
    d = top - float(v_top)
    below = d <= 0.0
    cross = np.flatnonzero(fin[:-1] & fin[1:] & (below[:-1] != below[1:]))
    if cross.size != 1:
        return None
    i = int(cross[0])
    slope = float(top[i + 1] - top[i])
    if not abs(slope) >= min_slope:
        return None
    v = float(i + (float(v_top) - top[i]) / slope)
    return v if v > v_top else None


def too_tall(shape: ShapeModel, u: float, v_bottom: float, span: float, tall: float) -> bool:
    """Whether a blob part `span` px tall standing on row `v_bottom` is taller than `tall`
    patch heights of a walker there, or has no walker size there (its bottom at or above the
    horizon)."""
    _, h = shape.size(float(u), float(v_bottom))
    return not (math.isfinite(h) and h > 0.0) or span > tall * h


def head_ground_points(shape: ShapeModel, rows: list[TrackRow], n_rows: int,
                       tall: float = TALL_HEIGHTS) -> np.ndarray | None:
    """(k, 3) array of t (s), x, y (m): the ground points under the heads of a track's OBSERVE
    rows whose foot point (u, v) and top row v_top are measured, where the foot row is not the
    feet: at least half of those rows stand a part taller than `tall` walker heights on their
    foot row (`too_tall`, span v - v_top). Each point is the ground point of (u, foot row of
    a walker whose head is on v_top: `head_foot_row`); rows without one are left out. None
    where the track has no such row or fewer than half of them are too tall (its foot rows are
    its feet: its own ground points stand)."""
    obs = int(TrackState.OBSERVE)
    seen = [(float(q.t), float(q.u), float(q.v), float(q.v_top)) for q in rows
            if q.state == obs and math.isfinite(q.u) and math.isfinite(q.v)
            and math.isfinite(q.v_top)]
    n_tall = sum(too_tall(shape, u, v, v - v_top, tall) for _, u, v, v_top in seen)
    if not seen or 2 * n_tall < len(seen):
        return None
    out = []
    for t, u, _, v_top in seen:
        foot = head_foot_row(shape, u, v_top, n_rows)
        if foot is not None:
            x, y, ok = ground_point(shape.camera, u, foot)
            if bool(ok):
                out.append((t, float(x), float(y)))
    return np.asarray(out, np.float64).reshape(-1, 3)
