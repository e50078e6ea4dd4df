"""Counting uses the camera's roll (issue 14, item 2): a synthetic scene rendered by a camera
rolled 4 degrees (`sim.scene`), counted with the roll in the config and with the same camera
but roll 0 (what counting did before issue 14: its NumPy camera dropped the roll).

Truth: per frame the rendered walkers' contact midpoints (x, y) m and foot points (u, v) px
(the lowest drawn row, up to ~0.15 m nearer than the midpoint), and the patch (w, h) px that a
0.5 x 1.7 m pedestrian standing at (x, y) has in the true, rolled camera (`upright_size` at the
midpoint's image). Figures measured on this scene (CPU; host float64, EKF float32) are in each
test's docstring; each bound sits between the two configs' figures, about 20 % above the
figure with the roll, so that a regression towards ignoring the roll fails.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.count import CountOptions, count_frames
from rhythmjax.count.options import VerdictOptions
from rhythmjax.count.patches import ShapeModel, ground_point
from rhythmjax.model.camera_np import project_3d, upright_size
from rhythmjax.model.params import config_from_dict
from rhythmjax.sim.scene import SceneSpec, render_scene, walker

from .test_pedestrians import SMALL


ROLL_DEG = 4.0
T = 60
FAST = CountOptions(verdicts=VerdictOptions(classify=False, online=False))


def _config(roll_deg: float):
    return config_from_dict({**SMALL, "camera": {**SMALL["camera"], "roll_deg": roll_deg}})


@pytest.fixture(scope="module")
def rolled():
    """The scene (three walkers crossing at 6, 9 and 12 m, over most of the image width), the
    two configs, and the count with each."""
    cfgs = {"roll": _config(ROLL_DEG), "flat": _config(0.0)}
    acts = (walker(-4.0, 6.0, 0.0, start_frame=2, phase=0.1),
            walker(4.5, 9.0, math.pi, start_frame=2, phase=0.6, grey_torso=150, grey_legs=70),
            walker(-3.0, 12.0, 0.0, start_frame=2, phase=0.3, grey_torso=200, grey_legs=40))
    scene = render_scene(3, SceneSpec(n_frames=T, actors=acts, camera=cfgs["roll"].camera))
    items = [(k, k / 15.0, f) for k, f in enumerate(scene.frames)]
    results = {name: count_frames(cfg, iter(items), options=FAST, n_frames=T)
               for name, cfg in cfgs.items()}
    return scene, cfgs, results


def _true_patch(scene, x, y):
    """(w, h) px of the 0.5 x 1.7 m pedestrian standing at ground (x, y) m, true camera."""
    cam = scene.spec.camera
    w, h, ok = upright_size(cam, *project_3d(cam, x, y, 0.0), 0.5, 1.7)
    assert np.all(ok)
    return w, h


def test_shape_and_ground_points_at_the_true_foot_points(rolled):
    """Patch sizes and ground points at every visible truth foot point (no tracking).

    Measured (median over 174 rows): ground point error 0.108 m with the roll, 0.361 m
    without; patch height error 0.88 % with, 3.86 % without; width error 0.94 % with, 3.44 %
    without."""
    scene, cfgs, _ = rolled
    rows = np.concatenate([np.stack([tr.u, tr.v, tr.x, tr.y], 1)[tr.visible]
                           for tr in scene.truth])
    w_true, h_true = _true_patch(scene, rows[:, 2], rows[:, 3])
    err = {}
    for name, cfg in cfgs.items():
        shape = ShapeModel.from_config(cfg, "3d")
        x, y, ok = ground_point(shape.camera, rows[:, 0], rows[:, 1])
        assert ok.all()
        w, h = shape.size(rows[:, 0], rows[:, 1])
        err[name] = (np.median(np.hypot(x - rows[:, 2], y - rows[:, 3])),
                     np.median(np.abs(h / h_true - 1)), np.median(np.abs(w / w_true - 1)))
    assert err["roll"][0] <= 0.13 and err["flat"][0] >= 0.30  # m
    assert err["roll"][1] <= 0.011 and err["flat"][1] >= 0.03
    assert err["roll"][2] <= 0.012 and err["flat"][2] >= 0.028


def test_counting_with_the_roll_tracks_closer_to_the_truth(rolled):
    """Through `count_frames` ("3d" dynamics): every measured MOT row matched to the nearest
    visible truth foot point of its frame (within 15 px; the foot point is the bottom centre of
    the row's box).

    Measured: 3 tracks and 3 walkers with either config; ground (the EKF state) error median
    0.162 m with the roll, 0.409 m without (90th percentile 0.302 m / 0.776 m); patch height
    error median 1.02 % with, 4.00 % without."""
    scene, _, results = rolled
    out = {}
    for name, res in results.items():
        assert res.counts["tracks"] == 3 and res.counts["walkers"] == 3
        m = res.mot
        g_err, h_err = [], []
        for r in np.flatnonzero(m["conf"] == 1.0):
            k = int(m["frame"][r]) - 1
            fu, fv = m["bb_left"][r] + 0.5 * m["bb_width"][r], m["bb_top"][r] + m["bb_height"][r]
            d, tr = min(((math.hypot(tr.u[k] - fu, tr.v[k] - fv), tr) for tr in scene.truth
                         if tr.visible[k]), key=lambda q: q[0])
            if d <= 15.0:
                g_err.append(math.hypot(m["x"][r] - tr.x[k], m["y"][r] - tr.y[k]))
                h_err.append(abs(m["bb_height"][r] / _true_patch(scene, tr.x[k], tr.y[k])[1] - 1))
        assert len(g_err) >= 120
        out[name] = (np.median(g_err), np.percentile(g_err, 90), np.median(h_err))
    assert out["roll"][0] <= 0.19 and out["flat"][0] >= 0.35  # m
    assert out["roll"][1] <= 0.36 and out["flat"][1] >= 0.65  # m
    assert out["roll"][2] <= 0.0125 and out["flat"][2] >= 0.033
