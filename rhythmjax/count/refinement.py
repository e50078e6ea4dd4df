"""Refinement of the pedestrians level (`pedestrian_level.PedestrianLevel`): blob columns no
tracked pedestrian's patch explains (`covers`, down to its foot row with `new.cover_to_feet`;
`free_runs`: each run with the test it fails, if any) start new pedestrians
(`new_pedestrians`), one per walker width of a run that passes, in the config's detection range
(`in_range`). Units: px, patch widths W and heights H at the foot point
(`patches.ShapeModel`), m on the ground. `level` is the `PedestrianLevel` (not imported here:
it imports this module)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .head_feet import head_foot_row, too_tall
from .patches import ground_point
from .pedestrian import Pedestrian, finite_uv


__all__ = ["REFUSALS", "FreeRun", "covers", "free_runs", "in_range", "new_pedestrians", "starts_on"]


REFUSALS = ("narrow", "thin", "short", "lifted")  # why a free run starts no one (`free_runs`)


@dataclass(frozen=True)
class FreeRun:
    """A run of blob columns no patch covers (`free_runs`): its blob's box origin (x0, y0) px,
    its columns c0..c1 in the blob's box, the blob's pixels there (`crop`), its foot row `vb`
    px (from the head with `from_head`), its centre column `uc` px, the patch (w, h) px at
    (uc, vb), the walkers it holds `n`, and `refused`: "" or the first test of `REFUSALS` it
    fails (narrower than new.min_widths W, fewer pixels than new.min_fill of n patches, shorter
    than new.min_height H, lifted and shorter than new.lifted_height H)."""

    x0: int
    y0: int
    c0: int
    c1: int
    crop: np.ndarray
    vb: float
    uc: float
    w: float
    h: float
    n: int
    from_head: bool
    refused: str


def covers(level) -> list[tuple[Pedestrian, tuple[float, float, float, float]]]:
    """Each pedestrian of `level` with the box (x0, y0, x1, y1) px its patch explains: the
    patch's rows, `new.walker_widths` patch widths of columns around its foot point (measured
    this frame, else predicted; a walker's blob spans its stance foot to its leading arm)."""
    out = []
    for p in level.peds:
        b = level.patch_at(p.z if finite_uv(p.z) else p.next_uv)
        half = 0.5 * level.opt.new.walker_widths * (b[2] - b[0])
        out.append((p, (0.5 * (b[0] + b[2]) - half, b[1], 0.5 * (b[0] + b[2]) + half, b[3])))
    return out


def free_runs(level, blobs, labels):
    """The runs of blob columns no patch covers (`new.walker_widths` W around each pedestrian's
    foot point, measured or predicted), per blob, each tested (`FreeRun.refused`); runs where
    the camera gives no patch size are left out. With `new.cover_to_feet` a cover explains its
    columns only down to its foot row plus `level.row_tolerance` px: a run is then made of the
    columns holding blob pixels no cover explains (a nearer walker in front of a tracked one),
    its foot row and height taken over all its blob pixels, its fill over the free ones only.
    With `new.join_gap_widths` runs of one blob closer than that many W (at the blob's bottom
    row) are joined (a walker's legs); with `new.fill_exposed` a run under a cover asks its fill
    of the patch rows below the cover only. Nothing in `level` changes."""
    opt = level.opt
    head = opt.new.head_feet
    below = level.row_tolerance if opt.new.cover_to_feet else math.inf
    cover = [c for _, c in covers(level)]
    for b in blobs:
        x0, y0, x1, y1 = b.box
        low = np.full(x1 - x0, -1.0)  # per column: the lowest crop row a cover explains
        for c in cover:
            if c[1] < y1 and c[3] > y0:
                cols = slice(max(0, int(math.floor(c[0])) - x0), max(0, int(math.ceil(c[2])) - x0))
                low[cols] = np.maximum(low[cols], c[3] + below - y0)
        if (low >= y1 - y0 - 1).all():  # every column explained to the bottom: no run
            continue
        wb, hb = (float(q) for q in level.shape.size(0.5 * (x0 + x1 - 1), y1 - 1))
        crop = labels[y0:y1, x0:x1] == b.label
        unexplained = crop & (np.arange(y1 - y0)[:, None] > low[None, :])
        ext = np.zeros(low.size + 2, np.int8)  # run edges of the columns with free pixels
        np.any(unexplained, axis=0, out=ext[1:-1].view(bool))
        edges = np.flatnonzero(np.diff(ext))
        if opt.new.join_gap_widths > 0 and edges.size > 2:  # a walker's legs: one run
            gap = opt.new.join_gap_widths * wb if math.isfinite(wb) else 0.0  # W at the bottom
            keep = np.r_[True, edges[2::2] - edges[1:-1:2] >= gap]  # runs starting anew
            edges = np.c_[edges[::2][keep], edges[1::2][np.r_[keep[1:], True]]].ravel()
        for c0, c1 in zip(edges[::2], edges[1::2]):
            sub = crop[:, c0:c1]
            rows = np.flatnonzero(sub.any(axis=1))
            vb = float(y0 + int(rows[-1]))
            span = rows[-1] - rows[0] + 1
            uc = x0 + 0.5 * (c0 + c1 - 1)
            from_head = head > 0 and too_tall(level.shape, uc, vb, float(span), head)
            if from_head and opt.new.head_feet_out_of_range:  # only where its bottom row
                from_head = not starts_on(level, (uc, vb))  # starts no one (legs lost)
            if from_head:  # legs lost in the mask: the feet from the head (`head_feet`)
                vf = head_foot_row(level.shape, uc, float(y0 + rows[0]), labels.shape[0])
                from_head = vf is not None and vf > vb
                vb = vf if from_head else vb
            w, h = (float(q) for q in level.shape.size(uc, vb))
            if not (math.isfinite(w) and w > 0):
                continue
            n = max(1, int(round((c1 - c0) / (opt.new.walker_widths * w))))
            fill = opt.new.min_fill * w * h * n  # pixels asked: of n whole patches, or with
            top = float(low[c0:c1].max())  # `new.fill_exposed` under a cover of their rows below
            if opt.new.fill_exposed and 0 <= top < math.inf:
                fill = opt.new.min_fill * w * min(h, vb - (y0 + top)) * n
            lifted = vb < y1 - 1 - opt.new.max_lift * hb  # above the blob's bottom: an arm,
            # or a farther walker merged with a nearer object (it stands taller than an arm)
            refused = ("narrow" if (c1 - c0) < opt.new.min_widths * w
                       else "thin" if unexplained[:, c0:c1].sum() < fill
                       else "short" if span < opt.new.min_height * h
                       else "lifted" if lifted and span < opt.new.lifted_height * min(h, vb + 1.0)
                       else "")
            yield FreeRun(x0, y0, int(c0), int(c1), crop, vb, uc, w, h, n, bool(from_head),
                          refused)


def new_pedestrians(level, blobs, labels) -> list[Pedestrian]:
    """Runs of blob columns no patch covers (`free_runs`), wide and full enough for a
    pedestrian, reaching the blob's bottom or lifted and tall enough (`new.*`): one new
    pedestrian per walker width of the run, side by side (groups), its foot point in the
    detection range (`in_range`); with `new.head_feet`, a run too tall for a walker standing on
    its bottom stands where its top row is a walker's head (`head_feet`: its legs lost in the
    mask). They are added to `level.peds` and returned; when the free slots run out the frame
    is listed in `level.full_frames` and those started so far are returned without being added
    (as the level always did)."""
    free_slots = sorted(set(range(level.filter.slots)) - {p.slot for p in level.peds})
    new: list[Pedestrian] = []
    for run in list(free_runs(level, blobs, labels)):
        if run.refused:
            continue
        c0, c1, n, crop = run.c0, run.c1, run.n, run.crop
        for k in range(n):
            a0, a1 = c0 + (c1 - c0) * k // n, c0 + (c1 - c0) * (k + 1) // n
            r = np.flatnonzero(crop[:, a0:a1].any(axis=1))
            if not free_slots:
                level.full_frames.append(level.n_frames)
                return new  # (as before the split: these are not added to level.peds)
            z = (run.x0 + 0.5 * (a0 + a1 - 1), float(run.y0 + r[-1])) if r.size else None
            if z is not None and run.from_head:  # one walker on the run: its row above
                vf = run.vb if n == 1 else head_foot_row(level.shape, z[0],
                                                         float(run.y0 + r[0]),
                                                         labels.shape[0])
                z = None if vf is None else (z[0], vf)
            if z is not None and in_range(level, z):
                p = level.new_pedestrian(free_slots.pop(0))
                p.z, p.z_width = z, float(a1 - a0)  # its share of the run
                new.append(p)
    level.peds += new
    return new


def starts_on(level, uv) -> bool:
    """A walker standing on foot point `uv` (px) has a patch size and its ground point in the
    detection range (`in_range`): the refinement could start one there."""
    w = float(level.shape.size(*uv)[0])
    return math.isfinite(w) and w > 0 and in_range(level, uv)


def in_range(level, uv) -> bool:
    """The foot point `uv` (px) has its ground point in the config's detection range (range_min
    to range_max m ahead): where `rhythmjax track` detects, and where a new pedestrian starts;
    always True with `new.in_range` off."""
    if not level.opt.new.in_range:
        return True
    _, y, ok = ground_point(level.shape.camera, *uv)
    thr = level.cfg.thresholds
    return bool(ok) and float(thr.range_min) <= float(y) <= float(thr.range_max)
