"""Random cameras of real video sizes, their footprints, and the acceptance study of issue 15.

The cameras: image 640x480 to 1920x1080, square pixels, a horizontal field of view of 45-90 deg,
the principal point off the image centre by up to 5 % of each side, height 1-10 m, tilt 5-40 deg,
roll +-5 deg; f is the config's (8 mm), as in (3). Footprints are straight walks of 2-6 m on the
ground the image sees (`rhythmjax.model.view.visible_range`), projected by OpenCV
(`cv2.projectPoints`) through the pin-hole that (3) is (centre (0, -f cos(theta),
h + f sin(theta)) in the ground frame, K = [[a f, 0, Uc], [0, b f, Vc], [0, 0, 1]], the image
rotated by roll about (Uc, Vc)), with Gaussian noise of `noise_px` in each coordinate.

``python -m fit.random_cameras [n_cameras] [seed] [--held-at-centre]`` runs the acceptance:
for each camera a config giving only the image size and fps, `rhythmjax-fit camera`'s own
defaults (`fit.calibrate.fit_footprints`), footprints of half the walkers for the fit and the
other half held out; it prints the held-out RMS (px per coordinate: the 1 px noise's own is 1.0,
its 2-D distance sqrt(2)) of the fitted camera, of the TRUE camera and of an OpenCV
least-squares homography fitted on the same points.
With --held-at-centre the fit is the one before issue 15 (principal point at the image centre,
roll 0: what a config giving only the image size meant then), for comparison.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import cv2
import numpy as np

from rhythmjax.model.params import Camera
from rhythmjax.model.view import visible_range


SIZES = ((640, 480), (720, 576), (800, 600), (1024, 768), (1280, 720), (1920, 1080))
F_M = 0.008  # m: the config's default f


def random_camera(rng: np.random.Generator, fps: float = 25.0) -> Camera:
    """A camera of (3) drawn as in the module doc; redrawn until the image sees at least 4 m of
    usable ground (`visible_range`)."""
    while True:
        w, h = SIZES[rng.integers(len(SIZES))]
        af = w / 2 / math.tan(math.radians(rng.uniform(45, 90)) / 2)
        cam = Camera(f=F_M, h=rng.uniform(1, 10), theta=math.radians(rng.uniform(5, 40)),
                     a=af / F_M, b=af / F_M, uc=w / 2 + rng.uniform(-0.05, 0.05) * w,
                     vc=h / 2 + rng.uniform(-0.05, 0.05) * h, roll=math.radians(rng.uniform(-5, 5)),
                     fps=fps, image_width=w, image_height=h)
        try:
            near, far = visible_range(cam)
        except ValueError:
            continue
        if far - near >= 4.0:
            return cam


def pinhole(cam: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(K, rvec, tvec) of OpenCV for the pin-hole that (3) with roll is (module doc; a = b)."""
    f, h, th, a, b, uc, vc, roll = (float(np.asarray(getattr(cam, k))) for k in
                                    ("f", "h", "theta", "a", "b", "uc", "vc", "roll"))
    s, c, sr, cr = math.sin(th), math.cos(th), math.sin(roll), math.cos(roll)
    R0 = np.array([[1.0, 0, 0], [0, -s, -c], [0, c, -s]])  # rows: camera right, down, axis
    R = np.array([[cr, -sr, 0], [sr, cr, 0], [0, 0, 1.0]]) @ R0
    C = np.array([0.0, -f * c, h + f * s])
    K = np.array([[a * f, 0, uc], [0, b * f, vc], [0, 0, 1.0]])
    return K, cv2.Rodrigues(R)[0], -R @ C


def project_cv(cam: Camera, x, y) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) px of ground points (x, y) m by `cv2.projectPoints` through `pinhole(cam)`."""
    K, rvec, tvec = pinhole(cam)
    P = np.stack([x, y, np.zeros_like(x)], 1).astype(np.float64)
    uv = cv2.projectPoints(P, rvec, tvec, K, None)[0].reshape(-1, 2)
    return uv[:, 0], uv[:, 1]


@dataclass
class Footprints:
    """Footprints of `n_walkers` straight walks: u, v (px, noisy), x, y (m), walker id, and the
    noise-free u0, v0 (px)."""

    u: np.ndarray
    v: np.ndarray
    x: np.ndarray
    y: np.ndarray
    walker: np.ndarray
    u0: np.ndarray
    v0: np.ndarray


def footprints(cam: Camera, rng: np.random.Generator, *, n_walkers: int = 40, per: int = 20,
               noise_px: float = 1.0, margin_px: float = 2.0) -> Footprints:
    """Walks of 2-6 m, `per` points each, inside the image (`margin_px` from its edges) and
    the derived detection range (`visible_range`); noise N(0, noise_px^2) on u and on v."""
    w, h = int(cam.image_width), int(cam.image_height)
    near, far = visible_range(cam)
    out = []
    while len(out) < n_walkers:
        y0 = rng.uniform(near, far)
        x0 = rng.uniform(-1.0, 1.0) * y0 * w / 2 / (float(cam.a) * float(cam.f)) * 1.2
        hd, s = rng.uniform(0, 2 * math.pi), np.linspace(0, rng.uniform(2, 6), per)
        x, y = x0 + s * math.cos(hd), y0 + s * math.sin(hd)
        if y.min() < near or y.max() > far:
            continue
        u, v = project_cv(cam, x, y)
        if (u.min() > margin_px and u.max() < w - margin_px and v.min() > margin_px
                and v.max() < h - margin_px):
            out.append((u, v, x, y, np.full(per, len(out))))
    u0, v0, x, y, wid = (np.concatenate(c) for c in zip(*out, strict=True))
    return Footprints(u0 + rng.normal(0, noise_px, u0.size), v0 + rng.normal(0, noise_px, v0.size),
                      x, y, wid, u0, v0)


def rms(du, dv) -> float:
    """RMS (px) per coordinate of residuals du, dv (u and v pooled)."""
    return float(np.sqrt(np.mean(np.concatenate([du, dv]) ** 2)))


def homography_heldout_rms(fp: Footprints, train, test) -> float:
    """Held-out RMS (px per coordinate) of ``cv2.findHomography`` (method 0, least squares)
    fitted on the training footprints."""
    src = np.stack([fp.x[train], fp.y[train]], 1)
    M, _ = cv2.findHomography(src, np.stack([fp.u[train], fp.v[train]], 1), 0)
    p = np.stack([fp.x[test], fp.y[test], np.ones(int(test.sum()))], 1) @ M.T
    return rms(p[:, 0] / p[:, 2] - fp.u[test], p[:, 1] / p[:, 2] - fp.v[test])


def only_size(size: tuple[int, int], fps: float) -> dict:
    """The config dict of the acceptance: the image size (w, h px) and fps, nothing else."""
    return {"camera": {"image_width_px": int(size[0]), "image_height_px": int(size[1]),
                       "fps": float(fps)}}


def study(n_cameras: int = 20, seed: int = 0, fit=None) -> list[dict]:  # pragma: no cover
    """One row per camera: the held-out RMS of the fit (the CLI's defaults on `only_size`'s
    config), of the true camera and of the OpenCV homography (px per coordinate), and the fit's
    verdict. `fit`: a function (u, v, x, y, image_size, fps) -> CameraFit (default: that of
    `fit.calibrate.fit_footprints`)."""
    from fit.calibrate import fit_footprints
    from rhythmjax.model.camera_np import project_3d

    fit = fit or (lambda u, v, x, y, size, fps: fit_footprints(u, v, x, y, only_size(size, fps)
                                                              ).fit)
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(n_cameras):
        cam = random_camera(rng)
        fp = footprints(cam, rng)
        test = fp.walker % 2 == 1
        train = ~test
        size = (int(cam.image_width), int(cam.image_height))
        r = fit(fp.u[train], fp.v[train], fp.x[train], fp.y[train], size, float(cam.fps))
        pu, pv = project_3d(r.camera, fp.x[test], fp.y[test], 0.0)
        tu, tv = project_3d(cam, fp.x[test], fp.y[test], 0.0)
        rows.append({"size": size, "h": float(cam.h), "theta": math.degrees(float(cam.theta)),
                     "roll": math.degrees(float(cam.roll)), "fit_rms": rms(pu - fp.u[test],
                                                                           pv - fp.v[test]),
                     "true_rms": rms(tu - fp.u[test], tv - fp.v[test]),
                     "homography_rms": homography_heldout_rms(fp, train, test),
                     "ok": r.success and not r.ill_determined, "fitted": r.fitted})
    return rows


def held_at_centre(u, v, x, y, size, fps):  # pragma: no cover - the study's comparison
    """The fit before issue 15 on the same config: principal point at the image centre, roll 0,
    (a f, b f, h, theta) fitted."""
    from fit.camera import fit_camera
    from rhythmjax.io import config_or_bad_input

    cam0 = config_or_bad_input(only_size(size, fps), "config").camera
    return fit_camera(u, v, x, y, cam0, fit=("af", "bf", "h", "theta"))


if __name__ == "__main__":  # pragma: no cover
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    before = "--held-at-centre" in sys.argv
    args = [a for a in sys.argv[2:] if not a.startswith("--")]
    rows = study(n, int(args[0]) if args else 0, held_at_centre if before else None)
    for r in rows:
        print(f"{r['size'][0]}x{r['size'][1]} h {r['h']:.2f} m tilt {r['theta']:.1f} roll "
              f"{r['roll']:+.1f}: held-out RMS fit {r['fit_rms']:.3f}, true camera "
              f"{r['true_rms']:.3f}, homography {r['homography_rms']:.3f} px"
              f"{'' if r['ok'] else '  (flagged)'}")
    f, t, hm = (np.array([r[k] for r in rows]) for k in ("fit_rms", "true_rms", "homography_rms"))
    print(f"{n} cameras: fit / noise {f.min():.3f}-{f.max():.3f} (median {np.median(f):.3f}); "
          f"fit / true camera {np.min(f / t):.3f}-{np.max(f / t):.3f}; homography / noise "
          f"{hm.min():.3f}-{hm.max():.3f}; flagged {sum(not r['ok'] for r in rows)}")
