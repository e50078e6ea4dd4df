"""How far the tracker's top row (the tracks format's `v_top`) lies from the true head row, on
rendered scenes (`rhythmjax.sim.scene`: textured ground, walkers with heights N(1.7, 0.08^2) m,
bicycles, dogs; sensor noise 2 grey levels) seen by a street camera (h 4 m, tilt 20 deg, a f
700 px, 640x480 at 15 fps: heads in view), tracked by `rhythmjax.track.OnlineTracker` with that
camera.

    python benchmarks/eval_top_row.py [n_scenes=3] [first_seed=0]

Each measured row (u, v, v_top finite) is matched to the object whose true foot point is
nearest at that frame (within 10 px); the true head row is the image row of the point
height_m above the object's body reference (`camera_np.project_3d`): the walker's head top, the
bicycle rider's, the dog's back. Prints per kind the signed error v_top - truth (px: negative =
above the head), its median, the median and 90th percentile of |error|, the error relative to
the true pixel height, and the share of measured rows with a top row.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import Camera, Config
from rhythmjax.sim.scene import random_spec, render_scene
from rhythmjax.track.tracker import OnlineTracker


def errors(seed: int, cfg: Config) -> dict[str, list[tuple[float, float, bool]]]:
    spec = random_spec(seed, n_walkers=6, n_bicycles=1, n_dogs=1, n_frames=150,
                       camera=cfg.camera)
    scene = render_scene(seed, spec)
    tracker = OnlineTracker(cfg)
    for k, frame in enumerate(scene.frames):
        tracker.update(k, k / scene.fps, frame)
    cols, _, _ = tracker.finish()
    heads, feet = [], []
    for tr, act in zip(scene.truth, spec.actors, strict=True):
        _, vh = project_3d(cfg.camera, tr.body_x, tr.body_y, np.full(tr.body_x.shape,
                                                                     act.height_m))
        heads.append(np.asarray(vh))
        feet.append(np.stack([tr.u, tr.v], -1))
    out: dict[str, list] = {}
    for i in range(len(cols["frame"])):
        u, v, top, f = cols["u"][i], cols["v"][i], cols["v_top"][i], int(cols["frame"][i])
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        d = [np.hypot(*(fe[f] - (u, v))) if np.all(np.isfinite(fe[f])) else np.inf
             for fe in feet]
        j = int(np.argmin(d))
        if d[j] > 10.0:
            continue
        kind = spec.actors[j].kind
        out.setdefault(kind, []).append((float(top - heads[j][f]),
                                         float(feet[j][f][1] - heads[j][f]),
                                         bool(np.isfinite(top))))
    return out


CAMERA = Camera(f=0.008, h=4.0, theta=math.radians(20.0), a=700 / 0.008, b=700 / 0.008,
                uc=320, vc=240, fps=15.0, image_width=640, image_height=480)


def main(n: int, s0: int) -> None:
    cfg = Config(camera=CAMERA)
    allr: dict[str, list] = {}
    for seed in range(s0, s0 + n):
        for k, v in errors(seed, cfg).items():
            allr.setdefault(k, []).extend(v)
    print(f"{n} rendered scenes (seeds {s0}-{s0 + n - 1}), tracked with the true camera")
    print("| kind | measured rows | with v_top | median error (px) | median abs (px) "
          "| p90 abs (px) | median abs / pixel height (%) |")
    print("|---|---|---|---|---|---|---|")
    for kind, rows in sorted(allr.items()):
        a = np.asarray(rows, float)
        ok = a[:, 2] > 0
        e, hp = a[ok, 0], a[ok, 1]
        if not e.size:
            print(f"| {kind} | {len(a)} | 0 | | | | |")
            continue
        print(f"| {kind} | {len(a)} | {ok.mean():.0%} | {np.median(e):+.1f} | "
              f"{np.median(np.abs(e)):.1f} | {np.percentile(np.abs(e), 90):.1f} | "
              f"{100 * np.median(np.abs(e) / hp):.1f} |")


if __name__ == "__main__":
    a = [int(q) for q in sys.argv[1:]]
    main(a[0] if a else 3, a[1] if len(a) > 1 else 0)
