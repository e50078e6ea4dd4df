"""Drawing one synthetic actor into an image: the projections of its 3-D parts (`sim.actors`) as
anti-aliased filled hulls and thick polylines, its own parts in painter's order (far first).

Used by `sim.scene.render_scene` (each part in its grey level) and by `sim.clean` (every part in
one fill level, the actor's silhouette as a mask).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..model.camera_np import HostCamera, depth_3d, project_3d
from . import actors as sa


SHIFT = 4  # fixed-point bits for sub-pixel polygon vertices
MIN_DEPTH = 0.2  # m; an actor with any vertex closer than this to the image plane is not drawn


def world_points(parts, x: float, y: float, heading: float):
    """The parts' body-frame points (m) concatenated and mapped to the world (x, y, z) m."""
    pts = np.concatenate([np.asarray(p[1], np.float64) for p in parts], 0)
    c, s = math.cos(heading), math.sin(heading)
    wx = x + pts[:, 0] * c - pts[:, 1] * s
    wy = y + pts[:, 0] * s + pts[:, 1] * c
    return wx, wy, pts[:, 2]


def draw_actor(img: np.ndarray, camera: HostCamera, afs: float, kind: str, attrs: dict,
               tau: float, bx: float, by: float, heading: float, fill: int | None = None):
    """Draw one actor of `kind` at local time `tau` s, body at (bx, by) m, heading rad, into the
    uint8 image `img` (in place); each part in its own grey, or all in `fill` when given.
    `afs` is a f in px per m at depth 1 m. Returns (umin, umax, vmax) px of the drawn extent, or
    None when a vertex is nearer than MIN_DEPTH m to the image plane (nothing drawn)."""
    parts = sa.object_parts(kind, tau, attrs)
    wx, wy, wz = world_points(parts, bx, by, heading)
    d = depth_3d(camera, wy, wz)
    if d.min() < MIN_DEPTH:
        return None
    u, v = project_3d(camera, wx, wy, wz)
    uv = np.clip(np.stack([u, v], 1), -4000.0, 4000.0)
    idx = np.cumsum([0] + [len(p[1]) for p in parts])
    anchor_y = np.array([p[4] for p in parts]) * math.cos(heading)  # ground y of (0, l, 0) - by
    scale = afs / float(np.mean(d))  # px per m at the actor
    umin, umax, vmax = math.inf, -math.inf, -math.inf
    for i in np.argsort(-anchor_y, kind="stable"):
        mode, _, grey, thick, _ = parts[i]
        colour = int(grey if fill is None else fill)
        q = uv[idx[i]:idx[i + 1]]
        if mode == "hull":
            q = cv2.convexHull(q.astype(np.float32))[:, 0, :]
            pts = np.rint(q * (1 << SHIFT)).astype(np.int32)
            cv2.fillPoly(img, [pts], colour, cv2.LINE_AA, SHIFT)
            r = 0.0
        else:
            pts = np.rint(q * (1 << SHIFT)).astype(np.int32)
            t = max(1, int(round(thick * scale)))
            cv2.polylines(img, [pts], mode == "closed", colour, t, cv2.LINE_AA, SHIFT)
            r = 0.5 * t
        umin, umax = min(umin, float(q[:, 0].min()) - r), max(umax, float(q[:, 0].max()) + r)
        vmax = max(vmax, float(q[:, 1].max()) + r)
    return umin, umax, vmax
