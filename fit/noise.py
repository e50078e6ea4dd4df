"""Process and measurement noise Q, R by maximum innovation likelihood of the EKF (4)-(9).

The loss is the negative total innovation log-likelihood sum_k log N(nu_k; 0, S_k) of every used
measurement of a batch of padded tracks, filtered by `rhythmjax.model.ekf_fused.filter_batch`
(`ekf.filter_batch` entry by entry, tested equal; 7.7x faster gradients) with `FromAnnotations`
validity (one filter, two uses: STYLE R5, R10). The parameters are `Noise`'s
unconstrained leaves (log q, log-Cholesky factor of R, log initial speed spread: STYLE R3), so
BFGS moves freely. Uncertainties: the inverse Hessian of the loss in the unconstrained
parameters, carried to q_std, r_std and r_corr by the delta method.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.flatten_util
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from rhythmjax.model.camera import project
from rhythmjax.model.ekf import FromAnnotations
from rhythmjax.model.ekf_fused import filter_batch
from rhythmjax.model.params import Camera, Noise


LEAVES = ("log_q", "log_r_diag", "r_offdiag", "log_init_speed_std")


def natural(noise: Noise) -> jax.Array:
    """(q_x, q_y m/s per sqrt(s), r_u, r_v px, r_corr, init_speed_std m/s)."""
    return jnp.concatenate([noise.q_std(), noise.r_std(), noise.r_corr()[None],
                            noise.init_speed_std()[None]])


NATURAL = ("q_x", "q_y", "r_u", "r_v", "r_corr", "init_speed_std")
UNITS = {"q_x": "m/s/sqrt(s)", "q_y": "m/s/sqrt(s)", "r_u": "px", "r_v": "px", "r_corr": "",
         "init_speed_std": "m/s"}


def neg_loglik(dynamic: Noise, args) -> jax.Array:
    """Negative total innovation log-likelihood (nats) of the batch, (4)-(9)."""
    static, camera, z, width, dt, present = args
    out = filter_batch(camera, eqx.combine(dynamic, static), FromAnnotations(), z, width, dt,
                       present)
    return -jnp.sum(out.loglik)


@dataclass
class NoiseFit:
    """Result of `fit_noise`: values and standard errors in natural units (`UNITS`)."""

    noise: Noise
    fitted: tuple[str, ...]
    values: dict[str, float]
    se: dict[str, float]
    loglik0: float  # nats, at the start
    loglik: float  # nats, at the fit
    n_measurements: int
    result: str
    success: bool
    num_steps: int
    ill_determined: bool
    reasons: list[str] = field(default_factory=list)

    @property
    def gain(self) -> float:
        """Log-likelihood gain over the start (nats)."""
        return self.loglik - self.loglik0

    def summary(self) -> str:
        names = [n for n in NATURAL if n in self.se]
        lines = [f"{k:14s} = {self.values[k]:9.4f} +- {self.se[k]:.4f} {UNITS[k]}" for k in names]
        lines.append(f"log-likelihood {self.loglik:.2f} nats over {self.n_measurements} "
                     f"measurements; gain {self.gain:+.2f} nats over the start")
        lines.append(f"solver: {self.result or 'successful'} after {self.num_steps} steps")
        if self.ill_determined:
            lines.append("ILL-DETERMINED: " + "; ".join(self.reasons))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"fitted": list(self.fitted), "values": self.values, "se": self.se,
                "units": UNITS, "loglik0": self.loglik0, "loglik": self.loglik,
                "gain": self.gain, "n_measurements": self.n_measurements,
                "result": self.result or "successful", "success": self.success,
                "num_steps": self.num_steps, "ill_determined": self.ill_determined,
                "reasons": self.reasons}


@eqx.filter_jit
def _solve(dynamic, args, scale, rtol, atol, max_steps):
    fn = lambda p, a: neg_loglik(p, a) / scale
    sol = optx.minimise(fn, optx.BFGS(rtol=rtol, atol=atol), dynamic, args=args, throw=False,
                        max_steps=max_steps)
    return sol.value, sol.result, sol.stats["num_steps"]


def _hessian_fd(grad, x, eps: float = 1e-4) -> np.ndarray:
    """Hessian by central differences of the (exact, autodiff) gradient; cheaper to compile than
    `jax.hessian` through the filter's scan, and accurate to ~eps^2 in float64."""
    cols = [(np.asarray(grad(x.at[i].add(eps))) - np.asarray(grad(x.at[i].add(-eps)))) / (2 * eps)
            for i in range(x.size)]
    return np.stack(cols, axis=1)


def _spec(fit: tuple[str, ...]) -> Noise:
    spec = jax.tree.map(lambda _: False, Noise())
    for leaf in fit:
        spec = eqx.tree_at(lambda n, leaf=leaf: getattr(n, leaf), spec, True)
    return spec


def fit_noise(
    camera: Camera, z, width, dt, present, noise0: Noise | None = None, *,
    fit: tuple[str, ...] = ("log_q", "log_r_diag", "r_offdiag"),
    max_steps: int = 200, rtol: float = 1e-8, atol: float = 1e-8,
) -> NoiseFit:
    """Fit `Noise` leaves `fit` (subset of `LEAVES`) by BFGS on the EKF's innovation likelihood.

    z (B, T, 2) px, width (B, T) px, dt (B, T) s, present (B, T) as in `rhythmjax.io.TrackBatch`;
    NaN z is a missing measurement. The camera is held fixed. Runs in float64.
    Raises ValueError for unusable input (no track with two measurements, non-finite dt).
    """
    noise0 = noise0 if noise0 is not None else Noise()
    unknown = [k for k in fit if k not in LEAVES]
    if unknown or not fit:
        raise ValueError(f"unknown noise parameter(s) {unknown}; choose from {LEAVES}")
    z, width, dt = (np.asarray(a, np.float64) for a in (z, width, dt))
    present = np.asarray(present, bool)
    if z.ndim != 3 or z.shape[2] != 2 or dt.shape != z.shape[:2] or present.shape != dt.shape:
        raise ValueError("expected z (B, T, 2), dt and present (B, T)")
    avail = present & np.all(np.isfinite(z), axis=-1)
    n_meas = int(np.sum(np.maximum(avail.sum(axis=1) - 1, 0)))  # the first one initialises
    if n_meas < 10 * len(fit):
        raise ValueError(f"{n_meas} usable measurements after the first of each track: too few "
                         f"to fit {len(fit)} noise parameters")
    if not np.all(np.isfinite(dt[present])) or np.any(dt[present] <= 0):
        raise ValueError("time steps dt must be finite and > 0")
    with jax.enable_x64(True):
        to64 = lambda a: jnp.asarray(a, jnp.float64) if eqx.is_inexact_array(a) else a
        noise0 = jax.tree.map(to64, noise0)
        camera = jax.tree.map(to64, camera)
        dyn, static = eqx.partition(noise0, _spec(tuple(fit)))
        args = (static, camera, jnp.asarray(z), jnp.asarray(width), jnp.asarray(dt),
                jnp.asarray(present))
        ll0 = -float(neg_loglik(dyn, args))
        val, res, steps = _solve(dyn, args, float(n_meas), rtol, atol, max_steps)
        ll = -float(neg_loglik(val, args))
        flat, unravel = jax.flatten_util.ravel_pytree(val)
        H = _hessian_fd(jax.jit(jax.grad(lambda p: neg_loglik(unravel(p), args))), flat)
        G = np.asarray(jax.jacfwd(lambda p: natural(eqx.combine(unravel(p), static)))(flat))
        noise = eqx.combine(val, static)
        nat = np.asarray(natural(noise))
    reasons = []
    success = res == optx.RESULTS.successful
    if not success:
        reasons.append(f"solver: {optx.RESULTS[res]}")
    H = 0.5 * (H + H.T)
    ev = np.linalg.eigvalsh(H) if np.all(np.isfinite(H)) else np.array([np.nan])
    if not np.all(ev > 0):
        reasons.append("Hessian not positive definite: a parameter is not determined")
        cov = np.full((flat.size, flat.size), np.nan)
    else:
        cov = np.linalg.inv(H)
    cov_nat = G @ cov @ G.T
    se_all = np.sqrt(np.clip(np.diag(cov_nat), 0, None))
    # natural quantities that move with the fitted leaves
    moves = np.any(np.abs(G) > 0, axis=1)
    values = {k: float(x) for k, x in zip(NATURAL, nat, strict=True)}
    se = {k: float(s) for k, s, m in zip(NATURAL, se_all, moves, strict=True) if m}
    for k, s in se.items():
        if k != "r_corr" and s > 0.5 * values[k]:
            reasons.append(f"standard error of {k} {s:.3g} {UNITS[k]} is more than half its "
                           f"value {values[k]:.3g}")
    if not math.isfinite(ll):
        reasons.append("log-likelihood is not finite")
    noise_out = jax.tree.map(lambda a: jnp.asarray(np.asarray(a), jnp.result_type(float))
                             if eqx.is_inexact_array(a) else a, noise)
    return NoiseFit(noise=noise_out, fitted=tuple(fit), values=values, se=se, loglik0=ll0,
                    loglik=ll, n_measurements=n_meas, result=optx.RESULTS[res],
                    success=bool(success), num_steps=int(steps), ill_determined=bool(reasons),
                    reasons=reasons)


def simulate(camera: Camera, noise: Noise, rng: np.random.Generator, n_tracks: int = 200,
             n_steps: int = 100, dt: float | None = None):
    """Tracks of the constant-velocity model (1) with velocity random walk (variance q^2 dt per
    step), started 6-14 m ahead with velocity ~ N(0, init_speed_std^2), observed through (3)
    with Gaussian noise R (px^2). Returns z (B, T, 2), width (B, T) (NaN), dt (B, T), present."""
    dt = float(camera.dt if dt is None else dt)
    q = np.asarray(noise.q_std(), float)
    L = np.asarray(noise.R_chol(), float)
    s0 = float(noise.init_speed_std())
    zs = np.zeros((n_tracks, n_steps, 2))
    for b in range(n_tracks):
        while True:
            pos = np.array([rng.uniform(-3, 3), rng.uniform(6, 14)])
            vel = rng.normal(0, s0, 2)
            dv = rng.normal(0, 1, (n_steps, 2)) * q * math.sqrt(dt)
            dv[0] = 0.0
            v = vel + np.cumsum(dv, axis=0)
            p = pos + dt * np.concatenate([np.zeros((1, 2)), np.cumsum(v[:-1], axis=0)])
            if p[:, 1].min() > 3.0:
                break
        with jax.enable_x64(True):
            u, vv = project(camera, jnp.asarray(p[:, 0]), jnp.asarray(p[:, 1]))
            zs[b] = np.stack([np.asarray(u), np.asarray(vv)], axis=1)
        zs[b] += rng.normal(0, 1, (n_steps, 2)) @ L.T
    return (zs, np.full((n_tracks, n_steps), np.nan), np.full((n_tracks, n_steps), dt),
            np.ones((n_tracks, n_steps), bool))

