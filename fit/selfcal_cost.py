"""The cost of self-calibration (`fit.selfcal`, issue 19): each cue's raw value per track
(`raw_cues`), their standardised residuals (`standardised`), the robust residual vector the
least squares minimises (`residuals`) and the cue weights (`cue_weights`). The cues and their
models are described in `fit.selfcal`'s module doc; heights are compared with the crowd's mean
height (`fit.selfcal_height.crowd_height`: the config's, or estimated about it), strides with
the crowd's mean stride relative to the walking model's (`crowd_stride`: 1, or estimated about it).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from fit.camera import CameraParams
from fit.selfcal_checks import HORIZON_MARGIN_PX
from fit.selfcal_crowd import crowd_mean
from fit.selfcal_data import SPEED_SAMPLES, Data
from fit.selfcal_gait import STRIDE_MODELS, expected_stride, relative_spread
from fit.selfcal_height import HEIGHT_STD_M, crowd_height, height_cues
from fit.selfcal_slant import profile_lean, slant_cue
from rhythmjax.model.camera import ground_from_image, ground_width, horizon_v
from rhythmjax.model.params import Camera, Config
from rhythmjax.model.rhythm import ground_speed


CAUCHY_C = 2.385  # Cauchy's constant at 95 % efficiency, in spreads
SHAPE_START = 0.1  # start spread of the shape residuals (relative change over a track)
N_BLOCKS = 7  # residual blocks per track (`standardised`)


class Weights(eqx.Module):
    """Per cue: a multiplier (0 = off) and the spreads of the shape residuals."""

    gait: jax.Array
    speed: jax.Array
    width: jax.Array
    width_scale: jax.Array
    sd_speed: jax.Array
    sd_wshape: jax.Array
    height: jax.Array
    sd_hshape: jax.Array
    stride_power: jax.Array  # the gait cue's stride model (`selfcal_gait`): 0 Table 1's
    sd_hmean: jax.Array  # the crowd's mean height's prior spread (m; 0: the config's, held)
    sd_tmean: jax.Array  # the crowd's mean stride's prior spread (m; 0: the model's, held)
    slant: jax.Array  # the slant cue (`fit.selfcal_slant`): heads over feet
    sd_gait: jax.Array  # the gait residuals' spread in the walking model's (1: the model's)
    sd_hlevel: jax.Array  # the heights' spread in HEIGHT_STD_M (1: the prior's 0.07 m)


def cauchy(r):
    """r -> sign(r) sqrt(2 rho(r)), rho Cauchy's with c = CAUCHY_C; smooth at 0."""
    x2 = (r / CAUCHY_C) ** 2
    small = x2 < 1e-12
    x2s = jnp.where(small, 1.0, x2)
    return r * jnp.sqrt(jnp.where(small, 1.0, jnp.log1p(x2s) / x2s))


def _linear_fit(t, y, w, degree):
    """Weighted least-squares polynomial coefficients (constant first) of y against t, per
    track (vmapped outside); y (T, k)."""
    A = jnp.stack([t**p for p in range(degree + 1)], -1)
    M = (A * w[:, None]).T @ A + 1e-9 * jnp.eye(degree + 1)
    return jnp.linalg.solve(M, (A * w[:, None]).T @ y)


def raw_cues(camera: Camera, data: Data, cfg: Config) -> dict[str, jax.Array]:
    """The cues' raw values per track (B): stride T (m), relative speed change, mean ground
    width (m), change of log width over the track, median height (m), change of log height,
    whether the track has heights, the head columns' median residual (px), its standard error
    (px), whether the track has head columns and the head column's change per metre of lean
    (px/m; `fit.selfcal_slant`), and the horizon hinge (px)."""
    u, v = data.z[..., 0], data.z[..., 1]
    gx, gy, ok = ground_from_image(camera, u, v)
    use = data.obs & ok
    xy = jnp.stack([gx, gy], -1)
    k = -(-data.t.shape[1] // SPEED_SAMPLES)  # every k-th frame: <= SPEED_SAMPLES samples
    speed = jax.vmap(ground_speed)(data.t[:, ::k], jnp.where(use[..., None], xy, 0.0)[:, ::k],
                                   use[:, ::k])
    dur = jnp.maximum(jnp.max(jnp.where(use, data.t, -jnp.inf), 1)
                      - jnp.min(jnp.where(use, data.t, jnp.inf), 1), 1e-3)
    tn = data.t / dur[:, None]
    w = use.astype(xy.dtype)
    c = jax.vmap(lambda t, p, w: _linear_fit(t, p, w, 2))(tn, jnp.where(use[..., None], xy, 0),
                                                          w)
    vel, acc = c[:, 1], 2.0 * c[:, 2]
    dspeed = jnp.sum(acc * vel, -1) / jnp.maximum(jnp.sum(vel**2, -1), 1e-12)
    wok = use & jnp.isfinite(data.width) & (data.width > 0)
    wid, okw = ground_width(camera, jnp.where(wok, data.width, 1.0), u, v)
    wok = wok & okw & (wid > 0)
    ww = wok.astype(xy.dtype)
    nw = jnp.maximum(jnp.sum(ww, 1), 1.0)
    wmean = jnp.sum(jnp.where(wok, wid, 0.0), 1) / nw
    logw = jnp.log(jnp.where(wok, wid, 1.0))
    cw = jax.vmap(lambda t, y, w: _linear_fit(t, y[:, None], w, 1))(tn, logw, ww)
    vh = horizon_v(camera) + jnp.tan(camera.roll) * (u - camera.uc)
    hinge = jnp.max(jnp.where(data.obs, vh + HORIZON_MARGIN_PX - v, -jnp.inf), 1)
    height, dlogh, hok = height_cues(camera, u, v, data.v_top, use, tn, data.top_depth)
    if data.u_top is None:  # the slant cue off: nothing computed
        slant, lean_g, slant_se = jnp.zeros_like(height), jnp.zeros_like(height), jnp.ones_like(
            height)
        sok = jnp.zeros(height.shape, bool)
    else:
        heading = vel / jnp.maximum(jnp.linalg.norm(vel, axis=-1, keepdims=True), 1e-9)
        slant, slant_se, sok, lean_g = slant_cue(camera, u, v, data.v_top, data.u_top, use,
                                                 data.top_depth, heading)
    return {"stride": speed / data.pace, "dspeed": dspeed, "width": wmean,
            "dlogw": cw[:, 1, 0], "height": height, "dlogh": dlogh, "hok": hok,
            "slant": slant, "slant_se": slant_se, "sok": sok, "lean_g": lean_g,
            "hinge": jnp.maximum(hinge, 0.0) / HORIZON_MARGIN_PX}


def _crowd(r: dict, data: Data, cfg: Config, wt: Weights) -> tuple[jax.Array, jax.Array]:
    """`crowd_height` of the tracks that carry heights, when the height cue is on."""
    hok = r["hok"] & data.valid & (wt.height > 0)
    return crowd_height(r["height"], hok, cfg.width.height, wt.sd_hmean,
                        HEIGHT_STD_M * wt.sd_hlevel)


def crowd_stride(r: dict, data: Data, cfg: Config, wt: Weights):
    """(ratio, mean, its prior residual): each track's stride over the walking model's
    expected stride (`expected_stride`, B), and the crowd's mean of that ratio
    (`fit.selfcal_crowd.crowd_mean` over the valid tracks with a finite stride, when the gait
    cue is on): 1 a priori with the spread sd_tmean / stride_mean, each walker's ratio about it
    with `relative_spread`. sd_tmean 0 holds it at 1 (Table 1's or the config's mean stride)."""
    t_mean = expected_stride(data.pace, cfg.walking, wt.stride_power)[0]
    ratio = r["stride"] / t_mean
    ok = data.valid & jnp.isfinite(ratio) & (wt.gait > 0)
    sd_mean = wt.sd_tmean / cfg.walking.stride_mean
    mean, prior = crowd_mean(jnp.where(ok, ratio, 1.0), ok, 1.0, sd_mean,
                             relative_spread(cfg.walking, wt.stride_power) * wt.sd_gait)
    return ratio, mean, prior


def _blocks(r: dict, data: Data, cfg: Config, wt: Weights):
    """The residual blocks of `standardised` from `raw_cues`' values, and the crowd's mean
    height's and mean stride's prior residuals (`crowd_height`, `crowd_stride`; 0 where held).
    Where the mean height is estimated, heights are compared with it relatively, (H / mean - 1)
    x 1.70 / 0.07, so that their spread does not shrink with the camera's scale; held,
    (H - 1.70) / 0.07. Strides likewise: estimated, (ratio / mean - 1) / `relative_spread`;
    held, (T - expected) / its spread. The slant's residuals less the crowd's lean
    (`fit.selfcal_slant.profile_lean`), in their standard errors."""
    wk, wm = cfg.walking, cfg.width
    wh = wt.height * r["hok"].astype(wt.height.dtype)
    ws = wt.slant * r["sok"].astype(wt.slant.dtype)
    slant = profile_lean(r["slant"], r["slant_se"], r["lean_g"], r["sok"] & data.valid)[1]
    mean_h, prior_h = _crowd(r, data, cfg, wt)
    t_mean, t_sd = expected_stride(data.pace, wk, wt.stride_power)
    ratio, mean_t, prior_t = crowd_stride(r, data, cfg, wt)
    gait = jnp.where(wt.sd_tmean > 0,
                     (ratio / mean_t - 1.0) / relative_spread(wk, wt.stride_power),
                     (r["stride"] - t_mean) / t_sd)
    valid = data.valid.astype(wt.gait.dtype)[None, :].repeat(N_BLOCKS, 0).ravel()
    # a cue that is off gives 0, even where a degenerate camera makes its value NaN
    weighted = lambda w, x: jnp.where(w > 0, w * x, 0.0)
    return valid * jnp.concatenate([
        weighted(wt.gait, gait / wt.sd_gait),
        weighted(wt.speed, r["dspeed"] / wt.sd_speed),
        weighted(wt.width_scale, (r["width"] - wm.mean) / wm.std),
        weighted(wt.width, r["dlogw"] / wt.sd_wshape),
        weighted(wh, jnp.where(wt.sd_hmean > 0, (r["height"] / mean_h - 1.0) * wm.height,
                               r["height"] - wm.height) / (HEIGHT_STD_M * wt.sd_hlevel)),
        weighted(wh, r["dlogh"] / wt.sd_hshape),
        weighted(ws, slant / r["slant_se"])]), jnp.stack([prior_h, prior_t])


def standardised(camera: Camera, data: Data, cfg: Config, wt: Weights) -> jax.Array:
    """The residual vector (before the robust loss): per track, each cue in its spreads
    (weight 0 = the cue is off); heights about the crowd's mean (`crowd_height`)."""
    return _blocks(raw_cues(camera, data, cfg), data, cfg, wt)[0]


def crowd_mean_height(camera: Camera, data: Data, cfg: Config, wt: Weights) -> float:
    """The crowd's mean height (m) under `camera` (`crowd_height`; the config's where held)."""
    return float(_crowd(raw_cues(camera, data, cfg), data, cfg, wt)[0])


def crowd_mean_stride(camera: Camera, data: Data, cfg: Config, wt: Weights) -> float:
    """The crowd's mean stride over the walking model's (`crowd_stride`; 1 where held)."""
    return float(crowd_stride(raw_cues(camera, data, cfg), data, cfg, wt)[1])


def residuals(dynamic: CameraParams, args) -> jax.Array:
    """The robust residual vector of the camera (optimistix's least squares): the cues'
    (`standardised`) through the robust loss, the horizon hinges, the crowd's mean height's
    and mean stride's priors."""
    static, like, f, data, cfg, wt = args
    cam = eqx.combine(dynamic, static).camera(like, f)
    r = raw_cues(cam, data, cfg)
    std, priors = _blocks(r, data, cfg, wt)
    return jnp.concatenate([cauchy(std), 10.0 * jnp.where(data.valid, r["hinge"], 0.0),
                            priors])



def cue_weights(cues, sd_speed=SHAPE_START, sd_wshape=SHAPE_START, width_scale=None,
                sd_hshape=SHAPE_START, stride_model: str = "table1",
                height_mean_sd: float = 0.0, stride_mean_sd: float = 0.0,
                sd_gait: float = 1.0, sd_hlevel: float = 1.0) -> Weights:
    """`Weights` of a cue set; the width's scale term is on with the width cue when
    `width_scale` is True, or (None) only without gait (module doc); the gait cue's stride
    model by name (`STRIDE_MODELS`); the crowd's mean height's and mean stride's prior spreads
    (m, 0: held); the gait residuals' and the heights' spreads in the model's (1: the
    model's, Table 1's stride spread and 0.07 m; `fit.selfcal` estimates them with
    `cue_spreads="data"`)."""
    on = lambda c: jnp.float64(1.0 if c in cues else 0.0)
    ws = "gait" not in cues if width_scale is None else width_scale
    scale = jnp.float64(1.0 if "width" in cues and ws else 0.0)
    return Weights(on("gait"), on("speed"), on("width"), scale, jnp.float64(sd_speed),
                   jnp.float64(sd_wshape), on("height"), jnp.float64(sd_hshape),
                   jnp.float64(STRIDE_MODELS[stride_model]), jnp.float64(height_mean_sd),
                   jnp.float64(stride_mean_sd), on("slant"), jnp.float64(sd_gait),
                   jnp.float64(sd_hlevel))


def model_spreads(std, n_used: int, hok) -> tuple[float, float]:
    """(gait, height level) spreads in the model's units from the standardised residuals `std`
    of a first fit (`standardised` with the model's spreads): 1.4826 x the MAD over the
    `n_used` walkers (heights: those with `hok`), floored at 1, the walking model's stride
    spread and the height prior's 0.07 m (never more weight than the model gives); 1 where no
    walker has the cue."""
    blk = np.asarray(std).reshape(N_BLOCKS, -1)[:, :n_used]

    def spread(a):
        return max(1.0, 1.4826 * float(np.median(np.abs(a - np.median(a))))) if a.size else 1.0

    return spread(blk[0]), spread(blk[4][np.asarray(hok, bool)])
