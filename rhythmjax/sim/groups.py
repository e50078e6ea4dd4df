"""Walkers in pairs, side by side: a scene's walkers re-drawn so that some walk with a partner
at the partner's shoulder (issue 16, twenty-fourth round), or in file, one behind the other
(`layout` "file", twenty-sixth round: walking toward or away from the camera, one stands in
front of the other in the image), the second possibly appearing 1-2 s later ("late": a walker
stepping in front of, or behind, one already in view).

Why: in our counting scenes two walkers whose image boxes overlap stand at different depths
(their foot rows a median 0.18 walker heights apart: one passes behind the other), while in
the independent renderer's crowd clips such walkers stand side by side (0.05 H apart;
`benchmarks/untracked_walkers.py`, docs/rules.md). Rules chosen on our scenes never met a pair.

A pair: the second walker takes the first's start frame, life, heading and ground speed (its own
pace, its step length scaled to that speed), its path shifted sideways, perpendicular to the
heading, by `spacing_m` (in file: along the heading, behind or ahead); the gait phases stay
independent. Everything else of the second walker (height, clothing, bag) is kept. A pair whose
second path would leave the image or the ground range while alive is tried on the other side,
then left unpaired.
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np

from ..model.camera_np import camera_tuple, project_3d
from .scene import ActorSpec, SceneSpec


__all__ = ["LATE_S", "LAYOUTS", "follower_of", "in_view", "late_of", "partner_of", "with_pairs"]


LAYOUTS = {"side": (0.55, 0.8), "file": (1.0, 2.5), "late": (1.0, 2.5)}  # a pair's spacing
# range, m, per layout (side: shoulder to shoulder; file: one pace to two strides and more
# between walkers in file; late: in file, the second walker appearing LATE_S after the first)
LATE_S = (1.0, 2.0)  # s: when the second walker of a "late" pair appears (uniform)


def in_view(spec: SceneSpec, actor: ActorSpec, range_m: tuple[float, float],
            margin_px: float) -> bool:
    """Whether the actor's foot point stays inside the image (`margin_px` from the left, right
    and bottom edges, px) and within the ground range `range_m` (y, m) in every frame it is
    alive (the rule of `scene.random_spec`'s paths)."""
    cam = spec.camera
    k = np.arange(spec.n_frames)
    n = spec.n_frames - actor.start_frame if actor.n_frames is None else actor.n_frames
    k = k[(k >= actor.start_frame) & (k < actor.start_frame + n)]
    tau = (k - actor.start_frame) / float(cam.fps)
    x = actor.x0 + actor.speed_mps * tau * math.cos(actor.heading_rad)
    y = actor.y0 + actor.speed_mps * tau * math.sin(actor.heading_rad)
    if not ((y > range_m[0]).all() and (y < range_m[1]).all()):
        return False
    u, v = project_3d(camera_tuple(cam), x, y, 0.0)
    return bool((u > margin_px).all() and (u < cam.image_width - margin_px).all()
                and (v < cam.image_height - margin_px).all())


def partner_of(lead: ActorSpec, other: ActorSpec, spacing_m: float, side: float) -> ActorSpec:
    """`other` walking beside `lead`: the lead's start, life, heading and speed (m/s), other's
    own pace (step length = the lead's speed / other's pace), its start point `spacing_m` m to
    the lead's left (side +1) or right (-1) of the heading."""
    h = lead.heading_rad
    return replace(other, x0=lead.x0 - side * spacing_m * math.sin(h),
                   y0=lead.y0 + side * spacing_m * math.cos(h), heading_rad=h,
                   start_frame=lead.start_frame, n_frames=lead.n_frames,
                   step_length_m=lead.speed_mps / other.pace_hz)


def follower_of(lead: ActorSpec, other: ActorSpec, gap_m: float, side: float) -> ActorSpec:
    """`other` walking in file with `lead`: the lead's start, life, heading and speed (m/s),
    other's own pace, its start point `gap_m` m ahead of the lead (side +1) or behind it (-1)
    along the heading."""
    h = lead.heading_rad
    return replace(partner_of(lead, other, 0.0, 1.0), x0=lead.x0 + side * gap_m * math.cos(h),
                   y0=lead.y0 + side * gap_m * math.sin(h))


def late_of(lead: ActorSpec, other: ActorSpec, gap_m: float, side: float, delay: int,
            fps: float) -> ActorSpec:
    """`follower_of` appearing `delay` frames after the lead (at `fps` frames/s): where the file
    puts it then, living that much less (a walker stepping in front of, or behind, one already
    in view)."""
    f = follower_of(lead, other, gap_m, side)
    step = f.speed_mps * delay / fps
    h = lead.heading_rad
    return replace(f, x0=f.x0 + step * math.cos(h), y0=f.y0 + step * math.sin(h),
                   start_frame=lead.start_frame + delay,
                   n_frames=None if lead.n_frames is None else lead.n_frames - delay)


def with_pairs(spec: SceneSpec, seed: int, fraction: float,
               spacing_m: tuple[float, float] | None = None,
               range_m: tuple[float, float] = (3.1, 19.9), margin_px: float = 8.0,
               layout: str = "side") -> SceneSpec:
    """The scene with walkers paired: in the order of the actors, each walker not yet in a pair
    is, with probability `fraction`, joined by the next unpaired walker (`partner_of` for
    `layout` "side", `follower_of` for "file", `late_of` for "late", its delay uniform in
    `LATE_S`; spacing uniform in `spacing_m` m, by default the layout's `LAYOUTS` range; a
    random side first). Deterministic given `seed`; `fraction` 0 returns `spec` itself."""
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"pair fraction must be in [0, 1], got {fraction}")
    if layout not in LAYOUTS:
        raise ValueError(f"pair layout must be one of {sorted(LAYOUTS)}, got {layout!r}")
    if fraction == 0.0:
        return spec
    spacing_m = LAYOUTS[layout] if spacing_m is None else spacing_m
    place = partner_of if layout == "side" else follower_of
    fps = float(spec.camera.fps)
    rng = np.random.default_rng(seed)
    actors = list(spec.actors)
    walkers = [i for i, a in enumerate(actors) if a.kind == "pedestrian"]
    j = 0
    while j + 1 < len(walkers):
        lead, i = actors[walkers[j]], walkers[j + 1]
        paired = False
        if rng.random() < fraction:
            spacing, first = float(rng.uniform(*spacing_m)), float(rng.choice([-1.0, 1.0]))
            if layout == "late":
                delay = int(rng.integers(round(LATE_S[0] * fps), round(LATE_S[1] * fps) + 1))
                place = functools.partial(late_of, delay=delay, fps=fps)
            for side in (first, -first):
                partner = place(lead, actors[i], spacing, side)
                if in_view(spec, partner, range_m, margin_px):
                    actors[i], paired = partner, True
                    break
        j += 2 if paired else 1
    return replace(spec, actors=tuple(actors))
