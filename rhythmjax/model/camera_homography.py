"""The camera of (3) from an image-ground homography (ETH's H.txt and the like), float64 NumPy.

The ground-to-image homography G ~ K [r1 r2 t] of a pin-hole with square pixels and a known
principal point (the image centre unless given) holds its focal length f in two constraints,
r1 . r2 = 0 and |r1| = |r2|, both linear in 1 / f^2: solved in least squares (closed form). Then
r1, r2, t follow up to a sign, R is the rotation nearest to [r1 r2 r1 x r2], and of the four
readings (the sign, the world's y mirrored or not) the one kept has the camera above the ground,
looking down, rolled less than 45 deg. (3) of that pin-hole (`camera_from.from_pinhole`) is then
compared with H's own mapping over the ground the image sees: a general homography has 8 degrees
of freedom and this camera 7, so the distance is stated (`CameraFrom.residual_*`), not hidden.
"""

from __future__ import annotations

import math

import numpy as np

from .camera_from import (
    CONVENTIONS,
    F_M,
    MAX_ROLL_DEG,
    CameraError,
    CameraFrom,
    GroundTransform,
    distances_px,
    from_pinhole,
    host_camera,
    section_of_pinhole,
    visible_samples,
)
from .camera_np import project_3d
from .lens import Pinhole


SINGULAR = 1e-12  # smallest / largest singular value under which H is singular


def ground_to_image(H, convention: str) -> np.ndarray:
    """G (3x3) mapping ground [x, y, 1] to image [u, v, 1] of a homography given as
    `convention`: "image-rowcol" (H maps [row, col, 1] to the ground, ETH's H.txt), "image-uv"
    (H maps [u, v, 1] to the ground) or "ground-to-image" (H maps [x, y, 1] to [u, v, 1]).
    Raises `CameraError` for a non-finite or singular H."""
    H = np.asarray(H, np.float64)
    if convention not in CONVENTIONS:
        raise CameraError("convention", f"unknown {convention!r}; one of {', '.join(CONVENTIONS)}")
    if H.shape != (3, 3) or not np.all(np.isfinite(H)):
        raise CameraError("H", f"expected a finite 3x3 matrix, got shape {H.shape}")
    s = np.linalg.svd(H, compute_uv=False)
    if not s[-1] > SINGULAR * s[0]:
        raise CameraError("H", f"singular (singular values {s[0]:.3g}, {s[1]:.3g}, {s[2]:.3g}): "
                          "no camera maps the ground through it")
    if convention == "ground-to-image":
        return H / np.linalg.norm(H)
    swap = np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, 1]])
    G = np.linalg.inv(H @ swap if convention == "image-rowcol" else H)
    return G / np.linalg.norm(G)


def focal_of_homography(G, principal_point, scale: float) -> float:
    """f (px) of the square-pixel pin-hole with this principal point nearest to G (ground to
    image), by least squares on r1 . r2 = 0 and |r1|^2 = |r2|^2, linear in w = (scale / f)^2
    (`scale` ~ the image size keeps the two equations of one magnitude)."""
    cx, cy = principal_point
    Gn = np.diag([1 / scale, 1 / scale, 1.0]) @ np.array([[1, 0, -cx], [0, 1, -cy], [0, 0, 1]]) @ G
    g1, g2 = Gn[:, 0], Gn[:, 1]
    a = np.array([g1[0] * g2[0] + g1[1] * g2[1], g1[0] ** 2 + g1[1] ** 2 - g2[0] ** 2 - g2[1] ** 2])
    b = np.array([g1[2] * g2[2], g1[2] ** 2 - g2[2] ** 2])
    w = -float(a @ b) / float(a @ a)
    if not (np.isfinite(w) and w > 1e-12):
        raise CameraError("H", "no square-pixel camera with the principal point at "
                          f"({cx:g}, {cy:g}) fits it (f^2 = {scale**2 / w if w else np.inf:.3g} "
                          "px^2; a camera looking straight down, or the wrong convention?)")
    return scale / float(np.sqrt(w))


def pinholes_of_homography(G, focal: float, principal_point):
    """The four (mirror, Pinhole) readings of G = K [r1 r2 t] up to sign and a mirrored y."""
    cx, cy = principal_point
    K = np.array([[focal, 0.0, cx], [0.0, focal, cy], [0.0, 0.0, 1.0]])
    out = []
    for mirror in (False, True):
        M = np.linalg.solve(K, G @ np.diag([1.0, -1.0 if mirror else 1.0, 1.0]))
        lam = (np.linalg.norm(M[:, 0]) + np.linalg.norm(M[:, 1])) / 2
        for sign in (1.0, -1.0):
            r1, r2, t = (sign * M[:, i] / lam for i in range(3))
            U, _, Vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
            R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
            out.append((mirror, Pinhole(K, R, t)))
    return out


def section_of(q, pp, image_size, f_m: float, mirror: bool, fps=None):
    """(section, transform) of the (3) parameters q = (log a f, log b f, roll, theta, heading,
    foot x, foot y, log H) with the principal point `pp` (the `refine` unknowns)."""
    laf, lbf, roll, th, psi, fx, fy, lh = (float(v) for v in q)
    section = {"f_m": f_m, "h_m": math.exp(lh) - f_m * math.sin(th), "theta_deg": math.degrees(th),
               "a_px_per_m": math.exp(laf) / f_m, "b_px_per_m": math.exp(lbf) / f_m,
               "uc_px": float(pp[0]), "vc_px": float(pp[1]), "roll_deg": math.degrees(roll),
               "image_width_px": int(image_size[0]), "image_height_px": int(image_size[1])}
    if fps is not None:
        section["fps"] = float(fps)
    return section, GroundTransform(psi, fx, fy, f_m * math.cos(th), mirror)


def refine(section: dict, tr: GroundTransform, samples, image_size, iterations: int = 100):
    """The (3) camera nearest to the source over `samples` (`visible_samples`): Levenberg-
    Marquardt on the pixel distances in (log a f, log b f, roll, theta, heading, foot, log H),
    the principal point held, central-difference Jacobian; started at (`section`, `tr`).
    Returns the start when no step lowers the sum of squares or a step leaves (3)'s bounds."""
    th = math.radians(section["theta_deg"])
    f_m, pp = section["f_m"], (section["uc_px"], section["vc_px"])
    q = np.array([math.log(section["a_px_per_m"] * f_m), math.log(section["b_px_per_m"] * f_m),
                  math.radians(section["roll_deg"]), th, tr.heading_rad, tr.foot_x_m,
                  tr.foot_y_m, math.log(section["h_m"] + f_m * math.sin(th))])

    def res(q):
        sec, t = section_of(q, pp, image_size, f_m, tr.mirror)
        x, y, us, vs = samples
        gx, gy = t.apply(x, y)
        u3, v3 = project_3d(host_camera(sec), gx, gy, np.zeros_like(gx))
        return np.concatenate([u3 - us, v3 - vs])

    def valid(q):
        return 0 < q[3] < math.radians(89.9) and abs(q[2]) < math.radians(MAX_ROLL_DEG) and (
            math.exp(q[7]) > f_m * math.sin(q[3]))

    r = res(q)
    cost, lam = float(r @ r), 1e-3
    steps = 1e-6 * np.maximum(1.0, np.abs(q))
    for _ in range(iterations):
        J = np.column_stack([(res(q + e) - res(q - e)) / (2 * e[j])
                             for j, e in enumerate(np.diag(steps))])
        A, g = J.T @ J, J.T @ r
        while lam < 1e12:
            q2 = q + np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), -g)
            r2 = res(q2) if valid(q2) else None
            if r2 is not None and float(r2 @ r2) < cost:
                break
            lam *= 10
        else:
            break
        done = cost - float(r2 @ r2) < 1e-12 * cost
        q, r, cost, lam = q2, r2, float(r2 @ r2), max(lam / 10, 1e-12)
        if done:
            break
    return section_of(q, pp, image_size, f_m, tr.mirror, section.get("fps"))


def camera_from_homography(H, convention: str, *, image_size, principal_point=None,
                           focal_px: float | None = None, fps=None,
                           f_m: float = F_M) -> CameraFrom:
    """(3) of an image-ground homography (module doc): the world in metres, principal point
    (u, v) px (None: the image centre), `focal_px` to start from instead of the closed form
    (needed when H holds no square-pixel camera with this principal point: then f = the larger
    image side is assumed, with a note). Then `refine` to the (3) nearest to H's own mapping,
    which the residual measures. Raises `CameraError` naming H (singular, no camera above the
    ground looking down fits it, the image sees no ground)."""
    G = ground_to_image(H, convention)
    w, h = image_size
    pp = (w / 2.0, h / 2.0) if principal_point is None else tuple(principal_point)
    notes = []
    if focal_px is not None:
        f = float(focal_px)
        notes.append(f"focal length started at the given {f:.1f} px")
    else:
        try:
            f = focal_of_homography(G, pp, float(max(w, h)))
            notes.append(f"focal length {f:.1f} px by least squares on H (square pixels, "
                         f"principal point ({pp[0]:g}, {pp[1]:g})), then refined")
        except CameraError:
            f = float(max(w, h))
            notes.append(f"no square-pixel camera with the principal point at ({pp[0]:g}, "
                         f"{pp[1]:g}) fits H, so H does not fix the focal length: started at "
                         f"{f:g} px (give --focal-px if you know it)")
    found, errors = None, []
    for mirror, p in pinholes_of_homography(G, f, pp):
        try:
            section_of_pinhole(p, image_size, f_m=f_m, mirror=mirror)
        except CameraError as e:
            errors.append((mirror, e))
            continue
        found = (mirror, p)
        break
    if found is None:
        tell = [e for m, e in errors if not m and e.key != "t"] or [e for _, e in errors]
        raise CameraError("H", tell[0].message) from None
    mirror, p = found
    if mirror:
        notes.append("the world's y is mirrored (a left-handed ground frame)")
    start = from_pinhole(p, image_size, f_m=f_m, mirror=mirror, fps=fps)
    Ginv = np.linalg.inv(G)

    def project(x, y):
        q = np.stack([x, y, np.ones_like(x)], -1) @ G.T
        X = np.stack([x, -y if mirror else y, np.zeros_like(x)], -1)
        return q[..., 0] / q[..., 2], q[..., 1] / q[..., 2], p.project(X)[2] > 0

    def ground(u, v):
        q = np.stack([u, v, np.ones_like(u)], -1) @ Ginv.T
        with np.errstate(all="ignore"):
            x, y = q[..., 0] / q[..., 2], q[..., 1] / q[..., 2]
        return x, y, np.isfinite(x) & np.isfinite(y)

    samples = visible_samples(start.section, start.transform, image_size, project, ground)
    section, tr = refine(start.section, start.transform, samples, image_size)
    d = distances_px(section, tr, samples)
    mx, rms = float(d.max()), float(np.sqrt(np.mean(d * d)))
    what = ("a homography that (3) with this principal point cannot match",) if mx > 1e-6 else ()
    return CameraFrom(section, tr, mx, rms, int(d.size), what, tuple(notes))
