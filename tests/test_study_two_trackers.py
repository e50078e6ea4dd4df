"""benchmarks/study_two_trackers.py: which rhythm Pedestrian tracks the counted tracks cover, and
which counted tracks one rhythm track joins (hand-made boxes and foot points)."""

from __future__ import annotations

import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_two_trackers as stt  # noqa: E402


def _mot(boxes):
    """MOT columns from (id, 1-based frame, left, top, width, height) rows."""
    a = np.asarray(boxes, np.float64)
    return {"id": a[:, 0].astype(int), "frame": a[:, 1].astype(int), "bb_left": a[:, 2],
            "bb_top": a[:, 3], "bb_width": a[:, 4], "bb_height": a[:, 5]}


def _record(boxes, counted, rhythm_rows, verdicts):
    """rhythm_rows: (track id, 0-based frame, u, v); verdicts: {track id: verdict}."""
    r = np.asarray(rhythm_rows, np.float64)
    ids = sorted(verdicts)
    return {"mot": _mot(boxes), "counted": counted,
            "tracks": {"track_id": r[:, 0].astype(int), "frame": r[:, 1].astype(int),
                       "u": r[:, 2], "v": r[:, 3]},
            "verdicts": {"track_id": ids, "verdict": [verdicts[i] for i in ids]}}


def test_a_foot_point_is_covered_inside_the_widened_box_only():
    # a box 20 px wide from u = 100, rows 50-150; margin 0.25: u 95-125, v 50-155
    boxes = stt.boxes_by_frame(_mot([(1, 1, 100, 50, 20, 100)]), [1], 0.25)
    assert list(boxes) == [0]
    assert stt.covering([(0, 95.0, 155.0)], boxes) == {1: 1}
    assert stt.covering([(0, 94.9, 100.0)], boxes) == {}
    assert stt.covering([(0, 110.0, 155.1)], boxes) == {}
    assert stt.covering([(0, 110.0, 49.9)], boxes) == {}  # above the box: not widened
    assert stt.covering([(1, 110.0, 100.0)], boxes) == {}  # another frame


def test_uncounted_tracks_cover_nothing_and_only_pedestrian_rhythm_tracks_are_read():
    boxes = [(1, k + 1, 100, 50, 20, 100) for k in range(4)]
    rows = [(7, k, 110, 140) for k in range(4)] + [(8, k, 300, 140) for k in range(4)]
    rec = _record(boxes, [], rows, {7: "pedestrian", 8: "non-pedestrian"})
    # track 1 not counted: rhythm track 7 lies in no counted box, so it is added; 8 is no walker
    assert stt.two_tracker_rules(rec) == {"added": [7], "merged": []}
    rec["counted"] = [1]
    assert stt.two_tracker_rules(rec) == {"added": [], "merged": []}


def test_a_track_covered_in_under_half_its_rows_is_added():
    boxes = [(1, k + 1, 100, 50, 20, 100) for k in range(2)]  # frames 0, 1
    rows = [(7, k, 110, 140) for k in range(5)]  # 2 of 5 rows covered
    assert stt.two_tracker_rules(_record(boxes, [1], rows, {7: "pedestrian"}))["added"] == [7]
    boxes += [(1, 3, 100, 50, 20, 100)]  # 3 of 5
    assert stt.two_tracker_rules(_record(boxes, [1], rows, {7: "pedestrian"}))["added"] == []


def test_one_rhythm_track_joins_two_counted_fragments_in_turn_but_not_simultaneous_ones():
    # counted 1 on frames 0-9 at u 100, counted 2 on frames 10-19 at u 200; the rhythm track
    # walks from one to the other
    boxes = [(1, k + 1, 100, 50, 20, 100) for k in range(10)]
    boxes += [(2, k + 1, 200, 50, 20, 100) for k in range(10, 20)]
    rows = [(5, k, 110 if k < 10 else 210, 140) for k in range(20)]
    rec = _record(boxes, [1, 2], rows, {5: "pedestrian"})
    assert stt.two_tracker_rules(rec) == {"added": [], "merged": [[1, 2]]}
    # counted 2 also present on frames 0-9 (elsewhere): 10 shared frames > 5, no join
    boxes2 = boxes + [(2, k + 1, 400, 50, 20, 100) for k in range(10)]
    rec2 = _record(boxes2, [1, 2], rows, {5: "pedestrian"})
    assert stt.two_tracker_rules(rec2)["merged"] == []
    # a fragment holding under half the rhythm rows it shares frames with is not joined
    rows3 = [(5, k, 110 if k < 10 else (210 if k < 14 else 500), 140) for k in range(20)]
    rec3 = _record(boxes, [1, 2], rows3, {5: "pedestrian"})
    assert stt.two_tracker_rules(rec3)["merged"] == []
