"""A detection cut by the image's left or right side: its foot column from the edge inside.

While a walker enters (or leaves) across a side of the image only part of its body is in view,
and the projections measure the centre of that part: the foot column u lies up to W/2 px from
the walker's and moves at a fraction of its speed (at entry it starts at the image edge while
the walker's centre is still outside). The filter then takes the walker for slower than it is;
once the whole body is in view its detection window, centred on the lagging prediction, holds
only the body's rear, the front starts a second object, and the two share one blob, which
measures neither (`dev_multi_01`: 10 frames): the walker is only predicted, and its rhythm
windows hold missing samples.

Only the edge inside the image is the walker's, so where the detection's box reaches a side
(within `margin_px`) and is narrower than W, the foot column is placed W/2 from that inner edge:
u = (inner edge) -/+ (W - 1)/2, where W (px) is the mean walker width at the foot row through
the camera (3) (`BodyOptions.side_anchor`). The width measured stays the cut one, so the width
gate (10) still judges the measurement as the paper does; only its column moves. Rows are
unchanged (the lowest row of the motion is the feet whichever part is in view).
"""

from __future__ import annotations

import dataclasses
import math

from ..vision.detect import SOBEL_HALO_PX, Detection


__all__ = ["anchor_at_side", "cut_side"]

SIDE_MARGIN_PX = SOBEL_HALO_PX + 1  # a box this close to a side reaches it (Sobel's halo)


def cut_side(det: Detection, image_width: int, margin_px: int = SIDE_MARGIN_PX) -> int:
    """-1 where the detection's box reaches the left side (its first column <= margin_px), +1
    the right side (its last column >= image_width - 1 - margin_px), 0 neither (or both: an
    object wider than the image has no inner edge)."""
    x0, _, w, _ = det.box
    left, right = x0 <= margin_px, x0 + w - 1 >= image_width - 1 - margin_px
    return -1 if left and not right else (1 if right and not left else 0)


def anchor_at_side(det: Detection, walker_px: float, image_width: int,
                   margin_px: int = SIDE_MARGIN_PX) -> Detection:
    """`det` with its foot column u (px) placed (W - 1)/2 from the inner edge of its box where
    the box reaches a side of the image and is narrower than W = `walker_px`; `det` itself
    otherwise (W not finite or not positive included). Pixel centres at integers: a box of
    columns x0 .. x0 + w - 1 whose left side is cut has its inner edge at x0 + w - 1 - halo."""
    side = cut_side(det, image_width, margin_px)
    if side == 0 or not math.isfinite(walker_px) or walker_px <= 0 or det.width >= walker_px:
        return det
    x0, _, w, _ = det.box
    half = 0.5 * (walker_px - 1.0)
    if side < 0:
        u = (x0 + w - 1 - SOBEL_HALO_PX) - half
    else:
        u = (x0 + SOBEL_HALO_PX) + half
    return dataclasses.replace(det, u=float(u))
