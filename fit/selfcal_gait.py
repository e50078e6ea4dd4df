"""The gait cue's stride model of self-calibration (`fit.selfcal`, `--stride-model`): the stride
T (m per step) expected of a walker stepping at pace F (Hz), from the walking model alone.

"table1" is Table 1's model, stride and pace independent. "walk-ratio" takes the stride in
proportion to the pace, a constant walk ratio T / F: gait studies find step length and cadence
rising together with walking speed, their ratio nearly the same at every speed (Sekiya &
Nagasaki 1998), so people who step slowly take shorter steps (docs/selfcal.md, "The stride given
the pace")."""

from __future__ import annotations

import jax.numpy as jnp


__all__ = ["MIN_RELATIVE_SPREAD", "STRIDE_MEAN_SD_M", "STRIDE_MODELS", "expected_stride",
           "relative_spread"]

STRIDE_MODELS = {"table1": 0.0, "walk-ratio": 1.0}  # the power of F in the expected stride
MIN_RELATIVE_SPREAD = 0.5  # the walk ratio's spread is at least this x Table 1's relative one
STRIDE_MEAN_SD_M = 0.05  # `--stride-mean-sd`'s suggested value (m): how far a crowd's mean
# stride may lie from the walking model's, set a priori: crowds' mean walking speeds in public
# places span about 1.1-1.5 m/s, and at a constant walk ratio the step goes as the square root
# of the speed, +-8 % about the middle, about 0.05 m of Table 1's 0.72 m (not chosen on any
# tracks)


def expected_stride(pace, walking, power):
    """The gait cue's stride model: mean and spread (m) of the stride T of a walker stepping at
    pace F (Hz), T ~ N(stride_mean (F / pace_mean)^p, (stride_std (F / pace_mean)^p s)^2).

    p = 0 is Table 1's model, stride and pace independent (s = 1: T ~ N(stride_mean,
    stride_std^2)). p = 1 is a constant walk ratio T / F; its spread s is what Table 1's spread
    of T leaves over the population once F varies (relative variances add: CV_T^2 = p^2 CV_F^2
    + CV^2 of the ratio), s = sqrt(1 - p^2 CV_F^2 / CV_T^2), at least `MIN_RELATIVE_SPREAD`
    (Table 1: CV_F 0.089, CV_T 0.125, s 0.70). No constant is fitted to any data."""
    scale = (pace / walking.pace_mean) ** power
    return walking.stride_mean * scale, walking.stride_std * scale * _spread_factor(walking, power)


def relative_spread(walking, power):
    """The spread of a walker's stride relative to its expected stride (`expected_stride`:
    sd / mean, the same at every pace): CV_T s (Table 1: 0.125 for p = 0, 0.0875 for p = 1)."""
    return walking.stride_std / walking.stride_mean * _spread_factor(walking, power)


def _spread_factor(walking, power):
    """s = sqrt(1 - p^2 CV_F^2 / CV_T^2), at least `MIN_RELATIVE_SPREAD` (`expected_stride`)."""
    cv_f = walking.pace_std / walking.pace_mean
    cv_t = walking.stride_std / walking.stride_mean
    return jnp.sqrt(jnp.maximum(1.0 - (power * cv_f / cv_t) ** 2, MIN_RELATIVE_SPREAD**2))
