"""Occlusion by depth order in the pedestrians level (`placement.depth_order`, default off).

On a fixed camera looking down at a ground plane the nearer of two walkers stands lower in the
image (a larger foot row v) and hides the farther one where they overlap. `PedestrianLevel.
_place` places the patches one after another, each shared placement claiming its rectangle so
that the next cannot take its pixels (`patches.place_patch`'s `claimed`). In the paper's order
(older first) an older far walker is placed before a nearer one that merged with it and takes
the nearer walker's feet, 20-35 px below its own, as its foot row (docs/rules.md, "Why the
counting tracker's pieces end"). With `depth_order`:

1. `placement_order`: patches are placed nearest first (largest predicted foot row), ties in
   the old order (more measured frames, then born earlier): the painter's order, reversed;
2. `feet_hidden`: a shared placement whose foot row sits directly on pixels a nearer patch
   claimed (a claimed pixel in the `HIDDEN_ROWS` rows below it, within the middle half of its
   width) has its feet behind that walker; it is measured across only, its foot row kept at
   the prediction (as `placement.lift_keep_u` does for lifted legs).
"""

from __future__ import annotations

import math

import numpy as np


__all__ = ["HIDDEN_ROWS", "feet_hidden", "placement_order"]

HIDDEN_ROWS = 2  # rows below a foot row searched for a nearer patch's claimed pixels (a priori)


def placement_order(peds, depth_order: bool) -> list:
    """The pedestrians in the order their patches are placed: older first (most measured frames
    `hits`, then earliest `born`: the default), or with `depth_order` nearest first (largest
    predicted foot row `next_uv[1]` px; a pedestrian without a finite prediction last), ties in
    the older-first order."""
    def age(q):
        return (-q.hits, q.born)

    if not depth_order:
        return sorted(peds, key=age)

    def depth(q):
        v = q.next_uv[1]
        return (0, -v, *age(q)) if math.isfinite(v) else (1, 0.0, *age(q))

    return sorted(peds, key=depth)


def feet_hidden(claimed: np.ndarray | None, u: float, v: float, w: float) -> bool:
    """Whether the foot point (u, v) px of a patch `w` px wide stands on pixels a nearer patch
    has claimed (`claimed`: (H, W) bool; None: nothing claimed): any claimed pixel in rows
    v + 1 .. v + `HIDDEN_ROWS` and columns u - w/4 .. u + w/4 (rounded to pixels, clipped to the
    image). False where those rows lie below the image."""
    if claimed is None:
        return False
    rows, cols = claimed.shape
    r0 = int(round(v)) + 1
    r1 = min(rows, r0 + HIDDEN_ROWS)
    c0 = max(0, int(math.floor(u - 0.25 * w + 0.5)))
    c1 = min(cols, int(math.floor(u + 0.25 * w + 0.5)) + 1)
    if r0 >= r1 or c0 >= c1:
        return False
    return bool(claimed[r0:r1, c0:c1].any())
