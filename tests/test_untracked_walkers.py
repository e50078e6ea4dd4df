"""benchmarks/untracked_walkers.py on a hand-made clip: the counted tracks split by what they
follow, and a walker beside another, inside a track's box, counted by hand."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import untracked_walkers as uw  # noqa: E402


def _record():
    # walkers 1 and 2 side by side in frames 0-3 (2's box overlaps 1's by 10 of 20 px = 0.5 of
    # its width), walker 2 alone at frame 4 (1 gone); walker 3 far from them, a dog (9) beside it
    rows = []
    for f in range(5):
        if f < 4:
            rows.append((f, 1, 100.0, 53.0))
        rows.append((f, 2, 110.0, 50.0))
        rows.append((f, 3, 300.0, 50.0))
        rows.append((f, 9, 305.0, 50.0))  # the dog overlapping walker 3 by 15 px
    tr = {"frame": np.array([r[0] for r in rows]), "id": np.array([r[1] for r in rows]),
          "bb_left": np.array([r[2] for r in rows]), "bb_top": np.array([r[3] for r in rows]),
          "bb_width": np.full(len(rows), 20.0), "bb_height": np.full(len(rows), 60.0)}
    # one track's box on walker 1 in frames 0-2 (mot frames are truth frames - offset)
    mot = {"frame": np.array([1, 2, 3]), "id": np.array([1, 1, 1]),
           "bb_left": np.full(3, 100.0), "bb_top": np.full(3, 53.0),
           "bb_width": np.full(3, 20.0), "bb_height": np.full(3, 60.0)}
    verdicts = {"track_id": np.array([1, 2, 3, 4, 5]),
                "verdict": np.array(["pedestrian", "unclassified", "unclassified",
                                     "non-pedestrian", "unclassified"], dtype=object),
                "counted": np.array([True, True, True, False, True])}
    kinds = {1: "pedestrian", 2: "pedestrian", 3: "pedestrian", 9: "dog"}
    return {"truth": tr, "mot": mot, "offset": -1, "verdicts": verdicts, "kinds": kinds,
            "true": 3}


def test_decompose_by_hand():
    own = {1: 1, 2: 1, 3: 9, 4: 3, 5: None}  # track 2 a second on walker 1; 4 on 3, not counted
    c = uw.decompose(_record(), own)
    assert c == {"true": 3, "first_P": 1, "second": 1, "non_walker": 1, "nothing": 1,
                 "missed_tracked": 1, "missed_untracked": 1}


def test_beside_and_covered_by_hand():
    r = _record()
    # walker 2: 1 beside in frames 0-3 of its 5 (overlap 10 px >= 0.3 x 20); the track's box
    # (on walker 1, 3 px lower) has IoU 10 x 57 / (2 x 1200 - 570) = 0.311 >= 0.3 with it in
    # frames 0-2
    # walker 1 stands 3 px (0.05 of its 60 px height) lower: nearer; 2 the farther
    assert uw.beside_and_covered(r, 2) == pytest.approx((4 / 5, 3 / 5, 0.05, 1.0))
    assert uw.beside_and_covered(r, 1) == pytest.approx((1.0, 3 / 4, 0.05, 0.0))
    got = uw.beside_and_covered(r, 3)  # the dog beside it is no walker
    assert got[:2] == (0.0, 0.0) and np.isnan(got[2]) and np.isnan(got[3])
