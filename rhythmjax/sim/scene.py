"""Synthetic video scenes with ground truth: walkers, bicycles and dogs seen by the camera of (3).

`render_scene(seed, spec)` draws a textured ground plane seen through the camera (a low-contrast
procedural texture in ground coordinates, mapped by inverse perspective; the camera is fixed, so
it does not move), a plain sky above the horizon, and the actors of `spec` as filled polygons in
painter's order (far first), their image shapes the projections of their 3-D parts
(`project_3d`). Then optional camera jitter (a per-frame image shift) and sensor noise. The
geometry and gaits are in `synth_actors`. Deterministic given the explicit seed (an int or a JAX
PRNG key); no global RNG is touched.

Truth per object (`ObjectTruth`): kind, pace (step frequency, Hz; a bicycle's is twice its
cadence, one push per leg per revolution), step length (m; speed / pace for bicycles), speed
(m/s), and per frame: the ground position (x, y) m of the contact midpoint (the midpoint of the
feet for a walker, of the four feet for a dog, of the wheel contacts for a bicycle); the foot
point (u, v) px as a perfect detector sees it: u the image column of that midpoint, v the lowest
image row of the drawn object (the nearest edge of its ground contact: up to ~0.15 m nearer than
the midpoint for a walker, i.e. up to ~12 px lower at 3 m, < 1 px at 20 m), jitter included; the
image width (px, the u-extent of the drawn shape); the body's constant-velocity ground position;
and `visible` (alive, in front of the camera and the foot point inside the image).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..model.camera_np import (
    camera_tuple,
    depth_3d as depth_3d,
    ground_of_pixels as _ground_of_pixels,
    project_3d as project_3d,
)
from ..model.params import Camera
from . import actors as sa
from .draw import MIN_DEPTH, draw_actor
from .placement import PlacementError, check_room, place_path


KINDS = ("pedestrian", "bicycle", "dog")


@dataclass(frozen=True)
class ActorSpec:
    """One object on a straight ground path: at local time tau = (frame - start_frame) / fps its
    body reference is at (x0, y0) + speed * tau * (cos heading, sin heading), speed = pace_hz *
    step_length_m. Alive for frames [start_frame, start_frame + n_frames) (None: to the end).
    Grey levels: torso, legs (trousers / dog legs / rider's legs), feet (shoes / tyres), head,
    extra (bag / bicycle frame). `phase` shifts the gait (cycles) and wheel/crank angles."""

    kind: str
    x0: float
    y0: float
    heading_rad: float
    pace_hz: float
    step_length_m: float
    start_frame: int = 0
    n_frames: int | None = None
    phase: float = 0.0
    height_m: float = 1.7
    body_length_m: float = 0.75
    grey_torso: int = 60
    grey_legs: int = 40
    grey_feet: int = 25
    grey_head: int = 90
    grey_extra: int = 200
    bag: bool = False
    bag_side: float = 1.0
    suitcase: bool = False  # a wheeled suitcase pulled behind (walkers; `actors.suitcase_parts`)
    articulated: bool = False  # walkers: knees and heel-to-toe feet (`sim.legs`), else rod legs

    @property
    def speed_mps(self) -> float:
        return self.pace_hz * self.step_length_m

    def attrs(self) -> dict:
        return {
            "pace_hz": self.pace_hz, "step_length_m": self.step_length_m, "phase": self.phase,
            "height_m": self.height_m, "body_length_m": self.body_length_m,
            "torso": self.grey_torso, "legs": self.grey_legs, "shoes": self.grey_feet,
            "tyre": self.grey_feet, "head": self.grey_head, "bag_grey": self.grey_extra,
            "frame": self.grey_extra, "bag": self.bag, "bag_side": self.bag_side,
            "suitcase": self.suitcase, "articulated": self.articulated,
            "speed_mps": self.speed_mps, "cadence_hz": self.pace_hz / 2.0,
        }


def walker(x0, y0, heading_rad, pace_hz=2.05, step_length_m=0.72, **kw) -> ActorSpec:
    return ActorSpec("pedestrian", x0, y0, heading_rad, pace_hz, step_length_m, **kw)


def bicycle(x0, y0, heading_rad, speed_mps=4.0, cadence_hz=1.2, **kw) -> ActorSpec:
    """A bicycle: pace = 2 cadence (one push per leg per revolution), step = speed / pace."""
    kw.setdefault("grey_feet", 20)
    kw.setdefault("grey_extra", 170)
    return ActorSpec("bicycle", x0, y0, heading_rad, 2 * cadence_hz,
                     speed_mps / (2 * cadence_hz), **kw)


def dog(x0, y0, heading_rad, pace_hz=4.0, step_length_m=0.28, **kw) -> ActorSpec:
    kw.setdefault("height_m", 0.5)
    return ActorSpec("dog", x0, y0, heading_rad, pace_hz, step_length_m, **kw)


@dataclass(frozen=True)
class SceneSpec:
    """A scene: n_frames at camera.fps, the actors, and rendering options. noise_std: sensor
    noise (grey levels, per pixel and frame); jitter_px: std of the per-frame camera shift (px);
    ground_mean / ground_contrast: grey level and texture amplitude of the ground; sky: grey
    level above the horizon."""

    n_frames: int
    actors: tuple[ActorSpec, ...] = ()
    camera: Camera = field(default_factory=Camera)
    noise_std: float = 2.0
    jitter_px: float = 0.0
    ground_mean: float = 120.0
    ground_contrast: float = 10.0
    sky: float = 195.0


@dataclass(frozen=True)
class ObjectTruth:
    """Truth of one object; per-frame arrays have length n_frames (NaN / False where not alive)."""

    track_id: str
    kind: str
    pace_hz: float
    step_length_m: float
    speed_mps: float
    u: np.ndarray
    v: np.ndarray
    width_px: np.ndarray
    x: np.ndarray
    y: np.ndarray
    body_x: np.ndarray
    body_y: np.ndarray
    alive: np.ndarray
    visible: np.ndarray


@dataclass(frozen=True)
class Scene:
    """frames (T, H, W) uint8; background (H, W) uint8, the noise-free empty scene without
    jitter; jitter (T, 2) px (du, dv) applied to each frame; truth one `ObjectTruth` per actor."""

    frames: np.ndarray
    background: np.ndarray
    jitter: np.ndarray
    truth: tuple[ObjectTruth, ...]
    spec: SceneSpec

    @property
    def fps(self) -> float:
        return float(self.spec.camera.fps)


# ----------------------------------------------------------------------------------------------
# background and noise


def _rng(seed) -> np.random.Generator:
    """A NumPy Generator from an int seed or a JAX PRNG key (raw uint32 or typed)."""
    if isinstance(seed, (int, np.integer)):
        return np.random.default_rng(int(seed))
    import jax

    arr = jax.numpy.asarray(seed)
    if jax.dtypes.issubdtype(arr.dtype, jax.dtypes.prng_key):
        arr = jax.random.key_data(arr)
    return np.random.default_rng([int(w) for w in np.asarray(arr).ravel()])


def render_background(camera: Camera, rng: np.random.Generator, *, ground_mean=120.0,
                      ground_contrast=10.0, sky=195.0) -> np.ndarray:
    """The empty scene (H, W) uint8: value-noise texture on the ground at 0.25 m and 1.5 m
    scales plus a fixed fine grain, a plain sky above the horizon."""
    H, W = camera.image_height, camera.image_width
    vv, uu = np.mgrid[0:H, 0:W].astype(np.float64)
    x, y, ok = _ground_of_pixels(camera, uu, vv)
    img = np.full((H, W), sky, np.float32)
    tex = np.zeros((H, W), np.float32)
    for cell, amp in ((0.25, 0.5), (1.5, 1.0)):
        n = int(60.0 / cell) + 2
        grid = rng.standard_normal((n, n)).astype(np.float32)
        mx = ((x + 30.0) / cell).astype(np.float32)
        my = (y / cell).astype(np.float32)
        tex += amp * cv2.remap(grid, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    tex += 0.3 * rng.standard_normal((H, W)).astype(np.float32)
    tex *= ground_contrast / 1.2
    img[ok] = ground_mean + tex[ok]
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def _noise_luts(std: float) -> tuple[np.ndarray, np.ndarray]:
    """Positive and negative parts of a 256-level quantised N(0, std^2), indexed by a random
    byte: add the one, subtract the other, saturating (exact clipping, no float pass)."""
    from statistics import NormalDist

    z = np.array([NormalDist().inv_cdf((i + 0.5) / 256) for i in range(256)])
    z *= 1.0 / z.std()
    q = np.rint(std * z)
    return np.maximum(q, 0).astype(np.uint8), np.maximum(-q, 0).astype(np.uint8)


# ----------------------------------------------------------------------------------------------
# rendering


def actor_paths(spec: SceneSpec):
    """Per actor: (alive mask, local time s, body x, body y, truth foot ground x, y m), each an
    array over the spec's frames."""
    T, fps = spec.n_frames, float(spec.camera.fps)
    k = np.arange(T)
    out = []
    for act in spec.actors:
        n = T - act.start_frame if act.n_frames is None else act.n_frames
        alive = (k >= act.start_frame) & (k < act.start_frame + n)
        tau = (k - act.start_frame) / fps
        ch, sh = math.cos(act.heading_rad), math.sin(act.heading_rad)
        bx = act.x0 + act.speed_mps * tau * ch
        by = act.y0 + act.speed_mps * tau * sh
        off = sa.contact_offset(act.kind, tau, act.attrs())
        out.append((alive, tau, bx, by, bx + off * ch, by + off * sh))
    return out


def render_scene(key_or_seed, spec: SceneSpec) -> Scene:
    """Render `spec` into frames and truth; deterministic given the seed (int or JAX key), which
    drives the ground texture, the sensor noise and the jitter."""
    for act in spec.actors:
        if act.kind not in KINDS:
            raise ValueError(f"unknown actor kind {act.kind!r}; expected one of {KINDS}")
    if spec.n_frames < 1:
        raise ValueError(f"n_frames must be >= 1, got {spec.n_frames}")
    cam = spec.camera
    root = _rng(key_or_seed)
    r_tex, r_noise, r_jit = (np.random.default_rng(s) for s in root.bit_generator.seed_seq.spawn(3))
    bg = render_background(cam, r_tex, ground_mean=spec.ground_mean,
                           ground_contrast=spec.ground_contrast, sky=spec.sky)
    T, H, W = spec.n_frames, cam.image_height, cam.image_width
    host = camera_tuple(cam)  # the camera as host floats, once (not per actor and frame)
    afs = host.a * host.f  # px per m at depth 1 m
    jitter = (r_jit.standard_normal((T, 2)) * spec.jitter_px if spec.jitter_px > 0
              else np.zeros((T, 2)))
    lut_p, lut_n = _noise_luts(spec.noise_std) if spec.noise_std > 0 else (None, None)
    paths = actor_paths(spec)
    attrs = [act.attrs() for act in spec.actors]
    nobj = len(spec.actors)
    wid = np.full((nobj, T), np.nan)
    vlow = np.full((nobj, T), np.nan)
    frames = np.empty((T, H, W), np.uint8)
    for k in range(T):
        img = bg.copy()
        live = [i for i in range(nobj) if paths[i][0][k]]
        live.sort(key=lambda i: -(paths[i][3][k]))  # far first
        for i in live:
            act = spec.actors[i]
            ext = draw_actor(img, host, afs, act.kind, attrs[i], float(paths[i][1][k]),
                        float(paths[i][2][k]), float(paths[i][3][k]), act.heading_rad)
            if ext is not None:
                wid[i, k], vlow[i, k] = ext[1] - ext[0], ext[2]
        if spec.jitter_px > 0:
            m = np.array([[1.0, 0.0, jitter[k, 0]], [0.0, 1.0, jitter[k, 1]]])
            img = cv2.warpAffine(img, m, (W, H), flags=cv2.INTER_LINEAR,
                                 borderMode=cv2.BORDER_REFLECT)
        if lut_p is not None:
            idx = np.frombuffer(r_noise.bytes(H * W), np.uint8).reshape(H, W)
            img = cv2.subtract(cv2.add(img, cv2.LUT(idx, lut_p)), cv2.LUT(idx, lut_n))
        frames[k] = img
    truth = []
    for i, act in enumerate(spec.actors):
        alive, _, bx, by, fx, fy = paths[i]
        u, v = project_3d(host, fx, fy, 0.0)
        v = np.where(np.isfinite(vlow[i]), vlow[i], v)  # the lowest drawn point (see module doc)
        u, v = u + jitter[:, 0], v + jitter[:, 1]
        front = depth_3d(host, fy, 0.0) > MIN_DEPTH
        vis = alive & front & (u >= 0) & (u <= W - 1) & (v >= 0) & (v <= H - 1)
        nan = np.where(alive & front, 1.0, np.nan)
        truth.append(ObjectTruth(
            track_id=f"{act.kind[:3]}{i:03d}", kind=act.kind, pace_hz=act.pace_hz,
            step_length_m=act.step_length_m, speed_mps=act.speed_mps, u=u * nan, v=v * nan,
            width_px=wid[i], x=np.where(alive, fx, np.nan), y=np.where(alive, fy, np.nan),
            body_x=np.where(alive, bx, np.nan), body_y=np.where(alive, by, np.nan),
            alive=alive, visible=vis))
    return Scene(frames, bg, jitter, tuple(truth), spec)


def scene_to_tracks_truth(scene: Scene) -> dict[str, np.ndarray]:
    """The truth as tracks-format columns (ARCHITECTURE.md): track_id, frame, t, u, v, width_px,
    intensity (NaN), label, x, y; one row per object per visible frame."""
    cols: dict[str, list] = {k: [] for k in ("track_id", "frame", "t", "u", "v", "width_px",
                                             "intensity", "label", "x", "y")}
    for tr in scene.truth:
        k = np.flatnonzero(tr.visible)
        cols["track_id"] += [tr.track_id] * len(k)
        cols["frame"] += k.tolist()
        cols["t"] += (k / scene.fps).tolist()
        for name, arr in (("u", tr.u), ("v", tr.v), ("width_px", tr.width_px), ("x", tr.x),
                          ("y", tr.y)):
            cols[name] += arr[k].tolist()
        cols["intensity"] += [math.nan] * len(k)
        cols["label"] += [tr.kind] * len(k)
    out = {k: np.asarray(v) for k, v in cols.items()}
    out["frame"] = out["frame"].astype(np.int64)
    for k in ("t", "u", "v", "width_px", "intensity", "x", "y"):
        out[k] = out[k].astype(np.float64)
    out["track_id"] = out["track_id"].astype(str)
    out["label"] = out["label"].astype(str)
    return out


# ----------------------------------------------------------------------------------------------
# random scenes

def random_spec(seed, n_walkers: int = 5, n_bicycles: int = 1, n_dogs: int = 1,
                n_frames: int = 150, *, camera: Camera | None = None, occlusion: bool = False,
                min_life: int = 80, max_life: int = 120, range_m: tuple[float, float] = (3.5, 19.5),
                bicycle_speed: tuple[float, float] = (3.0, 6.0), bag_fraction: float = 0.2,
                noise_std: float = 2.0, jitter_px: float = 0.0, margin_px: float = 8.0,
                crossing_fraction: float = 0.85, clothing: str = "contrasted",
                suitcase_fraction: float = 0.0, lateral_deg: float | None = None,
                articulated: bool = False) -> SceneSpec:
    """A random scene: walkers with the paper's pace N(2.05, 0.183) Hz and step length
    N(0.72, 0.09) m, bicycles at `bicycle_speed` m/s pedalling at 0.9-1.5 rev/s, dogs trotting
    at 3-5 Hz with 0.2-0.35 m steps. Each lives min_life..max_life frames (fewer for a bicycle
    that would cross the range faster: at most `crossing_fraction` of the time it needs to cover
    the range's depth at its speed), starts at a random frame, and moves on a straight path
    whose foot point stays in the image and within `range_m` (ground distance, m) for its whole
    life. Without `occlusion`, paths are re-drawn (up to 300 times) until the objects' image
    boxes never overlap; with it, overlaps are left as drawn. `clothing`: "contrasted" (every
    clothing grey at least 40 grey levels off the ground's 120) or "any" (uniform 20-235, some
    close to the ground; `sim.actors.CLOTHING`). A walker pulls a wheeled suitcase behind it
    with probability `suitcase_fraction` (0: none, and the scene is drawn as before the option
    existed). `lateral_deg`: every path heads within this many degrees of the image's rows (left
    or right: walkers crossing the view, as the dev clips' mostly do); None: any heading, which
    the in-view test turns mostly radial for long lives. `articulated`: walkers with knees and
    heel-to-toe feet (`sim.legs`; draws no random number, so the scene is otherwise the same).
    Deterministic given `seed`."""
    if clothing not in sa.CLOTHING:
        raise ValueError(f"clothing must be one of {sa.CLOTHING}, got {clothing!r}")
    camera = camera or Camera()
    check_room(camera, n_walkers, n_bicycles, n_dogs, n_frames, min_life, range_m)
    rng = _rng(seed)
    fps = float(camera.fps)
    kinds = ["pedestrian"] * n_walkers + ["bicycle"] * n_bicycles + ["dog"] * n_dogs
    placed: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []  # alive, u, hw, v
    actors = []
    k = np.arange(n_frames)
    for kind in kinds:
        kw = sa.sample_params(kind, rng, bicycle_speed, bag_fraction, clothing,
                              suitcase_fraction)
        speed = kw["pace_hz"] * kw["step_length_m"]
        life = int(rng.integers(min_life, max_life + 1))
        life = min(life, n_frames, max(16, int(crossing_fraction * (range_m[1] - range_m[0])
                                               / speed * fps)))
        best = None
        while best is None:  # a life too long for any path in view: shorten it by 10 %
            start = int(rng.integers(0, n_frames - life + 1))
            alive = (k >= start) & (k < start + life)
            best = place_path(camera, kind, rng, k, start, life, alive, speed, placed,
                              occlusion, range_m, margin_px, lateral_deg)
            if best is None:
                if life <= 16:
                    raise PlacementError("scene", f"could not place a {kind} path in view "
                                         f"within {range_m} m")
                life = max(16, int(0.9 * life))
        _, head, x0, y0, u, hw_px, v, h_px = best
        placed.append((alive, u, hw_px, v, h_px))
        if kind == "pedestrian" and articulated:
            kw["articulated"] = True
        actors.append(ActorSpec(kind, float(x0), float(y0), head, start_frame=start,
                                n_frames=life, **kw))
    return SceneSpec(n_frames=n_frames, actors=tuple(actors), camera=camera, noise_std=noise_std,
                     jitter_px=jitter_px)


__all__ = ["KINDS", "ActorSpec", "ObjectTruth", "PlacementError", "Scene", "SceneSpec",
           "actor_paths", "bicycle", "check_room", "depth_3d", "dog",
           "project_3d", "random_spec", "render_background", "render_scene",
           "scene_to_tracks_truth", "walker"]
