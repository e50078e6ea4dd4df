"""Model parameters as immutable equinox pytrees, with the paper's Table 1 defaults.

Every numeric field is a JAX array (so `jax.grad`, `jax.vmap` and optimistix see it); only true
structure (frame rate, image size, the AR order and window length) is static. Angles are radians
inside, degrees in config files; every config key carries its unit.
"""

from __future__ import annotations

import difflib
import math
import reprlib
from typing import Any, final

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float


def _f32(x: Any) -> Array:
    return jnp.asarray(x, dtype=jnp.result_type(float))


class ConfigError(ValueError):
    """A config value or key is invalid; `key` names it (dotted, e.g. ``camera.h_m``)."""

    def __init__(self, key: str, message: str):
        super().__init__(f"{key}: {message}")
        self.key = key


@final
class Camera(eqx.Module):
    """Pin-hole camera of equation (3).

    f (m, focal length), h (m, height above the ground), theta (rad, depression angle), a and b
    (px per m on the sensor, horizontal and vertical), uc and vc (px, image centre), roll (rad,
    an extension: the image of (3) rotated by +roll about (uc, vc), see `rhythmjax.camera`;
    0 is the paper's model). Only the products a*f and b*f (px) are well determined by image
    data; see `fit.camera`.
    """

    f: Float[Array, ""] = eqx.field(converter=_f32, default=0.008)
    h: Float[Array, ""] = eqx.field(converter=_f32, default=1.0)
    theta: Float[Array, ""] = eqx.field(converter=_f32, default=math.radians(15.0))
    a: Float[Array, ""] = eqx.field(converter=_f32, default=1.0e5)
    b: Float[Array, ""] = eqx.field(converter=_f32, default=1.0e5)
    uc: Float[Array, ""] = eqx.field(converter=_f32, default=256.0)
    vc: Float[Array, ""] = eqx.field(converter=_f32, default=256.0)
    roll: Float[Array, ""] = eqx.field(converter=_f32, default=0.0)
    fps: float = eqx.field(static=True, default=15.0)
    image_width: int = eqx.field(static=True, default=512)
    image_height: int = eqx.field(static=True, default=512)

    @property
    def dt(self) -> float:
        """Nominal sample interval Delta (s)."""
        return 1.0 / self.fps


@final
class Noise(eqx.Module):
    """Process and measurement noise, stored unconstrained (R3 of STYLE.md).

    Process noise (1) acts on the velocities only: a velocity random walk whose variance per step
    is ``q**2 * dt`` (q in m/s per sqrt(s)); at the nominal dt this is the paper's per-step Q.
    Measurement noise R (px^2) is a 2x2 SPD matrix held as a log-Cholesky factor.
    The first measurement of a track initialises the position; `init_speed_std` (m/s) is the prior
    spread of the initial velocity.
    """

    log_q: Float[Array, "2"] = eqx.field(converter=_f32)
    log_r_diag: Float[Array, "2"] = eqx.field(converter=_f32)
    r_offdiag: Float[Array, ""] = eqx.field(converter=_f32)
    log_init_speed_std: Float[Array, ""] = eqx.field(converter=_f32)

    def __init__(
        self,
        q_std=(0.4, 0.4),
        r_std=(2.0, 2.0),
        r_corr=0.0,
        init_speed_std=2.0,
    ):
        q_std, r_std = np.asarray(q_std, float), np.asarray(r_std, float)
        if q_std.shape != (2,) or r_std.shape != (2,):
            raise ConfigError("noise", "q and r standard deviations need two values each")
        if not (np.all(q_std > 0) and np.all(r_std > 0) and init_speed_std > 0):
            raise ConfigError("noise", "standard deviations must be > 0")
        if not -1.0 < r_corr < 1.0:
            raise ConfigError("noise.r_corr", f"correlation {r_corr} outside (-1, 1)")
        self.log_q = np.log(q_std)
        # R = L L^T, L = [[l11, 0], [l21, l22]]
        l11 = r_std[0]
        l21 = r_corr * r_std[1]
        l22 = r_std[1] * math.sqrt(1.0 - r_corr**2)
        self.log_r_diag = np.log([l11, l22])
        self.r_offdiag = l21
        self.log_init_speed_std = math.log(init_speed_std)

    def q_std(self) -> Float[Array, "2"]:
        """Velocity noise (m/s per sqrt(s)) for x and y."""
        return jnp.exp(self.log_q)

    def Q(self, dt) -> Float[Array, "4 4"]:
        """Process noise covariance of (1) for a step of dt seconds; state (x, vx, y, vy)."""
        q2 = jnp.exp(2.0 * self.log_q) * dt
        zero = jnp.zeros((), q2.dtype)
        return jnp.diag(jnp.stack([zero, q2[0], zero, q2[1]]))

    def R_chol(self) -> Float[Array, "2 2"]:
        d = jnp.exp(self.log_r_diag)
        zero = jnp.zeros((), d.dtype)
        return jnp.stack([jnp.stack([d[0], zero]), jnp.stack([self.r_offdiag, d[1]])])

    def R(self) -> Float[Array, "2 2"]:
        """Measurement noise covariance of (2), px^2."""
        L = self.R_chol()
        return L @ L.T

    def r_std(self) -> Float[Array, "2"]:
        return jnp.sqrt(jnp.diag(self.R()))

    def r_corr(self) -> Float[Array, ""]:
        R = self.R()
        return R[0, 1] / jnp.sqrt(R[0, 0] * R[1, 1])

    def init_speed_std(self) -> Float[Array, ""]:
        return jnp.exp(self.log_init_speed_std)


@final
class WidthModel(eqx.Module):
    """Pedestrian body size in m: ground width ~ N(mean, std^2), used by the width gate (10),
    and height (an average pedestrian's, 1.7 m: the detection window and body box of the
    online tracker, count's patches of Masoud & Papanikolopoulos (width `mean`, this height),
    the overlay's boxes)."""

    mean: Float[Array, ""] = eqx.field(converter=_f32, default=0.5)
    std: Float[Array, ""] = eqx.field(converter=_f32, default=0.12)
    height: Float[Array, ""] = eqx.field(converter=_f32, default=1.7)

    def height_per_width(self) -> float:
        """Height over mean width (3.4 by default) as a host float: a walker W px wide at its
        foot point is this many W tall. Each float32 value is read as the shortest decimal
        that stands for it (1.7, not 1.7000000476837158), so host arithmetic gives what the
        literals 1.7 / 0.5 gave."""
        return host_float(self.height) / host_float(self.mean)


def host_float(x) -> float:
    """A scalar parameter as a host float: the shortest decimal that its dtype round-trips
    (float32 1.7 -> 1.7, where float() gives 1.7000000476837158), so host code that took a
    literal gives the same figures when it reads the config instead."""
    return float(str(np.asarray(x)[()]))


@final
class WalkingModel(eqx.Module):
    """Typical walking (Table 1): pace F ~ N(pace_mean, pace_std^2) Hz, stride T ~ N(...) m."""

    pace_mean: Float[Array, ""] = eqx.field(converter=_f32, default=2.050)
    pace_std: Float[Array, ""] = eqx.field(converter=_f32, default=0.183)
    stride_mean: Float[Array, ""] = eqx.field(converter=_f32, default=0.720)
    stride_std: Float[Array, ""] = eqx.field(converter=_f32, default=0.090)


@final
class Thresholds(eqx.Module):
    """Thresholds and window sizes (Table 1 and Sec. 5).

    p_thr: peak power threshold of (13), in the units of the normalised rhythm signal (see
    `rhythm.normalise_intensity`); r_thr: evaluation threshold after (15); k_sigma1..3: approval
    thresholds of (10), (11), (14); n: samples in the rhythm window; m: AR order; range_min/max:
    detection range (m); predict_timeout: seconds in PREDICT before a track is dropped;
    hop: samples between the starts of successive rhythm windows (N: the paper's back-to-back
    windows; 0, the default: N/2, each sample in two windows); harmonic_ratio: a peak that
    passes (14) is refused when a peak within 10 % of twice its frequency holds at least this
    fraction of its power (a trotting dog's half-pace component; 0, the default: off, the
    paper's (13)-(15) exactly; 0.25 was the default until issue 16: it helped on the project's
    own scenes only); see `rhythm.half_pace`. trend_cycles (rule 38): a window the paper's
    (13)-(15) does not judge Pedestrian whose strongest peak completes fewer than this many
    cycles over the window (F N dt < trend_cycles: a trend, not a rhythm) is judged again with
    its least-squares line removed, and is Pedestrian when that says so (reason
    matched-detrended); 0, the default: off; see `rhythm.judge_window_looks`.
    """

    p_thr: Float[Array, ""] = eqx.field(converter=_f32, default=10.0)
    r_thr: Float[Array, ""] = eqx.field(converter=_f32, default=0.1)
    k_sigma1: Float[Array, ""] = eqx.field(converter=_f32, default=3.0)
    k_sigma2: Float[Array, ""] = eqx.field(converter=_f32, default=3.0)
    k_sigma3: Float[Array, ""] = eqx.field(converter=_f32, default=3.0)
    range_min: Float[Array, ""] = eqx.field(converter=_f32, default=3.0)
    range_max: Float[Array, ""] = eqx.field(converter=_f32, default=20.0)
    predict_timeout: Float[Array, ""] = eqx.field(converter=_f32, default=1.0)
    harmonic_ratio: Float[Array, ""] = eqx.field(converter=_f32, default=0.0)
    n: int = eqx.field(static=True, default=64)
    m: int = eqx.field(static=True, default=15)
    hop: int = eqx.field(static=True, default=0)
    trend_cycles: float = eqx.field(static=True, default=0.0)

    @property
    def hop_samples(self) -> int:
        """Samples between rhythm-window starts: `hop`, or N // 2 when `hop` is 0."""
        return self.hop or max(1, self.n // 2)


@final
class Config(eqx.Module):
    """Everything the model needs, one pytree; see `config_to_dict` for the JSON layout."""

    camera: Camera = Camera()
    noise: Noise = Noise()
    width: WidthModel = WidthModel()
    walking: WalkingModel = WalkingModel()
    thresholds: Thresholds = Thresholds()


# ----------------------------------------------------------------------------------------------
# JSON layout: section -> key (with unit) -> (getter from the Module, checker)

def _s(x) -> float:
    return float(np.asarray(x))


_CAMERA_KEYS = ("f_m", "h_m", "theta_deg", "a_px_per_m", "b_px_per_m", "uc_px", "vc_px",
                "roll_deg", "fps", "image_width_px", "image_height_px")
_NOISE_KEYS = ("q_std_mps_per_sqrt_s", "r_std_px", "r_corr", "init_speed_std_mps")
_WIDTH_KEYS = ("mean_m", "std_m", "height_m")
_WALKING_KEYS = ("pace_mean_hz", "pace_std_hz", "stride_mean_m", "stride_std_m")
_THRESHOLD_KEYS = ("p_thr", "r_thr", "k_sigma1", "k_sigma2", "k_sigma3", "n_samples", "ar_order",
                   "range_min_m", "range_max_m", "predict_timeout_s", "window_hop_samples",
                   "harmonic_max_ratio", "trend_max_cycles", "window_s")
WINDOW_S = 64 / 15  # s: the rhythm window of Table 1, N = 64 samples at 15 fps
SECTIONS = {"camera": _CAMERA_KEYS, "noise": _NOISE_KEYS, "width": _WIDTH_KEYS,
            "walking": _WALKING_KEYS, "thresholds": _THRESHOLD_KEYS}


def walking_top_speed(cfg: Config) -> float:
    """The fastest ground speed (m/s) the walking model's test (14) accepts for any rhythm:
    speed = pace x stride with both within k_sigma3 of the model, so at most
    (pace_mean + k_sigma3 pace_std) x (stride_mean + k_sigma3 stride_std) (2.57 m/s with the
    paper's Table 1). A window moving faster is judged non-pedestrian whatever its spectrum."""
    w, k = cfg.walking, float(cfg.thresholds.k_sigma3)
    return walking_top_pace(cfg) * (float(w.stride_mean) + k * float(w.stride_std))


def walking_pace_band(cfg: Config) -> tuple[float, float]:
    """The paces (Hz) the walking model's test (14) accepts: pace_mean -+ k_sigma3 pace_std
    (1.50-2.60 Hz with the paper's Table 1)."""
    mean, k = float(cfg.walking.pace_mean), float(cfg.thresholds.k_sigma3)
    return mean - k * float(cfg.walking.pace_std), mean + k * float(cfg.walking.pace_std)


def walking_top_pace(cfg: Config) -> float:
    """The fastest pace (Hz) the walking model's test (14) accepts: the top of
    `walking_pace_band` (2.60 Hz with the paper's Table 1)."""
    return walking_pace_band(cfg)[1]


def config_to_dict(cfg: Config) -> dict[str, dict[str, Any]]:
    """The JSON-ready nested dict of a Config; keys carry units (ARCHITECTURE.md, config)."""
    c, n, w, k, t = cfg.camera, cfg.noise, cfg.width, cfg.walking, cfg.thresholds
    return {
        "camera": {
            "f_m": _s(c.f), "h_m": _s(c.h), "theta_deg": math.degrees(_s(c.theta)),
            "a_px_per_m": _s(c.a), "b_px_per_m": _s(c.b), "uc_px": _s(c.uc), "vc_px": _s(c.vc),
            "roll_deg": math.degrees(_s(c.roll)), "fps": float(c.fps),
            "image_width_px": int(c.image_width),
            "image_height_px": int(c.image_height),
        },
        "noise": {
            "q_std_mps_per_sqrt_s": [float(v) for v in np.asarray(n.q_std())],
            "r_std_px": [float(v) for v in np.asarray(n.r_std())],
            "r_corr": _s(n.r_corr()),
            "init_speed_std_mps": _s(n.init_speed_std()),
        },
        "width": {"mean_m": _s(w.mean), "std_m": _s(w.std), "height_m": _s(w.height)},
        "walking": {"pace_mean_hz": _s(k.pace_mean), "pace_std_hz": _s(k.pace_std),
                    "stride_mean_m": _s(k.stride_mean), "stride_std_m": _s(k.stride_std)},
        "thresholds": {
            "p_thr": _s(t.p_thr), "r_thr": _s(t.r_thr), "k_sigma1": _s(t.k_sigma1),
            "k_sigma2": _s(t.k_sigma2), "k_sigma3": _s(t.k_sigma3), "n_samples": int(t.n),
            "ar_order": int(t.m), "range_min_m": _s(t.range_min), "range_max_m": _s(t.range_max),
            "predict_timeout_s": _s(t.predict_timeout), "window_hop_samples": int(t.hop),
            "harmonic_max_ratio": _s(t.harmonic_ratio),
            "trend_max_cycles": float(t.trend_cycles),
        },
    }


# ranges beyond the types (issue 17): no number above MAGNITUDE (float32 holds it and products
# stay finite); the window at most MAX_SAMPLES (100 s at 1000 fps); image, timeout, fps bounds
MAGNITUDE, MAX_SAMPLES, MAX_IMAGE_PX, MAX_TIMEOUT_S, MAX_FPS = 1e12, 100_000, 100_000, 86_400.0, 1e3
_REPR = reprlib.Repr()  # a config value in a message, cut short (long lists, deep nesting)
_REPR.maxstring = _REPR.maxother = _REPR.maxlong = 40
_short = _REPR.repr
_PIXEL = {"lo": -MAX_IMAGE_PX, "hi": MAX_IMAGE_PX, "lo_open": False, "hi_open": False}


def _num(sec: str, key: str, v: Any, *, lo=None, hi=None, lo_open=True, hi_open=True,
         integer=False) -> Any:
    """The number `v` of config key `sec.key`, checked: a JSON number (not a bool), finite,
    within +/-MAGNITUDE, an integer if `integer`, and in (lo, hi) (`lo_open`/`hi_open` False:
    that end included); else a `ConfigError` naming the key."""
    name = f"{sec}.{key}"
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(name, f"expected a number, got {_short(v)}")
    if isinstance(v, int) and abs(v) > MAGNITUDE:
        raise ConfigError(name, f"an integer of ~{int(v.bit_length() * 0.30103) + 1} digits is "
                          f"out of range "
                          f"(at most {MAGNITUDE:g} in size)")
    if not math.isfinite(v):
        raise ConfigError(name, f"must be finite, got {v!r}")
    if abs(v) > MAGNITUDE:
        raise ConfigError(name, f"{v!r} is out of range (at most {MAGNITUDE:g} in size)")
    if integer and float(v) != int(v):
        raise ConfigError(name, f"expected an integer, got {v!r}")
    if lo is not None and (v <= lo if lo_open else v < lo):
        raise ConfigError(name, f"must be {'>' if lo_open else '>='} {lo}, got {v!r}")
    if hi is not None and (v >= hi if hi_open else v > hi):
        raise ConfigError(name, f"must be {'<' if hi_open else '<='} {hi}, got {v!r}")
    return int(v) if integer else float(v)


def _pair(sec: str, key: str, v: Any) -> tuple[float, float]:
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise ConfigError(f"{sec}.{key}", f"expected a list of two numbers, got {_short(v)}")
    return (_num(sec, key, v[0], lo=0.0), _num(sec, key, v[1], lo=0.0))


def config_from_dict(d: Any) -> Config:
    """Build a Config from a (possibly partial) nested dict; omitted keys take the defaults.

    Raises `ConfigError` naming the key for an unknown section or key (with a suggestion), a
    non-number, or an out-of-range value.
    """
    if not isinstance(d, dict):
        raise ConfigError("config", "expected a JSON object at the top level")
    for sec, body in d.items():
        if sec not in SECTIONS:
            raise ConfigError(sec, "unknown section" + _suggest(sec, SECTIONS))
        if not isinstance(body, dict):
            raise ConfigError(sec, "expected an object")
        for key in body:
            if key not in SECTIONS[sec]:
                raise ConfigError(f"{sec}.{key}", "unknown key" + _suggest(key, SECTIONS[sec]))
    full = config_to_dict(Config())
    for sec, body in d.items():
        full[sec].update(body)
    c, n, w, k, t = (full[s] for s in SECTIONS)
    given_c, given_t = d.get("camera", {}), d.get("thresholds", {})
    # The principal point defaults to the centre of the image (256, 256 for the default 512 x 512).
    for key, size in (("uc_px", "image_width_px"), ("vc_px", "image_height_px")):
        if key not in given_c:
            c[key] = _num("camera", size, c[size], lo=0, hi=MAX_IMAGE_PX, hi_open=False,
                          integer=True) / 2.0
    # The rhythm window is a duration: N = round(window_s * fps) unless n_samples is given.
    if "window_s" in given_t and "n_samples" in given_t:
        raise ConfigError("thresholds.window_s", "give the rhythm window as window_s or as "
                          "n_samples, not both")
    if "n_samples" not in given_t:
        window_s = _num("thresholds", "window_s", given_t.get("window_s", WINDOW_S), lo=0.0)
        fps = _num("camera", "fps", c["fps"], lo=0.0, hi=MAX_FPS, hi_open=False)
        t["n_samples"] = max(4, round(window_s * fps))
        if t["n_samples"] > MAX_SAMPLES:
            raise ConfigError("thresholds.window_s", f"{window_s:g} s at {fps:g} fps is "
                              f"{t['n_samples']} samples; at most {MAX_SAMPLES}")

    theta_deg = _num("camera", "theta_deg", c["theta_deg"], lo=0.0, hi=90.0)
    if "theta_deg" in d.get("camera", {}) and theta_deg < 0.6:
        raise ConfigError("camera.theta_deg", f"{theta_deg} looks like radians; give degrees")
    camera = Camera(
        f=_num("camera", "f_m", c["f_m"], lo=0.0), h=_num("camera", "h_m", c["h_m"], lo=0.0),
        theta=math.radians(theta_deg),
        a=_num("camera", "a_px_per_m", c["a_px_per_m"], lo=0.0),
        b=_num("camera", "b_px_per_m", c["b_px_per_m"], lo=0.0),
        uc=_num("camera", "uc_px", c["uc_px"], **_PIXEL), vc=_num("camera", "vc_px", c["vc_px"],
                                                                   **_PIXEL),
        roll=math.radians(_num("camera", "roll_deg", c["roll_deg"], lo=-45.0, hi=45.0)),
        fps=_num("camera", "fps", c["fps"], lo=0.0, hi=MAX_FPS, hi_open=False),
        image_width=_num("camera", "image_width_px", c["image_width_px"], lo=0, hi=MAX_IMAGE_PX,
                         hi_open=False, integer=True),
        image_height=_num("camera", "image_height_px", c["image_height_px"], lo=0,
                          hi=MAX_IMAGE_PX, hi_open=False, integer=True),
    )
    noise = Noise(
        q_std=_pair("noise", "q_std_mps_per_sqrt_s", n["q_std_mps_per_sqrt_s"]),
        r_std=_pair("noise", "r_std_px", n["r_std_px"]),
        r_corr=_num("noise", "r_corr", n["r_corr"], lo=-1.0, hi=1.0),
        init_speed_std=_num("noise", "init_speed_std_mps", n["init_speed_std_mps"], lo=0.0),
    )
    width = WidthModel(mean=_num("width", "mean_m", w["mean_m"], lo=0.0),
                       std=_num("width", "std_m", w["std_m"], lo=0.0),
                       height=_num("width", "height_m", w["height_m"], lo=0.0))
    walking = WalkingModel(
        pace_mean=_num("walking", "pace_mean_hz", k["pace_mean_hz"], lo=0.0),
        pace_std=_num("walking", "pace_std_hz", k["pace_std_hz"], lo=0.0),
        stride_mean=_num("walking", "stride_mean_m", k["stride_mean_m"], lo=0.0),
        stride_std=_num("walking", "stride_std_m", k["stride_std_m"], lo=0.0),
    )
    n_samples = _num("thresholds", "n_samples", t["n_samples"], lo=3, hi=MAX_SAMPLES,
                     hi_open=False, integer=True)
    ar_order = _num("thresholds", "ar_order", t["ar_order"], lo=0, integer=True)
    if ar_order >= n_samples - 1:
        raise ConfigError("thresholds.ar_order",
                          f"AR order {ar_order} must be < n_samples - 1 = {n_samples - 1}")
    rmin = _num("thresholds", "range_min_m", t["range_min_m"], lo=0.0)
    rmax = _num("thresholds", "range_max_m", t["range_max_m"], lo=rmin)
    thresholds = Thresholds(
        p_thr=_num("thresholds", "p_thr", t["p_thr"], lo=0.0, lo_open=False),
        r_thr=_num("thresholds", "r_thr", t["r_thr"], lo=0.0, hi=1.0, lo_open=False),
        k_sigma1=_num("thresholds", "k_sigma1", t["k_sigma1"], lo=0.0),
        k_sigma2=_num("thresholds", "k_sigma2", t["k_sigma2"], lo=0.0),
        k_sigma3=_num("thresholds", "k_sigma3", t["k_sigma3"], lo=0.0),
        range_min=rmin, range_max=rmax,
        predict_timeout=_num("thresholds", "predict_timeout_s", t["predict_timeout_s"], lo=0.0,
                             hi=MAX_TIMEOUT_S, hi_open=False),
        harmonic_ratio=_num("thresholds", "harmonic_max_ratio", t["harmonic_max_ratio"], lo=0.0,
                            lo_open=False),
        n=n_samples, m=ar_order,
        hop=_num("thresholds", "window_hop_samples", t["window_hop_samples"], lo=0, lo_open=False,
                 hi=n_samples, hi_open=False, integer=True),
        trend_cycles=_num("thresholds", "trend_max_cycles", t["trend_max_cycles"], lo=0.0,
                          lo_open=False, hi=n_samples / 2, hi_open=False),
    )
    return Config(camera, noise, width, walking, thresholds)


def _suggest(word: str, options) -> str:
    close = difflib.get_close_matches(word, list(options), n=1)
    return f" (did you mean {close[0]!r}?)" if close else f" (known: {', '.join(options)})"
