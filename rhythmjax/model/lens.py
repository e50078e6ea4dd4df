"""Calibrated pin-hole cameras as a user's calibration holds them, in float64 NumPy: the pin-hole
with OpenCV's lens distortion (`Pinhole`, `opencv_distortion`) and Tsai's model (`TsaiCalibration`,
the PETS / ETISEO XML). `camera_from` turns them into the camera of (3).

Conventions (OpenCV's and Tsai's alike): a world point X maps to camera coordinates
x_c = R X + t (x right, y down, z along the optical axis), normalised coordinates (x_c / z_c,
y_c / z_c), the lens distortion acts on those, and pixels are K [x_d, y_d, 1] (u right, v down).
World coordinates are metres here; readers convert (Tsai's millimetres, `--world-unit`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


Distortion = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
OPENCV_COUNTS = (4, 5, 8, 12, 14)  # numbers of distortion coefficients cv2 accepts


def opencv_distortion(coeffs) -> Distortion | None:
    """OpenCV's distortion of normalised coordinates for the coefficients (k1, k2, p1, p2[, k3[,
    k4, k5, k6[, s1, s2, s3, s4[, tau_x, tau_y]]]]): radial (rational), tangential and thin prism
    terms, as `cv2.projectPoints` applies them. None when every coefficient is 0. Raises
    ValueError for another count or a tilted sensor (tau_x, tau_y not 0)."""
    d = np.asarray(coeffs, np.float64).ravel()
    if d.size not in OPENCV_COUNTS:
        raise ValueError(f"expected 4, 5, 8, 12 or 14 distortion coefficients, got {d.size}")
    if d.size == 14 and np.any(d[12:] != 0):
        raise ValueError("a tilted sensor (tau_x, tau_y not 0) is not supported")
    if not np.any(d):
        return None
    k = np.zeros(12)
    k[: min(d.size, 12)] = d[:12]
    k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = k

    def distort(x, y):
        r2 = x * x + y * y
        r4 = r2 * r2
        radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) + s1 * r2 + s2 * r4
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + s3 * r2 + s4 * r4
        return xd, yd

    return distort


def undistort(distort: Distortion | None, xd, yd, iterations: int = 40):
    """Normalised (x, y) whose distortion is (xd, yd), by fixed-point iteration, and `ok` where
    it converged to 1e-9 (strong distortion can fold the image near its edges)."""
    xd, yd = np.asarray(xd, np.float64), np.asarray(yd, np.float64)
    if distort is None:
        return xd, yd, np.isfinite(xd) & np.isfinite(yd)
    x, y = xd.copy(), yd.copy()
    with np.errstate(all="ignore"):
        for _ in range(iterations):
            ex, ey = distort(x, y)
            x, y = x + (xd - ex), y + (yd - ey)
        ex, ey = distort(x, y)
        ok = np.hypot(ex - xd, ey - yd) < 1e-9
    return x, y, ok & np.isfinite(x) & np.isfinite(y)


@dataclass(frozen=True)
class Pinhole:
    """A calibrated camera: K (3x3, px; skew allowed), R (world -> camera rotation), t (m),
    `distort` (normalised -> distorted normalised coordinates, None for none)."""

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    distort: Distortion | None = None

    @property
    def centre(self) -> np.ndarray:
        """Camera centre in world coordinates (m), -R^T t."""
        return -self.R.T @ self.t

    def project(self, X):
        """(u, v) px of world points X (..., 3) m, and their depth z_c (m; > 0 in front)."""
        pc = np.asarray(X, np.float64) @ self.R.T + self.t
        with np.errstate(divide="ignore", invalid="ignore"):
            x, y = pc[..., 0] / pc[..., 2], pc[..., 1] / pc[..., 2]
        if self.distort is not None:
            x, y = self.distort(x, y)
        K = self.K
        return K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2], pc[..., 2]

    def ground_of_pixels(self, u, v):
        """World (x, y) m on the ground z = 0 of pixels (u, v), and `ok` (the ray goes down,
        the undistortion converged); x = y = NaN where not ok."""
        u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
        K = self.K
        yd = (v - K[1, 2]) / K[1, 1]
        xd = (u - K[0, 2] - K[0, 1] * yd) / K[0, 0]
        x, y, ok = undistort(self.distort, xd, yd)
        ray = np.stack([x, y, np.ones_like(x)], -1) @ self.R  # R^T [x, y, 1]
        c = self.centre
        ok = ok & (ray[..., 2] < -1e-12)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(ok, -c[2] / ray[..., 2], np.nan)
        return c[0] + s * ray[..., 0], c[1] + s * ray[..., 1], ok


def rotation_xyz(rx: float, ry: float, rz: float) -> np.ndarray:
    """R = Rz(rz) Ry(ry) Rx(rx) (rad), Tsai's order."""
    ca, sa, cb, sb, cg, sg = (math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry),
                              math.cos(rz), math.sin(rz))
    Rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    Ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    Rz = np.array([[cg, -sg, 0], [sg, cg, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


@dataclass(frozen=True)
class TsaiCalibration:
    """Tsai (1987) camera as PETS / ETISEO write it: world (mm) -> camera x_c = R X + T with
    R = Rz Ry Rx (`Rxyz`, rad); undistorted sensor point (mm) X_u = focal x_c / z_c; radial
    distortion X_u = X_d (1 + kappa1 r_d^2) (kappa1 in mm^-2); pixels u = cx + sx X_d / dpx,
    v = cy + Y_d / dy (dpx, dy mm/px) at the calibration's size `width` x `height` px (None when
    the file does not say). Methods take world metres and a pixel `scale` (the video's size over
    the calibration's)."""

    focal: float  # mm
    kappa1: float  # mm^-2
    cx: float
    cy: float  # px
    sx: float
    dpx: float
    dy: float  # mm/px
    T: tuple[float, float, float]  # mm
    Rxyz: tuple[float, float, float]  # rad
    width: int | None = None
    height: int | None = None  # px

    @property
    def R(self) -> np.ndarray:
        return rotation_xyz(*self.Rxyz)

    @property
    def centre_m(self) -> np.ndarray:
        """Camera centre (m, world), -R^T T."""
        return -self.R.T @ np.asarray(self.T, np.float64) / 1000.0

    @property
    def h_m(self) -> float:
        """Height of the camera centre above the ground z = 0 (m)."""
        return float(self.centre_m[2])

    @property
    def theta_rad(self) -> float:
        """Depression of the optical axis below the horizontal."""
        return float(math.asin(-self.R[2, 2]))

    @property
    def roll_rad(self) -> float:
        """The camera's rotation about its optical axis (image rotated by +roll about the
        principal point, u right, v down): sin(roll) = (camera x axis)_z / cos(theta)."""
        return float(math.asin(self.R[0, 2] / math.cos(self.theta_rad)))

    @property
    def yaw_rad(self) -> float:
        """Heading of the optical axis on the ground: atan2(axis_y, axis_x) (world)."""
        return float(math.atan2(self.R[2, 1], self.R[2, 0]))

    def focal_px(self, scale: float = 1.0) -> tuple[float, float]:
        """(horizontal focal sx / dpx, vertical focal / dy) in px at the scaled size."""
        return (self.focal * self.sx / self.dpx * scale, self.focal / self.dy * scale)

    def distortion(self) -> Distortion | None:
        """Tsai's radial distortion on normalised coordinates (None for kappa1 = 0): r_u =
        focal |x_n| mm, r_d solves r_d (1 + kappa1 r_d^2) = r_u (Newton), x_d = x_n r_d / r_u."""
        k, f = self.kappa1, self.focal
        if k == 0:
            return None

        def distort(x, y):
            ru = f * np.hypot(x, y)
            rd = ru.copy()
            for _ in range(20):
                rd = rd - (rd * (1 + k * rd**2) - ru) / (1 + 3 * k * rd**2)
            s = np.where(ru > 0, rd / np.where(ru > 0, ru, 1.0), 1.0)
            return x * s, y * s

        return distort

    def pinhole(self, scale: float = 1.0) -> Pinhole:
        """The calibration as a `Pinhole` in metres at the scaled pixel size."""
        fu, fv = self.focal_px(scale)
        K = np.array([[fu, 0.0, self.cx * scale], [0.0, fv, self.cy * scale], [0.0, 0.0, 1.0]])
        return Pinhole(K, self.R, np.asarray(self.T, np.float64) / 1000.0, self.distortion())

    def world_to_image(self, x, y, z=0.0, scale: float = 1.0):
        """(u, v) px of world points (m), radial distortion included."""
        X = np.stack(np.broadcast_arrays(*(np.asarray(q, np.float64) for q in (x, y, z))), -1)
        u, v, _ = self.pinhole(scale).project(X)
        return u, v

    def ground_of_image(self, u, v, scale: float = 1.0):
        """(x, y) m on the ground z = 0 of image points (px), the distortion undone exactly;
        NaN above the horizon."""
        xd = (np.asarray(u, np.float64) / scale - self.cx) * self.dpx / self.sx
        yd = (np.asarray(v, np.float64) / scale - self.cy) * self.dy
        k = 1 + self.kappa1 * (xd**2 + yd**2)
        ray = np.stack([xd * k, yd * k, np.full_like(xd, self.focal)], -1) @ self.R  # R^T ray
        c = self.centre_m
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(ray[..., 2] < 0, -c[2] / ray[..., 2], np.nan)
        return c[0] + s * ray[..., 0], c[1] + s * ray[..., 1]
