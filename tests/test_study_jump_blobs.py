"""benchmarks/study_jump_blobs.py: the placements it watches are restored, and a jump piece's
record (widest blob, shared, worst placed foot point against the truth) on hand-made rows."""

from __future__ import annotations

import os
import sys
from types import SimpleNamespace

import numpy as np
import pytest


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_jump_blobs as sjb  # noqa: E402


def test_watching_restores_the_module():
    mod = SimpleNamespace(place_patch=lambda *a, **k: "placed", gated=lambda *a: "z")
    before = (mod.place_patch, mod.gated)
    log: dict = {}
    with sjb.watched_placements(mod, log):
        shape = SimpleNamespace(size=lambda u, v: (20.0, 50.0))
        assert mod.place_patch(None, None, None, shape, 10.0, 30.0, radius_px=6.0,
                               bbox=(0, 0, 70, 40)) == "placed"
        p, level = object(), SimpleNamespace(n_frames=5)
        assert mod.gated(level, p, SimpleNamespace(u=11.0, v=31.0, w=19.0, h=48.0)) == "z"
    assert (mod.place_patch, mod.gated) == before
    # 70 px of blob box over W = 20 px; radius 6 px < 0.5 W: shared; frame index 4
    assert log == {id(p): {4: (3.5, True, 11.0, 31.0, 19.0, 48.0)}}


def _box(frame):
    return SimpleNamespace(frame=frame)


def test_a_jump_piece_record():
    # walker 7's truth box: bottom centre (100 + 2 f, 150) in frame index f (MOT frame f + 1)
    frames = np.arange(0, 30)
    truth = {"frame": frames + 1, "id": np.full(30, 7), "bb_left": 90.0 + 2 * frames,
             "bb_top": np.full(30, 100.0), "bb_width": np.full(30, 20.0),
             "bb_height": np.full(30, 50.0)}
    piece = SimpleNamespace(end_reason="velocity-jump", boxes=[_box(f) for f in range(5, 20)],
                            ground=[SimpleNamespace(y=12.0)])
    # placed on the walker until 19, then (dropped by the jump rule) 9 px right, 25 px low
    log = {id(piece): {f: (1.5 if f < 20 else 4.2, f >= 20, 100.0 + 2 * f + (9 if f >= 20
                                                                              else 0),
                           150.0 + (25 if f >= 20 else 0), 20.0, 50.0) for f in range(5, 24)}}
    other = SimpleNamespace(end_reason="timeout", boxes=piece.boxes, ground=piece.ground)
    owner = lambda boxes, tr, off, kinds: (7, "pedestrian")  # noqa: E731
    recs = sjb.jump_pieces([piece, other], log, truth, {7: "pedestrian"}, 0, 8, owner)
    near = sjb.jump_pieces([piece], log, truth, {7: "pedestrian"}, 0, 0, owner)
    # dropped frames 20-23: the patch 9 px right and 25 px low of the 20 x 50 truth box: IoU
    # (11 x 25) / (2 x 1000 - 275) = 0.159 < 0.3: on nothing
    assert recs == [{"ratio": 4.2, "shared": True, "du": 9.0, "dv": 25.0, "y": 12.0,
                     "dropped_on": "nothing"}]
    # only the end frame (19) itself: on the walker, and no dropped frame looked at
    assert near == [{"ratio": 1.5, "shared": False, "du": 0.0, "dv": 0.0, "y": 12.0,
                     "dropped_on": "not placed"}]


def test_what_the_dropped_frames_stood_on():
    # walker 7 at left 100, walker 8 at left 140, a bicycle 9 at left 180 (20 x 50 boxes,
    # bottom 150) in frame indices 0-9 (truth frames 1-10)
    F = np.arange(10)
    truth = {"frame": np.r_[F, F, F] + 1, "id": np.r_[[7] * 10, [8] * 10, [9] * 10],
             "bb_left": np.r_[[100.0] * 10, [140.0] * 10, [180.0] * 10],
             "bb_top": np.full(30, 100.0), "bb_width": np.full(30, 20.0),
             "bb_height": np.full(30, 50.0)}
    kinds = {7: "pedestrian", 8: "pedestrian", 9: "bicycle"}
    at = lambda f, left: (f, left + 10.0, 150.0, 20.0, 50.0)  # noqa: E731
    on = lambda placed: sjb.dropped_on(placed, truth, kinds, 7, 0)  # noqa: E731
    assert on([at(1, 100.0), at(2, 100.0)]) == "own walker"
    assert on([at(1, 140.0), at(2, 140.0), at(3, 100.0)]) == "another walker"
    assert on([at(1, 180.0)]) == "non-walker"
    assert on([at(1, 300.0)]) == "nothing"
    assert on([at(1, 100.0), at(2, 140.0)]) == "own walker"  # a tie: DROPPED_ON's order
    assert on([at(20, 100.0)]) == "nothing"  # no truth in that frame
    assert on([]) == "not placed"


@pytest.mark.parametrize("frame, found", [(3, (106.0, 150.0)), (40, None)])
def test_truth_foot(frame, found):
    frames = np.arange(0, 30)
    truth = {"frame": frames + 1, "id": np.full(30, 7), "bb_left": 90.0 + 2 * frames,
             "bb_top": np.full(30, 100.0), "bb_width": np.full(30, 20.0),
             "bb_height": np.full(30, 50.0)}
    assert sjb.truth_foot(truth, 7, frame, 0) == found
