"""benchmarks/study_faint_legs.py: a box's upper half and lower 40 %, hand-worked."""

from __future__ import annotations

import math
import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_faint_legs as sfl  # noqa: E402


def test_box_halves_hand_worked():
    mask = np.zeros((20, 10), np.uint8)
    diff = np.zeros((20, 10))
    mask[2:7, 2:6] = 1  # the box's rows 0-4 (upper half of 10 rows), all four columns
    diff[2:7, 2:6] = -40.0  # |I - B| 40 there
    diff[8:12, 2:6] = np.arange(16).reshape(4, 4)  # rows 6-9 (lower 40 %): 0..15
    up, low, d_up, d_low = sfl.box_halves(mask, diff, (2, 2, 4, 10))
    assert (up, low, d_up) == (1.0, 0.0, 40.0)
    assert d_low == np.percentile(np.arange(16), 75) == 11.25
    # clipped at the image's edge: the box's rows past row 19 do not exist
    up, low, _, d_low = sfl.box_halves(mask, diff, (2, 14, 4, 10))
    assert up == 0.0 and math.isnan(low) and math.isnan(d_low)
