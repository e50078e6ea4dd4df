"""The slant cue of self-calibration (`fit.selfcal`, issue 19): people's heads over their feet.

A tilted camera images a vertical segment as a segment through the vertical vanishing point,
Vc + b f / tan(theta) px below the principal point for a camera without roll (the camera of
(3)): a walker standing off the image's centre column leans outwards, its head's column farther
from Uc than its feet's by about (u - Uc) (v - v_top) / (b f / tan(theta) + Vc - v) px. The
foot-head heights (`fit.selfcal_height`) fix the horizon row, Vc - b f tan(theta), and the scale;
the slant fixes b f / tan(theta); the two together give a f and the tilt apart, which heights
alone give only through the second-order change of a person's pixel height with depth.

Per row of a track with a top row v_top and a head column u_top (the tracks format's optional
columns; `rhythmjax count` writes both): the walker's height H from v_top (`height_from_top`,
(H1), the same `depth_m`), then the column of the point H m above the foot point's ground point
(`rhythmjax.model.camera.project_3d`, roll included): the predicted head column. The residual is
u_top - that column (px); per track its median over the rows, in units of its own standard
error: 1.2533 x 1.4826 x the rows' MAD / sqrt(n) (the median's, from the data), floored at
`SLANT_FLOOR_PX`; the error is part of the residual's function of the camera (its gradient
included, so the least squares' Jacobian is exact).

Walkers lean into their stride: a silhouette's head may lie ahead of its feet in the walking
direction (the two rendered walkers of tests/test_count_top_row.py fall short of the pin-hole's
lean by 1.3 and 1.7 px, each towards its walking direction), and people entering at the image's
sides walk inwards, against the slant. So the head point is taken delta m ahead along the
track's ground direction: per track the column's change per metre of delta, g (px/m, the median
over its rows), and delta, one unknown for the crowd, profiled out of the weighted least squares
in closed form (`profile_lean`). No constant is chosen on any data: the noise is each track's
own, the lean the crowd's. Measured on count's tracks the cue does not help (measured leans are
smaller than the pin-hole's for other reasons too; docs/selfcal.md, "Heads over feet"), so it is
not among the default cues.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from fit.selfcal_crowd import masked_median
from fit.selfcal_height import MIN_TOP_ROWS, head_from_top
from rhythmjax.model.camera import project_3d
from rhythmjax.model.params import Camera


SLANT_FLOOR_PX = 0.05  # px: a track's standard error is never below this (pixels are integers:
# a head column is a mean of pixel centres; a floor against a track with no scatter at all)
MEDIAN_SE = 1.2533  # the median's standard error over the mean's for normal noise
MAD_SD = 1.4826  # a normal spread over its MAD


def head_point(camera: Camera, u, v, v_top, depth_m=0.0):
    """(x, y, H m, ok): the head point over the foot point (u, v) px: its ground point `depth_m`
    m beyond the foot point's along the ground, H the height whose top projects to the row
    v_top (`fit.selfcal_height.head_from_top`); ok as there, and H > 0."""
    x, y, H, ok = head_from_top(camera, u, v, v_top, depth_m)
    return x, y, H, ok & (H > 0)


def head_column(camera: Camera, u, v, v_top, depth_m=0.0):
    """(u_head px, ok): the column of the head point (`head_point`) over the foot point (u, v)
    px whose top row is v_top px. Differentiable in the camera."""
    x, y, H, ok = head_point(camera, u, v, v_top, depth_m)
    uh, _ = project_3d(camera, x, y, H)
    ok = ok & jnp.isfinite(uh)
    return jnp.where(ok, uh, u), ok


LEAN_STEP_M = 0.1  # m: the forward step of the head column's change with the lean (within
# 0.5 % of the derivative in tests/test_selfcal_slant.py; the lean itself is a few centimetres)


def slant_cue(camera: Camera, u, v, v_top, u_top, use, depth_m=0.0, heading=None):
    """Per track (B,): (the median of u_top - `head_column` over the rows `use` (B, T) with a
    finite head, px; its standard error px (module doc); usable: at least
    `MIN_TOP_ROWS` such rows; g: the median change of the head column per metre of lean along
    `heading` (B, 2), the track's unit ground direction (x, y), px/m; 0 without a heading)."""
    x, y, H, ok = head_point(camera, u, v, v_top, depth_m)
    uh, _ = project_3d(camera, x, y, H)
    ok = ok & jnp.isfinite(uh) & use & jnp.isfinite(u_top)
    uh = jnp.where(ok, uh, u)
    r = jnp.where(ok, u_top, uh) - uh
    med = jax.vmap(masked_median)(r, ok)
    g = jnp.zeros(med.shape, uh.dtype)
    if heading is not None:
        step = LEAN_STEP_M * heading
        ahead, _ = project_3d(camera, x + step[:, None, 0], y + step[:, None, 1], H)
        g_row = jnp.where(ok, (ahead - uh) / LEAN_STEP_M, 0.0)
        g = jax.vmap(masked_median)(g_row, ok)
    n = jnp.sum(ok, 1)
    enough = n >= MIN_TOP_ROWS
    mad = jax.vmap(masked_median)(jnp.abs(r - med[:, None]), ok)
    se = MEDIAN_SE * MAD_SD * mad / jnp.sqrt(jnp.maximum(n, 1))
    se = jnp.maximum(jnp.where(enough, se, 1.0), SLANT_FLOOR_PX)
    return jnp.where(enough, med, 0.0), se, enough, jnp.where(enough, g, 0.0)


def profile_lean(residual, se, g, usable):
    """(delta m, the residuals less delta g, px): the crowd's lean delta minimising the
    weighted squares of (residual - delta g) / se over the `usable` tracks (B,), in closed
    form; 0 where no usable track has g != 0. Differentiable."""
    w = jnp.where(usable, 1.0 / se**2, 0.0)
    den = jnp.sum(w * g**2)
    delta = jnp.where(den > 0, jnp.sum(w * g * residual) / jnp.where(den > 0, den, 1.0), 0.0)
    return delta, residual - delta * g


def slant_walkers(batch, used: np.ndarray) -> int:
    """How many of the used tracks have a top row and a head column on `MIN_TOP_ROWS` rows."""
    top, col = getattr(batch, "v_top", None), getattr(batch, "u_top", None)
    if top is None or col is None:
        return 0
    ok = batch.present & np.all(np.isfinite(batch.z), -1) & np.isfinite(top) & np.isfinite(col)
    return int(np.sum(np.sum(ok[used], 1) >= MIN_TOP_ROWS))
