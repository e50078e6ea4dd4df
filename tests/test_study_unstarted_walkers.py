"""benchmarks/study_unstarted_walkers.py: a truth frame's cause and a started pedestrian's fate,
worked by hand on made-up frames (no tracker run)."""

from __future__ import annotations

import os
import sys
from types import SimpleNamespace

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_unstarted_walkers as su  # noqa: E402


BOX = np.array([100.0, 40.0, 20.0, 60.0])  # the walker's box: columns 100-120, rows 40-100


def _seen(fg_rows=(70, 100), live=(), covers=(), runs=()):
    fg = np.zeros((200, 300), bool)
    fg[fg_rows[0]:fg_rows[1], 105:115] = True
    return {"fg": fg, "live": list(live), "covers": list(covers), "runs": list(runs)}


def test_each_cause_by_hand():
    whose = lambda p: p.label  # noqa: E731
    ped = SimpleNamespace(label="a track on nothing")
    # a live patch on the box itself (IoU 1): tracked, named by what its track follows
    assert su.frame_cause(_seen(live=[((100.0, 40.0, 20.0, 60.0), ped)]), BOX, whose) == \
        "tracked: a track on nothing"
    # a patch beside it (columns 114-134: IoU 6 x 60 / (2 x 1200 - 360) = 0.18 < 0.3): not so
    off = [((114.0, 40.0, 20.0, 60.0), ped)]
    assert su.frame_cause(_seen(live=off), BOX, whose) == "free: no run there"
    # no foreground in the box's lower half (rows 70-100), only above it
    assert su.frame_cause(_seen(fg_rows=(40, 69)), BOX, whose) == "no mask"
    assert su.frame_cause(None, BOX, whose) == "no mask"
    # its centre column 110 inside another's cover: a nearer one (foot row 120 below its 100)
    # or a farther one (foot row 90)
    assert su.frame_cause(_seen(covers=[(95.0, 50.0, 125.0, 120.0, 120.0)]), BOX, whose) == \
        "covered by a nearer"
    assert su.frame_cause(_seen(covers=[(95.0, 20.0, 125.0, 90.0, 90.0)]), BOX, whose) == \
        "covered by a farther"
    # a cover whose rows miss the box (rows 0-30) does not count
    assert su.frame_cause(_seen(covers=[(95.0, 0.0, 125.0, 30.0, 30.0)]), BOX, whose) == \
        "free: no run there"
    # a free run over columns 104-116 refused as thin, its bottom at the hips (row 70): lifted
    # 30 px = 0.5 box heights above the box's bottom
    lifts = []
    assert su.frame_cause(_seen(runs=[(104, 116, "thin", 70.0)]), BOX, whose, lifts) == \
        "free: thin"
    assert lifts == [0.5]
    # a run under a farther one's cover (new.cover_to_feet: its legs below that one's feet)
    # names the run's test, not the cover
    below = _seen(covers=[(95.0, 20.0, 125.0, 90.0, 90.0)], runs=[(104, 116, "narrow", 100.0)])
    assert su.frame_cause(below, BOX, whose) == "free: narrow"


def test_fates_and_what_a_track_follows():
    kinds = {1: "pedestrian", 2: "dog"}
    rows = [object() for _ in range(12)]
    tentative = SimpleNamespace(track_id=0, rows=rows[:2])
    short = SimpleNamespace(track_id=5, rows=rows[:9])
    kept = SimpleNamespace(track_id=3, rows=rows)
    assert su.start_fate(tentative, 10) == "tentative"
    assert su.start_fate(short, 10) == "short"
    assert su.start_fate(kept, 10) == "output"
    owner = {3: 1, 4: None, 6: 2}
    assert su.follows(kept, owner, kinds, {}) == "another walker's track"
    assert su.follows(SimpleNamespace(track_id=4, rows=rows), owner, kinds, {}) == \
        "a track on nothing"
    assert su.follows(SimpleNamespace(track_id=6, rows=rows), owner, kinds, {}) == \
        "a track on a non-walker"
    # track 7 is no output track of its own: its first row now sits in track 3 (stitched)
    piece = SimpleNamespace(track_id=7, rows=rows[5:])
    holder = {id(r): kept for r in rows}
    assert su.follows(piece, owner, kinds, holder) == "stitched into another walker's track"
    assert su.follows(SimpleNamespace(track_id=8, rows=[object()]), owner, kinds, holder) == \
        "no output track"
