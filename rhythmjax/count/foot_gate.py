"""Gates on a placed patch's foot point before it updates the filter (`PedestrianLevel._place`):
a foot point that has left the feet for a few frames (legs hidden behind a nearer object, feet
clipped at the image bottom, a patch slid onto another blob's bottom, a foot point at hip level
near the horizon) reads metres off on the ground and makes a fragment too fast or a duplicate.
A gated placement gives no measurement: the pedestrian predicts that frame.

(a) `placement.in_range`: the measured foot point has no ground point (at or above the horizon)
    or its ground point lies beyond the detection range (`thresholds.range_max` m ahead);
    `placement.gate_heights` (> 0): its ground point lies farther than this many walker heights
    (`width.height` m) from the predicted foot point's ground point.
(b) `placement.lift_heights` (> 0): the blob bottom under the patch (the placement's foot row,
    the lowest related pixel in its columns) lies more than this many patch heights (H at the
    predicted foot point) above the predicted foot row: the legs are not visible, the patch is
    not measured at the feet.
Units are the camera's: walker heights on the ground, patch heights in the image; all off by
default (see `PlacementOptions`).
"""

from __future__ import annotations

import math

from .patches import ground_point


__all__ = ["foot_gate", "gated"]


def foot_gate(camera, pred_uv, pred_h: float, z_uv, *, range_max: float, walker_m: float,
              in_range: bool = False, gate_heights: float = 0.0,
              lift_heights: float = 0.0) -> str | None:
    """Why the measured foot point `z_uv` (px) of a patch predicted at `pred_uv` (px, patch
    height `pred_h` px there) is not used, or None when it is: "horizon" / "range" / "jump"
    (option a) or "lift" (option b). `camera`: `ShapeModel.camera`; `range_max` m;
    `walker_m`: a walker's height m (`width.height`)."""
    if lift_heights > 0 and math.isfinite(pred_h) and \
            pred_uv[1] - z_uv[1] > lift_heights * pred_h:
        return "lift"
    if not (in_range or gate_heights > 0):
        return None
    zx, zy, ok = (float(q) for q in ground_point(camera, *z_uv))
    if in_range:
        if not ok:
            return "horizon"
        if zy > range_max:
            return "range"
    if gate_heights > 0 and ok:
        px, py, pok = (float(q) for q in ground_point(camera, *pred_uv))
        if pok and math.hypot(zx - px, zy - py) > gate_heights * walker_m:
            return "jump"
    return None


def gated(level, p, pl) -> tuple[float, float] | None:
    """`PedestrianLevel._place`: pedestrian `p`'s measurement from its placement `pl` under the
    gates of its options' `placement` (reasons counted in `level.gated`): (pl.u, pl.v), None
    (gated: it predicts), or with `placement.lift_keep_u` a lifted one (b) measured across only,
    at its predicted foot row (pl.u, predicted v)."""
    o = level.opt.placement
    if not (o.in_range or o.gate_heights > 0 or o.lift_heights > 0):
        return (pl.u, pl.v)
    why = foot_gate(level.shape.camera, p.next_uv, float(level.shape.size(*p.next_uv)[1]),
                    (pl.u, pl.v), range_max=float(level.cfg.thresholds.range_max),
                    walker_m=float(level.cfg.width.height), in_range=o.in_range,
                    gate_heights=o.gate_heights, lift_heights=o.lift_heights)
    if why is None:
        return (pl.u, pl.v)
    level.gated[why] = level.gated.get(why, 0) + 1
    if why == "lift" and o.lift_keep_u:
        return (pl.u, float(p.next_uv[1]))
    return None
