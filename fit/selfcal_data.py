"""What self-calibration (`fit.selfcal`) reads from tracks: each track's gait peak, the used tracks'
arrays (`select`, `make_data`: the rows with a foot point; `fit.selfcal_rows` can restrict them to
the tracker's observed rows first), and synthetic scenes of walkers (and bicycles, dogs) seen by
random cameras for its tests and benchmark.

The gait peak does not depend on the camera: the pace F of (12) is a peak of the MEM spectrum of
the rhythm signal I(k) (window B, Sec. 4.1), computed here exactly as the classifier computes it
(`rhythmjax.model.rhythm`: gaps filled, the window normalised, Burg's spectrum of order M relative
to the white-noise level, S of (13) over every local maximum), on windows of N samples from each
track's first frame, one every `hop_samples`. A track has a *clear gait peak* when one of its
windows holds a peak in the walking model's pace band (|F - pace_mean| <= k_sigma3 pace_std,
(14)'s pace half), above P_thr (13), with R of (15) above R_thr. Its pace is that peak's
frequency (the window with the largest R). Stride, speed and widths do depend on the camera and
are left to the fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from fit.camera import CameraParams
from rhythmjax.model import mem
from rhythmjax.model.camera import ground_from_image
from rhythmjax.model.params import Camera, Config
from rhythmjax.model.rhythm import (
    MAX_MISSING_FRACTION,
    spectral_sum,
    window_spectrum,
)


@dataclass
class GaitPeaks:
    """Per track (B): pace F (Hz, NaN without a clear peak), its power (x the white level), R of
    (15), and whether the peak is clear (module doc)."""

    pace_hz: np.ndarray
    power: np.ndarray
    ratio: np.ndarray
    clear: np.ndarray


def _window_peak(cfg: Config, x, dt):
    """(F Hz, power, R) of the best in-band peak of one window (NaN, 0, 0 when none)."""
    thr, wk = cfg.thresholds, cfg.walking
    known = jnp.isfinite(x)
    enough = jnp.sum(~known) <= MAX_MISSING_FRACTION * x.shape[0]
    spec, nonconstant = window_spectrum(x, dt, thr.m)
    ok = nonconstant & spec.ok & enough

    def white(pk):
        mask = pk.mask & ok
        return mem.Peaks(pk.freq, jnp.where(mask, pk.power / dt, 0.0), mask)

    peaks = white(spec.peaks)
    total = spectral_sum(white(mem.local_maxima(spec.psd, spec.freqs)), thr.p_thr)
    ratio = peaks.power / jnp.where(total > 0, total, 1.0)
    band = jnp.abs(peaks.freq - wk.pace_mean) <= thr.k_sigma3 * wk.pace_std
    good = peaks.mask & band & (peaks.power > thr.p_thr)
    k = jnp.argmax(jnp.where(good, ratio, -1.0))
    has = good[k]
    return (jnp.where(has, peaks.freq[k], jnp.nan), jnp.where(has, peaks.power[k], 0.0),
            jnp.where(has, ratio[k], 0.0))


@eqx.filter_jit
def _track_peaks(cfg: Config, intensity, length, dt):
    n, hop = cfg.thresholds.n, cfg.thresholds.hop_samples
    T = intensity.shape[1]
    starts = jnp.arange(max(1, (T - n) // hop + 1)) * hop

    def one(x, L):
        def win(s):
            w = jax.lax.dynamic_slice_in_dim(x, jnp.clip(s, 0, max(T - n, 0)), n)
            f, p, r = _window_peak(cfg, w, dt)
            inside = s + n <= L
            return jnp.where(inside, f, jnp.nan), jnp.where(inside, p, 0.0), jnp.where(
                inside, r, 0.0)
        f, p, r = jax.vmap(win)(starts)
        k = jnp.argmax(r)
        return f[k], p[k], r[k]

    return jax.vmap(one)(intensity, length)


def gait_peaks(cfg: Config, intensity: np.ndarray, length: np.ndarray) -> GaitPeaks:
    """Clear gait peaks (module doc) of padded tracks: `intensity` (B, T) I(k) from each track's
    first frame (NaN missing), `length` (B,) frames; the sample interval is 1 / camera.fps."""
    n = cfg.thresholds.n
    x = np.asarray(intensity, np.float32)
    if x.shape[1] < n:
        x = np.pad(x, ((0, 0), (0, n - x.shape[1])), constant_values=np.nan)
    f, p, r = (np.asarray(a, np.float64) for a in _track_peaks(
        cfg, jnp.asarray(x), jnp.asarray(length, jnp.int32), jnp.float32(1.0 / cfg.camera.fps)))
    clear = np.isfinite(f) & (r > float(cfg.thresholds.r_thr))
    return GaitPeaks(np.where(clear, f, np.nan), p, r, clear)


# ----------------------------------------------------------------------------------------------
# the used tracks as the fit reads them (moved from fit.selfcal)

SPEED_SAMPLES = 48  # the Theil-Sen speed of a track over at most this many of its frames
PAD_TRACKS = 8  # the used tracks are padded to a multiple of this
MIN_ROWS = 20  # a track needs this many measured rows


class Data(eqx.Module):
    """The used tracks, padded (B, T), float64: foot points z (px, 0 where `obs` is False),
    widths (px, NaN missing), times (s from the track's middle), pace F (Hz), top rows v_top
    (px, NaN missing) and top_depth (m, a scalar): how much farther from the camera, along the
    ground, the point a top row images lies than the foot point's (`fit.selfcal_height`); the
    head's columns u_top at the top rows (px, NaN missing; `fit.selfcal_slant`), None when the
    slant cue is off (its terms are then not computed at all)."""

    z: jax.Array
    width: jax.Array
    t: jax.Array
    obs: jax.Array
    pace: jax.Array
    valid: jax.Array  # False on the padding (copies of the first track, weight 0)
    v_top: jax.Array
    top_depth: jax.Array
    u_top: jax.Array | None


def select(cfg: Config, batch) -> tuple[np.ndarray, np.ndarray]:
    """(used mask (B,), pace Hz (B,)) of a `rhythmjax.io.TrackBatch`: tracks with a clear gait
    peak (`gait_peaks`), at least `MIN_ROWS` measured foot points and two on the frames the
    speed takes (every k-th of the padded length, `raw_cues`; else the speed is undefined)."""
    peaks = gait_peaks(cfg, batch.intensity, batch.length)
    z = np.asarray(batch.z)
    seen = batch.present & np.all(np.isfinite(z), -1)
    k = -(-(z.shape[1] - z.shape[1] % -SPEED_SAMPLES) // SPEED_SAMPLES)
    ok = (np.sum(seen, 1) >= MIN_ROWS) & (np.sum(seen[:, ::k], 1) >= 2)
    return peaks.clear & ok, peaks.pace_hz


def make_data(batch, used: np.ndarray, pace: np.ndarray, top_depth_m: float = 0.0,
              head_columns: bool = False) -> Data:
    """`Data` of the used tracks of a batch, float64 (call inside ``jax.enable_x64``);
    `top_depth_m` the top rows' depth offset (m, `Data`); `head_columns`: carry u_top (the
    slant cue is on), else None."""
    z = np.asarray(batch.z, np.float64)[used]
    obs = batch.present[used] & np.all(np.isfinite(z), -1)
    t = np.asarray(batch.t, np.float64)[used]
    lo = np.min(np.where(obs, t, np.inf), 1)
    hi = np.max(np.where(obs, t, -np.inf), 1)
    t = np.where(obs, t - 0.5 * (lo + hi)[:, None], 0.0)
    B, T = obs.shape
    pad = np.r_[np.arange(B), np.zeros(-B % PAD_TRACKS, np.int64)]  # one compiled shape per
    # PAD_TRACKS tracks and per SPEED_SAMPLES frames (the speed's stride k is kept: no change)
    cols = -T % SPEED_SAMPLES
    wide = lambda a, fill: np.pad(a, [(0, 0), (0, cols)] + [(0, 0)] * (a.ndim - 2),
                                  constant_values=fill)
    def head(name):  # the optional head rows / columns of the used tracks, NaN where absent
        col = getattr(batch, name, None)
        return (np.full(obs.shape, np.nan) if col is None
                else np.where(obs, np.asarray(col, np.float64)[used], np.nan))
    return Data(*(jnp.asarray(a[pad]) for a in (
        wide(np.where(obs[..., None], z, 0.0), 0.0),
        wide(np.asarray(batch.width, np.float64)[used], np.nan), wide(t, 0.0),
        wide(obs, False), pace[used])), jnp.asarray(np.arange(pad.size) < B),
        jnp.asarray(wide(head("v_top"), np.nan)[pad]), jnp.asarray(float(top_depth_m),
                                                                    jnp.float64),
        jnp.asarray(wide(head("u_top"), np.nan)[pad]) if head_columns else None)


# ----------------------------------------------------------------------------------------------
# synthetic scenes with random cameras (the tests and benchmarks/eval_selfcal.py)

SIZES = ((640, 480), (720, 576), (800, 600), (1024, 768), (1280, 720), (1920, 1080))
F_M = 0.008  # m, the config's default f


def random_camera(rng: np.random.Generator, fps: float = 15.0) -> Camera:
    """h 2-10 m, tilt 5-40 deg, a f = b f 400-1500 px, an image size of `SIZES`, principal
    point at the image centre, roll 0 (what a config giving only the image size holds). Not
    checked for view: `scene` redraws when the simulator cannot place its paths."""
    w, hh = SIZES[rng.integers(len(SIZES))]
    af = rng.uniform(400.0, 1500.0)
    return Camera(f=F_M, h=rng.uniform(2.0, 10.0), theta=math.radians(rng.uniform(5.0, 40.0)),
                  a=af / F_M, b=af / F_M, uc=w / 2, vc=hh / 2, fps=fps, image_width=w,
                  image_height=hh)


def camera_values(cam: Camera) -> dict[str, float]:
    """a f (px), h (m), theta (deg), uc, vc (px), roll (deg) of a camera."""
    f = float(cam.f)
    return {"af": float(cam.a) * f, "bf": float(cam.b) * f, "h": float(cam.h),
            "theta": math.degrees(float(cam.theta)), "uc": float(cam.uc),
            "vc": float(cam.vc), "roll": math.degrees(float(cam.roll))}


def scene(rng: np.random.Generator, *, walkers: int = 20, bicycles: int = 0, dogs: int = 0,
          cars: int = 0, tries: int = 50, **camera_kw):
    """(camera, tracks columns, truth) of a random camera (`random_camera`) and
    `rhythmjax.sim.tracks.make_tracks` on it (1.5 px foot-point noise, 3 % gaps, 72-110 frames
    at 15 fps); redrawn while the simulator cannot place the paths in view (a camera that sees
    too little of the 3-20 m ground)."""
    from fit.walking import make_labelled
    from rhythmjax.model.params import ConfigError

    for _ in range(tries):
        cam = random_camera(rng, **camera_kw)
        try:
            cols, truth = make_labelled(n_walkers=walkers, n_bicycles=bicycles, n_dogs=dogs,
                                        n_cars=cars, seed=int(rng.integers(2**31)), camera=cam)
        except ConfigError:
            continue
        return cam, cols, truth
    raise RuntimeError(f"no camera of {tries} draws could hold the scene")


# ----------------------------------------------------------------------------------------------
# the camera's parameters (moved from fit.selfcal)

def make_params(v: dict[str, float]) -> CameraParams:
    """`CameraParams` (fit.camera's unconstrained form) of natural values (`fit.camera.UNITS`)."""
    p = min(max(v["theta"], 0.5), 89.5) / 90.0
    return CameraParams(*(jnp.asarray(x, jnp.float64) for x in (
        math.log(v["af"]), math.log(v["bf"] / v["af"]), math.log(v["h"]),
        math.log(p / (1 - p)), v["uc"], v["vc"], math.radians(v["roll"]), 0.0, 0.0, 0.0)))


def camera_of(values: dict[str, float], like: Camera) -> Camera:
    """The `Camera` of natural values (`fit.camera.UNITS`), f and static fields of `like`."""
    f = float(like.f)
    return Camera(f=f, h=values["h"], theta=math.radians(values["theta"]), a=values["af"] / f,
                  b=values["bf"] / f, uc=values["uc"], vc=values["vc"],
                  roll=math.radians(values["roll"]), fps=like.fps,
                  image_width=like.image_width, image_height=like.image_height)


def radial(camera: Camera, batch, used: np.ndarray, within_deg: float = 15.0) -> bool:
    """Whether every used track's ground heading (first to last measured foot point through
    `camera`) lies within `within_deg` of the optical axis's ground direction (y)."""
    z = np.asarray(batch.z, np.float64)[used]
    ok = np.all(np.isfinite(z), -1)
    first, last = np.argmax(ok, 1), z.shape[1] - 1 - np.argmax(ok[:, ::-1], 1)
    i = np.arange(z.shape[0])
    with jax.enable_x64(True):
        ends = [ground_from_image(camera, jnp.asarray(z[i, k, 0]), jnp.asarray(z[i, k, 1]))
                for k in (first, last)]
    dx, dy = (np.asarray(ends[1][j]) - np.asarray(ends[0][j]) for j in (0, 1))
    ang = np.degrees(np.arctan2(np.abs(dx), np.abs(dy)))
    return bool(np.all(ang <= within_deg))


def scene_batch(cols: dict, cfg: Config, *, max_gap_frames: int = 5):
    """A `TrackBatch` of a scene's tracks columns with their heads (v_top, u_top), through a
    temporary file so that `rhythmjax.io.read_tracks`' validation applies (as
    `fit.walking.batch_of`, which keeps only the required columns and the label)."""
    import tempfile
    from pathlib import Path

    from rhythmjax.io import read_tracks, to_batch, write_table

    keep = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "v_top",
            "u_top")
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "tracks.parquet"
        write_table(p, cols, [k for k in cols if k in keep])
        tr = read_tracks(p, fps=cfg.camera.fps)
    return to_batch(tr, max_gap_frames=max_gap_frames, min_len=cfg.thresholds.n,
                    fps=cfg.camera.fps)


def row_spread(batch, used: np.ndarray, height_px: float) -> float:
    """The 10-90 % range of the used tracks' median foot rows, as a fraction of the image
    height: near 0 when every walker is at about the same depth (nothing foreshortens)."""
    v = np.asarray(batch.z, np.float64)[used][..., 1]
    med = np.array([np.median(r[np.isfinite(r)]) for r in v if np.isfinite(r).any()])
    if med.size < 2:
        return 0.0
    return float(np.subtract(*np.percentile(med, [90, 10]))) / float(height_px)
