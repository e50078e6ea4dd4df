"""Start values for the camera fit: in the camera's ground frame a (h, theta) grid with the linear
parameters solved in closed form (`grid_starts`); in a world frame of the data's own
(`fit_camera(world=True)`) a plane-to-image homography by the normalised DLT, and the camera
pose it implies."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np


def dlt_homography(X, Y, u, v) -> np.ndarray:
    """Least-squares plane-to-image homography (normalised DLT): [u, v, 1] ~ M [X, Y, 1]."""
    def norm(a, b):
        m, s = np.array([a.mean(), b.mean()]), np.sqrt(2) / np.mean(np.hypot(a - a.mean(),
                                                                             b - b.mean()))
        return np.array([[s, 0, -s * m[0]], [0, s, -s * m[1]], [0, 0, 1.0]])
    Tw, Ti = norm(X, Y), norm(u, v)
    P = np.stack([X, Y, np.ones_like(X)]).T @ Tw.T
    q = np.stack([u, v, np.ones_like(u)]).T @ Ti.T
    z = np.zeros_like(P)
    A = np.concatenate([np.hstack([P, z, -q[:, :1] * P]), np.hstack([z, P, -q[:, 1:2] * P])])
    M = np.linalg.svd(A)[2][-1].reshape(3, 3)
    return np.linalg.inv(Ti) @ M @ Tw


def pose_from_homography(M: np.ndarray, c0: dict[str, float], X, Y
                         ) -> tuple[dict[str, float], float]:
    """Start values (a f, h, theta, roll, tx, ty, yaw; `NAMES` units) and the mirror sign from a
    plane-to-image homography, with the principal point (and b/a) of `c0`: K^-1 M = [r1 r2 t]
    up to scale; a f from the orthogonality of r1, r2 (else `c0`'s)."""
    ba = c0["bf"] / c0["af"]
    B = np.array([[1, 0, -c0["uc"]], [0, 1 / ba, -c0["vc"] / ba], [0, 0, 1.0]]) @ M
    (h11, h12, _), (h21, h22, _), (h31, h32, _) = B
    a = np.array([h11 * h12 + h21 * h22, h11**2 + h21**2 - h12**2 - h22**2])
    b = np.array([h31 * h32, h31**2 - h32**2])
    w = -(a @ b) / max(a @ a, 1e-300)  # 1 / af^2
    af = 1 / math.sqrt(w) if w > 0 else c0["af"]
    B = np.diag([1 / af, 1 / af, 1.0]) @ B
    lam = 2.0 / (np.linalg.norm(B[:, 0]) + np.linalg.norm(B[:, 1]))
    if np.median(M[2, 0] * X + M[2, 1] * Y + M[2, 2]) < 0:  # the points in front of the camera
        lam = -lam
    r1, r2, t = lam * B[:, 0], lam * B[:, 1], lam * B[:, 2]
    U, _, Vt = np.linalg.svd(np.stack([r1, r2, np.cross(r1, r2)], 1))
    R = U @ Vt  # rows: camera x (right), y (down), z (axis) in world coordinates
    C = -R.T @ t
    mirror = 1.0
    if C[2] < 0:  # world Z = X x Y points down: mirror Y
        mirror, R, C = -1.0, R @ np.diag([1, -1, -1.0]), C * np.array([1, -1, -1.0])
    th = math.asin(np.clip(-R[2, 2], -1, 1))
    roll = math.asin(np.clip(R[0, 2] / math.cos(th), -1, 1))
    fx, fy = R[2, :2] / np.hypot(*R[2, :2])
    tx, ty = -(C[0] * fy - C[1] * fx), -(C[0] * fx + C[1] * fy)
    return {"af": af, "h": float(C[2]), "theta": math.degrees(th), "roll": math.degrees(roll),
            "tx": float(tx), "ty": float(ty), "yaw": math.degrees(math.atan2(fx, fy))}, mirror


@jax.jit
def grid_starts(f, u, v, x, y, uc0, vc0, fit_center):
    """Starts of `fit.camera.fit_camera`: the profile SSE (px^2) over a (h, theta) grid (m, rad),
    with (a f, Uc) and (b f, Vc) (px) solved linearly at each point (variable projection; the
    principal point held at (uc0, vc0) unless `fit_center`). Returns (sse (K,), params (K, 6) in
    `fit.camera.NAMES[:6]` order and units)."""
    hs = jnp.exp(jnp.linspace(math.log(0.2), math.log(50.0), 40))
    ths = jnp.deg2rad(jnp.linspace(0.5, 75.0, 60))
    H, TH = jnp.meshgrid(hs, ths, indexing="ij")

    def one(h, th):
        s, c = jnp.sin(th), jnp.cos(th)
        d = f + y * c + h * s
        d = jnp.where(jnp.abs(d) > 1e-3, d, 1e-3)
        gu, gv = x / d, -(y * s - h * c) / d

        def lin(g, obs, c0):
            gm, om = jnp.mean(g), jnp.mean(obs)  # obs = c + k g, by (centred) normal equations
            k_c = jnp.sum((g - gm) * (obs - om)) / jnp.maximum(jnp.sum((g - gm) ** 2), 1e-30)
            k_nc = jnp.sum(g * (obs - c0)) / jnp.maximum(jnp.sum(g * g), 1e-30)
            k = jnp.where(fit_center, k_c, k_nc)
            c_ = jnp.where(fit_center, om - k_c * gm, c0)
            return k, c_, jnp.sum((obs - c_ - k * g) ** 2)

        af, uc, su = lin(gu, u, uc0)
        bf, vc, sv = lin(gv, v, vc0)
        ok = (af > 0) & (bf > 0) & jnp.all(d > 1e-3)
        return jnp.where(ok, su + sv, jnp.inf), jnp.stack([af, bf, h, jnp.rad2deg(th), uc, vc])

    sse, par = jax.vmap(jax.vmap(one))(H, TH)
    return sse.reshape(-1), par.reshape(-1, 6)
