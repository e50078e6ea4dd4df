"""The result of self-calibration (`fit.selfcal`): values, standard errors from the
Gauss-Newton covariance, what the data determine, and the reasons a fit is refused."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.flatten_util
import numpy as np

from fit.camera import NAMES, UNITS, determination, value_lines
from rhythmjax.model.params import Camera


@dataclass
class SelfcalFit:
    """Result of `fit_selfcal`; `values`, `se`, `cov` in natural units (`fit.camera.UNITS`)."""

    camera: Camera | None
    cues: tuple[str, ...]
    fitted: tuple[str, ...]
    values: dict[str, float]
    se: dict[str, float]
    cov: np.ndarray
    cond: float
    weak_direction: str
    result: str
    success: bool
    num_steps: int
    ill_determined: bool
    reasons: list[str] = field(default_factory=list)
    n_tracks: int = 0
    n_walkers: int = 0
    walker_ids: list[str] = field(default_factory=list)
    spreads: dict[str, float] = field(default_factory=dict)
    cue_rms: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def determination(self) -> dict[str, str]:
        """"determined" (SE at most a tenth of `fit.camera.se_limits`), "weak" (up to it) or
        "not determined" (beyond it, non-finite, or in a singular direction)."""
        return determination(self.fitted, self.values, self.se, self.cond, self.weak_direction)

    def summary(self) -> str:
        lines = value_lines(self.fitted, self.values, self.se, self.determination())
        lines.append(f"cues: {', '.join(self.cues)}; walkers used: {self.n_walkers} of "
                     f"{self.n_tracks} tracks (a clear gait peak)")
        if self.cue_rms:
            lines.append("cue RMS (spreads): " + ", ".join(
                f"{k} {q:.3g}" for k, q in self.cue_rms.items()))
        lines.append(f"condition number {self.cond:.3g}; least determined combination: "
                     f"{self.weak_direction or '-'}")
        lines.append(f"solver: {self.result or 'successful'} after {self.num_steps} steps")
        lines += self.notes
        if self.ill_determined:
            lines.append("ILL-DETERMINED: " + "; ".join(self.reasons))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"cues": list(self.cues), "fitted": list(self.fitted), "values": self.values,
                "se": self.se, "units": {k: UNITS[k] for k in self.fitted},
                "cov": self.cov.tolist(), "cond": self.cond,
                "weak_direction": self.weak_direction, "result": self.result or "successful",
                "success": self.success, "num_steps": self.num_steps,
                "ill_determined": self.ill_determined, "reasons": self.reasons,
                "n_tracks": self.n_tracks, "n_walkers": self.n_walkers,
                "walker_ids": self.walker_ids, "spreads": self.spreads,
                "cue_rms": self.cue_rms, "notes": self.notes,
                "determination": self.determination() if self.fitted else {}}


def report(J: np.ndarray, G: np.ndarray, r: np.ndarray, fitted: tuple[str, ...], n_eff: int):
    """(cov, se, cond, weak direction) in natural units from the Jacobian J of the residuals
    r over the unconstrained parameters and G = d natural / d unconstrained (fitted rows):
    cov = s^2 (J_nat^T J_nat)^-1, s^2 = |r|^2 / (n_eff - p), on column-normalised J_nat. A
    parameter with no effect on the residuals gets an infinite SE; so does every parameter
    where J or r is not finite (a degenerate camera: the fit is then flagged, not crashed)."""
    p = len(fitted)
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(r)) and np.all(np.isfinite(G))):
        return (np.full((p, p), np.inf), {k: math.inf for k in fitted}, math.inf,
                "residuals not finite")
    J_nat = J @ np.linalg.inv(G)
    s2 = float(np.sum(r**2)) / max(n_eff - p, 1)
    norm = np.linalg.norm(J_nat, axis=0)
    dead = ~(norm > 1e-12 * max(float(np.max(norm)), 1e-300))
    scale = np.where(dead, 1.0, norm)
    Jn = J_nat / scale
    _, sv, vt = np.linalg.svd(Jn, full_matrices=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 and not dead.any() else math.inf
    w = vt[-1] / np.max(np.abs(vt[-1]))
    weak = " ".join(f"{c:+.2f} {fitted[i]}" for i, c in enumerate(w) if abs(c) >= 0.1)
    with np.errstate(all="ignore"):
        cov = s2 * np.linalg.pinv(Jn.T @ Jn) / np.outer(scale, scale)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    se = np.where(dead, np.inf, se)
    cov[dead, :] = np.inf
    cov[:, dead] = np.inf
    return cov, {k: float(se[i]) for i, k in enumerate(fitted)}, cond, weak


def jacobians(residuals, val, static, args, fitted: tuple[str, ...]):
    """(J, G, r) of `report` at the fitted `CameraParams` `val` (float64 numpy)."""
    flat, unravel = jax.flatten_util.ravel_pytree(val)
    J = np.asarray(jax.jacfwd(lambda q: residuals(unravel(q), args))(flat))
    Gfull = np.asarray(jax.jacfwd(lambda q: eqx.combine(unravel(q), static).natural())(flat))
    return J, Gfull[[NAMES.index(k) for k in fitted]], np.asarray(residuals(val, args))


STATIONARY_COS = 1e-4  # a fit stopped at max_steps counts as converged below this


def stationarity(J: np.ndarray, r: np.ndarray) -> float:
    """Largest |cosine| between the residual vector and a Jacobian column: 0 at a stationary
    point of the squared sum, whatever the parameters' scales (MINPACK's gtol test)."""
    norms = np.linalg.norm(J, axis=0) * np.linalg.norm(r)
    with np.errstate(all="ignore"):
        cos = np.abs(J.T @ r) / np.where(norms > 0, norms, 1.0)
    return float(np.max(cos)) if np.all(np.isfinite(cos)) else math.inf
