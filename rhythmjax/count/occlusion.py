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

`placement.wide_widths` (> 0; default 0, off) is the same question for a pedestrian alone on its
blobs when they are far wider than one walker (`is_wide`: their box wider than wide_widths W):
they hold something else as well (a group, a vehicle in front), whose bottom may lie under the
walker's columns. It is placed as a shared one is (the shared search radius), and its measured
foot row is used only within `foot_row_tolerance` of the prediction: k_sigma2 (Table 1) times the
foot row's noise std r_std_v (the config's R), px; beyond that it is measured across only.

`placement.shared_row_gate` (default off) refuses the foot row on shared blobs outright: a
pedestrian sharing its blob with another whose placed foot row lies beyond that tolerance of the
prediction takes no measurement (it predicts through the merge; `Pedestrian.unseen`), and with
`placement.shared_row_unsampled` that row gives no rhythm sample either (a missing I(k)).

All are off: each was measured against a decision rule written first (training, held-out and
third pools of our scenes, the dev crowds, PETS09) and none passed it (docs/rules.md, "What the
pieces that end by the velocity jump were placed on" and "A merge that holds the time-out").
"""

from __future__ import annotations

import math

import numpy as np

from ..model.params import Config, host_float


__all__ = ["HIDDEN_ROWS", "feet_hidden", "foot_row_tolerance", "is_wide", "placement_order",
           "row_gated"]

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


def is_wide(box, w: float, widths: float) -> bool:
    """Whether a blob box (x0, y0, x1, y1, half-open px) is wider than `widths` patch widths `w`
    px; never when `widths` <= 0 (off) or `w` is not finite."""
    return widths > 0 and math.isfinite(w) and (box[2] - box[0]) > widths * w


def foot_row_tolerance(cfg: Config) -> float:
    """k_sigma2 x r_std_v px: how far from its predicted row a pedestrian on wide blobs may
    measure its foot row (Table 1's k_sigma2 = 3; r_std_v the config's foot-row noise std,
    `noise.r_std_px[1]`)."""
    return host_float(cfg.thresholds.k_sigma2) * float(np.asarray(cfg.noise.r_std())[1])


def row_gated(level, p, pl, z, *, shared: bool, wide: bool, claimed: np.ndarray | None):
    """`PedestrianLevel._place`: pedestrian `p`'s measurement `z` (u, v) px from placement `pl`
    under the row rules, each counted in `level.gated`: "hidden" (`placement.depth_order`, a
    `shared` placement whose feet stand on a nearer patch's `claimed` pixels) and "wide" (a
    `wide` one whose row lies beyond `level.row_tolerance` px of the prediction): measured
    across only, (pl.u, predicted v); "rewound" (`count.rewind`, its row off): across only, or
    None (it predicts) with `life.rewind_predict`; "shared-row" (`placement.shared_row_gate`, a
    shared one whose row is off): None, `p.unseen` set. Otherwise `z` unchanged."""
    opt, v_pred = level.opt, float(p.next_uv[1])
    off = abs(pl.v - v_pred) > level.row_tolerance
    why, across = None, (pl.u, v_pred)
    if shared and opt.placement.depth_order and feet_hidden(claimed, pl.u, pl.v, pl.w):
        why, z = "hidden", across  # behind a nearer one
    elif wide and off:
        why, z = "wide", across  # its row: another object's
    elif p.rewound and off:
        why, z = "rewound", None if opt.life.rewind_predict else across
    elif shared and off and opt.placement.shared_row_gate:
        why, z, p.unseen = "shared-row", None, True
    if why is not None:
        level.gated[why] = level.gated.get(why, 0) + 1
    return z
