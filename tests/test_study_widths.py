"""benchmarks/study_widths.py: the width gate's spread with its mean held (hand-worked, and the
maximum of the likelihood by a grid), and the rows matched to a true walker."""

from __future__ import annotations

import math
import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_widths as sw  # noqa: E402


def test_held_mean_std_hand_worked():
    # (0 + 0.04 + 0.04 + 0.01) / 4 = 0.0225 -> 0.15; NaN rows are left out
    assert math.isclose(sw.held_mean_std([0.5, 0.7, 0.3, 0.6, np.nan], 0.5), 0.15, rel_tol=1e-12)
    assert math.isnan(sw.held_mean_std([np.nan], 0.5))
    # not the sample std: the mean is held, so an offset sample has the larger spread
    w = np.array([0.6, 0.7, 0.8])
    assert sw.held_mean_std(w, 0.5) > np.std(w)


def test_held_mean_std_maximises_the_likelihood():
    rng = np.random.default_rng(3)
    w = rng.normal(0.65, 0.14, 400)
    s = np.linspace(0.05, 0.5, 9001)  # a grid of spreads, 5e-5 m apart
    loglik = -len(w) * np.log(s) - ((w - 0.5) ** 2).sum() / (2 * s ** 2)
    assert abs(s[np.argmax(loglik)] - sw.held_mean_std(w, 0.5)) <= 5e-5


def test_matched_ratios():
    W = np.array([40.0, 40.0, 40.0, 40.0, np.nan])
    u = np.array([100.0, 100.0, 113.0, np.nan, 100.0])  # 0 px, 13 px, 13 px off; no u; no W
    v = np.array([200.0, 204.0, 200.0, 200.0, 200.0])
    wp = np.array([48.0, 60.0, 52.0, 50.0, 50.0])
    ut, vt = np.full(5, 100.0), np.array([200.0, 191.0, 200.0, 200.0, 200.0])
    # 0.35 W = 14 px: rows 0-2 are within it, row 3 has no foot point, row 4 no W
    assert np.allclose(sw.matched_ratios(u, v, wp, ut, vt, W), [1.2, 1.5, 1.3])
    u[2] = 114.5  # 14.5 px: beyond
    assert np.allclose(sw.matched_ratios(u, v, wp, ut, vt, W), [1.2, 1.5])
    v[1] = 205.0  # exactly 14 px: not within (strict)
    assert np.allclose(sw.matched_ratios(u, v, wp, ut, vt, W), [1.2])
