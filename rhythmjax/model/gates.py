"""The paper's discrete gates, (10), (11) and (14): booleans from numbers, no filter code.

Every comparison is written `d2 <= k**2`, so a NaN distance *rejects* (RELIABILITY.md, 37);
`~(d2 > k**2)` would accept it. `PaperGates` composes (10) and (11) into the `valid` input of
`ekf.step` for inference; fitting uses `ekf.FromAnnotations` instead.
"""

from __future__ import annotations

import jax.numpy as jnp
import jax.scipy.linalg as jsl
from jaxtyping import Array, Bool, Float

from .camera import ground_width
from .ekf import AbstractValidity, Gaussian, Update, inverse_2x2
from .params import Camera, Thresholds, WalkingModel, WidthModel


def width_distance2(
    camera: Camera, model: WidthModel, z: Float[Array, "2"], width_px: Float[Array, ""]
) -> Float[Array, ""]:
    """(wid - mean)^2 / sigma^2 of (10): wid (m) is the inverse perspective of the image width
    `width_px` at the foot point z = (u_p, v_p). NaN where the foot point has no ground point."""
    wid, ok = ground_width(camera, width_px, z[0], z[1])
    d2 = (wid - model.mean) ** 2 / model.std**2
    return jnp.where(ok, d2, jnp.nan)


def width_ok(camera: Camera, model: WidthModel, k_sigma1, z, width_px) -> Bool[Array, ""]:
    """(10): the measured object is as wide as a pedestrian (no occlusion)."""
    return width_distance2(camera, model, z, width_px) <= k_sigma1**2


def outlier_distance2(prior: Gaussian, temporary_mean: Float[Array, "4"]) -> Float[Array, ""]:
    """(11): [X(k|k-1) - X~]^T P(k|k-1)^-1 [X(k|k-1) - X~], by a Cholesky solve of P(k|k-1).

    X~ is the temporary estimate of (4) made with the new measurement. NaN when P(k|k-1) is not
    positive definite (so the gate rejects)."""
    dx = prior.mean - temporary_mean
    L = jnp.linalg.cholesky(prior.cov)
    w = jsl.solve_triangular(L, dx, lower=True)
    return w @ w


def outlier_distance2_of_update(cand: Update) -> Float[Array, ""]:
    """(11) for the temporary update `cand` itself, without the 4x4 P^-1: since
    X~ - X(k|k-1) = K nu with K = P H^T S^-1, the distance is w^T (H P H^T) w with w = S^-1 nu.
    Equal to `outlier_distance2(prior, cand.posterior.mean)` (tests: 1e-10 in float64); this is
    the form the filter uses, a 2x2 solve per step instead of a 4x4 factorisation."""
    Sinv, _ = inverse_2x2(cand.innovation_cov)
    w = Sinv @ cand.innovation
    return w @ (cand.prior_meas_cov @ w)


def outlier_ok(prior: Gaussian, temporary_mean, k_sigma2) -> Bool[Array, ""]:
    """(11): the measurement is not an outlier."""
    return outlier_distance2(prior, temporary_mean) <= k_sigma2**2


def walking_ok(model: WalkingModel, k_sigma3, pace_hz, stride_m) -> Bool[Array, "*b"]:
    """(14): pace F (Hz) and stride T (m) both within k_sigma3 of the walking model."""
    dF = (pace_hz - model.pace_mean) ** 2 / model.pace_std**2
    dT = (stride_m - model.stride_mean) ** 2 / model.stride_std**2
    return (dF <= k_sigma3**2) & (dT <= k_sigma3**2)


def in_range(thresholds: Thresholds, y_m) -> Bool[Array, "*b"]:
    """Fig. 3: the object is inside the detection range (distance ahead, m)."""
    return (y_m >= thresholds.range_min) & (y_m <= thresholds.range_max)


class PaperGates(AbstractValidity):
    """Inference: a measurement is valid when it passes (10) and (11) (Fig. 2); a track may
    start (DETECT -> OBSERVE) when its first measurement lies in the detection range (Fig. 3:
    the range is the only test there, so an object wider than a pedestrian starts a track and
    is then only predicted)."""

    width_model: WidthModel
    thresholds: Thresholds

    def accept_initial(self, camera: Camera, z, width, ground_xy) -> Bool[Array, ""]:
        return in_range(self.thresholds, ground_xy[1])

    def __call__(self, camera: Camera, prior: Gaussian, cand: Update, z, width) -> Bool[Array, ""]:
        return (width_ok(camera, self.width_model, self.thresholds.k_sigma1, z, width)
                & (outlier_distance2_of_update(cand) <= self.thresholds.k_sigma2**2))


class OutlierGate(AbstractValidity):
    """The outlier gate (11) alone, for a tracker that measures its own objects' widths apart
    (the counting tracker, `count.options.PlacementOptions.outlier_gate`): a measurement is
    used when the temporary update it makes lies within k_sigma2 of the prediction; any first
    measurement may start a track (the counting tracker checks its detection range itself)."""

    thresholds: Thresholds

    def accept_initial(self, camera: Camera, z, width, ground_xy) -> Bool[Array, ""]:
        return jnp.asarray(True)

    def __call__(self, camera: Camera, prior: Gaussian, cand: Update, z, width) -> Bool[Array, ""]:
        return outlier_distance2_of_update(cand) <= self.thresholds.k_sigma2**2


class InnovationGate(OutlierGate):
    """The usual tracking gate instead of (11): the measurement's normalised innovation squared
    nu^T S^-1 nu (`ekf.Update.nis`, S = H P H^T + R) within k_sigma2^2 (chi-square with 2 degrees
    of freedom: 98.9 % of good measurements pass at 3); not the paper's, which tests the state
    shift (11) and so, with a settled filter and R above H P H^T, accepts large foot-row jumps.
    A NaN innovation rejects."""

    def __call__(self, camera: Camera, prior: Gaussian, cand: Update, z, width) -> Bool[Array, ""]:
        return cand.nis <= self.thresholds.k_sigma2**2
