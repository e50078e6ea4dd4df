"""A detection cut by the image's side, its foot column from the inner edge (track/sides.py).

Reference: a body of known columns a .. b (true centre (a + b) / 2, W = b - a + 1 px) drawn into
a motion image with the Sobel halo of one column each side, partly outside the image; the
projections of `detect_in_window` measure the visible part, and the anchored column must be the
body's own centre, exactly (integer columns, no rounding in the rule).
"""

import math

import numpy as np
import pytest

from rhythmjax.track.sides import SIDE_MARGIN_PX, anchor_at_side, cut_side
from rhythmjax.vision.detect import SOBEL_HALO_PX, Detection, detect_in_window


IMAGE_W, IMAGE_H = 160, 120


def body_motion(a: int, b: int, rows=(40, 90)) -> np.ndarray:
    """Motion image of a body over columns a .. b (may lie partly outside), with the halo."""
    m = np.zeros((IMAGE_H, IMAGE_W), np.uint8)
    lo, hi = max(a - SOBEL_HALO_PX, 0), min(b + SOBEL_HALO_PX, IMAGE_W - 1)
    m[rows[0]:rows[1] + 1, lo:hi + 1] = 1
    return m


def detect(m: np.ndarray, centre_u: float) -> Detection:
    det = detect_in_window(m, (centre_u, 70.0), (120, 100), fraction=0.1)
    assert det is not None
    return det


@pytest.mark.parametrize("a", [-30, -20, -11, -5])
def test_left_cut_body_gets_its_own_centre(a):
    W = 41
    b = a + W - 1
    det = detect(body_motion(a, b), 20.0)
    assert cut_side(det, IMAGE_W) == -1
    assert det.u > (a + b) / 2 + 2  # the visible part's centre lies inside the body's
    out = anchor_at_side(det, float(W), IMAGE_W)
    assert out.u == pytest.approx((a + b) / 2, abs=1e-9)
    assert (out.v, out.width, out.box) == (det.v, det.width, det.box)  # only u moves


@pytest.mark.parametrize("b", [IMAGE_W + 25, IMAGE_W + 8])
def test_right_cut_body_gets_its_own_centre(b):
    W = 41
    a = b - W + 1
    det = detect(body_motion(a, b), IMAGE_W - 20.0)
    assert cut_side(det, IMAGE_W) == 1
    out = anchor_at_side(det, float(W), IMAGE_W)
    assert out.u == pytest.approx((a + b) / 2, abs=1e-9)


def test_whole_body_and_wide_or_unknown_widths_unchanged():
    det = detect(body_motion(50, 90), 70.0)  # inside: nothing cut
    assert cut_side(det, IMAGE_W) == 0
    assert anchor_at_side(det, 41.0, IMAGE_W) is det
    cut = detect(body_motion(-10, 30), 20.0)  # cut, but as wide as W or wider: left alone
    assert anchor_at_side(cut, cut.width, IMAGE_W) is cut
    for w in (math.nan, 0.0, -3.0):
        assert anchor_at_side(cut, w, IMAGE_W) is cut


def test_margin_and_both_sides():
    box = lambda x0, w: Detection(u=x0 + (w - 1) / 2, v=50.0, width=w - 2.0, box=(x0, 10, w, 40),  # noqa: E731
                                  area=100)
    assert cut_side(box(SIDE_MARGIN_PX, 20), IMAGE_W) == -1
    assert cut_side(box(SIDE_MARGIN_PX + 1, 20), IMAGE_W) == 0
    assert cut_side(box(IMAGE_W - 20 - SIDE_MARGIN_PX, 20), IMAGE_W) == 1
    assert cut_side(box(IMAGE_W - 21 - SIDE_MARGIN_PX, 20), IMAGE_W) == 0
    both = box(0, IMAGE_W)  # wider than the image: no inner edge
    assert cut_side(both, IMAGE_W) == 0
    assert anchor_at_side(both, 2.0 * IMAGE_W, IMAGE_W) is both


def test_tracker_option_defaults_off_and_is_read():
    from rhythmjax.track.options import TrackerOptions, with_changes

    assert TrackerOptions().body.side_anchor is False
    assert with_changes(TrackerOptions(), {"body.side_anchor": True}).body.side_anchor is True


def test_tracker_entering_walker_measured_nearer_its_centre():
    """Through the tracker: a walker entering across the left side at 8 m. While its body is
    cut (the first rows) the anchored columns lie nearer its true centre than the visible part's
    centre does (the renderer's walker is wider than the 0.5 m W, so not exactly on it)."""
    from rhythmjax.model.params import Config
    from rhythmjax.sim import scene as synth
    from rhythmjax.track.options import TrackerOptions, with_changes
    from rhythmjax.track.tracker import OnlineTracker

    cfg = Config()
    act = synth.walker(-5.5, 8.0, 0.0, pace_hz=1.9, step_length_m=0.62)
    sc = synth.render_scene(3, synth.SceneSpec(n_frames=48, actors=(act,), camera=cfg.camera))
    err = {}
    for on in (False, True):
        tr = OnlineTracker(cfg, with_changes(TrackerOptions(), {"body.side_anchor": on}))
        for i, f in enumerate(sc.frames):
            tr.update(i, i / sc.fps, f)
        tracks, _, _ = tr.finish()
        first = np.argsort(tracks["frame"])[:6]
        err[on] = np.abs(tracks["u"][first] - sc.truth[0].u[tracks["frame"][first]])
    assert np.all(np.isfinite(err[True])) and np.all(np.isfinite(err[False]))
    assert err[False].mean() > 10.0  # the visible part's centre: biased inwards
    assert err[True].mean() < err[False].mean() - 2.0
