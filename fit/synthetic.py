"""Synthetic footprints from random known cameras, and the calibration study of issue 5.

Run ``python -m fit.synthetic [n_cameras]`` for the coverage, standard-error and held-out figures.
"""

from __future__ import annotations

import math
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from rhythmjax.model.camera import ground_from_image, project
from rhythmjax.model.params import Camera


def random_camera(rng: np.random.Generator, f: float = 0.008) -> Camera:
    """Height 1-8 m, tilt 8-30 deg, principal point up to 15 px off (256, 256), a f 600-1400 px,
    b/a within 4 %; redrawn until ground 6-12 m ahead is in the 512 x 512 image."""
    while True:
        af = rng.uniform(600, 1400)
        cam = Camera(f=f, h=rng.uniform(1, 8), theta=math.radians(rng.uniform(8, 30)),
                     a=af / f, b=af * rng.uniform(0.96, 1.04) / f,
                     uc=256 + rng.uniform(-15, 15), vc=256 + rng.uniform(-15, 15))
        _, v = project(cam, jnp.asarray([0.0, 0.0]), jnp.asarray([6.0, 12.0]))
        if np.all((np.asarray(v) > 20) & (np.asarray(v) < 492)):
            return cam


def truth(cam: Camera) -> dict[str, float]:
    """The camera's values in `fit.camera.NAMES` units (px, m, deg)."""
    f = float(cam.f)
    return {"af": float(cam.a) * f, "bf": float(cam.b) * f, "h": float(cam.h),
            "theta": math.degrees(float(cam.theta)), "uc": float(cam.uc), "vc": float(cam.vc)}


def footprints(cam: Camera, rng: np.random.Generator, n: int = 500, noise_px: float = 1.0,
               n_walkers: int = 25):
    """(u, v, x, y, walker): n footprints of straight walks 3-25 m ahead inside the 512 x 512
    image, (u, v) with Gaussian noise of `noise_px` (px) in each coordinate; float64."""
    per = n // n_walkers
    out = []
    with jax.enable_x64(True):
        for w in range(n_walkers):
            for _ in range(1000):
                y0, x0, hd = rng.uniform(3, 25), rng.uniform(-8, 8), rng.uniform(0, 2 * np.pi)
                s = np.linspace(0, rng.uniform(2, 6), per)
                x, y = x0 + s * np.cos(hd), y0 + s * np.sin(hd)
                u, v = (np.asarray(a) for a in project(cam, jnp.asarray(x), jnp.asarray(y)))
                if (y.min() > 3 and y.max() < 25 and u.min() > 0 and u.max() < 512
                        and v.min() > 0 and v.max() < 512):
                    break
            else:
                raise RuntimeError("could not place a walker in view")
            out.append((u, v, x, y, np.full(per, w)))
    u, v, x, y, wid = (np.concatenate(c) for c in zip(*out, strict=True))
    return (u + rng.normal(0, noise_px, u.size), v + rng.normal(0, noise_px, v.size), x, y, wid)


def ground_error_m(cam: Camera, u, v, x, y) -> np.ndarray:
    """Distance (m) between the back-projection of (u, v) through `cam` and the true (x, y)."""
    with jax.enable_x64(True):
        gx, gy, _ = ground_from_image(cam, jnp.asarray(u), jnp.asarray(v))
        return np.hypot(np.asarray(gx) - x, np.asarray(gy) - y)


def se_over_spread(cam: Camera, camera0: Camera, fit: tuple[str, ...], n_draws: int,
                   seed: int) -> np.ndarray:
    """Mean reported standard error over the sample spread of the estimates, per fitted
    parameter, over `n_draws` fresh noise draws of the footprints (1 = honest error bars)."""
    from .camera import fit_camera

    est, ses = [], []
    for i in range(n_draws):
        u, v, x, y, _ = footprints(cam, np.random.default_rng(seed + i))
        r = fit_camera(u, v, x, y, camera0, fit=fit)
        est.append([r.values[k] for k in fit])
        ses.append([r.se[k] for k in fit])
    return np.mean(ses, axis=0) / np.std(est, axis=0, ddof=1)


def study(n_cameras: int = 20, seed: int = 0) -> None:  # pragma: no cover - a script
    from fit.camera import fit_camera, reprojection_rms

    rng = np.random.default_rng(seed)
    for fit in (("af", "bf", "h", "theta"), ("af", "h", "theta", "uc", "vc")):
        inside, rms_ratio, gerr, se_h, se_t = 0, [], [], [], []
        for _ in range(n_cameras):
            cam = random_camera(rng)
            tr = truth(cam)
            u, v, x, y, w = footprints(cam, rng, n=1000)
            train = w % 2 == 0
            test = ~train
            c0 = (Camera(uc=tr["uc"], vc=tr["vc"]) if "uc" not in fit
                  else Camera(a=1e5, b=1e5 * tr["bf"] / tr["af"]))
            r = fit_camera(u[train][:500], v[train][:500], x[train][:500], y[train][:500], c0,
                           fit=fit)
            ok = all(abs(r.values[k] - tr[k]) <= 3 * r.se[k] for k in fit)
            inside += ok
            rms_ratio.append(reprojection_rms(r.camera, u[test], v[test], x[test], y[test]))
            gerr.append(np.median(ground_error_m(r.camera, u[test], v[test], x[test], y[test])))
            se_h.append(r.se["h"])
            se_t.append(r.se["theta"])
        print(f"fit {fit}: truth inside 3 sigma for {inside}/{n_cameras} cameras; held-out RMS / "
              f"noise {min(rms_ratio):.3f}-{max(rms_ratio):.3f}; median ground error "
              f"{100 * np.median(gerr):.1f} cm; SE h {100 * min(se_h):.1f}-"
              f"{100 * max(se_h):.1f} cm, SE theta {min(se_t):.3f}-{max(se_t):.3f} deg")
    cam = random_camera(np.random.default_rng(seed + 1))
    fit = ("af", "bf", "h", "theta")
    c0 = Camera(uc=float(cam.uc), vc=float(cam.vc))
    ratio = se_over_spread(cam, c0, fit, 200, seed=1000)
    print("reported SE / Monte-Carlo spread (200 draws):",
          ", ".join(f"{k} {q:.3f}" for k, q in zip(fit, ratio, strict=True)))
    u, v, x, y, _ = footprints(cam, np.random.default_rng(7), n=10_000, n_walkers=500)
    fit_camera(u, v, x, y, c0, fit=fit)
    t0 = time.perf_counter()
    r = fit_camera(u, v, x, y, c0, fit=fit)
    print(f"10 000 footprints: {time.perf_counter() - t0:.3f} s after compilation, "
          f"{r.num_steps} steps")


if __name__ == "__main__":  # pragma: no cover
    study(int(sys.argv[1]) if len(sys.argv) > 1 else 20)
