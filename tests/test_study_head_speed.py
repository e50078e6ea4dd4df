"""benchmarks/study_head_speed.py: a track's walker by its head row, and the classes of the
tracks a rule adds, on a hand-made clip record."""

from __future__ import annotations

import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_head_speed as sh  # noqa: E402


def _record(counted):
    # truth: walker 1's box (100..130 x 50..150) and a bicycle 2's (300..340 x 80..150), frames
    # 0-9; track 1 on walker 1's upper body (top row 55, inside its top 30 %: rows 45..80),
    # track 2 on nothing, track 3 on the bicycle's box (MOT box equal to it)
    f = np.arange(10)
    truth = {"frame": np.concatenate([f, f]), "id": np.repeat([1, 2], 10),
             "bb_left": np.repeat([100.0, 300.0], 10), "bb_top": np.repeat([50.0, 80.0], 10),
             "bb_width": np.repeat([30.0, 40.0], 10), "bb_height": np.repeat([100.0, 70.0], 10)}
    tracks = {"track_id": np.repeat([1, 2, 3], 10), "frame": np.tile(f, 3),
              "u": np.repeat([115.0, 200.0, 320.0], 10),
              "v_top": np.concatenate([np.full(10, 55.0), np.full(10, 55.0),
                                       np.full(10, np.nan)])}
    mot = {"frame": f + 1, "id": np.full(10, 3), "bb_left": np.full(10, 300.0),
           "bb_top": np.full(10, 80.0), "bb_width": np.full(10, 40.0),
           "bb_height": np.full(10, 70.0)}
    return {"clip": "c", "truth": truth, "tracks": tracks, "mot": mot, "offset": 0,
            "kinds": {1: "pedestrian", 2: "bicycle"},
            "verdicts": {"track_id": np.array([1, 2, 3]), "counted": np.array(counted)}}


def test_head_owner():
    r = _record([False, False, False])
    assert sh.head_owner(r, 1) == 1  # its top row in walker 1's top 30 %
    assert sh.head_owner(r, 2) is None  # column 200: in no box
    assert sh.head_owner(r, 3) is None  # no top row


def test_added_classes():
    before = _record([False, False, False])
    after = _record([True, True, True])
    got = sh.added_classes(before, after)
    assert got == {"walker not counted": 1, "no one": 1, "non-walker": 1}
    before = _record([False, False, True])  # nothing added where counted before
    assert sh.added_classes(before, after) == {"walker not counted": 1, "no one": 1}
