"""benchmarks/study_switch_rows.py: a track's rows on its object, on others, and its relink
(hand-made tracks and truths)."""

from __future__ import annotations

import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_switch_rows as sw  # noqa: E402


def test_on_object_bounds_across_and_down():
    # across: max(10, W / 2); down: 10 px; NaN is never on it
    u = [100.0, 109.9, 110.0, 124.9, 125.0, 100.0, 100.0, np.nan]
    v = [50.0, 50.0, 50.0, 50.0, 50.0, 59.9, 60.0, 50.0]
    w = [10.0, 10.0, 10.0, 50.0, 50.0, 10.0, 10.0, 10.0]
    got = sw.on_object(u, v, w, 100.0, 50.0)
    assert got.tolist() == [True, True, False, True, False, True, False, False]


def test_row_profile_counts_a_switch_through_a_lost_stretch():
    """The off rows are counted by their nearest object; an on row's nearest name is not
    counted, whatever it is."""
    f = 20
    frames = np.arange(f)
    bike = np.stack([np.where(frames < 12, 100.0 + 5 * frames, np.nan), np.full(f, 80.0)])
    # rows 0-5 on the bicycle, 6-8 lost (state NONE, not observed), 9-15 on the walker (one
    # 3 px off), 16 off the bicycle with no object in view, 17-19 predicted (not observed);
    # `nearest` holds one name per observed row (14 of them)
    u = np.r_[100.0 + 5 * frames[:6], [np.nan] * 3, [300.0] * 6, 303.0, 250.0, [np.nan] * 3]
    v = np.r_[[80.0] * 6, [np.nan] * 3, [120.0] * 7, 160.0, [np.nan] * 3]
    state = np.r_[[2] * 6, [0] * 3, [2] * 8, [3] * 3]
    nearest = ["bic004"] * 6 + ["ped000"] * 7 + [None]
    prof = sw.row_profile(frames, u, v, np.full(f, 20.0), state, bike, nearest)
    assert (prof["on"], prof["off"], prof["first"], prof["relink"]) == (6, 8, "object", True)
    assert dict(prof["others"]) == {"ped000": 7}  # the row with no object in view: no one


def test_row_profile_without_a_lost_stretch_or_observations():
    frames = np.arange(4)
    obj = np.stack([np.full(4, 50.0), np.full(4, 50.0)])
    u = np.array([200.0, 50.0, 50.0, np.nan])
    v = np.array([50.0, 50.0, 50.0, np.nan])
    prof = sw.row_profile(frames, u, v, np.full(4, 10.0), [2, 3, 2, 0], obj,
                          ["ped001", "obj", "obj"])
    # the NONE row after the last observed one is no relink; the first observed row is off
    assert (prof["on"], prof["off"], prof["first"], prof["relink"]) == (2, 1, "other", False)
    assert dict(prof["others"]) == {"ped001": 1}
    none = sw.row_profile(frames, [np.nan] * 4, [np.nan] * 4, [10.0] * 4, [0] * 4, obj, [])
    assert (none["on"], none["off"], none["first"], none["relink"]) == (0, 0, None, False)


def test_truth_shorter_than_the_track_is_out_of_view():
    prof = sw.row_profile([0, 5], [10.0, 10.0], [10.0, 10.0], [10.0, 10.0], [2, 2],
                          np.array([[10.0, 10.0], [10.0, 10.0]]), ["obj", "ped002"])
    assert (prof["on"], prof["off"]) == (1, 1)
    assert dict(prof["others"]) == {"ped002": 1}
