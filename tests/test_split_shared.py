"""Splitting a shared blob between its sharers (`track.split.split_shared`, the tracker's
`body.split_shared`), on hand-made motion images: W = 10 px, windows 60 px high."""

from __future__ import annotations

import numpy as np

from rhythmjax.track.options import BodyOptions
from rhythmjax.track.split import Predicted, front_split, split_shared
from rhythmjax.vision.detect import detect_in_window, shared_detections


W = 10.0  # walker width px
FRACTION = BodyOptions().slice_fraction


def _predicted(u: float, v: float) -> Predicted:
    """A track's window as the tracker places it: centre (u, 65) px, 60 px high, its body box
    1.2 W wide (cols int(u - 6) .. +11) and rows 45-89, predicted foot point (u, v)."""
    return Predicted(centre=(u, 65.0), height=60.0, core=(int(u - 6), 45, 12, 45), foot=(u, v),
                     W=W)


def _split(motion, predicted, near_widths=0.25):
    return split_shared(motion, set(predicted), predicted, overlap=0.5,
                        near_widths=near_widths, fraction=FRACTION)


def test_two_blobs_side_by_side_each_sharer_gets_its_own_foot_point():
    M = np.zeros((120, 100), np.uint8)
    M[50:90, 40:50] = 1  # object 1: cols 40-49, rows 50-89: bottom centre (44.5, 89)
    M[50:90, 52:62] = 1  # object 2: cols 52-61, 2 px to its right: bottom centre (56.5, 89)
    predicted = {0: _predicted(45.0, 88.0), 1: _predicted(57.0, 90.0)}
    # today's detections (window 2.5 W wide, parts joined over 1.8 W): each takes in both
    # objects (dilated by 3 px they are one region): cols 40-57 and 45-61 overlap by 13/17
    wide = {s: detect_in_window(M, p.centre, (25, 60), fraction=FRACTION, core=p.core,
                                body_px=1.8 * W) for s, p in predicted.items()}
    assert shared_detections(wide, 0.5) == {0, 1}
    # split: windows 12 px wide, cols 39-50 and 51-62, hold one object each
    out = _split(M, predicted)
    assert set(out) == {0, 1}
    assert abs(out[0].u - 44.5) <= 1 and abs(out[0].v - 89) <= 1
    assert abs(out[1].u - 56.5) <= 1 and abs(out[1].v - 89) <= 1
    assert out[0].width == 8.0 and out[1].width == 8.0  # 10 px less the Sobel halo


def test_one_blob_is_not_split():
    M = np.zeros((120, 100), np.uint8)
    M[50:90, 40:60] = 1  # one object, cols 40-59
    predicted = {0: _predicted(47.0, 89.0), 1: _predicted(52.0, 89.0)}  # 0.5 W apart
    # windows cols 41-52 and 46-57: the re-detections overlap by 7 of 12 cols: still shared
    assert _split(M, predicted) == {}


def test_a_re_detection_far_from_its_prediction_is_refused():
    M = np.zeros((120, 100), np.uint8)
    M[50:90, 40:50] = 1
    M[50:90, 52:62] = 1
    predicted = {0: _predicted(45.0, 80.0), 1: _predicted(57.0, 90.0)}  # 0: feet 9 px lower
    assert set(_split(M, predicted)) == {1}
    assert set(_split(M, predicted, near_widths=1.0)) == {0, 1}


def _at(u: float, foot_v: float) -> Predicted:
    """A window as the tracker places it for a foot point (u, foot_v): 60 px high, its bottom
    `foot_v` + 6 (centre raised by 24 px), the body box 1.2 W wide and 45 rows high above the
    foot."""
    return Predicted(centre=(u, foot_v - 24.0), height=60.0,
                     core=(int(u - 6), int(foot_v - 44), 12, 45), foot=(u, foot_v), W=W)


def test_the_front_sharer_is_measured_below_the_back_ones_feet():
    """Two walkers 4 px apart across (never split across), the front one's feet 10 px (1 W)
    lower: front rows 60-99 (feet at row 99), back rows 50-89 (feet at 89)."""
    M = np.zeros((130, 100), np.uint8)
    M[50:90, 42:52] = 1  # back object: cols 42-51, feet at row 89
    M[60:100, 46:56] = 1  # front object: cols 46-55, feet at row 99
    predicted = {0: _at(47.0, 89.0), 1: _at(51.0, 99.0)}
    assert _split(M, predicted) == {}  # across: the re-detections overlap
    out = split_shared(M, set(predicted), predicted, overlap=0.5, near_widths=0.3,
                       fraction=FRACTION, depth_widths=0.5, margin_widths=0.1)
    assert set(out) == {1}  # the back sharer gets nothing
    # the strip: rows 90 (89 + 1 px margin) to 105, cols 45-56: only the front legs, feet at 99
    assert abs(out[1].u - 51.0) <= 1 and out[1].v == 99
    # width and top from the whole body box (cols 45-56, rows 55-99): both objects' motion there
    whole = detect_in_window(M, predicted[1].centre, (12, 60), fraction=FRACTION,
                             core=predicted[1].core, body_px=None)
    assert out[1].width == whole.width and out[1].top == whole.top
    # not in front by more than depth_widths W: nothing
    assert front_split(M, [1], [0, 1], predicted, depth_widths=1.5, margin_widths=0.1,
                       near_widths=0.3, fraction=FRACTION) == {}
    # a foot point farther than near_widths W from the prediction: refused
    far = {0: predicted[0], 1: _at(51.0, 96.0)}  # predicted 3 px above the measured 99
    assert front_split(M, [1], [0, 1], far, depth_widths=0.5, margin_widths=0.1,
                       near_widths=0.2, fraction=FRACTION) == {}
    assert set(front_split(M, [1], [0, 1], far, depth_widths=0.5, margin_widths=0.1,
                           near_widths=0.4, fraction=FRACTION)) == {1}
