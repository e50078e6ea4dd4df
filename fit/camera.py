"""Camera calibration from footprints: equation (3) fitted by Levenberg-Marquardt (STYLE R10).

Data: image foot points (u, v) in px with their ground positions (x, y) in m. Neglecting the
focal length f (mm) against the depth (m), (3) reads

    u = Uc + a f x / d,    v = Vc - b f (y sin(theta) - h cos(theta)) / d,
    d = f + y cos(theta) + h sin(theta),

so f enters only through the products a f and b f (px): f is held fixed (given, or the start
camera's) and (a f, b f, h, theta[, Uc, Vc]) are fitted; a = af / f and b = bf / f.

Inside, the parameters are unconstrained so the model is defined everywhere (RELIABILITY 0.6):
log(a f), log(b/a), log(h), and theta = 90 deg * sigmoid(s). For fixed (h, theta) the model is
linear in (a f, Uc) and (b f, Vc); a grid over (h, theta) with those solved in closed form gives
the starts (variable projection), so the fit converges from any start camera.

Identifiability: (3) maps the ground plane to the image by a homography with only five free
combinations (Uc, a f / cos(theta), (f + h sin(theta)) / cos(theta), Vc - b f tan(theta) and
b f (h / cos(theta) + f tan(theta)) / cos(theta)), exact even with f in the depth. So with the
principal point free, b/a must be held (fit "af" without "bf"); fitting all six is flagged
ill-determined, with the singular direction named. Any member of that family projects and
back-projects identically.

Extensions (issue 5, real footprints): "roll" (deg; the image of (3) rotated about (Uc, Vc),
see `rhythmjax.model.camera`), and with ``world=True`` a planar rigid transform from the data's
world frame (m) to the ground frame of (3) (camera foot at the origin, y ahead),

    x = cos(yaw) X - sin(yaw) s Y + tx,    y = sin(yaw) X + cos(yaw) s Y + ty,

s = +-1 (a mirrored world frame, fixed at the start), fitted with the camera ("tx", "ty",
"yaw"). The start then comes from a DLT homography decomposed with the principal point held.
A fit that ends at a bound (a f above `af_max_factor` image sizes: a near-affine camera with
meaningless h and theta; theta or roll at the edge of their range) is reported ill-determined.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import equinox as eqx
import jax
import jax.flatten_util
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from fit.determination import (
    GTOL as GTOL,
    NAMES as NAMES,
    UNITS as UNITS,
    WORLD as WORLD,
    determination as determination,
    se_limits as se_limits,
    stationarity,
    value_lines as value_lines,
)
from fit.homography import dlt_homography as dlt_homography, grid_starts, pose_from_homography
from rhythmjax.model.camera import project
from rhythmjax.model.params import Camera


class CameraParams(eqx.Module):
    """The fitted camera, unconstrained: log a f (px), log(b/a), log h (m), theta logit
    (theta = 90 deg * sigmoid), Uc and Vc (px), roll (rad), and the world-to-ground transform
    tx, ty (m), yaw (rad). Holding `log_ba` fixed keeps b/a (pixel aspect) at the start
    camera's while a f moves. `mirror` (+-1, static) flips the world Y axis."""

    log_af: jax.Array
    log_ba: jax.Array
    log_h: jax.Array
    theta_logit: jax.Array
    uc: jax.Array
    vc: jax.Array
    roll: jax.Array
    tx: jax.Array
    ty: jax.Array
    yaw: jax.Array
    mirror: float = eqx.field(static=True, default=1.0)

    def natural(self) -> jax.Array:
        """Values in `NAMES` order and `UNITS` (px, m, deg)."""
        theta = 90.0 * jax.nn.sigmoid(self.theta_logit)
        return jnp.stack([jnp.exp(self.log_af), jnp.exp(self.log_af + self.log_ba),
                          jnp.exp(self.log_h), theta, self.uc, self.vc,
                          jnp.rad2deg(self.roll), self.tx, self.ty, jnp.rad2deg(self.yaw)])

    def camera(self, like: Camera, f) -> Camera:
        """A `Camera` with these values, focal length f (m) and `like`'s static fields."""
        af, bf, h, theta_deg, uc, vc = self.natural()[:6]
        return Camera(f=f, h=h, theta=jnp.deg2rad(theta_deg), a=af / f, b=bf / f, uc=uc, vc=vc,
                      roll=self.roll, fps=like.fps, image_width=like.image_width,
                      image_height=like.image_height)

    def ground(self, X, Y):
        """World (X, Y) m -> ground (x, y) m of (3); the identity at tx = ty = yaw = 0."""
        c, s = jnp.cos(self.yaw), jnp.sin(self.yaw)
        Ym = self.mirror * Y
        return c * X - s * Ym + self.tx, s * X + c * Ym + self.ty


def _params(af, bf, h, theta_deg, uc, vc, roll_deg=0.0, tx=0.0, ty=0.0, yaw_deg=0.0,
            mirror=1.0) -> CameraParams:
    p = theta_deg / 90.0
    return CameraParams(*(jnp.asarray(v, jnp.float64) for v in (
        math.log(af), math.log(bf / af), math.log(h), math.log(p / (1 - p)), uc, vc,
        math.radians(roll_deg), tx, ty, math.radians(yaw_deg))), mirror=float(mirror))


@dataclass
class CameraFit:
    """Result of `fit_camera`. `values`, `se` and `cov` are in natural units (`UNITS`)."""

    camera: Camera
    fitted: tuple[str, ...]
    values: dict[str, float]
    se: dict[str, float]
    cov: np.ndarray  # over `fitted`, natural units
    rms_px: float
    sigma_px: float  # residual scale sqrt(SSE / (2n - p))
    cond: float  # condition number of the column-normalised Jacobian
    weak_direction: str  # smallest singular direction, named
    result: str  # optimistix RESULTS message ("" = successful)
    success: bool
    num_steps: int
    ill_determined: bool
    reasons: list[str] = field(default_factory=list)
    n_points: int = 0
    loss: str = "l2"
    mirror: float = 1.0

    def to_ground(self, X, Y) -> tuple[np.ndarray, np.ndarray]:
        """World (X, Y) m -> the ground frame of `camera` (m), by the fitted transform (the
        identity unless fitted with ``world=True``)."""
        yaw = math.radians(self.values["yaw"])
        c, s = math.cos(yaw), math.sin(yaw)
        X, Ym = np.asarray(X, np.float64), self.mirror * np.asarray(Y, np.float64)
        return c * X - s * Ym + self.values["tx"], s * X + c * Ym + self.values["ty"]

    def determination(self) -> dict[str, str]:
        """Per fitted parameter: "determined" (standard error at most a tenth of `se_limits`:
        5 % of a f, b f, h; 1 deg of theta, roll; 20 px of Uc, Vc; 5 m, 2 deg of the world
        transform), "weak" (up to the limit) or "not determined" (beyond it, non-finite, or in
        the singular direction of a Jacobian with condition number above 1e8)."""
        return determination(self.fitted, self.values, self.se, self.cond, self.weak_direction)

    def summary(self) -> str:
        lines = value_lines(self.fitted, self.values, self.se, self.determination())
        lines.append(f"reprojection RMS {self.rms_px:.3f} px over {self.n_points} points, "
                     f"loss {self.loss}")
        lines.append(f"condition number {self.cond:.3g}; least determined combination: "
                     f"{self.weak_direction}")
        lines.append(f"solver: {self.result or 'successful'} after {self.num_steps} steps")
        if self.ill_determined:
            lines.append("ILL-DETERMINED: " + "; ".join(self.reasons))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"fitted": list(self.fitted), "values": self.values, "se": self.se,
                "units": {k: UNITS[k] for k in self.fitted}, "cov": self.cov.tolist(),
                "rms_px": self.rms_px, "sigma_px": self.sigma_px, "cond": self.cond,
                "weak_direction": self.weak_direction, "result": self.result or "successful",
                "success": self.success, "num_steps": self.num_steps,
                "ill_determined": self.ill_determined, "reasons": self.reasons,
                "n_points": self.n_points, "loss": self.loss, "mirror": self.mirror,
                "determination": self.determination()}


# ----------------------------------------------------------------------------------------------
# Residuals and robust losses

def _robust(r, loss: str, k):
    """Residual transform r -> sign(r) sqrt(2 rho(r)), smooth at 0 (sum of squares = sum rho)."""
    if loss == "l2":
        return r
    x2 = (r / k) ** 2
    small = x2 < 1e-12
    x2s = jnp.where(small, 1.0, x2)
    if loss == "huber":
        w = jnp.where(x2 <= 1.0, 1.0, (2.0 * jnp.sqrt(x2s) - 1.0) / x2s)
    else:  # cauchy
        w = jnp.where(small, 1.0, jnp.log1p(x2s) / x2s)
    return r * jnp.sqrt(w)


def residuals(dynamic: CameraParams, args) -> jax.Array:
    """Reprojection residuals (u, v stacked, px) of (3), robustly transformed."""
    static, like, f, u, v, X, Y, loss, k = args
    p = eqx.combine(dynamic, static)
    pu, pv = project(p.camera(like, f), *p.ground(X, Y))
    return _robust(jnp.concatenate([pu - u, pv - v]), loss, k)


@eqx.filter_jit
def _solve(dynamic, args, rtol, atol, max_steps):
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    sol = optx.least_squares(residuals, solver, dynamic, args=args, throw=False,
                             max_steps=max_steps)
    return sol.value, sol.result, sol.stats["num_steps"]


# ----------------------------------------------------------------------------------------------

def _check_input(u, v, x, y, n_par, world=False):
    arrs = [np.asarray(a, np.float64).ravel() for a in (u, v, x, y)]
    if len({a.size for a in arrs}) != 1:
        raise ValueError("u, v, x, y must have the same length")
    for name, a in zip(("u", "v", "x", "y"), arrs, strict=True):
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise ValueError(f"{bad.size} non-finite {name} coordinate(s) (first at index "
                             f"{bad[0]}); drop incomplete footprints before fitting")
    n = arrs[0].size
    need = max(4, -(-n_par // 2))  # two equations per footprint; 4 fix a ground homography
    if n < need:
        raise ValueError(f"{n} footprints for {n_par} parameters: need at least {need} (each "
                         "gives two equations, and 4 are the fewest that fix the ground plane)")
    g = np.stack([arrs[2], arrs[3]], axis=1)
    sv = np.linalg.svd(g - g.mean(axis=0), compute_uv=False)
    if sv[1] <= 1e-6 * max(sv[0], 1e-12):
        raise ValueError("all footprints lie on one line on the ground: the camera is not "
                         "determined (annotate walkers spread across the view)")
    if not world and np.any(arrs[3] <= 0):
        i = int(np.flatnonzero(arrs[3] <= 0)[0])
        raise ValueError(f"ground y (distance ahead of the camera's foot, m) must be > 0 for every "
                         f"footprint (index {i}: y = {arrs[3][i]:.6g}); for x, y in a world frame "
                         "of the data's own use --world (world=True)")
    return arrs


def fit_camera(
    u, v, x, y, camera0: Camera | None = None, *,
    fit: tuple[str, ...] = ("af", "bf", "h", "theta"),
    f: float | None = None,
    world: bool = False,
    af_max_factor: float = 8.0,
    loss: Literal["l2", "huber", "cauchy"] = "l2",
    scale_px: float | None = None,
    n_starts: int = 3,
    max_steps: int = 256,
    rtol: float = 1e-10,
    atol: float = 1e-10,
) -> CameraFit:
    """Fit the camera of (3) to footprints (u, v px; x, y m) by Levenberg-Marquardt.

    `fit` is a subset of ``NAMES``; the rest are held at `camera0`'s values (default: the
    paper's camera). `f` (m) is held fixed (default `camera0.f`). Robust losses use the
    transformed residual sign(r) sqrt(2 rho(r)) with scale `scale_px` (default: 1.345 (Huber) or
    2.385 (Cauchy) times the MAD of an L2 fit's residuals). Starts: the best `n_starts` points of
    a (h, theta) grid and the start camera. Holding "bf" holds b/a. Runs in float64.
    ``world=True``: (x, y) are in the data's own world frame; (tx, ty, yaw) are fitted too and
    the start is the pose of a DLT homography (principal point held at `camera0`'s).
    A f above `af_max_factor` times the larger image side is reported as a near-affine,
    ill-determined fit. Raises ValueError for unusable input (non-finite values, fewer points
    than parameters, all ground points on one line, y <= 0 without `world`).
    """
    camera0 = camera0 if camera0 is not None else Camera()
    fit = tuple(fit) + tuple(k for k in WORLD if world and k not in fit)
    unknown = [k for k in fit if k not in NAMES]
    if unknown or len(set(fit)) != len(fit):
        raise ValueError(f"unknown parameter(s) {unknown}; choose from {NAMES}")
    if loss not in ("l2", "huber", "cauchy"):
        raise ValueError(f"loss must be 'l2', 'huber' or 'cauchy', not {loss!r}")
    if not world and any(k in fit for k in WORLD):
        raise ValueError("tx, ty, yaw are fitted with world=True")
    u, v, x, y = _check_input(u, v, x, y, len(fit), world)
    f = float(camera0.f) if f is None else float(f)
    c0 = dict(zip(NAMES, (float(camera0.a) * float(camera0.f), float(camera0.b) * float(camera0.f),
                          float(camera0.h), math.degrees(float(camera0.theta)),
                          float(camera0.uc), float(camera0.vc),
                          math.degrees(float(camera0.roll)), 0.0, 0.0, 0.0), strict=True))
    mirror = 1.0
    if world:  # the pose of the DLT homography; parameters not fitted keep camera0's values
        pose, mirror = pose_from_homography(dlt_homography(x, y, u, v), c0, x, y)
        c0 = {**c0, **{k: pose[k] for k in ("af", "h", "theta", "roll") + WORLD if k in fit}}
        c0["bf"] = c0["af"] * float(camera0.b) / float(camera0.a)
        c0["theta"] = min(max(c0["theta"], 0.5), 89.5)
    with jax.enable_x64(True):
        data = tuple(jnp.asarray(a) for a in (u, v, x, y))
        spec = CameraParams(*(k in fit for k in NAMES), mirror=mirror)
        fc = "uc" in fit and "vc" in fit
        starts = [c0]
        if not world:
            sub = np.linspace(0, len(u) - 1, min(len(u), 512)).astype(int)  # starts need no more
            sse, par = (np.asarray(a) for a in grid_starts(
                jnp.float64(f), *(a[sub] for a in data), c0["uc"], c0["vc"], jnp.asarray(fc)))
            order = np.argsort(sse)[:max(n_starts - 1, 0)]
            starts += [{**c0, **dict(zip(NAMES[:6], par[i], strict=True))} for i in order
                       if np.isfinite(sse[i])]
        for s in starts[1:]:  # fixed parameters stay at the start camera's values (b/a for bf)
            s.update({k: c0[k] for k in NAMES if k not in fit})
            if "bf" not in fit:
                s["bf"] = s["af"] * c0["bf"] / c0["af"]
            s["theta"] = min(max(s["theta"], 0.5), 89.5)

        def run(start, loss_, k):
            p0 = _params(*(start[k_] for k_ in NAMES), mirror=mirror)
            dyn, static = eqx.partition(p0, spec)
            args = (static, camera0, jnp.float64(f), *data, loss_, jnp.float64(k))
            val, res, steps = _solve(dyn, args, rtol, atol, max_steps)
            r = np.asarray(residuals(val, args))
            cost = float(np.sum(r**2)) if np.all(np.isfinite(r)) else np.inf
            return cost, val, static, args, res, int(steps)

        best = min((run(s, "l2", 1.0) for s in starts), key=lambda t: t[0])
        if loss != "l2":
            cost, val, static, args, _, _ = best
            raw = np.asarray(residuals(val, args))
            k = scale_px or (1.345 if loss == "huber" else 2.385) * 1.4826 * float(
                np.median(np.abs(raw - np.median(raw))))
            start = dict(zip(NAMES, np.asarray(eqx.combine(val, static).natural()), strict=True))
            best = run(start, loss, max(k, 1e-6))
        out = _report(best, fit, loss, len(u))
    out.mirror = mirror
    af_max = af_max_factor * max(camera0.image_width, camera0.image_height)
    if out.values["af"] > af_max:  # fit ended at the bound: near-affine, h and theta meaningless
        out.ill_determined = True
        out.reasons.append(f"a f {out.values['af']:.4g} px above its bound {af_max:.4g} px "
                           "(near-affine camera: h and theta are not determined)")
    elif out.values["af"] < 0.05 * af_max / af_max_factor:
        out.ill_determined = True
        out.reasons.append(f"a f {out.values['af']:.4g} px below 5 % of the image size")
    out.camera = _camera(out.values, f, camera0)  # float32 outside the x64 context
    return out


def _camera(values: dict[str, float], f: float, like: Camera) -> Camera:
    return Camera(f=f, h=values["h"], theta=math.radians(values["theta"]), a=values["af"] / f,
                  b=values["bf"] / f, uc=values["uc"], vc=values["vc"],
                  roll=math.radians(values["roll"]), fps=like.fps,
                  image_width=like.image_width, image_height=like.image_height)


def _report(best, fit, loss, n) -> CameraFit:
    cost, val, static, args, res, steps = best
    full = eqx.combine(val, static)
    flat, unravel = jax.flatten_util.ravel_pytree(val)
    J = np.asarray(jax.jacfwd(lambda p: residuals(unravel(p), args))(flat))
    nat_of = lambda p: eqx.combine(unravel(p), static).natural()
    Gfull = np.asarray(jax.jacfwd(nat_of)(flat))  # (6, p)
    idx = [NAMES.index(k) for k in fit]
    G = Gfull[idx]  # d natural / d unconstrained (square, invertible)
    J_nat = J @ np.linalg.inv(G)
    p = len(fit)
    dof = max(2 * n - p, 1)
    sigma2 = cost / dof
    scale = np.linalg.norm(J_nat, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    _, svals, vt = np.linalg.svd(J_nat / scale, full_matrices=False)
    cond = float(svals[0] / svals[-1]) if svals[-1] > 0 else math.inf
    w = vt[-1] / np.max(np.abs(vt[-1]))
    weak = " ".join(f"{c:+.2f} {fit[i]}" for i, c in enumerate(w) if abs(c) >= 0.1)
    JtJ = (J_nat / scale).T @ (J_nat / scale)
    with np.errstate(all="ignore"):
        cov = sigma2 * np.linalg.pinv(JtJ) / np.outer(scale, scale)
    se_arr = np.sqrt(np.clip(np.diag(cov), 0, None))
    nat = np.asarray(full.natural())
    values = dict(zip(NAMES, (float(t) for t in nat), strict=True))
    se = {k: float(se_arr[i]) for i, k in enumerate(fit)}
    msg = optx.RESULTS[res]
    success = res == optx.RESULTS.successful
    if res == optx.RESULTS.nonlinear_max_steps_reached:
        cos = stationarity(J, np.asarray(residuals(val, args)))
        if cos <= GTOL:
            success, msg = True, (f"stationary at max_steps (largest |cos(J_i, r)| {cos:.1e} <= "
                                  f"{GTOL:g}); the 1e-10 step test was not met")
    reasons = []
    if not success:
        reasons.append(f"solver: {msg}")
    if "theta" in fit and not 0.2 < values["theta"] < 89.8:
        reasons.append(f"theta {values['theta']:.3f} deg at the edge of (0, 90)")
    if "h" in fit and not 0.01 < values["h"] < 1e3:
        reasons.append(f"h {values['h']:.3g} m at the edge of its domain")
    if not np.all(np.isfinite(se_arr)) or cond > 1e8:
        reasons.append(f"singular Jacobian (condition number {cond:.3g})")
    huge = se_limits(values)
    if "roll" in fit and abs(values["roll"]) > 45.0:
        reasons.append(f"roll {values['roll']:.3g} deg beyond +-45 deg")
    reasons += [f"standard error of {k} {se[k]:.3g} {UNITS[k]} is above its limit "
                f"{huge[k]:.3g}" for k in fit if se[k] > huge[k]]
    raw = np.asarray(residuals(val, args[:-2] + ("l2", args[-1])))
    return CameraFit(
        camera=args[1], fitted=fit, values=values, se=se, cov=cov,
        rms_px=float(np.sqrt(np.mean(raw**2))), sigma_px=float(math.sqrt(sigma2)), cond=cond,
        weak_direction=weak, result=msg, success=bool(success), num_steps=steps,
        ill_determined=bool(reasons), reasons=reasons, n_points=n, loss=loss)


def reprojection_rms(camera: Camera, u, v, x, y) -> float:
    """RMS (px) of the reprojection residuals of (3) over footprints, u and v together."""
    with jax.enable_x64(True):
        pu, pv = project(camera, jnp.asarray(np.asarray(x, float)),
                         jnp.asarray(np.asarray(y, float)))
        r = np.concatenate([np.asarray(pu) - u, np.asarray(pv) - v])
    return float(np.sqrt(np.mean(r**2)))
