"""benchmarks/paired_tracker.py: per-scene counts from a by-track score, and the paired bootstrap
interval of the pooled difference (hand-worked cases: a constant difference has no spread; the
interval of a mixed one holds its sum and lies within the extreme resamples)."""

from __future__ import annotations

import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import paired_tracker as pt  # noqa: E402


def test_scene_counts():
    objs = [{"kind": "pedestrian", "verdict": "pedestrian"},
            {"kind": "pedestrian", "verdict": "unclassified"},
            {"kind": "pedestrian", "verdict": "missed"},
            {"kind": "bicycle", "verdict": "pedestrian"},
            {"kind": "dog", "verdict": "non-pedestrian"}]
    assert pt.scene_counts({"objects": objs}) == (3, 1, 1)


def test_paired_interval():
    assert pt.paired_interval(np.zeros(12)) == (0.0, 0.0, 0.0)
    assert pt.paired_interval(np.ones(7)) == (7.0, 7.0, 7.0)
    d = np.array([1, -1, 0, 0, 2, 0, -1, 0, 1, 0], float)
    s, lo, hi = pt.paired_interval(d)
    assert s == 2.0 and lo < s < hi
    assert -10.0 <= lo and hi <= 20.0  # every resample sums 10 draws of -1 .. 2
    assert pt.paired_interval(d) == (s, lo, hi)  # a fixed generator
    # the bootstrap sums' spread: sqrt(n) x the scenes' standard deviation, within 15 %
    sd = np.sqrt(len(d)) * d.std()
    assert abs((hi - lo) / (2 * 1.96) - sd) < 0.15 * sd
