"""The camera of (3) for host code (rendering, patch sizes, stitching, relinking): a thin float64
NumPy front on the one set of formulas in `camera` (`project_with`, `ground_with`, ...), roll
included. The camera's constants are Python floats (`host_terms`); arrays are NumPy float64.
`SCALAR` is an array namespace for plain Python floats, for callers that evaluate one point at a
time (NumPy's per-call cost on 0-d arrays would dominate there); it gives the same float64
values as the NumPy front."""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from .camera import (
    Terms,
    depth_with,
    ground_with,
    height_from_top_with,
    image_width_with,
    project_with,
    upright_size_with,
)
from .params import Camera


class HostCamera(NamedTuple):
    """A camera's parameters as Python floats: f, h (m), theta (rad), a, b (px/m), uc, vc (px),
    roll (rad). A tuple, so hashable (a cache key) and unpackable."""

    f: float
    h: float
    theta: float
    a: float
    b: float
    uc: float
    vc: float
    roll: float = 0.0


def camera_tuple(camera: Camera | tuple) -> HostCamera:
    """`HostCamera` of a `Camera` (its float32 values exactly, as float64); a `HostCamera`
    passes through, another tuple is read as one, as Python floats (a 7-tuple without the roll,
    the older form, as roll = 0)."""
    if isinstance(camera, HostCamera):
        return camera
    if isinstance(camera, tuple):
        return HostCamera(*(float(q) for q in camera))
    return HostCamera(*(float(np.asarray(getattr(camera, k))) for k in HostCamera._fields))


@functools.lru_cache(maxsize=64)
def _terms_of(host: HostCamera) -> Terms:
    return Terms(host.f, host.h, host.a, host.b, host.uc, host.vc, math.sin(host.theta),
                 math.cos(host.theta), math.sin(host.roll), math.cos(host.roll))


def host_terms(camera: Camera | tuple) -> Terms:
    """`camera.Terms` as Python floats (sines and cosines by `math`; cached per camera)."""
    return _terms_of(camera_tuple(camera))


class SCALAR:
    """The array namespace of plain Python floats and bools (`where`, `isfinite`)."""

    @staticmethod
    def where(cond, a, b):
        return a if cond else b

    isfinite = staticmethod(math.isfinite)


_SCALARS = (float, int, np.float64)


def _f64(q) -> np.ndarray:
    return np.asarray(q, np.float64)


def _scalars(*qs) -> bool:
    """True when every argument is a plain number: then the front runs on Python floats
    (`SCALAR`; the same float64 bits, without NumPy's per-call cost on 0-d arrays)."""
    return all(type(q) in _SCALARS for q in qs)


def depth_3d(camera: Camera | tuple, y, z):
    """Denominator of (3) for a point at height z (m): f + y cos(theta) + (h - z) sin(theta)."""
    return depth_with(host_terms(camera), _f64(y), _f64(z))


def project_3d(camera: Camera | tuple, x, y, z):
    """(u, v) px of the point (x, y) m on the ground plane and z m above it: equation (3) with
    roll, the camera height h replaced by h - z (`camera.project_with`). z = 0 is (3) exactly.
    Behind the camera (depth <= 1 mm, see `depth_3d`) the values are finite and meaningless.
    Arrays give arrays; numbers give Python floats."""
    if _scalars(x, y, z):
        return project_with(SCALAR, host_terms(camera), float(x), float(y), float(z))
    return project_with(np, host_terms(camera), _f64(x), _f64(y), _f64(z))


def ground_of_pixels(camera: Camera | tuple, u, v):
    """Inverse perspective: ground (x, y) m of image points (u, v) px and `ok` (below the
    horizon, in front of the camera, finite); x = y = 0 where not ok (`camera.ground_with`).
    Arrays give arrays; numbers give Python floats and a bool."""
    if _scalars(u, v):
        return ground_with(SCALAR, host_terms(camera), float(u), float(v))
    return ground_with(np, host_terms(camera), _f64(u), _f64(v))


def image_width_of(camera: Camera | tuple, width_m, y):
    """Image width (px, along the rows) of a lateral ground width (m) at distance y (m)."""
    return image_width_with(np, host_terms(camera), _f64(width_m), _f64(y))


def upright_size(camera: Camera | tuple, u, v, width_m: float, height_m: float):
    """(w, h, ok) px of an upright width_m x height_m m box standing at the foot point (u, v) px
    (`camera.upright_size_with`); NaN where not ok."""
    return upright_size_with(np, host_terms(camera), _f64(u), _f64(v), width_m, height_m)


def height_of_top(camera: Camera | tuple, u, v, v_top):
    """(H m, ok) of the upright segment standing on the ground point of the foot point (u, v) px
    whose top is seen at the image row v_top px (`camera.height_from_top_with`, the inverse of
    `upright_size`'s height): ok where (u, v) is on the ground in front of the camera and v_top
    is finite below the vertical vanishing point; H = 0 where not."""
    k = host_terms(camera)
    x, y, ok = ground_with(np, k, _f64(u), _f64(v))
    H, ok_top = height_from_top_with(np, k, x, y, _f64(v_top))
    ok = ok & ok_top
    return np.where(ok, H, 0.0), ok
