"""What a camera of (3) sees, in the units a person checks a camera by: the horizon's row, the
ground distance of an image row, a person's height in pixels, and the detection range the image
implies. Float64 host code (`camera_np`); used to derive the default detection range and by the
`rhythmjax camera` screen.

The derived detection range (`visible_range`) is the ground the image's centre column sees: from
the bottom row's ground distance (near) to the top row's (far; unbounded when the top row is at
or above the horizon), capped where a person of `height_m` would be less than `MIN_PERSON_PX`
tall (the rhythm window is W x W/5 px at the feet, and a 20 px walker is about 6 px wide: the
smallest window that still holds a row).
"""

from __future__ import annotations

import math

import numpy as np

from .camera import MIN_DEPTH_M
from .camera_np import camera_tuple, depth_3d, ground_of_pixels, project_3d
from .params import Camera, host_float


MIN_PERSON_PX = 20.0  # px: a walker shorter than this in the image is out of the derived range
NEAR_FLOOR_M = 0.1  # m: the derived range starts no nearer (the config's range is y > 0)
PERSON_HEIGHT_M = 1.7  # m: WidthModel.height's default, the person of the report


def focal_px(camera: Camera | tuple) -> tuple[float, float]:
    """(a f, b f): the horizontal and vertical focal lengths in px."""
    c = camera_tuple(camera)
    return c.a * c.f, c.b * c.f


def horizon_row(camera: Camera | tuple) -> float:
    """Image row (px) of the horizon at the principal point's column, Vc - b f tan(theta) /
    cos(roll) (rows above it see no ground)."""
    c = camera_tuple(camera)
    return c.vc - c.b * c.f * math.tan(c.theta) / math.cos(c.roll)


def ground_distance_at_row(camera: Camera | tuple, v: float) -> float:
    """Ground distance y (m, ahead of the camera's foot) seen at row v (px) of the principal
    point's column; inf on or above the horizon."""
    c = camera_tuple(camera)
    _, y, ok = ground_of_pixels(camera, float(c.uc), float(v))
    return float(y) if ok else math.inf


def row_of_distance(camera: Camera | tuple, y_m: float | int) -> float:
    """Image row (px) of the ground point y_m m straight ahead (x = 0)."""
    return float(project_3d(camera, 0.0, float(y_m), 0.0)[1])


def person_height_px(camera: Camera | tuple, y_m: float | int,
                     height_m: float = PERSON_HEIGHT_M) -> float:
    """Image height (px) of an upright person height_m m tall standing y_m m straight ahead;
    NaN when the head or the feet are behind the camera."""
    feet = project_3d(camera, 0.0, float(y_m), 0.0)[1]
    head = project_3d(camera, 0.0, float(y_m), float(height_m))[1]
    ok = min(depth_3d(camera, y_m, 0.0), depth_3d(camera, y_m, height_m)) > MIN_DEPTH_M
    return float(feet - head) if ok else math.nan


def distance_of_person_px(camera: Camera | tuple, px: float,
                          height_m: float = PERSON_HEIGHT_M) -> float:
    """The farthest ground distance (m) at which a person height_m tall is still `px` px tall;
    inf when even 1 km away the person is taller, 0 when nowhere. Near the foot of a high camera
    a person's image height first grows with distance (seen from above), then falls: a scan on
    a log grid finds the last distance at or above `px`, and bisection refines it."""
    grid = np.geomspace(1e-2, 1000.0, 400)
    tall = np.array([person_height_px(camera, float(y), height_m) >= px for y in grid])
    if tall[-1]:
        return math.inf
    if not tall.any():
        return 0.0
    k = int(np.flatnonzero(tall)[-1])
    lo, hi = float(grid[k]), float(grid[k + 1])
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        if person_height_px(camera, mid, height_m) >= px:
            lo = mid
        else:
            hi = mid
    return lo


def visible_range(camera: Camera, height_m: float = PERSON_HEIGHT_M
                  ) -> tuple[float, float]:
    """(near, far) m: the derived detection range (module doc). near is the bottom row's ground
    distance, at least `NEAR_FLOOR_M` (a steep camera's bottom row sees behind its foot); far
    the top row's, or the distance where a person is `MIN_PERSON_PX` tall if nearer. Raises
    ValueError when the image sees no usable ground (the bottom row at or above the horizon, or
    near >= far)."""
    c = camera_tuple(camera)
    height = int(getattr(camera, "image_height", 2 * c.vc))
    near = ground_distance_at_row(camera, float(height))
    if not math.isfinite(near):
        raise ValueError(f"the bottom row of the image is above the horizon (row "
                         f"{horizon_row(camera):.0f}): the camera sees no ground")
    near = max(near, NEAR_FLOOR_M)  # a camera looking steeply down sees behind its foot (y < 0)
    far = min(ground_distance_at_row(camera, 0.0),
              distance_of_person_px(camera, MIN_PERSON_PX, height_m))
    if not far > near:
        raise ValueError(f"no usable ground: the bottom row sees {near:.1f} m, and beyond "
                         f"{far:.1f} m a person is under {MIN_PERSON_PX:g} px tall or out of view")
    return near, far


def camera_report(camera: Camera, height_m: float = PERSON_HEIGHT_M) -> dict:
    """The numbers a person checks a camera by (px, m, deg): focal lengths, h, tilt, roll,
    principal point, image size, fps, the horizon's row (and whether it is in the image), the
    ground distance at the bottom and centre rows (inf above the horizon), the derived detection
    range (None when the image sees no usable ground, with the reason), and a `height_m` person's
    height in px at 5, 10 and 20 m with the row of its feet."""
    c = camera_tuple(camera)
    w, h = int(camera.image_width), int(camera.image_height)
    af, bf = focal_px(camera)
    hz = horizon_row(camera)
    try:
        rng, why = visible_range(camera, height_m), None
    except ValueError as e:
        rng, why = None, str(e)
    return {
        "focal_px": [af, bf], "h_m": c.h, "tilt_deg": math.degrees(c.theta),
        "roll_deg": math.degrees(c.roll), "principal_point_px": [c.uc, c.vc],
        "image_size_px": [w, h], "fps": float(camera.fps),
        "hfov_deg": math.degrees(2 * math.atan(w / (2 * af))),
        "horizon_row_px": hz, "horizon_in_image": bool(0 <= hz < h),
        "ground_m_at_bottom_row": ground_distance_at_row(camera, float(h)),
        "ground_m_at_centre_row": ground_distance_at_row(camera, h / 2),
        "detection_range_m": None if rng is None else list(rng), "no_range_reason": why,
        "person_height_m": host_float(height_m),
        "person_px_at_m": {str(d): person_height_px(camera, d, height_m) for d in (5, 10, 20)},
        "person_row_at_m": {str(d): row_of_distance(camera, d) for d in (5, 10, 20)},
    }


def format_report(r: dict) -> str:
    """`camera_report` as the screen `rhythmjax camera` prints: one fact per line."""
    fmt = lambda x: "beyond the horizon" if not np.isfinite(x) else f"{x:.1f} m"  # noqa: E731
    hz = r["horizon_row_px"]
    lines = [
        f"focal length      {r['focal_px'][0]:.1f} px (horizontal), {r['focal_px'][1]:.1f} px "
        f"(vertical); horizontal field of view {r['hfov_deg']:.1f} deg",
        f"camera height     {r['h_m']:.2f} m",
        f"tilt              {r['tilt_deg']:.2f} deg below the horizontal",
        f"roll              {r['roll_deg']:.2f} deg",
        f"principal point   ({r['principal_point_px'][0]:.1f}, {r['principal_point_px'][1]:.1f}) "
        f"px in a {r['image_size_px'][0]} x {r['image_size_px'][1]} image at {r['fps']:g} fps",
        f"horizon           row {hz:.0f} " + ("(in the image)" if r["horizon_in_image"] else
                                              "(above the image)" if hz < 0 else
                                              "(BELOW the image: no ground in view)"),
        f"ground at rows    bottom {fmt(r['ground_m_at_bottom_row'])}, centre "
        f"{fmt(r['ground_m_at_centre_row'])}",
    ]
    if r["detection_range_m"] is None:
        lines.append(f"detection range   none: {r['no_range_reason']}")
    else:
        lo, hi = r["detection_range_m"]
        lines.append(f"detection range   {lo:.1f}-{hi:.1f} m (derived: bottom row to top row, "
                     f"or where a person is {MIN_PERSON_PX:g} px tall)")
    rows = r["person_row_at_m"]
    where = lambda d: ("" if 0 <= rows[d] < r["image_size_px"][1] else  # noqa: E731
                       " (feet below the image)" if rows[d] >= 0 else " (feet above the image)")
    sizes = ", ".join(f"{px:.0f} px at {d} m{where(d)}" if np.isfinite(px) else f"- at {d} m"
                      for d, px in r["person_px_at_m"].items())
    lines.append(f"a {r['person_height_m']:g} m person  {sizes}")
    return "\n".join(lines)
