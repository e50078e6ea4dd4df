"""The foot-head height cue of self-calibration (`fit.selfcal`, issue 19).

A walker's height H (m) is the length of the vertical segment standing on the ground point of
its foot point (u, v) px whose top projects to the measured top row v_top px of its moving
region (the head; the tracks format's optional `v_top` column). With the camera of (3) and a
point z m above the ground point (x, y) (`rhythmjax.model.camera.project_3d`), the depth is
d(z) = d0 - z sin(theta), d0 = f + y cos(theta) + h sin(theta), and the image row satisfies

    (Vc - v(z)) d(z) = N0 + N1 z,   N1 = b f cos(theta) cos(roll),
    N0 = cos(roll) b f (y sin(theta) - h cos(theta)) - sin(roll) a f x,

so with q = Vc - v_top and the foot point's own row (z = 0: (Vc - v) d0 = N0),

    H = (q d0 - N0) / (N1 + q sin(theta)) = d0 (v - v_top) / (N1 + q sin(theta))      (H1)

(a d0 / (b f) times the pixel height for a level camera). H scales with h for fixed angles and
image; its change with the position in the image fixes the horizon and the vertical vanishing
point, so heights alone determine a f, theta and (with people's mean height) h: the classical
foot-head calibration. Per track the cue gives the median height (robust to the rows where the
tracker's top row is off) and the change of log height over the track (a linear fit against
time, rows more than `TRIM_LOG` from the track's median left out), both differentiable in the
camera (the median through a sort).

A silhouette's top row is not quite the top of that vertical segment: seen from above, the
topmost pixel of a head is its far edge and the lowest pixel of the feet their near edge, so
the point the top row images lies D m farther along the ground than the foot point's (x, y).
With `depth_m` = D, (H1) is taken at (x, y + D) (y grows away from the camera): d0 and N0 with
y + D. The plain segment (D = 0, the default) reads a walker z m tall as z + (h - z) D / (y + D)
(h the camera's height): 1.82 m for 1.7 m at 10 m from a 7 m camera with D = 0.23 m.
`--top-depth` and docs/selfcal.md give what it changes on measured tracks.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from fit.selfcal_crowd import crowd_mean, masked_median
from rhythmjax.model.camera import ground_from_image, height_from_top_with, terms
from rhythmjax.model.params import Camera


HEIGHT_STD_M = 0.07  # people's heights ~ N(1.7, 0.07^2) m (issue 19); the mean is the config's
HEIGHT_MEAN_SD_M = 0.05  # `--height-mean-sd`'s default (m): how far a crowd's mean
# height (its sex ratio, its country's stature, shoes, where the tracker's top row sits on the
# head) may lie from the config's mean, set a priori: adult statures by country, both sexes
# together, spread over about 1.60-1.77 m (not chosen on any tracks)
MIN_TOP_ROWS = 10  # a track needs this many rows with a top row for the height cue
TRIM_LOG = 0.15  # rows whose log height is further than this from the track's median: out of
# the slope (a top row 15 % off: the head clipped or another object's motion joined)


def height_from_top(camera: Camera, u, v, v_top, depth_m=0.0):
    """(H m, ok) of (H1): the height above the ground point of the foot point (u, v) px whose
    top, `depth_m` m farther along the ground (module doc), projects to the image row v_top
    px. `ok` is False where the foot point is not on the ground in front of the camera
    (`ground_from_image`), v_top is not finite, or the top lies at or beyond the vertical
    vanishing point (denominator <= 0); H is 0 there (finite, so gradients stay finite).
    Differentiable in the camera."""
    return head_from_top(camera, u, v, v_top, depth_m)[2:]


def head_from_top(camera: Camera, u, v, v_top, depth_m=0.0):
    """(x, y, H, ok): `height_from_top`'s H and ok with the ground point (x, y) m of the head,
    `depth_m` m beyond the foot point's along the ground."""
    x, y, ok = ground_from_image(camera, u, v)
    y = y + depth_m
    ok = ok & jnp.isfinite(v_top)
    v_top = jnp.where(ok, v_top, v)  # data, not parameters: no NaN reaches a gradient
    H, ok_top = height_from_top_with(jnp, terms(camera), x, y, v_top)
    ok = ok & ok_top
    return x, y, jnp.where(ok, H, 0.0), ok


def crowd_height(height, usable, prior_mean, sd_mean, sd_each=HEIGHT_STD_M):
    """(mean height m, its prior residual) of the crowd whose walkers' median heights are
    `height` (B,) where `usable` (`fit.selfcal_crowd.crowd_mean` with each walker's height
    N(mean, sd_each^2) about the crowd's mean, sd_each HEIGHT_STD_M by default): the crowd's
    mean is unknown, N(prior_mean, sd_mean^2) a priori, profiled out of the least squares.
    `sd_mean` 0: the mean is the prior's (residual 0), as without this rule; also with no
    usable walker.
    Differentiable in `height`."""
    return crowd_mean(height, usable, prior_mean, sd_mean, sd_each)


def _slope(t, y, w):
    """Weighted least-squares slope of y against t (T,)."""
    sw = jnp.maximum(jnp.sum(w), 1e-12)
    tb, yb = jnp.sum(w * t) / sw, jnp.sum(w * y) / sw
    return jnp.sum(w * (t - tb) * (y - yb)) / jnp.maximum(jnp.sum(w * (t - tb) ** 2), 1e-12)


def height_cues(camera: Camera, u, v, v_top, use, tn, depth_m=0.0):
    """Per track (B,): (median height m, change of log height over the track, usable) of foot
    points (u, v), top rows v_top (px; `depth_m` m farther, `height_from_top`) and the rows `use`
    (B, T), times `tn` (B, T) in units of the track's duration. Usable: at least
    `MIN_TOP_ROWS` rows with a height."""
    H, ok = height_from_top(camera, u, v, v_top, depth_m)
    ok = ok & use & (H > 0)
    med = jax.vmap(masked_median)(H, ok)
    enough = jnp.sum(ok, 1) >= MIN_TOP_ROWS
    med = jnp.where(enough, med, 1.0)
    logh = jnp.log(jnp.where(ok, H, 1.0))
    keep = ok & (jnp.abs(logh - jax.lax.stop_gradient(jnp.log(med))[:, None]) <= TRIM_LOG)
    dlogh = jax.vmap(_slope)(tn, logh, keep.astype(H.dtype))
    return med, jnp.where(enough, dlogh, 0.0), enough


def top_walkers(batch, used: np.ndarray) -> int:
    """How many of the used tracks have a top row (v_top) on at least `MIN_TOP_ROWS` rows."""
    top = getattr(batch, "v_top", None)
    if top is None:
        return 0
    ok = batch.present & np.all(np.isfinite(batch.z), -1) & np.isfinite(top)
    return int(np.sum(np.sum(ok[used], 1) >= MIN_TOP_ROWS))
