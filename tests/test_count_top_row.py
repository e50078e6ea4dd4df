"""The head row and column that `rhythmjax count` writes (`v_top`, `count.widths.measured_top`;
`u_top`, the foot point's u plus `count.widths.measured_lean`), against the pin-hole of (3)
written out here in NumPy float64 (a point (x, y, z): depth = f + y cos(theta) + (h - z)
sin(theta), u = Uc + a f x / depth, v = Vc - b f (y sin(theta) - (h - z) cos(theta)) / depth;
no roll) on a rendered scene."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.count import count_frames
from rhythmjax.count.options import CountOptions, VerdictOptions
from rhythmjax.model.params import config_from_dict
from rhythmjax.sim.scene import SceneSpec, render_scene, walker


HIGH_SMALL = {"camera": {"f_m": 0.008, "h_m": 5.0, "theta_deg": 20.0, "a_px_per_m": 50000.0,
                         "b_px_per_m": 50000.0, "uc_px": 160.0, "vc_px": 120.0, "fps": 15.0,
                         "image_width_px": 320, "image_height_px": 240},
              "thresholds": {"range_min_m": 2.0, "range_max_m": 30.0}}
HEIGHTS_M = (1.8, 1.6)


def row_of(cam, y: float, z: float) -> float:
    f, h, th = float(cam.f), float(cam.h), float(cam.theta)
    depth = f + y * math.cos(th) + (h - z) * math.sin(th)
    return float(cam.vc) - float(cam.b) * f * (y * math.sin(th) - (h - z) * math.cos(th)) / depth


def column_of(cam, x: float, y: float, z: float) -> float:
    f, h, th = float(cam.f), float(cam.h), float(cam.theta)
    return float(cam.uc) + float(cam.a) * f * x / (f + y * math.cos(th) + (h - z) * math.sin(th))


@pytest.fixture(scope="module")
def counted():
    """(camera, scene, count's tracks) of two walkers (1.8 m at 12 m, 1.6 m at 8 m, 4 m either
    side of the centre line) seen from 5 m up."""
    cfg = config_from_dict(HIGH_SMALL)
    cam = cfg.camera
    actors = (walker(-4.0, 12.0, 0.3, start_frame=3, height_m=HEIGHTS_M[0]),
              walker(4.0, 8.0, 2.8, start_frame=3, height_m=HEIGHTS_M[1]))
    scene = render_scene(1, SceneSpec(n_frames=60, actors=actors, camera=cam))
    quiet = CountOptions(verdicts=VerdictOptions(classify=False, online=False))
    t = count_frames(cfg, iter([(k, k / scene.fps, f) for k, f in enumerate(scene.frames)]),
                     options=quiet).tracks
    return cam, scene, t


def matched(scene, t):
    """(track rows with a foot point, the truth, its height) of each track following a walker."""
    for tid in np.unique(t["track_id"]):
        rows = (t["track_id"] == tid) & np.isfinite(t["v"])
        for truth, height in zip(scene.truth, HEIGHTS_M):
            if np.median(np.abs(t["v"][rows] - truth.v[t["frame"][rows]])) <= 1.0:
                yield rows, truth, height


def test_head_rows_of_two_rendered_walkers(counted):
    """Two walkers (1.8 m at 12 m, 1.6 m at 8 m; 53 and 62 px tall) seen from 5 m up: each
    track's foot rows follow its walker's (median within 1 px), and where its blobs are its own
    the top row is the walker's head row: given on >= 80 % of its measured rows, median
    |error| <= 2 px (measured 0.8 and 1.5 px; the mask's edge lies a pixel outside the
    silhouette). A top taken from the patch (the model walker's 1.7 m) would be off by 3-4 px, a
    missing column would fail the count of rows."""
    cam, scene, t = counted
    found = []
    for rows, truth, height in matched(scene, t):
        top = rows & np.isfinite(t["v_top"])
        assert top.sum() >= 0.8 * rows.sum() >= 30
        want = np.array([row_of(cam, y, height) for y in truth.y[t["frame"][top]]])
        assert np.median(np.abs(t["v_top"][top] - want)) <= 2.0
        found.append(height)
    assert sorted(found) == sorted(HEIGHTS_M)


def test_head_columns_lean_outwards(counted):
    """Off the centre column a tilted camera's verticals lean outwards (the left walker's head
    2.8 px left of its feet, the right one's 3.0 px right, by the pin-hole): the head column is
    given on >= 90 % of the rows with a top row, and the median measured lean (u_top - u) has
    the true lean's sign and at least a third of its size (measured -1.5 and +1.3 px: a
    silhouette leans less than the vertical through its foot point, docs/selfcal.md "Heads over
    feet"); a column taken from the upright patch (u_top == u) would fail."""
    cam, scene, t = counted
    found = []
    for rows, truth, height in matched(scene, t):
        top = rows & np.isfinite(t["v_top"]) & np.isfinite(t["u_top"])
        assert top.sum() >= 0.9 * np.sum(rows & np.isfinite(t["v_top"]))
        fr = t["frame"][top]
        true = np.array([column_of(cam, x, y, height) - column_of(cam, x, y, 0.0)
                         for x, y in zip(truth.x[fr], truth.y[fr])])
        lean = float(np.median(t["u_top"][top] - t["u"][top]))
        assert abs(np.median(true)) > 2.0
        assert np.sign(lean) == np.sign(np.median(true)) and abs(lean) >= abs(np.median(true)) / 3
        found.append(height)
    assert sorted(found) == sorted(HEIGHTS_M)
