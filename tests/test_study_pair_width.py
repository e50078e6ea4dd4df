"""benchmarks/study_pair_width.py: the fraction of a counted track's frames whose box meets two
or more walkers' truth boxes (hand-made boxes, IoUs worked by hand)."""

from __future__ import annotations

import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_pair_width as spw  # noqa: E402


def _boxes(rows):
    """MOT-like columns from (id, frame, left, top, width, height) rows."""
    a = np.asarray(rows, np.float64)
    return {"id": a[:, 0].astype(int), "frame": a[:, 1].astype(int), "bb_left": a[:, 2],
            "bb_top": a[:, 3], "bb_width": a[:, 4], "bb_height": a[:, 5]}


def test_pair_fraction_counts_frames_on_two_walkers():
    """Track 7's box (0, 0, 10, 20) in frames 1-4 (1-based). Walkers 1 and 2 (0-based frames):
    frame 0 both on it (walker 2 shifted 3 px: IoU 140/260 = 0.54); frame 1 walker 2 shifted 8
    px (IoU 40/360 = 0.11 < 0.3): one; frame 2 both again; frame 3 walker 2 alone with the
    object 3 (not a walker) on the box: one. Two of four frames: 0.5. Another track, or no
    walker, gives 0."""
    truth = _boxes([
        (1, 0, 0, 0, 10, 20), (2, 0, 3, 0, 10, 20),
        (1, 1, 0, 0, 10, 20), (2, 1, 8, 0, 10, 20),
        (1, 2, 0, 0, 10, 20), (2, 2, 1, 0, 10, 20),
        (2, 3, 0, 0, 10, 20), (3, 3, 0, 0, 10, 20),
    ])
    mot = _boxes([(7, f, 0, 0, 10, 20) for f in (1, 2, 3, 4)] + [(8, 1, 50, 0, 10, 20)])
    assert spw.pair_fraction(mot, truth, [1, 2], 7) == 0.5
    assert spw.pair_fraction(mot, truth, [1, 2], 8) == 0.0
    assert spw.pair_fraction(mot, truth, [], 7) == 0.0
    assert spw.pair_fraction(mot, truth, [1, 2, 3], 7) == 0.75  # object 3 a walker: frame 3 too
