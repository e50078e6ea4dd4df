"""Splitting a shared blob between its sharers (`track.split.split_shared`, the tracker's
`body.split_shared`), on hand-made motion images: W = 10 px, windows 60 px high."""

from __future__ import annotations

import numpy as np

from rhythmjax.track.options import BodyOptions
from rhythmjax.track.split import Predicted, split_shared
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
