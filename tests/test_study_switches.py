"""benchmarks/study_switches.py: which non-walkers judged Pedestrian by track had their
deciding window on something else (hand-made cases)."""

from __future__ import annotations

import os
import sys
from types import SimpleNamespace


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_switches as ss  # noqa: E402


def test_switched_lists_only_pedestrian_tracks_given_to_non_walkers():
    walker, bike, dog = (SimpleNamespace(kind=k) for k in ("pedestrian", "bicycle", "dog"))
    by_track = {1: walker, 2: bike, 3: dog, 4: bike, 5: dog}
    by_window = {1: walker, 2: walker, 3: dog, 4: walker}  # 5 followed no one in its window
    verdicts = {"track_id": [1, 2, 3, 4, 5, 6],
                "verdict": ["pedestrian", "pedestrian", "pedestrian", "non-pedestrian",
                            "pedestrian", "pedestrian"]}  # 6: given to no object
    assert ss.switched(by_track, by_window, verdicts) == [
        (2, "bicycle", "pedestrian"), (3, "dog", "dog"), (5, "dog", "none")]
