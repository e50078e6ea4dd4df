"""benchmarks/fit_tracker_noise.py: which tracker rows are a walker's measurements (the padded
batch is fit_count_noise's `batch`, tested in test_count_filter_noise.py). Hand-made truth: a
walker at u = 100 + 2 k, v = 200 px, 40 px wide; a bicycle far away."""

from __future__ import annotations

import os
import sys

import numpy as np

from rhythmjax.sim.scene import ObjectTruth


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import fit_tracker_noise as ftn  # noqa: E402


T = 30


def _truth(name, kind, u0):
    k = np.arange(T, dtype=float)
    nan = np.full(T, np.nan)
    return ObjectTruth(track_id=name, kind=kind, pace_hz=2.0, step_length_m=0.7, speed_mps=1.4,
                       u=u0 + 2.0 * k, v=np.full(T, 200.0), width_px=np.full(T, 40.0), x=nan,
                       y=nan, body_x=nan, body_y=nan, alive=np.ones(T, bool),
                       visible=np.ones(T, bool))


def _tracks():
    """Track 1 on the walker (frames 2..21; frame 10 off by 25 px, frame 12 unmeasured, frame 15
    written twice as a relink can); track 2 on the bicycle."""
    f1 = np.r_[np.arange(2, 16), 15, np.arange(16, 22)]
    u1 = 100.0 + 2.0 * f1 + 1.0
    u1[f1 == 10] += 25.0
    u1[f1 == 12] = np.nan
    f2 = np.arange(0, 20)
    return {"track_id": np.r_[np.ones(len(f1), int), np.full(len(f2), 2)],
            "frame": np.r_[f1, f2], "u": np.r_[u1, 400.0 + 3.0 * f2],
            "v": np.r_[np.full(len(f1), 201.0), np.full(len(f2), 150.0)]}


def test_walker_rows_kept_near_the_truth_only():
    truth = [_truth("ped000", "pedestrian", 100.0), _truth("bic000", "bicycle", 400.0)]
    rows = ftn.labelled_rows(_tracks(), truth, within=0.5)
    assert len(rows) == 1  # the bicycle's track is not a walker's
    r = rows[0]
    assert list(r[:, 0]) == list(range(2, 22))  # one row per frame, in order
    gone = r[np.isnan(r[:, 1]), 0]
    assert list(gone) == [10, 12]  # 25 px > 0.5 x 40 px off; unmeasured
    keep = np.isfinite(r[:, 1])
    np.testing.assert_allclose(r[keep, 1], 100.0 + 2.0 * r[keep, 0] + 1.0)
    np.testing.assert_allclose(r[keep, 2], 201.0)
    assert np.isfinite(ftn.labelled_rows(_tracks(), truth, within=0.7)[0][8, 1])  # frame 10
