"""Whether a random scene's objects can be placed in the view at all, and each object's random
path (`scene.random_spec`)."""

from __future__ import annotations

import math

import numpy as np

from ..model.camera_np import camera_tuple, depth_3d, project_3d
from ..model.params import Camera, ConfigError
from . import actors as sa


class PlacementError(ConfigError, RuntimeError):
    """The objects asked for cannot be placed in the view (a `ConfigError`: exit 2 at the
    command line; a `RuntimeError` for callers that skip such a seed)."""


def check_room(camera: Camera, n_walkers: int, n_bicycles: int, n_dogs: int, n_frames: int,
               min_life: int, range_m: tuple[float, float]) -> None:
    """Refuse (`PlacementError`, saying why) a scene whose objects cannot all be placed: their
    image boxes (`actors.EXTENT`) at the far end of the range, where they are smallest, each
    alive at least min(min_life, n_frames) of the n_frames, would cover more than the whole
    image on average. Placement keeps boxes apart by re-drawing paths, 300 tries per object
    against every object placed (a cost that grows with the square of the count), so such a
    scene would never finish: 100 000 walkers ran for hours. The paper's 512x512 camera at
    19.9 m holds about 86 walkers side by side."""
    if n_walkers < 0 or n_bicycles < 0 or n_dogs < 0 or n_frames < 1:
        raise PlacementError("scene", "object counts must be >= 0 and n_frames >= 1")
    host = camera_tuple(camera)
    afs = host.a * host.f
    d = float(depth_3d(host, float(range_m[1]), 0.0))
    if not d > 0:
        return
    area = {k: 2.0 * w * h * (afs / d) ** 2 for k, (w, h) in sa.EXTENT.items()}
    counts = {"pedestrian": n_walkers, "bicycle": n_bicycles, "dog": n_dogs}
    busy = min(min_life, n_frames) / n_frames
    image = float(camera.image_width * camera.image_height)
    cover = sum(counts[k] * area[k] for k in counts) * busy / image
    if cover <= 1.0:
        return
    fit = int(image / (area["pedestrian"] * busy))
    raise PlacementError(
        "scene", f"cannot place {n_walkers} walkers, {n_bicycles} bicycles and {n_dogs} dogs "
        f"in the {camera.image_width}x{camera.image_height} view: even at the far end of the "
        f"range ({float(range_m[1]):g} m), where they are smallest, their image boxes, each "
        f"alive at least {min(min_life, n_frames)} of {n_frames} frames, would cover the image "
        f"{cover:.3g} times over (about {fit} walkers fit); ask for fewer objects or more frames")


def place_path(camera: Camera, kind: str, rng: np.random.Generator, k: np.ndarray, start: int,
               life: int, alive: np.ndarray, speed: float, placed: list, occlusion: bool,
               range_m: tuple[float, float], margin_px: float,
               lateral_deg: float | None = None):
    """Up to 300 random straight paths for one actor of `kind` alive at frames `alive` (of the
    frame indices `k`, from `start` for `life` frames) at `speed` m/s: the first whose image box
    clashes with no `placed` actor's (each (alive, u, half-width, v, height) px), else the least
    clashing one in view: (clash frames, heading rad, x m, y m at `start`, u, half-width, v,
    height px per frame); None when none stays in view (within `range_m` m and `margin_px` px
    of the image's sides and bottom). Headings uniform, or within `lateral_deg` degrees of the
    x axis, left or right (`scene.random_spec`)."""
    fps, W, H = float(camera.fps), camera.image_width, camera.image_height
    host = camera_tuple(camera)
    afs = host.a * host.f
    best = None
    for _ in range(300):
        if lateral_deg is None:
            head = float(rng.uniform(-math.pi, math.pi))
        else:  # within lateral_deg of the x axis (the image's rows), left or right
            head = math.radians(float(rng.uniform(-lateral_deg, lateral_deg))) + (
                math.pi if rng.random() < 0.5 else 0.0)
        ym = float(rng.uniform(*range_m))
        half = 0.8 * (W / 2) * ym * math.cos(host.theta) / afs
        xm = float(rng.uniform(-half, half))
        tau = (k - start - life / 2) / fps
        x = xm + speed * tau * math.cos(head)
        y = ym + speed * tau * math.sin(head)
        u, v = project_3d(host, x, y, 0.0)
        a = alive
        if not ((y[a] > range_m[0]).all() and (y[a] < range_m[1]).all()
                and (u[a] > margin_px).all() and (u[a] < W - margin_px).all()
                and (v[a] < H - margin_px).all()):
            continue
        d = depth_3d(host, y, 0.0)
        hw_px, h_px = sa.EXTENT[kind][0] * afs / d, sa.EXTENT[kind][1] * afs / d
        clash = 0
        if not occlusion:
            for a2, u2, hw2, v2, h2 in placed:
                both = a & a2
                clash += int(np.sum(both & (np.abs(u - u2) < hw_px + hw2)
                                    & (v - h_px < v2) & (v2 - h2 < v)))
        if best is None or clash < best[0]:
            best = (clash, head, x[start], y[start], u, hw_px, v, h_px)
        if clash == 0:
            break
    return best
