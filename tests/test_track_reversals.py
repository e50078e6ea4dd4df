"""benchmarks/track_reversals.py on hand-made tracks: the first turn back and what the track
follows on either side of it, worked by hand."""

from __future__ import annotations

import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import track_reversals as tr  # noqa: E402


def test_first_turn_by_hand():
    # 1 s blocks of 3 rows: (1, 0), (1, 0), (-1, 0.2): the turn after block 1 (cos -0.98)
    vx, vy = np.array([1, 1, 1, 1, 1, 1, -1, -1, -1.0]), np.array([0, 0, 0, 0, 0, 0, .2, .2, .2])
    assert tr.first_turn(vx, vy, 3) == 1
    # a right-angle turn (cos 0) is no turn back; nor a slow one (0.4 m/s < MIN_SPEED)
    assert tr.first_turn(np.array([1, 1, 0, 0.0]), np.array([0, 0, 1, 1.0]), 2) is None
    assert tr.first_turn(np.array([0.4, 0.4, -0.4, -0.4]), np.zeros(4), 2) is None
    # a last partial block is left out: the turn in its one row does not count
    assert tr.first_turn(np.array([1, 1, -1.0]), np.zeros(3), 2) is None


def _record(second_walker: int):
    """A 4-frame track at 2 fps turning back after frame 1; walker 1 under its boxes in frames
    0-1, then walker `second_walker` (its box moved there) in frames 2-3."""
    truth = {"frame": np.array([0, 1, 2, 3, 0, 1, 2, 3]), "id": np.array([1] * 4 + [2] * 4),
             "bb_left": np.array([0, 5, 10, 15, 100, 95, 90, 85.0]),
             "bb_top": np.zeros(8), "bb_width": np.full(8, 20.0), "bb_height": np.full(8, 50.0)}
    left = [0, 5] + ([10, 15] if second_walker == 1 else [90, 85])
    mot = {"frame": np.array([1, 2, 3, 4]), "id": np.ones(4, int),
           "bb_left": np.array(left, float), "bb_top": np.zeros(4), "bb_width": np.full(4, 20.0),
           "bb_height": np.full(4, 50.0), "vx": np.array([1, 1, -1, -1.0]), "vy": np.zeros(4)}
    return {"mot": mot, "truth": truth, "offset": -1, "fps": 2.0,
            "kinds": {1: "pedestrian", 2: "pedestrian"},
            "verdicts": {"track_id": np.array([1]), "counted": np.array([True])}}


def test_a_turn_on_one_walker_and_on_two():
    one = tr.reversals(_record(1))
    assert one["tracks"] == one["turning"] == one["turning, counted"] == one["one walker"] == 1
    two = tr.reversals(_record(2))
    assert two["two walkers"] == 1 and two["one walker"] == 0
    r = _record(2)
    r["kinds"][2] = "dog"
    assert tr.reversals(r)["other"] == 1
    assert tr.block_object(r, np.array([0, 1])) == 1
