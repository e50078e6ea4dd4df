"""benchmarks/study_merge_hold.py: the coasts and ends it watches are tallied by hand and the
module is restored."""

from __future__ import annotations

import os
import sys
from collections import Counter
from types import SimpleNamespace

import pytest

from rhythmjax.count.coast import advance_coast
from rhythmjax.count.pedestrian import Pedestrian


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_merge_hold as smh  # noqa: E402


def test_watching_tallies_and_restores():
    class Level:
        def _end(self, p, reason):
            return reason

    mod = SimpleNamespace(advance_coast=advance_coast, PedestrianLevel=Level)
    before = (mod.advance_coast, Level._end)
    tally, longest = Counter(), {}
    p = Pedestrian(slot=0, born=0)
    with smh.watched_coasts(mod, tally, longest):
        for measured, merged in ((True, False), (False, True), (False, True), (False, False)):
            p.merged = merged
            mod.advance_coast(p, measured, 0.25, 3.0)
        assert Level()._end(p, "timeout") == "timeout"
        assert Level()._end(p, "clip-end") == "clip-end"
    assert (mod.advance_coast, Level._end) == before
    # 4 frames, 3 unmeasured, 2 merged and held (entered measured); then 0.25 s coasting
    assert tally == {"frames": 4, "unmeasured": 3, "merged": 2, "held": 2, "end timeout": 1,
                     "timeout held": 1, "end clip-end": 1}
    assert longest == {id(p): pytest.approx(0.5)} and p.coast == pytest.approx(0.25)
