"""benchmarks/uncounted_walkers.py on a hand-made clip record."""

from __future__ import annotations

import os
import sys

import numpy as np


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import uncounted_walkers as uw  # noqa: E402


def test_uncounted_walkers_by_hand():
    # tracks 1-5: on walker 1 (counted), walker 1 again (not counted: walker 1 is followed),
    # walker 2 (no-peak), walker 2 (too fast), the bicycle 3; track 6 on nothing
    record = {"kinds": {1: "pedestrian", 2: "pedestrian", 3: "bicycle"},
              "verdicts": {"track_id": np.arange(1, 7),
                           "verdict": np.array(["pedestrian", "unclassified", "non-pedestrian",
                                                "unclassified", "unclassified", "unclassified"],
                                               dtype=object),
                           "reason": np.array(["matched", "too-short", "no-peak", "too-short",
                                               "too-short", "too-short"], dtype=object),
                           "counted": np.array([True, False, False, False, False, False]),
                           "too_fast": np.array([False, False, False, True, False, True])}}
    owners = {1: 1, 2: 1, 3: 2, 4: 2, 5: 3, 6: None}
    got = uw.uncounted(record, owner_of=lambda r: owners)
    assert got == {("non-pedestrian", "no-peak", ""): 1,
                   ("unclassified", "too-short", "too fast"): 1}
    # track 3 (the no-peak one): 4 rows, one predicted, one without I(k)
    record["tracks"] = {"track_id": np.array([3, 3, 3, 3, 1]),
                        "state": np.array(["observe", "predict", "observe", "observe", "observe"]),
                        "intensity": np.array([1.0, 2.0, np.nan, 3.0, 1.0])}
    assert uw.no_peak_rows(record, owner_of=lambda r: owners) == [(4, 0.25, 0.25)]
