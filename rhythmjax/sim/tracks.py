"""Synthetic tracks files with known truth: walkers, bicycles, dogs and cars seen by a camera.

This is the tracks-format generator (one row per track per frame) that tests, benchmarks and the
README use; rendered video scenes are `rhythmjax.synth`. Deterministic given `seed`. The
helpers below (`kind_params`, `track_frames`, `rhythm_per_px`, ...) take arrays too:
`sim.bulk` draws the same model for 1e4-1e6+ tracks a block at a time.

Rhythm signal model (window B of Sec. 4.1, sum of absolute frame differences in grey levels):
- walker: each step (period 1/F) has a swing phase (about 80 % of the step) in which one foot
  moves fast; I(k) follows the swing speed sin(pi phase / 0.8)^1.5, with a left/right asymmetry
  (a component at F/2) and noise; pace F ~ N(2.05, 0.183) Hz, stride T ~ N(0.72, 0.09) m
  (Table 1), speed F*T;
- bicycle: 2.5-3.5 m/s along the road (faster ones would cross the range in fewer than N
  frames and are `too-short`); the pedalling legs give a weak modulation at twice the
  cadence (0.9-1.5 rev/s), so its pace can look human while its stride (speed / F, over
  1.4 m) cannot;
- dog: trot at 3-5 Hz with 0.2-0.35 m steps;
- car: 2-3.5 m/s, no rhythm, just noise on a constant.
Every intensity scales with the window area (W x W/5 px, W the image width of a 0.5 m walker).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from ..model.camera import image_width, project
from ..model.camera_np import project_3d
from ..model.params import Camera, ConfigError


KINDS = ("pedestrian", "bicycle", "dog", "car")
# apparent ground width (m) seen head-on and side-on
WIDTH_M = {"pedestrian": (0.50, 0.36), "bicycle": (0.60, 1.70), "dog": (0.30, 0.80),
           "car": (1.80, 4.20)}
RANGE_Y_M = (3.3, 19.7)  # a path stays this far ahead (m), inside Table 1's 3-20 m
START_Y_M = (5.0, 17.0)  # where a walker's, a dog's path starts (m ahead)
EDGE_PX = 5.0  # a path stays this far inside the image (px)
RADIAL_RANGE_M = 14.5  # bicycles and cars are tracked at most this far (m) along the road
# height (m) of an object's top (the head; a bicycle's rider), N(mean, std^2) per object
HEIGHT_M = {"pedestrian": (1.70, 0.07), "bicycle": (1.75, 0.05), "dog": (0.50, 0.08),
            "car": (1.50, 0.10)}


def heads(camera: Camera, x, y, height_m: float, noise_v, noise_u) -> tuple[np.ndarray, ...]:
    """(v_top, u_top) px: the image row and column of the point `height_m` m above the ground
    point (x, y) m (the head over the foot point, slanted towards the vertical vanishing point;
    equation (3) with z), plus `noise_v` and `noise_u` px."""
    u, v = project_3d(camera, x, y, np.full(np.shape(x), height_m))
    return np.asarray(v) + noise_v, np.asarray(u) + noise_u


@dataclass(frozen=True)
class TrackTruth:
    track_id: str
    label: str
    pace_hz: float  # NaN for cars
    stride_m: float  # NaN for cars
    speed_mps: float
    n_frames: int


def kind_params(kind: str, rng: np.random.Generator, size: int | None = None):
    """(pace Hz, stride m, speed m/s, modulation depth) of `size` objects of one kind (Python
    floats when `size` is None, else arrays). Draws in this order: pace then stride
    (pedestrian), speed then cadence (bicycle), pace then step (dog), speed (car)."""
    full = (lambda q: q) if size is None else (lambda q: np.full(size, q))
    if kind == "pedestrian":
        pace = np.clip(rng.normal(2.05, 0.183, size), 1.6, 2.6)
        stride = np.clip(rng.normal(0.72, 0.09, size), 0.5, 0.95)
        if size is None:
            pace, stride = float(pace), float(stride)
        return pace, stride, pace * stride, full(1.0)
    if kind == "bicycle":
        speed, cadence = rng.uniform(2.5, 3.5, size), rng.uniform(0.9, 1.5, size)
        return 2 * cadence, speed / (2 * cadence), speed, full(0.2)
    if kind == "dog":
        pace, step = rng.uniform(3.0, 5.0, size), rng.uniform(0.2, 0.35, size)
        return pace, step, pace * step, full(0.8)
    return full(math.nan), full(math.nan), rng.uniform(2.0, 3.5, size), full(0.0)


def track_frames(kind: str, rng: np.random.Generator, speed, fps: float | int,
                 min_frames: int, max_frames: int, size: int | None = None):
    """Frames each object is tracked: 20-55 for a short track (`kind` "short"), else
    min_frames-max_frames, for bicycles and cars at most the frames they take to cross
    `RADIAL_RANGE_M` at `speed` m/s. An int when `size` is None, else an int64 array."""
    n = (rng.integers(20, 56, size) if kind == "short"
         else rng.integers(min_frames, max_frames + 1, size))
    if kind in ("bicycle", "car"):  # fast objects leave the detection range sooner
        n = np.minimum(n, np.asarray(RADIAL_RANGE_M / np.asarray(speed) * fps).astype(np.int64))
    return int(n) if size is None else n.astype(np.int64)


def start_half_width(camera: Camera, y0):
    """Half the lateral span (m) a path may start in at y0 m ahead: 80 % of the image's."""
    return 0.8 * (camera.image_width / 2) * y0 * math.cos(float(camera.theta)) / float(
        camera.a * camera.f)


def in_view(camera: Camera, u, v, y):
    """Whether the foot point (u, v) px is `EDGE_PX` inside the image and y (m) in
    `RANGE_Y_M`, element-wise."""
    return ((u > EDGE_PX) & (u < camera.image_width - EDGE_PX) & (v > EDGE_PX)
            & (v < camera.image_height - EDGE_PX) & (y > RANGE_Y_M[0]) & (y < RANGE_Y_M[1]))


def seen_width_m(label: str, heading):
    """Apparent ground width (m) of an object moving at `heading` rad: its side-on width when
    moving across the view, its head-on width when moving along it (`WIDTH_M`)."""
    front, side = WIDTH_M[label]
    xp = math if np.ndim(heading) == 0 else np
    return abs(xp.sin(heading)) * front + abs(xp.cos(heading)) * side


def swing(phase: np.ndarray) -> np.ndarray:
    """Swing speed of a step at `phase` (steps): sin(pi p / 0.8)^1.5 in the swing phase
    (the first 80 % of a step), 0 in the stance."""
    p = np.mod(phase, 1.0)
    return np.where(p < 0.8, np.sin(np.pi * np.clip(p / 0.8, 0, 1)) ** 1.5, 0.0)


def rhythm_per_px(t, pace, phase, asym, depth, noise, intensity_noise: float, car):
    """I(k) per window pixel (grey levels) at times t (s): 4 + 20 depth swing(pace t + phase),
    every other step scaled by `asym` (1 for no asymmetry), plus intensity_noise x 20 x
    `noise` (standard normal draws); for a car (`car` True) 3 + 0.5 noise, no rhythm. Arrays
    broadcast; intensity is this times the window area, clipped at 0."""
    with np.errstate(invalid="ignore"):
        cyc = pace * t + phase
        s = swing(cyc) * np.where(np.floor(cyc) % 2 == 0, 1.0, asym)
        walk = 4.0 + 20.0 * depth * s + intensity_noise * 20.0 * noise
    return np.where(car, 3.0 + 0.5 * noise, walk)


# random tries to place one path (200 missed feasible paths for 1 object in ~1000, issue
# 17); a path no try fits is cut where it leaves the view (`_path`, issue 18)
PLACE_TRIES = 3000


def _path(camera: Camera, rng, speed, n_frames, y_range, radial):
    """A straight path that stays in view and in the detection range for n_frames (random
    tries). Where none of `PLACE_TRIES` does (a walker in the tail of Table 1's pace and
    stride, 2.4 m/s for 107 frames, covers 17 m: no straight path from a start in `y_range`
    fits), the try that stays in view longest, cut where it leaves: the object is tracked for
    fewer frames, as a tracker would lose it. Under half of n_frames in view is a
    `ConfigError` naming the camera (it sees too little ground)."""
    dt = 1.0 / camera.fps
    best, best_len = None, 0
    for _ in range(PLACE_TRIES):
        heading = (rng.uniform(-0.35, 0.35) + rng.choice([0.5, -0.5]) * math.pi if radial
                   else rng.uniform(-math.pi, math.pi))
        y0 = rng.uniform(*y_range)
        if radial:  # start at the end of the range it moves away from
            y0 = rng.uniform(15.0, 19.0) if math.sin(heading) < 0 else rng.uniform(4.0, 6.0)
        x0 = rng.uniform(-start_half_width(camera, y0), start_half_width(camera, y0))
        t = np.arange(n_frames) * dt
        x = x0 + speed * math.cos(heading) * t
        y = y0 + speed * math.sin(heading) * t
        u, v = (np.asarray(a) for a in project(camera, jnp.asarray(x), jnp.asarray(y)))
        inside = in_view(camera, u, v, y)
        if inside.all():
            return x, y, heading
        stay = int(np.argmin(inside))
        if stay > best_len:
            best, best_len = (x[:stay], y[:stay], heading), stay
    if best is not None and 2 * best_len >= n_frames:
        return best
    raise ConfigError("camera", f"no straight path of {n_frames} frames stays in view and in "
                      f"3.3-19.7 m ahead in {PLACE_TRIES} random tries (the best "
                      f"{best_len} frames); is the camera sensible (`rhythmjax camera`)?")


def make_tracks(
    *,
    n_walkers: int = 20,
    n_bicycles: int = 5,
    n_dogs: int = 5,
    n_cars: int = 3,
    n_short: int = 0,
    seed: int = 0,
    camera: Camera | None = None,
    r_std_px: float = 1.5,
    gap_rate: float = 0.03,
    intensity_noise: float = 0.15,
    min_frames: int = 72,
    max_frames: int = 110,
) -> tuple[dict[str, np.ndarray], list[TrackTruth]]:
    """Columns of a tracks file (ARCHITECTURE.md) and the truth per track.

    `n_short` extra walkers are tracked for fewer than 64 frames (expected `too-short`). Columns:
    track_id, frame, t, u, v, width_px, intensity, label, x, y (true ground position, m).
    Measurements are missing (empty u, v, width) at `gap_rate` of frames. v_top: the image row
    of the object's top (`heads`: a height per object from `HEIGHT_M`, noise as the foot
    point's), drawn from a generator of its own (seed (seed, 19)) so that the other columns
    are those of earlier versions; u_top: the head's column at that height (`heads`,
    noise as the foot point's from a generator (seed, 23)), where v_top is given."""
    camera = camera or Camera()
    rng = np.random.default_rng(seed)
    rng_top = np.random.default_rng([seed, 19])
    rng_head = np.random.default_rng([seed, 23])
    kinds = (["pedestrian"] * n_walkers + ["bicycle"] * n_bicycles + ["dog"] * n_dogs
             + ["car"] * n_cars + ["short"] * n_short)
    cols: dict[str, list] = {k: [] for k in ("track_id", "frame", "t", "u", "v", "width_px",
                                             "intensity", "label", "x", "y", "v_top",
                                             "u_top")}
    truth = []
    frame0 = 0
    for i, kind in enumerate(kinds):
        label = "pedestrian" if kind == "short" else kind
        pace, stride, speed, depth = kind_params(label, rng)
        n = track_frames(kind if kind == "short" else label, rng, speed, camera.fps,
                         min_frames, max_frames)
        radial = label in ("bicycle", "car")
        x, y, heading = _path(camera, rng, speed, n, START_Y_M, radial)
        n = len(x)  # fewer where the object leaves the view (`_path`)
        u, v = (np.asarray(a, float) for a in project(camera, jnp.asarray(x), jnp.asarray(y)))
        u = u + rng.normal(0, r_std_px, n)
        v = v + rng.normal(0, r_std_px, n)
        w_m = seen_width_m(label, heading)
        if label == "pedestrian":
            w_m = rng.normal(w_m, 0.04)
        w_px = np.asarray(image_width(camera, jnp.asarray(w_m), jnp.asarray(y)), float)
        w_px = w_px * (1 + rng.normal(0, 0.05, n))
        W = np.asarray(image_width(camera, jnp.asarray(0.5), jnp.asarray(y)), float)
        area = W * W / 5.0
        t = np.arange(n) / camera.fps
        if label == "car":
            per_px = rhythm_per_px(t, pace, 0.0, 1.0, depth, rng.standard_normal(n),
                                   intensity_noise, True)
        else:
            ph = rng.uniform(0, 1)
            # left and right steps differ a little: a peak at F/2
            asym = rng.uniform(0.8, 0.95) if label == "pedestrian" else 1.0
            per_px = rhythm_per_px(t, pace, ph, asym, depth, rng.standard_normal(n),
                                   intensity_noise, False)
        intensity = np.maximum(per_px, 0.0) * area
        gaps = rng.random(n) < gap_rate
        u[gaps], v[gaps], w_px[gaps] = np.nan, np.nan, np.nan
        height = rng_top.normal(*HEIGHT_M[label])
        top, head = heads(camera, x, y, height, rng_top.normal(0, r_std_px, n),
                          rng_head.normal(0, r_std_px, n))
        top[gaps | ~(top >= 0)] = np.nan  # a head above the image is not measured
        head[~np.isfinite(top)] = np.nan
        tid = f"{label[:3]}{i:03d}" if kind != "short" else f"sho{i:03d}"
        frames = frame0 + np.arange(n)
        frame0 += int(rng.integers(0, 5))
        cols["track_id"] += [tid] * n
        cols["frame"] += list(frames)
        cols["t"] += list(frames / camera.fps)
        for k, a in (("u", u), ("v", v), ("width_px", w_px), ("intensity", intensity),
                     ("x", x), ("y", y), ("v_top", top), ("u_top", head)):
            cols[k] += list(a)
        cols["label"] += [label] * n
        truth.append(TrackTruth(tid, label, pace, stride if label != "car" else math.nan,
                                speed, n))
    out = {k: np.asarray(v) for k, v in cols.items()}
    out["frame"] = out["frame"].astype(np.int64)
    return out, truth
