"""A crowd's mean, unknown, estimated with the camera in self-calibration (`fit.selfcal`): the
mean of the walkers' heights (`fit.selfcal_height.crowd_height`) and of their strides relative
to the walking model's (`fit.selfcal_cost`, `stride_mean_sd`). Both are the same Gaussian
hierarchy: the crowd's mean a priori N(prior_mean, sd_mean^2), each walker N(mean, sd_each^2)
about it; the mean's posterior mean is profiled out of the least squares, its prior residual
added to the residuals.
"""

from __future__ import annotations

import jax.numpy as jnp


__all__ = ["crowd_mean", "masked_median"]


def masked_median(x, mask):
    """Median of x (T,) over `mask` (the mean of the two middle values for an even count);
    differentiable in x (through a sort). Undefined (a large number) when mask is all False."""
    xs = jnp.sort(jnp.where(mask, x, 1e30))
    n = jnp.sum(mask)
    lo = xs[jnp.maximum((n - 1) // 2, 0)]
    hi = xs[jnp.maximum(n // 2, 0)]
    return 0.5 * (lo + hi)


def crowd_mean(x, usable, prior_mean, sd_mean, sd_each):
    """(mean, its prior residual) of a crowd whose walkers' values are `x` (B,) where `usable`:
    the mean is N(prior_mean, sd_mean^2) a priori and each walker's value N(mean, sd_each^2)
    about it, so with n walkers of median value m (the median over walkers: robust to a
    bicycle's or a dog's track)

        mean = (n m / sd_each^2 + prior_mean / sd_mean^2) / (n / sd_each^2 + 1 / sd_mean^2)

    (the Gaussian posterior mean) and the prior residual (mean - prior_mean) / sd_mean.
    `sd_mean` 0: the mean is the prior's (residual 0); also with no usable walker.
    Differentiable in `x`."""
    n = jnp.sum(usable).astype(x.dtype)
    free = (sd_mean > 0) & (n > 0)
    m = masked_median(x, usable)
    prec = 1.0 / jnp.where(free, sd_mean, 1.0) ** 2
    a = n / sd_each**2
    mean = jnp.where(free, (a * jnp.where(free, m, 0.0) + prec * prior_mean) / (a + prec),
                     prior_mean)
    return mean, jnp.where(free, (mean - prior_mean) / jnp.where(free, sd_mean, 1.0), 0.0)
