"""Whether a random scene's objects can be placed in the view at all (`scene.random_spec`)."""

from __future__ import annotations

from ..model.camera_np import camera_tuple, depth_3d
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
