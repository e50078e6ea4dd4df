"""Which objects of a synthetic scene can be classified: clean frames and the longest clean run.

The convention is the independent renderer's (`../shared/data/dev/README.md`, "classifiable"),
so that the own scenes and the dev clips are scored against the same denominator (issue 16's
targets: walkers judged Pedestrian of all *classifiable* walkers). A frame is **clean** for an
object when
- its foot point, the projection (3) of its ground contact midpoint, lies in the image;
- its ground distance ahead of the camera is within `range_m` (3-20 m);
- at least `min_unhidden` (80 %) of the pixels of a `window_m` (0.6 m) x `window_m` / 5 window at
  its feet (`vision.window_b.window_b_rect`, W the image width of 0.6 m at the foot point) are
  not hidden by nearer objects: a pixel is hidden when the silhouettes of the actors drawn after
  it in the renderer's painter's order (nearer bodies) cover at least half of it.
An object is **classifiable** when its longest run of consecutive clean frames is at least N (64,
the paper's window).

The silhouettes are the renderer's own drawing (`sim.draw.draw_actor` with one fill level), so
"hidden" means hidden in the rendered frame, before camera shake and noise (both move every
object alike).
"""

from __future__ import annotations

import numpy as np

from ..model.camera_np import camera_tuple, project_3d
from ..vision.window_b import window_b_rect
from .draw import draw_actor
from .scene import Scene, actor_paths


WINDOW_M = 0.6  # m, width of the window at the feet (its height is a fifth: 0.12 m)
RANGE_M = (3.0, 20.0)  # m, ground distance ahead of the camera
MIN_UNHIDDEN = 0.8  # fraction of the window's pixels not hidden by nearer objects
HIDDEN_LEVEL = 128  # a pixel at least half covered by a silhouette (fill 255) is hidden


def longest_run(flags) -> int:
    """The length of the longest run of consecutive True values (0 for none)."""
    best = run = 0
    for f in np.asarray(flags, bool):
        run = run + 1 if f else 0
        best = max(best, run)
    return best


def hidden_fractions(scene: Scene, *, window_m: float = WINDOW_M,
                     range_m: tuple[float, float] = RANGE_M) -> np.ndarray:
    """(n_objects, n_frames): the fraction of the pixels of the window at each object's feet
    hidden by nearer objects (module doc), NaN where its foot point is outside the image or the
    range (or it is not alive); the objects in `scene.truth`'s order."""
    spec = scene.spec
    host = camera_tuple(spec.camera)
    afs = host.a * host.f
    H, Wd = spec.camera.image_height, spec.camera.image_width
    T, n = spec.n_frames, len(spec.actors)
    paths = actor_paths(spec)
    attrs = [act.attrs() for act in spec.actors]
    foot = []
    for alive, _, _, _, fx, fy in paths:
        u, v = project_3d(host, fx, fy, 0.0)
        ul, _ = project_3d(host, fx - window_m / 2, fy, 0.0)
        ur, _ = project_3d(host, fx + window_m / 2, fy, 0.0)
        ok = (alive & np.isfinite(u) & np.isfinite(v) & (u >= 0) & (u <= Wd - 1) & (v >= 0)
              & (v <= H - 1) & (fy >= range_m[0]) & (fy <= range_m[1]))
        foot.append((u, v, np.abs(ur - ul), ok))
    frac = np.full((n, T), np.nan)
    mask = np.zeros((H, Wd), np.uint8)  # one actor's silhouette, redrawn per actor and frame
    for k in range(T):
        live = sorted((i for i in range(n) if paths[i][0][k]), key=lambda i: -paths[i][3][k])
        if not any(foot[i][3][k] for i in live):
            continue
        nearer = np.zeros((H, Wd), np.uint8)  # union of the silhouettes drawn after the current
        for j, i in enumerate(reversed(live)):  # nearest first
            u, v, w, ok = foot[i]
            if ok[k]:
                x0, y0, x1, y1 = window_b_rect((H, Wd), float(u[k]), float(v[k]), float(w[k]))
                if x1 > x0 and y1 > y0:
                    frac[i, k] = float(np.mean(nearer[y0:y1, x0:x1] >= HIDDEN_LEVEL))
            if j == len(live) - 1:  # the farthest: no one behind it to hide
                break
            mask[:] = 0
            act = spec.actors[i]
            draw_actor(mask, host, afs, act.kind, attrs[i], float(paths[i][1][k]),
                       float(paths[i][2][k]), float(paths[i][3][k]), act.heading_rad, fill=255)
            np.maximum(nearer, mask, out=nearer)
    return frac


def clean_frames(scene: Scene, *, min_unhidden: float = MIN_UNHIDDEN, **kw) -> np.ndarray:
    """(n_objects, n_frames) bool: whether each frame is clean for each object (module doc):
    in the image and the range, at least `min_unhidden` of its window not hidden; `kw` as for
    `hidden_fractions`."""
    frac = hidden_fractions(scene, **kw)
    with np.errstate(invalid="ignore"):
        return np.isfinite(frac) & (1.0 - frac >= min_unhidden)


def classifiable(scene: Scene, n: int = 64, **kw) -> dict[str, tuple[int, bool]]:
    """{object track_id: (longest clean run in frames, whether it is >= n, the paper's N)};
    `kw` as for `clean_frames`."""
    flags = clean_frames(scene, **kw)
    out = {}
    for obj, f in zip(scene.truth, flags):
        run = longest_run(f)
        out[obj.track_id] = (run, run >= n)
    return out
