"""Self-calibration from people walking (issue 19): the camera of (3) from unlabelled tracks.

Only tracks with a clear gait peak are used (`fit.selfcal_data.gait_peaks`: a peak in the
walking model's pace band, above P_thr (13), with R of (15) above R_thr); their pace F (Hz) does
not depend on the camera. Everything else does, through the project's camera model: the foot
points (u, v) px go to the ground by the inverse of (3) (`rhythmjax.model.camera.
ground_from_image`), widths by the inverse of (10)'s image width (`camera.ground_width`). The
cues, each a residual per track in units of its spread (`CUES`):

- ``gait``: the stride of (12), T = D / (F N dt) = speed / F with the classifier's Theil-Sen
  ground speed (`rhythmjax.model.rhythm.ground_speed`) over the whole track (every k-th
  frame, at most `SPEED_SAMPLES`), against the walking
  model (Table 1 or the config's): (T - stride_mean) / stride_std. Ground distances scale with
  the camera height h, F does not: this fixes the metric scale (and, with walkers in several
  directions and at several depths, the foreshortening). With ``stride_model="walk-ratio"``
  (`fit.selfcal_gait.expected_stride`) the stride follows the pace instead: people who step
  slowly take shorter steps, at a constant walk ratio T / F (Sekiya & Nagasaki 1998 report the
  walk ratio nearly independent of walking speed), so T ~ N(stride_mean F / pace_mean, sd^2)
  with the spread that leaves Table 1's spread of T over the population.
- ``speed``: a walker's ground speed is constant along its track. A quadratic fit of the ground
  positions against time gives the relative change of speed over the track, (a . v) / |v|^2 at
  the track's middle (dimensionless; 0 for the true camera). Scale-free: it fixes the horizon
  (a combination of tilt and focal length), never h.
- ``width``: people's ground widths follow the config's width model N(mean, std^2) whatever
  their distance: (mean width of the track - mean) / std, and the change of log width over the
  track (a linear fit against time, dimensionless) / its spread.
- ``height``: foot-head heights (`fit.selfcal_height`): per row, the height H (m) of the
  vertical segment on the foot point's ground point whose top projects to the track's top row
  v_top (the tracks format's optional column); per track the median H against people's heights
  N(width.height, `HEIGHT_STD_M`^2), and the change of log H over the track / its spread.
  Alone, the classical foot-head calibration: it fixes h, theta and a f. The crowd's mean
  height is estimated too, about width.height with the spread `height_mean_sd` (0.05 m by
  default; 0 holds it at width.height: `fit.selfcal_height.crowd_height`), and the heights are
  compared with it.
  The crowd's mean stride can be estimated the same way (`stride_mean_sd`, 0 by default: held at
  the walking model's): each walker's stride over its expected stride, about the crowd's mean of
  that ratio, 1 a priori with the spread stride_mean_sd / stride_mean
  (`fit.selfcal_cost.crowd_stride`).
- ``slant`` (not in `DEFAULT_CUES`): heads over feet (`fit.selfcal_slant`): per track the median
  of the head column u_top (the tracks format's optional column, `rhythmjax count` writes it)
  less the column of the point H m above the foot point's ground point (H from v_top), in units
  of its own standard error. People off the image's centre column lean towards the vertical
  vanishing point, b f / tan(theta) below the principal point: with heights' horizon row
  (b f tan(theta) above it) this gives a f and the tilt apart. Scale-free. The head is taken
  delta m ahead of the feet along the track's ground direction (walkers lean into their
  stride), delta one unknown for the crowd, profiled out (`fit.selfcal_slant.profile_lean`).

The spreads of the three shape residuals (speed, width, height change) are measurement noise, not a
model's: they are estimated from the data (1.4826 x MAD after a first fit), floored at
`SHAPE_FLOOR`. The gait residual's and the height level's spreads are the model's (Table 1's, 0.07
m); `cue_spreads="data"` estimates them the same way, floored at the model's
(`fit.selfcal_cost.model_spreads`; off by default). Every residual goes through Cauchy's loss (c =
2.385 spreads): bicycles and dogs that slip through the gait selection (a bicycle's stride is
1.4-1.9 m: 8-13 spreads) do not pull the scale. Rows used: every cue but the pace reads every row
with a foot point (a `predict` row of the tracker's holds the detection its gates refused);
`rhythmjax-fit selfcal --observed-only` keeps only the `observe` rows' foot points, widths and top
rows where the tracks give the state (`fit.selfcal_rows`, off by default), the rhythm signal on
every row. A hinge keeps every used foot point below the horizon; foot points far from their
track's image path can be left out first (`fit.selfcal_outliers`, off by default), and before that
the frame-difference detector's union of two frames can be undone in the foot points, widths and
top rows (`fit.selfcal_union`, off by default). The fit is
Levenberg-Marquardt (optimistix) over log a f, log h and the tilt (and the roll, the principal
point when asked), in float64, from the best points of a grid over tilt and a f with h set by
the median stride. ``speed`` alone leaves h free; ``gait`` or ``width`` fix it. Standard errors
come from the Gauss-Newton covariance scaled by the residual variance (as `fit.camera`).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.flatten_util
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from fit.camera import NAMES, UNITS, CameraParams, se_limits
from fit.selfcal_checks import geometry_reasons
from fit.selfcal_cost import (
    N_BLOCKS,
    crowd_mean_height,
    crowd_mean_stride,
    cue_weights,
    model_spreads,
    raw_cues,
    residuals,
    standardised,
)
from fit.selfcal_data import (
    MIN_ROWS,
    camera_of,
    camera_values,
    make_data,
    make_params,
    radial,
    select,
)
from fit.selfcal_gait import STRIDE_MODELS, expected_stride
from fit.selfcal_height import HEIGHT_MEAN_SD_M, HEIGHT_STD_M, MIN_TOP_ROWS, top_walkers
from fit.selfcal_outliers import without_outliers
from fit.selfcal_report import STATIONARY_COS, SelfcalFit, jacobians, report, stationarity
from fit.selfcal_slant import slant_walkers
from fit.selfcal_union import undo_union
from rhythmjax.model.params import Camera, Config


CUES = ("gait", "speed", "width", "height", "slant")
DEFAULT_CUES = CUES[:4]  # the height cue is dropped (a note) where the tracks have no top rows
CUE_SPREADS = ("model", "data")  # `fit_selfcal(cue_spreads=)`
SHAPE_FLOOR = 0.02  # their spread is never below this (set a priori; seeds 0-5 checked)
MIN_WALKERS = 5  # fewer tracks with a clear gait peak: refused
MIN_ROW_SPREAD = 0.02  # walkers' median foot rows (10-90 %) span less of the image: refused
# (a quarter of the smallest on the development seeds 0-5, 0.083; added after CASIA-B's walks)
FITTABLE = ("af", "h", "theta", "roll", "uc", "vc")  # what `fit_selfcal` can fit
THETA_GRID = (3.0, 6.0, 10.0, 15.0, 20.0, 26.0, 33.0, 40.0, 50.0, 60.0)
AF_GRID = (0.3, 0.42, 0.6, 0.8, 1.05, 1.35, 1.8, 2.4)  # x the image width


@eqx.filter_jit
def _solve(dynamic, args, max_steps):
    solver = optx.LevenbergMarquardt(rtol=1e-6, atol=1e-6)
    sol = optx.least_squares(residuals, solver, dynamic, args=args, throw=False,
                             max_steps=max_steps)
    return sol.value, sol.result, sol.stats["num_steps"]


@eqx.filter_jit
def _grid_raw(stack, like, f, data, cfg):
    return jax.vmap(lambda p: raw_cues(p.camera(like, f), data, cfg))(stack)


@eqx.filter_jit
def _grid_cost(stack, static, args):
    one = lambda d: jnp.sum(residuals(d, (static,) + args) ** 2)
    return jax.vmap(one)(stack)


# ----------------------------------------------------------------------------------------------

def param_spec(fitted) -> CameraParams:
    """The filter spec (True = fitted) of `CameraParams` for names of `fit.camera.NAMES`."""
    return CameraParams(*(k in fitted for k in NAMES))


def _starts(cam0: Camera, values0, data, cfg, cues, spec, n_best: int, width_scale=None,
            stride_model: str = "table1", height_mean_sd: float = 0.0,
            stride_mean_sd: float = 0.0):
    """The best `n_best` grid points (tilt x a f) with h from the median stride (each over
    its pace's share of the expected stride, `expected_stride`), or height, or width."""
    f = float(cam0.f)
    grid = []
    # a f held (not in `spec`): every start at the start camera's
    af_grid = AF_GRID if spec.log_af else (values0["af"] / float(cam0.image_width),)
    for th in THETA_GRID:
        for k in af_grid:
            af = k * cam0.image_width
            grid.append({**values0, "af": af, "bf": af * values0["bf"] / values0["af"],
                         "theta": th, "h": 1.0})
    h1 = jax.tree.map(lambda *xs: jnp.stack(xs), *[make_params(g) for g in grid])
    raw = _grid_raw(h1, cam0, jnp.float64(f), data, cfg)
    raw = [{k: np.asarray(q[i]) for k, q in raw.items()} for i in range(len(grid))]
    valid = np.asarray(data.valid)
    expected = expected_stride(data.pace, cfg.walking, STRIDE_MODELS[stride_model])[0]
    pace_share = np.asarray(expected)[valid] / float(cfg.walking.stride_mean)  # 1 for table1
    nanmedian = lambda a: float(np.median(a[np.isfinite(a)])) if np.isfinite(a).any() else 0.0
    for g, r in zip(grid, raw, strict=True):
        r = {k: q[valid] for k, q in r.items()}
        if "gait" in cues:
            s = nanmedian(np.asarray(r["stride"]) / pace_share)
            g["h"] = float(cfg.walking.stride_mean) / s if s > 0 else values0["h"]
        elif "height" in cues:
            s = nanmedian(np.where(r["hok"], r["height"], np.nan))
            g["h"] = float(cfg.width.height) / s if s > 0 else values0["h"]
        elif "width" in cues:
            s = nanmedian(np.asarray(r["width"]))
            g["h"] = float(cfg.width.mean) / s if s > 0 else values0["h"]
        else:
            g["h"] = values0["h"]
        g["h"] = float(min(max(g["h"], 0.2), 200.0)) if np.isfinite(g["h"]) else values0["h"]
    dyns = [eqx.partition(make_params(g), spec)[0] for g in grid + [values0]]
    static = eqx.partition(make_params(values0), spec)[1]
    stack = jax.tree.map(lambda *xs: jnp.stack(xs), *dyns)
    wt = cue_weights(cues, width_scale=width_scale, stride_model=stride_model,
                     height_mean_sd=height_mean_sd, stride_mean_sd=stride_mean_sd)
    cost = np.asarray(_grid_cost(stack, static, (cam0, jnp.float64(f), data, cfg, wt)))
    order = [i for i in np.argsort(cost) if np.isfinite(cost[i])][:n_best]
    return [(grid + [values0])[i] for i in order]


def _values(val, static) -> dict[str, float]:
    nat = np.asarray(eqx.combine(val, static).natural())
    return dict(zip(NAMES, (float(q) for q in nat), strict=True))


def _refused(cam0, cues, fitted, n_tracks, n_used, ids, reason) -> SelfcalFit:
    return SelfcalFit(None, cues, (), camera_values(cam0), {}, np.zeros((0, 0)), math.inf, "",
                      "not run", True, 0, True, [reason], n_tracks, n_used, ids)


def fit_selfcal(cfg: Config, batch, *, cues=DEFAULT_CUES,
                fit=("af", "h", "theta"), max_steps: int = 200, n_starts: int = 3,
                width_scale: bool | None = None, outliers: bool = False,
                frame_union: bool = False, stride_model: str = "table1",
                height_mean_sd: float = HEIGHT_MEAN_SD_M,
                stride_mean_sd: float = 0.0, top_depth_m: float = 0.0,
                cue_spreads: str = "model") -> SelfcalFit:
    """Self-calibrate the camera of `cfg` (the start; its image size, fps, f, b/a and whatever
    is not in `fit` are held) from the tracks of a `rhythmjax.io.TrackBatch` (padded from each
    track's first frame), with the `cues` (a subset of `CUES`). `fit` is a subset
    of ("af", "h", "theta", "roll", "uc", "vc") holding h and theta (without "af" the focal
    length is held at the start's: a known lens); b f follows a f at the start's b/a. Refuses
    (ill_determined with a reason, no camera) with fewer than `MIN_WALKERS` walkers; flags the
    fit ill-determined when a fitted parameter is not determined (module doc). The height cue
    needs top rows (`batch.v_top`) on `MIN_TOP_ROWS` rows of `MIN_WALKERS` walkers: alone it is
    refused without them, with other cues it is dropped (a note says so). With `outliers` the
    foot points of `fit.selfcal_outliers`' rule are left out first (a note gives how many);
    with `frame_union`, before that, the frame-difference union is undone in the foot points,
    widths and top rows (`fit.selfcal_union`, at the config's fps). `stride_model` is the gait
    cue's (`STRIDE_MODELS`, `expected_stride`): "table1" or "walk-ratio". `height_mean_sd` (m)
    lets the crowd's mean height differ from the config's by about that much
    (`fit.selfcal_height.crowd_height`; a note gives its estimate); 0 holds it.
    `stride_mean_sd` (m) does the same for the crowd's mean stride against the walking model's
    (`fit.selfcal_cost.crowd_stride`; 0, the default, holds it). `top_depth_m` (m): the top
    rows image a point that far beyond the foot point along the ground (`fit.selfcal_height`;
    0, the default: the vertical segment on the foot point). `cue_spreads` (`CUE_SPREADS`):
    "model" (the default) takes the gait residuals' and the heights' spreads from the walking
    model and the height prior; "data" estimates both after the first fit as the shape
    residuals' are (1.4826 MAD), floored at the model's (docs/selfcal.md: measured, off)."""
    if cue_spreads not in CUE_SPREADS:
        raise ValueError(f"cue spreads {cue_spreads!r}: choose from {', '.join(CUE_SPREADS)}")
    for name, sd in (("height_mean_sd", height_mean_sd), ("stride_mean_sd", stride_mean_sd),
                     ("top_depth_m", top_depth_m)):
        if not (sd >= 0 and math.isfinite(sd)):
            raise ValueError(f"{name} {sd}: a distance in m, >= 0")
    if stride_model not in STRIDE_MODELS:
        raise ValueError(f"stride model {stride_model!r}: choose from "
                         f"{', '.join(STRIDE_MODELS)}")
    bad = [c for c in cues if c not in CUES]
    cues = tuple(c for c in CUES if c in cues)
    if bad or not cues:
        raise ValueError(f"cues {list(bad) or 'none'}: choose from {', '.join(CUES)}")
    fitted = tuple(k for k in NAMES if k in fit)
    if not {"h", "theta"} <= set(fitted) or set(fit) - set(FITTABLE):
        raise ValueError(f"fit {fit}: h and theta, optionally af, roll, uc, vc")
    cam0 = cfg.camera
    if frame_union:
        batch = undo_union(batch, float(cam0.fps))[0]
    batch, dropped = without_outliers(batch) if outliers else (batch, None)
    used, pace = select(cfg, batch)
    ids = [i for i, u in zip(batch.ids, used, strict=True) if u]
    n_tracks, n_used = len(batch.ids), int(used.sum())
    if n_used < MIN_WALKERS:
        return _refused(cam0, cues, fitted, n_tracks, n_used, ids,
                        f"only {n_used} of {n_tracks} tracks have a clear gait peak and "
                        f"{MIN_ROWS} measured rows; self-calibration needs at least "
                        f"{MIN_WALKERS} walkers")
    notes = [] if dropped is None else [
        f"{int(dropped[used].sum())} foot points of the walkers left out as outliers (each "
        "track's image path, fit.selfcal_outliers)"]
    for cue, walkers_with, what in (("height", top_walkers, "top rows (v_top)"),
                                    ("slant", slant_walkers, "head columns (v_top, u_top)")):
        if cue in cues and (n_with := walkers_with(batch, used)) < MIN_WALKERS:
            why = (f"only {n_with} of the {n_used} walkers have {what} on {MIN_TOP_ROWS} "
                   f"rows; the {cue} cue needs {MIN_WALKERS}")
            if cues == (cue,):
                return _refused(cam0, cues, fitted, n_tracks, n_used, ids, why)
            cues = tuple(c for c in cues if c != cue)
            notes.append(f"cue {cue} dropped: {why}")
    if top_depth_m > 0 and "height" in cues:
        notes.append(f"top rows taken {top_depth_m:g} m beyond their foot points along the "
                     "ground (--top-depth)")
    values0 = camera_values(cam0)
    spec = param_spec(fitted)
    f = float(cam0.f)
    with jax.enable_x64(True):
        data = make_data(batch, used, pace, top_depth_m, head_columns="slant" in cues)
        starts = _starts(cam0, values0, data, cfg, cues, spec, n_starts, width_scale,
                         stride_model, height_mean_sd, stride_mean_sd)

        def run(start, wt):
            dyn, static = eqx.partition(make_params(start), spec)
            args = (static, cam0, jnp.float64(f), data, cfg, wt)
            val, res, steps = _solve(dyn, args, max_steps)
            r = np.asarray(residuals(val, args))
            cost = float(np.sum(r**2)) if np.all(np.isfinite(r)) else math.inf
            return cost, val, static, args, res, int(steps)

        wt = cue_weights(cues, width_scale=width_scale, stride_model=stride_model,
                         height_mean_sd=height_mean_sd, stride_mean_sd=stride_mean_sd)
        best = min((run(s, wt) for s in starts), key=lambda t: t[0])
        # the shape residuals' spreads from the data (1.4826 MAD), then the final fit
        raw = raw_cues(eqx.combine(best[1], best[2]).camera(cam0, f), data, cfg)
        mad = lambda a: 1.4826 * float(np.median(np.abs(a - np.median(a))))
        sd_s = max(mad(np.asarray(raw["dspeed"])[:n_used]), SHAPE_FLOOR)
        sd_w = max(mad(np.asarray(raw["dlogw"])[:n_used]), SHAPE_FLOOR)
        hok = np.asarray(raw["hok"])[:n_used]
        sok = np.asarray(raw["sok"])[:n_used]
        sd_h = max(mad(np.asarray(raw["dlogh"])[:n_used][hok]) if hok.any() else 0.0,
                   SHAPE_FLOOR)
        sd_g, sd_l = (1.0, 1.0) if cue_spreads == "model" else model_spreads(
            standardised(eqx.combine(best[1], best[2]).camera(cam0, f), data, cfg, wt), n_used,
            hok)
        wt = cue_weights(cues, sd_s, sd_w, width_scale, sd_h, stride_model, height_mean_sd,
                         stride_mean_sd, sd_g, sd_l)
        best = run(_values(best[1], best[2]), wt)
        cost, val, static, args, res, steps = best
        J, G, r = jacobians(residuals, val, static, args, fitted)
        n_eff = n_used * (("gait" in cues) + ("speed" in cues) + ("width" in cues)
                          + int(float(wt.width_scale) > 0)) + 2 * int(hok.sum()) * (
                              "height" in cues) + int(sok.sum()) * ("slant" in cues)
        cov, se, cond, weak = report(J, G, r, fitted, n_eff)
        values = _values(val, static)
        cam_fit = eqx.combine(val, static).camera(cam0, f)
        std = np.asarray(standardised(cam_fit, data, cfg, wt))
        if height_mean_sd > 0 and "height" in cues:
            notes.append(f"the walkers' mean height {crowd_mean_height(cam_fit, data, cfg, wt):.3f}"
                         f" m (prior {float(cfg.width.height):.2f} +- {height_mean_sd:g} m)")
        if cue_spreads == "data":
            notes.append(f"spreads from the walkers (--cue-spreads data): strides {sd_g:.2f} x "
                         f"the walking model's, heights {sd_l:.2f} x {HEIGHT_STD_M:g} m")
        if stride_mean_sd > 0 and "gait" in cues:
            ratio = crowd_mean_stride(cam_fit, data, cfg, wt)
            notes.append(f"the walkers' mean stride {ratio:.3f} x the walking model's (prior 1 +- "
                         f"{stride_mean_sd / float(cfg.walking.stride_mean):.3f})")
    blk = std.reshape(N_BLOCKS, -1)[:, :n_used]
    parts = {"gait": blk[0], "speed": blk[1], "width": np.r_[blk[2], blk[3]],
             "height": np.r_[blk[4][hok], blk[5][hok]], "slant": blk[6][sok]}
    cue_rms = {k: float(np.sqrt(np.mean(parts[k] ** 2))) if parts[k].size else math.nan
               for k in cues}
    msg = optx.RESULTS[res]
    success = res == optx.RESULTS.successful
    if res == optx.RESULTS.nonlinear_max_steps_reached:
        cos = stationarity(J, r)
        success = cos <= STATIONARY_COS
        msg = (f"stationary at max_steps (largest |cos(J_i, r)| {cos:.1e})" if success else
               f"{max_steps} steps without converging (largest |cos(J_i, r)| {cos:.1e})")
    out = SelfcalFit(camera_of(values, cam0), cues, fitted, values, se, cov, cond, weak,
                     "" if res == optx.RESULTS.successful else msg, bool(success), steps,
                     False, [], n_tracks, n_used, ids,
                     {"speed_change": sd_s, "log_width_change": sd_w,
                      "log_height_change": sd_h, "stride_in_model": sd_g,
                      "height_in_prior": sd_l}, cue_rms, notes)
    det = out.determination()
    if not success:
        out.reasons.append(f"solver: {msg}")
    if not 0.5 < values["theta"] < 89.5:
        out.reasons.append(f"theta {values['theta']:.3f} deg at the edge of (0, 90)")
    if values["af"] < 0.1 * cam0.image_width:
        out.reasons.append(f"a f {values['af']:.3g} px under a tenth of the image width: a "
                           "near-orthographic camera, which makes every track's speed constant "
                           "while the robust loss discounts every stride")
    lim = se_limits({**{k: 0.0 for k in NAMES}, **values})
    out.reasons += [f"{k} not determined by the cues {', '.join(cues)} (SE {se[k]:.3g} "
                    f"{UNITS[k]}, limit {lim[k]:.3g})" for k in fitted
                    if det[k] == "not determined"]
    if out.reasons and radial(out.camera, batch, used):
        out.reasons.append("every walker moves along the optical axis (within 15 deg): "
                           "lateral and radial distances cannot be compared")
    out.reasons += geometry_reasons(out.camera, batch, used, MIN_ROW_SPREAD, ids)
    out.ill_determined = bool(out.reasons)
    return out
