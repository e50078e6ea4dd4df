"""Rule 41 (`body.lean_column`, track/lean.py): window B's column moved by the lean of an upright
body at half its height.

Reference: equation (3) written out here in float64, u = uc + a f x / (f + y cos(theta) +
(h - z) sin(theta)), for a point z m above the ground point (x, y), with no roll; the lean of a
body of height H is u(H/2) - u(0). Through the tracker, every window B's column must be the
measured foot column less that lean (and the measured column itself with the rule off)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import Camera, Config
from rhythmjax.track.lean import lean_px


CAMERA = Camera(f=0.008, h=3.0, theta=math.radians(20.0), a=1.0e5, b=1.0e5, uc=256.0,
                vc=256.0)


def u_of(x: float, y: float, z: float, cam: Camera = CAMERA) -> float:
    f, h, th = float(cam.f), float(cam.h), float(cam.theta)
    return float(cam.uc) + float(cam.a) * f * x / (f + y * math.cos(th) + (h - z) * math.sin(th))


@pytest.mark.parametrize("x, y", [(2.0, 8.0), (-3.5, 12.0), (0.7, 5.0), (-0.2, 20.0)])
def test_lean_is_equation_3_at_half_the_height(x, y):
    u, v = project_3d(CAMERA, x, y, 0.0)
    expected = u_of(x, y, 0.85) - u_of(x, y, 0.0)
    assert lean_px(CAMERA, u, v, 1.7) == pytest.approx(expected, rel=1e-6, abs=1e-6)
    # outwards: the same sign as the column's side of the image centre, and grows with |x|
    assert math.copysign(1.0, expected) == math.copysign(1.0, x)
    assert abs(lean_px(CAMERA, *project_3d(CAMERA, 2 * x, y, 0.0), 1.7)) > abs(expected)


def test_no_lean_on_the_centre_column_or_for_an_untilted_camera():
    u, v = project_3d(CAMERA, 0.0, 9.0, 0.0)
    assert lean_px(CAMERA, u, v, 1.7) == pytest.approx(0.0, abs=1e-9)
    level = Camera(f=0.008, h=1.0, theta=0.0, a=1.0e5, b=1.0e5, uc=256.0, vc=256.0)
    u, v = project_3d(level, 2.0, 9.0, 0.0)
    assert lean_px(level, u, v, 1.7) == pytest.approx(0.0, abs=1e-9)


def test_no_ground_point_gives_no_lean():
    # the horizon lies at vc - a f tan(theta) = -35 px: row -100 is above it
    assert lean_px(CAMERA, 300.0, -100.0, 1.7) == 0.0
    assert lean_px(CAMERA, math.nan, 300.0, 1.7) == 0.0
    assert lean_px(CAMERA, 300.0, math.inf, 1.7) == 0.0


@pytest.mark.parametrize("on", [False, True])
def test_tracker_puts_window_b_under_the_body(monkeypatch, on):
    """A walker 2.5 m right of the optical axis coming nearer: every I(k) is summed at the measured
    foot column less the lean (on) or at it (off), at the measured row, and the measurement the
    EKF reads (the tracks' u, v) is the same either way. Rule 54's upper-body column is off here:
    it keeps window B on the slice extent where the track's u moves (`test_column_filter.py`)."""
    from rhythmjax.sim import scene as synth
    from rhythmjax.track import tracker as trk
    from rhythmjax.track.options import TrackerOptions, with_changes

    cfg = Config()
    act = synth.walker(2.5, 12.0, -math.pi / 2, pace_hz=1.9, step_length_m=0.65)
    sc = synth.render_scene(5, synth.SceneSpec(n_frames=40, actors=(act,), camera=cfg.camera))
    calls = []
    inner = trk.detect.window_b_intensity

    def record(D, u, v, W, **kw):
        calls.append((float(u), float(v)))
        return inner(D, u, v, W, **kw)

    monkeypatch.setattr(trk.detect, "window_b_intensity", record)
    opt = with_changes(TrackerOptions(), {"body.lean_column": on,
                                          "body.window_candidates": False,
                                          "body.column_rows": None})  # rule 54's column off
    tr = trk.OnlineTracker(cfg, opt)
    for i, f in enumerate(sc.frames):
        tr.update(i, i / sc.fps, f)
    tracks, _, _ = tr.finish()
    rows = np.isfinite(tracks["intensity"])
    assert rows.sum() >= 20 and len(calls) == rows.sum()
    u, v = tracks["u"][rows], tracks["v"][rows]
    lean = np.array([lean_px(cfg.camera, a, b, float(cfg.width.height)) for a, b in zip(u, v)])
    assert np.all(lean > 1.0)  # right of the centre column: a lean of px, outwards
    got = np.array(calls)
    np.testing.assert_allclose(got[:, 0], u - lean if on else u, atol=1e-6)
    np.testing.assert_allclose(got[:, 1], v, atol=1e-6)


def test_window_b_foot_chooses_as_the_tracker_does():
    """The measured point (plus a side cut's shift, less the lean with rule 41) on a measured
    frame; the filtered point on a predicted one or with `body.sample_estimate`."""
    from rhythmjax.track.lean import window_b_foot
    from rhythmjax.track.options import TrackerOptions, with_changes

    z, est = (300.0, 320.0), (297.5, 318.0)
    lean = lean_px(CAMERA, *z, 1.7)
    assert lean > 1.0
    paper = TrackerOptions()
    on = with_changes(paper, {"body.lean_column": True})
    assert window_b_foot(z, est, True, 0.0, paper, CAMERA, 1.7) == (300.0, 320.0)
    assert window_b_foot(z, est, True, 4.0, paper, CAMERA, 1.7) == (304.0, 320.0)
    got = window_b_foot(z, est, True, 4.0, on, CAMERA, 1.7)
    assert got[0] == pytest.approx(304.0 - lean, abs=1e-9) and got[1] == 320.0
    assert window_b_foot(z, est, False, 4.0, on, CAMERA, 1.7) == est
    filtered = with_changes(paper, {"body.sample_estimate": True, "body.lean_column": True})
    assert window_b_foot(z, est, True, 4.0, filtered, CAMERA, 1.7) == est
