"""Synthetic tracks files with known truth: walkers, bicycles, dogs and cars seen by a camera.

This is the tracks-format generator (one row per track per frame) that tests, benchmarks and the
README use; rendered video scenes are `rhythmjax.synth`. Deterministic given `seed`.

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
from ..model.params import Camera, ConfigError


KINDS = ("pedestrian", "bicycle", "dog", "car")
# apparent ground width (m) seen head-on and side-on
_WIDTH = {"pedestrian": (0.50, 0.36), "bicycle": (0.60, 1.70), "dog": (0.30, 0.80),
          "car": (1.80, 4.20)}


@dataclass(frozen=True)
class TrackTruth:
    track_id: str
    label: str
    pace_hz: float  # NaN for cars
    stride_m: float  # NaN for cars
    speed_mps: float
    n_frames: int


def _kind_params(kind: str, rng: np.random.Generator) -> tuple[float, float, float, float]:
    """(pace Hz, stride m, speed m/s, modulation depth) of one object."""
    if kind == "pedestrian":
        pace = float(np.clip(rng.normal(2.05, 0.183), 1.6, 2.6))
        stride = float(np.clip(rng.normal(0.72, 0.09), 0.5, 0.95))
        return pace, stride, pace * stride, 1.0
    if kind == "bicycle":
        speed, cadence = rng.uniform(2.5, 3.5), rng.uniform(0.9, 1.5)
        return 2 * cadence, speed / (2 * cadence), speed, 0.2
    if kind == "dog":
        pace, step = rng.uniform(3.0, 5.0), rng.uniform(0.2, 0.35)
        return pace, step, pace * step, 0.8
    return math.nan, math.nan, rng.uniform(2.0, 3.5), 0.0


PLACE_TRIES = 3000  # 200 failed for 1 in ~1000 objects (issue 17: 1000-object scenes)


def _swing(phase: np.ndarray) -> np.ndarray:
    p = np.mod(phase, 1.0)
    return np.where(p < 0.8, np.sin(np.pi * np.clip(p / 0.8, 0, 1)) ** 1.5, 0.0)


def _path(camera: Camera, rng, speed, n_frames, y_range, radial):
    """A straight path that stays in view and in the detection range for n_frames (random tries;
    a camera that sees too little ground for one is a `ConfigError` naming the camera)."""
    dt = 1.0 / camera.fps
    for _ in range(PLACE_TRIES):
        heading = (rng.uniform(-0.35, 0.35) + rng.choice([0.5, -0.5]) * math.pi if radial
                   else rng.uniform(-math.pi, math.pi))
        y0 = rng.uniform(*y_range)
        if radial:  # start at the end of the range it moves away from
            y0 = rng.uniform(15.0, 19.0) if math.sin(heading) < 0 else rng.uniform(4.0, 6.0)
        half = 0.8 * (camera.image_width / 2) * y0 * math.cos(float(camera.theta)) / float(
            camera.a * camera.f)
        x0 = rng.uniform(-half, half)
        t = np.arange(n_frames) * dt
        x = x0 + speed * math.cos(heading) * t
        y = y0 + speed * math.sin(heading) * t
        u, v = (np.asarray(a) for a in project(camera, jnp.asarray(x), jnp.asarray(y)))
        inside = ((u > 5) & (u < camera.image_width - 5) & (v > 5)
                  & (v < camera.image_height - 5) & (y > 3.3) & (y < 19.7))
        if inside.all():
            return x, y, heading
    raise ConfigError("camera", f"no straight path of {n_frames} frames stays in view and in "
                      f"3.3-19.7 m ahead in {PLACE_TRIES} random tries; is the camera sensible "
                      "(`rhythmjax camera`)?")


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
    Measurements are missing (empty u, v, width) at `gap_rate` of frames."""
    camera = camera or Camera()
    rng = np.random.default_rng(seed)
    kinds = (["pedestrian"] * n_walkers + ["bicycle"] * n_bicycles + ["dog"] * n_dogs
             + ["car"] * n_cars + ["short"] * n_short)
    cols: dict[str, list] = {k: [] for k in ("track_id", "frame", "t", "u", "v", "width_px",
                                             "intensity", "label", "x", "y")}
    truth = []
    frame0 = 0
    for i, kind in enumerate(kinds):
        label = "pedestrian" if kind == "short" else kind
        pace, stride, speed, depth = _kind_params(label, rng)
        n = int(rng.integers(20, 56)) if kind == "short" else int(rng.integers(min_frames,
                                                                               max_frames + 1))
        radial = label in ("bicycle", "car")
        if radial:  # fast objects leave the detection range sooner
            n = min(n, int(14.5 / speed * camera.fps))
        x, y, heading = _path(camera, rng, speed, n, (5.0, 17.0), radial)
        u, v = (np.asarray(a, float) for a in project(camera, jnp.asarray(x), jnp.asarray(y)))
        u = u + rng.normal(0, r_std_px, n)
        v = v + rng.normal(0, r_std_px, n)
        front, side = _WIDTH[label]
        w_m = abs(math.sin(heading)) * front + abs(math.cos(heading)) * side
        if label == "pedestrian":
            w_m = rng.normal(w_m, 0.04)
        w_px = np.asarray(image_width(camera, jnp.asarray(w_m), jnp.asarray(y)), float)
        w_px = w_px * (1 + rng.normal(0, 0.05, n))
        W = np.asarray(image_width(camera, jnp.asarray(0.5), jnp.asarray(y)), float)
        area = W * W / 5.0
        t = np.arange(n) / camera.fps
        if label == "car":
            per_px = 3.0 + 0.5 * rng.standard_normal(n)
        else:
            ph = rng.uniform(0, 1)
            swing = _swing(pace * t + ph)
            if label == "pedestrian":  # left and right steps differ a little: a peak at F/2
                step_no = np.floor(pace * t + ph)
                swing = swing * np.where(step_no % 2 == 0, 1.0, rng.uniform(0.8, 0.95))
            per_px = 4.0 + 20.0 * depth * swing
            per_px = per_px + intensity_noise * 20.0 * rng.standard_normal(n)
        intensity = np.maximum(per_px, 0.0) * area
        gaps = rng.random(n) < gap_rate
        u[gaps], v[gaps], w_px[gaps] = np.nan, np.nan, np.nan
        tid = f"{label[:3]}{i:03d}" if kind != "short" else f"sho{i:03d}"
        frames = frame0 + np.arange(n)
        frame0 += int(rng.integers(0, 5))
        cols["track_id"] += [tid] * n
        cols["frame"] += list(frames)
        cols["t"] += list(frames / camera.fps)
        for k, a in (("u", u), ("v", v), ("width_px", w_px), ("intensity", intensity),
                     ("x", x), ("y", y)):
            cols[k] += list(a)
        cols["label"] += [label] * n
        truth.append(TrackTruth(tid, label, pace, stride if label != "car" else math.nan,
                                speed, n))
    out = {k: np.asarray(v) for k, v in cols.items()}
    out["frame"] = out["frame"].astype(np.int64)
    return out, truth
