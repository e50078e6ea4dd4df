"""benchmarks/study_count_window_b.py: the window grid by hand, and the best peak power of a
walker-like I(k) against a flat one and one with too many missing samples."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_count_window_b as scw  # noqa: E402


def test_window_starts_skip_gaps():
    frames = np.arange(10)
    assert scw.window_starts(frames, 4) == [0, 2, 4, 6]
    gap = np.concatenate([np.arange(5), np.arange(8, 13)])  # a stitching gap after row 4
    assert scw.window_starts(gap, 4) == [0, 6]  # rows 2-5 and 4-7 hold the gap
    assert scw.window_starts(np.arange(3), 4) == []


def test_best_power_sees_a_rhythm():
    from rhythmjax.model.params import config_from_dict

    cfg = config_from_dict({})
    n = int(cfg.thresholds.n)
    fps = float(cfg.camera.fps)
    t = np.arange(2 * n) / fps
    xy = np.stack([1.4 * t, np.full_like(t, 8.0)], 1)
    rng = np.random.default_rng(3)
    walk = 100.0 + 40.0 * np.sin(2 * np.pi * 2.0 * t) + rng.normal(0, 2.0, t.size)
    flat = 100.0 + rng.normal(0, 2.0, t.size)
    starts = scw.window_starts(np.arange(2 * n), n)
    assert starts == [0, n // 2, n]
    assert scw.best_power(cfg, walk, t, xy, starts) > 10 * max(
        1.0, scw.best_power(cfg, flat, t, xy, starts))
    holes = walk.copy()
    holes[::3] = np.nan  # a third missing in every window: none judged
    assert np.isnan(scw.best_power(cfg, holes, t, xy, starts))


def test_leg_column_and_the_compared_places():
    D = np.zeros((100, 200), np.float32)
    D[60:71, 118:121] = 5.0  # legs in columns 118-120 (centroid 119) over rows 60-70
    # window B rows for W = 20: 4 rows ending at v = 70; reach W: columns 90-129 (u = 110)
    assert scw.leg_column(D, 110.0, 70.0, 20.0) == pytest.approx(119.0, abs=1e-9)
    assert scw.leg_column(D, 110.0, 70.0, 20.0, 0.25) == 110.0  # columns 105-114: all zero
    assert scw.leg_column(D, 110.0, 50.0, 20.0) == 110.0  # rows 47-50: none there
    got = scw.places(10.0, 20.0, 11.0, 21.0, 12.0)
    assert got == {"truth": (10.0, 20.0), "truth-column": (10.0, 21.0), "truth-row": (11.0, 20.0),
                   "legs": (11.0, 21.0), "legs-half": (11.0, 21.0), "estimate-column": (12.0, 21.0)}
    assert tuple(got) == scw.PLACES
