"""The camera of (3) from what a user has, in float64 NumPy: a focal length (or field of view),
height and tilt; a calibrated pin-hole K, R, t with OpenCV's distortion; a Tsai calibration; an
image-ground homography. Each gives a `CameraFrom`: the config's camera section, the planar
transform from the source's world to the ground frame of (3), and how far (3) is from the source.

Why this can be exact: (3) is a pin-hole with principal point (uc, vc), focal lengths a f and
b f (px), no skew, whose centre is at (0, -f cos(theta), h + f sin(theta)) of its own ground
frame (its depth f + y cos(theta) + h sin(theta) is the distance along the optical axis from
there), the image rotated by `roll` about (uc, vc). So a pin-hole at height H (m) looking down
by theta is (3) with h = H - f sin(theta), and a world ground point enters (3)'s frame by a
rotation about the camera's foot, y' = (its distance ahead of the foot) - f cos(theta)
(`GroundTransform`).

Assumed of a world frame (and checked): ground plane z = 0, z up, the camera above it and
looking down (tilt > 0), rolled less than 45 deg. A camera with square pixels and no skew or
lens distortion converts exactly (to float64 rounding); a f != b f is exact without roll. What
(3) cannot hold (lens distortion, skew, a f != b f with roll, a homography that is no
square-pixel camera) is not approximated silently: `residual_max_px` / `residual_rms_px` are the
distances between the source's own image of ground points and (3)'s, over the ground the image
sees (a grid of pixels, ground points within `MAX_GROUND_M` of the camera's foot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .camera_np import HostCamera, project_3d
from .lens import Pinhole, TsaiCalibration, opencv_distortion
from .params import Camera, ConfigError, config_from_dict
from .view import horizon_row


MAX_GROUND_M = 200.0  # m: ground points farther from the camera's foot are left out of residuals
GRID = (49, 37)  # pixels across x down the image at which the residual is measured
F_M = 0.008  # m: the config's f when the source gives none (only a f, b f and h - ... matter)
MAX_ROLL_DEG = 45.0  # the config's bound
CONVENTIONS = ("image-rowcol", "image-uv", "ground-to-image")


class CameraError(ConfigError):
    """The source gives no camera of (3); `key` names the field (K, R, t, H, tilt_deg, ...)."""

    def __init__(self, key: str, message: str):
        super().__init__(key, message)
        self.message = message


@dataclass(frozen=True)
class GroundTransform:
    """World (x, y) in world units -> the ground frame of (3) (m): scale by `unit_m`, negate y
    when `mirror` (a left-handed world, or one with z down), then rotate about the camera's foot
    (`foot_x_m`, `foot_y_m`, world m) so that y' runs along the optical axis's heading
    `heading_rad` (from world x towards world y) and x' to its right, and shift y' back by
    `back_m` = f cos(theta)."""

    heading_rad: float
    foot_x_m: float
    foot_y_m: float
    back_m: float
    mirror: bool = False
    unit_m: float = 1.0

    def matrix(self) -> np.ndarray:
        """The 2x3 affine [A | b]: (x', y') = A (x, y) + b, x and y in world units."""
        c, s = math.cos(self.heading_rad), math.sin(self.heading_rad)
        rot = np.array([[s, -c], [c, s]])
        A = rot @ np.diag([1.0, -1.0 if self.mirror else 1.0]) * self.unit_m
        b = -rot @ np.array([self.foot_x_m, self.foot_y_m]) - np.array([0.0, self.back_m])
        return np.column_stack([A, b])

    def apply(self, x, y):
        """(x', y') m in the ground frame of (3) of world points (x, y) (world units)."""
        m = self.matrix()
        x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
        return m[0, 0] * x + m[0, 1] * y + m[0, 2], m[1, 0] * x + m[1, 1] * y + m[1, 2]

    def inverse(self, gx, gy):
        """World (x, y) (world units) of ground-frame points (x', y') m."""
        m = self.matrix()
        A_inv = np.linalg.inv(m[:, :2])
        dx, dy = np.asarray(gx, np.float64) - m[0, 2], np.asarray(gy, np.float64) - m[1, 2]
        return A_inv[0, 0] * dx + A_inv[0, 1] * dy, A_inv[1, 0] * dx + A_inv[1, 1] * dy

    def as_dict(self) -> dict:
        return {"heading_deg": math.degrees(self.heading_rad),
                "camera_foot_world_m": [self.foot_x_m, self.foot_y_m],
                "back_m": self.back_m, "mirror_world_y": self.mirror, "world_unit_m": self.unit_m,
                "matrix_2x3": self.matrix().tolist()}


@dataclass(frozen=True)
class CameraFrom:
    """A camera of (3) from a source. `section`: the config's camera section (float64; keys of
    `params`); `transform`: world -> ground frame of (3) (None without a world frame);
    `residual_max_px`, `residual_rms_px` over `n_points` ground points (0 when exact);
    `unrepresented`: what of the source (3) cannot hold; `notes`: what was assumed or read."""

    section: dict
    transform: GroundTransform | None = None
    residual_max_px: float = 0.0
    residual_rms_px: float = 0.0
    n_points: int = 0
    unrepresented: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    def camera(self) -> Camera:
        """The `Camera` (float32 fields) of the section, defaults for what it leaves out."""
        return config_from_dict({"camera": self.section}).camera

    def host(self) -> HostCamera:
        return host_camera(self.section)

    def project_world(self, x, y, z=0.0):
        """(u, v) px by (3) of world points (world units; z m above the ground)."""
        gx, gy = self.transform.apply(x, y) if self.transform else (x, y)
        return project_3d(self.host(), gx, gy, np.zeros_like(np.asarray(gx)) + z)


def host_camera(section: dict) -> HostCamera:
    """The float64 `HostCamera` of a camera section (principal point: the image centre when the
    section leaves it out)."""
    s = section
    return HostCamera(s.get("f_m", F_M), s["h_m"], math.radians(s["theta_deg"]),
                      s["a_px_per_m"], s["b_px_per_m"],
                      s.get("uc_px", s["image_width_px"] / 2.0),
                      s.get("vc_px", s["image_height_px"] / 2.0),
                      math.radians(s.get("roll_deg", 0.0)))


def horizon_of(section: dict) -> float:
    """The horizon's row (px) at the principal point's column (`view.horizon_row` of the
    section's float64 camera)."""
    return horizon_row(host_camera(section))


# ----------------------------------------------------------------------------------------------
# a pin-hole -> (3)

def section_of_pinhole(p: Pinhole, image_size, *, f_m: float = F_M, mirror: bool = False,
                       unit_m: float = 1.0) -> tuple[dict, GroundTransform, float]:
    """(camera section, transform, off) of the undistorted pin-hole `p` (world m, z up) in an
    image of `image_size` (w, h) px: heading and tilt from the optical axis, the roll and
    a f, b f from K times the rotation about the axis (Procrustes: the rotation nearest to it,
    then its diagonal); `off` (px) is what that leaves, |skew-like part| of K R_axis (0 for
    square pixels, or no roll and no skew). Raises `CameraError` naming t (camera under the
    ground), R (looking up or straight down, rolled 45 deg or more) or K."""
    K, R = np.asarray(p.K, np.float64), np.asarray(p.R, np.float64)
    if not np.all(np.isfinite(K)) or K.shape != (3, 3) or np.any(K[2] != (0, 0, 1)) or K[1, 0]:
        raise CameraError("K", "expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]]")
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise CameraError("K", f"focal lengths must be > 0, got fx {K[0, 0]:g}, fy {K[1, 1]:g}")
    err = np.abs(R @ R.T - np.eye(3)).max() if R.shape == (3, 3) else np.inf
    if not err < 1e-6:
        raise CameraError("R", f"not a rotation matrix (|R R^T - I| = {err:.2g})")
    if np.linalg.det(R) < 0:
        raise CameraError("R", "a reflection (det R = -1), not a rotation")
    C = p.centre
    if not C[2] > 0:
        raise CameraError("t", f"the camera centre is {-C[2]:.4g} m below the ground plane z = 0 "
                          "(world z must point up; a frame with z down needs --world-z-down)")
    axis = R[2]
    tilt = math.degrees(math.atan2(-axis[2], math.hypot(axis[0], axis[1])))
    if not tilt > 0:
        raise CameraError("R", f"the camera looks {-tilt:.1f} deg above the horizontal (at the "
                          "sky); (3) needs a camera looking down")
    if math.hypot(axis[0], axis[1]) < 1e-9:
        raise CameraError("R", "the camera looks straight down; (3) needs a tilt below 90 deg")
    theta, psi = math.radians(tilt), math.atan2(axis[1], axis[0])
    right = np.array([math.sin(psi), -math.cos(psi), 0.0])
    R3 = np.stack([right, np.cross(axis, right), axis])  # world -> camera of (3) before roll
    A = K[:2, :2] @ (R @ R3.T)[:2, :2]
    roll = math.atan2(A[1, 0] - A[0, 1], A[0, 0] + A[1, 1])
    if abs(math.degrees(roll)) >= MAX_ROLL_DEG:
        raise CameraError("R", f"the image is rolled by {math.degrees(roll):.1f} deg; (3) takes "
                          f"less than {MAX_ROLL_DEG:g} (an image on its side or upside down?)")
    c, s = math.cos(roll), math.sin(roll)
    D = np.array([[c, s], [-s, c]]) @ A  # Rot(roll)^T A: diag(a f, b f) when representable
    h = float(C[2]) - f_m * math.sin(theta)
    if not h > 0:
        raise CameraError("t", f"camera height {C[2]:.4g} m is below f sin(theta)")
    w, hh = (int(q) for q in image_size)
    section = {"f_m": float(f_m), "h_m": h, "theta_deg": tilt,
               "a_px_per_m": float(D[0, 0]) / f_m, "b_px_per_m": float(D[1, 1]) / f_m,
               "uc_px": float(K[0, 2]), "vc_px": float(K[1, 2]),
               "roll_deg": math.degrees(roll), "image_width_px": w, "image_height_px": hh}
    tr = GroundTransform(psi, float(C[0]), float(C[1]), f_m * math.cos(theta), mirror, unit_m)
    return section, tr, float(np.hypot(D[0, 1], D[1, 0]))


def visible_samples(section: dict, transform: GroundTransform, image_size, project, ground):
    """World ground points the source images inside the image, and their source pixels:
    (x, y, u, v) arrays. `ground(u, v) -> (x, y, ok)` gives the ground points (world units) of a
    `GRID` of pixels, `project(x, y) -> (u, v, in_front)` the source's pixels of them; kept are
    those in front, inside the image (half a pixel of slack for rounding at its edges) and
    within `MAX_GROUND_M` of the camera's foot (by `transform`). Raises `CameraError` when none
    are (naming the horizon's row of `section`)."""
    w, h = image_size
    uu, vv = np.meshgrid(np.linspace(0, w, GRID[0]), np.linspace(0, h, GRID[1]))
    x, y, ok = ground(uu.ravel(), vv.ravel())
    x, y = np.where(ok, x, 0.0), np.where(ok, y, 0.0)
    gx, gy = transform.apply(x, y)
    ok = ok & (np.hypot(gx, gy + transform.back_m) <= MAX_GROUND_M)
    with np.errstate(all="ignore"):
        us, vs, front = project(x, y)
    ok = ok & front & (us > -0.5) & (us < w + 0.5) & (vs > -0.5) & (vs < h + 0.5)
    if not np.any(ok):
        raise CameraError("camera", f"the image sees no ground within {MAX_GROUND_M:g} m (the "
                          f"horizon is at row {horizon_of(section):.0f})")
    return x[ok], y[ok], us[ok], vs[ok]


def distances_px(section: dict, transform: GroundTransform, samples) -> np.ndarray:
    """|(3)'s pixel - the source's| (px) of `visible_samples`."""
    x, y, us, vs = samples
    gx, gy = transform.apply(x, y)
    u3, v3 = project_3d(host_camera(section), gx, gy, np.zeros_like(gx))
    return np.hypot(u3 - us, v3 - vs)


def residual_px(section: dict, transform: GroundTransform, image_size, project, ground):
    """(max, RMS, n): the distance (px) between the source's image of the ground it sees and
    (3)'s (`section` through `transform`), over `visible_samples`."""
    d = distances_px(section, transform,
                     visible_samples(section, transform, image_size, project, ground))
    return float(d.max()), float(np.sqrt(np.mean(d * d))), int(d.size)


def from_pinhole(p: Pinhole, image_size, *, f_m: float = F_M, mirror: bool = False,
                 unit_m: float = 1.0, extra=(), notes=(), fps=None) -> CameraFrom:
    """`CameraFrom` of a pin-hole in world metres (world points of the transform in world units
    of `unit_m` m, y negated first when `mirror`); the residual includes its distortion."""
    section, tr, off = section_of_pinhole(p, image_size, f_m=f_m, mirror=mirror, unit_m=unit_m)
    sy = -1.0 if mirror else 1.0

    def project(x, y):
        X = np.stack([x * unit_m, sy * y * unit_m, np.zeros_like(x)], -1)
        u, v, z = p.project(X)
        return u, v, z > 0

    def ground(u, v):
        x, y, ok = p.ground_of_pixels(u, v)
        return x / unit_m, sy * y / unit_m, ok

    what = list(extra)
    if p.distort is not None:
        what.insert(0, "lens distortion")
    if p.K[0, 1] != 0:
        what.append("skew")
    elif off > 1e-9 * p.K[0, 0]:
        what.append("fx != fy with roll")
    if fps is not None:
        section["fps"] = float(fps)
    mx, rms, n = residual_px(section, tr, image_size, project, ground)
    return CameraFrom(section, tr, mx, rms, n, tuple(what), tuple(notes))


def scale_to(image_size, calibration_size, what: str) -> float:
    """The factor from `calibration_size` to `image_size` (w, h px): one scale for both axes
    (within 0.5 %), else `CameraError` naming `what`."""
    (w, h), (cw, ch) = image_size, calibration_size
    sx, sy = w / cw, h / ch
    if abs(sx - sy) > 0.005 * sx:
        raise CameraError(what, f"the {w}x{h} image is not a scaled copy of the {cw}x{ch} "
                          f"calibration (x scale {sx:.4g}, y scale {sy:.4g})")
    return sx


# ----------------------------------------------------------------------------------------------
# the sources

def camera_from_intrinsics(*, h_m: float, tilt_deg: float, image_size,
                           focal_px: float | None = None, hfov_deg: float | None = None,
                           roll_deg: float = 0.0, principal_point=None, fps=None,
                           f_m: float = F_M) -> CameraFrom:
    """(3) of a square-pixel camera: focal length `focal_px` (px) or horizontal field of view
    `hfov_deg` across the image width, its centre `h_m` m above the ground, looking down by
    `tilt_deg`, rolled by `roll_deg`, principal point (u, v) px (None: the image centre, left
    out of the section so that it follows the video). Exact: h = h_m - f sin(tilt); the ground
    frame is the camera foot's, y shifted back by f cos(tilt)."""
    w, hh = (int(q) for q in image_size)
    if (focal_px is None) == (hfov_deg is None):
        raise CameraError("focal_px", "give the focal length in px or the field of view, one")
    if focal_px is None:
        if not 0 < hfov_deg < 180:
            raise CameraError("hfov_deg", f"must be in (0, 180) deg, got {hfov_deg:g}")
        focal_px = w / 2 / math.tan(math.radians(hfov_deg) / 2)
    for key, v, ok in (("focal_px", focal_px, focal_px > 0), ("h_m", h_m, h_m > 0),
                       ("tilt_deg", tilt_deg, 0 < tilt_deg < 90),
                       ("roll_deg", roll_deg, abs(roll_deg) < MAX_ROLL_DEG)):
        if not (math.isfinite(v) and ok):
            raise CameraError(key, {"tilt_deg": "must be in (0, 90) deg below the horizontal",
                                    "roll_deg": f"must be within +-{MAX_ROLL_DEG:g} deg"}.get(
                                        key, "must be > 0") + f", got {v:g}")
    th = math.radians(tilt_deg)
    section = {"f_m": float(f_m), "h_m": h_m - f_m * math.sin(th), "theta_deg": float(tilt_deg),
               "a_px_per_m": focal_px / f_m, "b_px_per_m": focal_px / f_m,
               "roll_deg": float(roll_deg), "image_width_px": w, "image_height_px": hh}
    if principal_point is not None:
        section["uc_px"], section["vc_px"] = (float(q) for q in principal_point)
    if fps is not None:
        section["fps"] = float(fps)
    if not horizon_of(section) < hh:
        raise CameraError("tilt_deg", "the horizon is below the image: it sees no ground")
    return CameraFrom(section)


def camera_from_krt(K, t, *, image_size, R=None, rvec=None, dist=None, calibration_size=None,
                    fps=None, f_m: float = F_M, unit_m: float = 1.0,
                    z_down: bool = False) -> CameraFrom:
    """(3) of an OpenCV-style calibration: x_cam = R X + t (R, or the Rodrigues vector `rvec`),
    K (px), `dist` OpenCV's coefficients; t and the world in units of `unit_m` m, the ground
    z = 0 with z up (`z_down`: z points down, the world is turned over about its x axis and its
    y mirrored). K is scaled to `image_size` when `calibration_size` (w, h) differs."""
    K = np.array(K, np.float64)
    if R is None:
        R = rodrigues(rvec)
    R = np.asarray(R, np.float64)
    notes = []
    if calibration_size is not None and tuple(calibration_size) != tuple(image_size):
        s = scale_to(image_size, calibration_size, "image_size")
        K[:2] *= s
        notes.append(f"K scaled by {s:.6g} from the calibration's {calibration_size[0]}x"
                     f"{calibration_size[1]} to {image_size[0]}x{image_size[1]}")
    try:
        distort = None if dist is None else opencv_distortion(dist)
    except ValueError as e:
        raise CameraError("dist", str(e)) from None
    if z_down:
        R = R @ np.diag([1.0, -1.0, -1.0])
    p = Pinhole(K, R, np.asarray(t, np.float64).ravel() * unit_m, distort)
    return from_pinhole(p, image_size, f_m=f_m, mirror=z_down, unit_m=unit_m, notes=notes,
                        fps=fps)


def camera_from_tsai(tsai: TsaiCalibration, *, image_size=None, fps=None) -> CameraFrom:
    """(3) of a Tsai calibration (world mm in the file; the transform takes world metres),
    scaled to `image_size` when it differs from the calibration's size (None: that size)."""
    cal = None if tsai.width is None or tsai.height is None else (tsai.width, tsai.height)
    notes = []
    if image_size is None:
        if cal is None:
            raise CameraError("Geometry", "the calibration does not give its image size; give "
                              "the video or the image size")
        image_size = cal
    if cal is None:
        cal = tuple(image_size)
        notes.append(f"the calibration does not give its image size: assumed {cal[0]}x{cal[1]}")
    scale = 1.0 if tuple(cal) == tuple(image_size) else scale_to(image_size, cal, "Geometry")
    if scale != 1.0:
        notes.append(f"calibration {cal[0]}x{cal[1]} scaled by {scale:.6g} to "
                     f"{image_size[0]}x{image_size[1]}")
    return from_pinhole(tsai.pinhole(scale), image_size, f_m=tsai.focal / 1000.0, notes=notes,
                        fps=fps)


def rodrigues(rvec) -> np.ndarray:
    """The rotation matrix of a Rodrigues vector (rad; OpenCV's cv2.Rodrigues)."""
    r = np.asarray(rvec, np.float64).ravel()
    if r.size != 3 or not np.all(np.isfinite(r)):
        raise CameraError("rvec", f"expected 3 finite numbers, got {r.size}")
    a = float(np.linalg.norm(r))
    if a == 0:
        return np.eye(3)
    k = r / a
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * Kx + (1 - math.cos(a)) * Kx @ Kx
