"""The camera of (3) in NumPy float64 for points above the ground (synthetic rendering): a point
z m above the ground is seen as a ground point by a camera h - z high. z = 0 is (3) exactly, with
roll = 0 (the renderer draws for the paper's camera)."""

from __future__ import annotations

import math

import numpy as np

from .params import Camera


def camera_tuple(camera: Camera | tuple) -> tuple[float, ...]:
    """(f, h, theta, a, b, uc, vc) as Python floats (m, m, rad, px/m, px/m, px, px); a tuple
    passes through unchanged. The roll extension is not carried: these NumPy mirrors of (3)
    serve the renderer and the pedestrian patches, both for the paper's roll-free camera."""
    if isinstance(camera, tuple):
        return camera
    return tuple(float(np.asarray(getattr(camera, k))) for k in ("f", "h", "theta", "a", "b",
                                                                     "uc", "vc"))


def depth_3d(camera: Camera | tuple, y, z):
    """Denominator of (3) for a point at height z (m): f + y cos(theta) + (h - z) sin(theta)."""
    f, h, th = camera_tuple(camera)[:3]
    return f + np.asarray(y, np.float64) * math.cos(th) + (h - np.asarray(z, np.float64)) * \
        math.sin(th)


def project_3d(camera: Camera | tuple, x, y, z):
    """(u, v) px of the point (x, y) m on the ground plane and z m above it: equation (3) with the
    camera height h replaced by h - z (the camera at height h looks down by theta; a point z
    above the ground is seen as a ground point by a camera h - z high). z = 0 is (3) exactly.
    NumPy float64; no check for points behind the camera (see `depth_3d`)."""
    f, h, th, a, b, uc, vc = camera_tuple(camera)
    x, y, z = (np.asarray(q, np.float64) for q in (x, y, z))
    s, c = math.sin(th), math.cos(th)
    d = f + y * c + (h - z) * s
    return uc + a * f * x / d, vc - b * f * (y * s - (h - z) * c) / d


def ground_of_pixels(camera: Camera, u, v):
    """Inverse perspective (NumPy): ground (x, y) of pixels (u, v) and a below-horizon mask."""
    f, h, th, a, b, uc, vc = camera_tuple(camera)
    s, c = math.sin(th), math.cos(th)
    dv = vc - v
    den = b * f * s - dv * c
    ok = den > 1e-6 * b * f
    den = np.where(ok, den, 1.0)
    y = (dv * (f + h * s) + b * f * h * c) / den
    d = f + y * c + h * s
    ok &= d > 1e-3
    x = (u - uc) * np.where(ok, d, 1.0) / (a * f)
    return np.where(ok, x, 0.0), np.where(ok, y, 0.0), ok
