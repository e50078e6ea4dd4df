"""`benchmarks/study_mean_refused.py`: which deciding windows rule 35b's per-pixel rows decided.
Hand-made windows (`test_mean_refused`'s): the sum noise and the mean a walker's sine (the mean
decided: the sum's own outcome, not Pedestrian, is returned); the sum a walker's sine (the sum
decided: None); no Pedestrian verdict (None). The object itself is left as it was."""

from __future__ import annotations

import os
import sys

from rhythmjax.model.status import Verdict

from .test_mean_refused import CFG, _judged, _noise, _sine


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_mean_refused as smr  # noqa: E402


def test_sum_outcome_names_the_windows_the_mean_decided():
    by_mean = _judged(_noise(1), _sine(2.0, 2))
    before = (by_mean.result, by_mean.win_start, by_mean.windows_done, by_mean.mean_rows)
    summed = smr.sum_outcome(CFG, by_mean)
    assert summed is not None and int(summed["verdict"]) != Verdict.PEDESTRIAN
    assert int(summed["verdict"]) == int(_judged(_noise(1)).result["verdict"])
    assert (by_mean.result, by_mean.win_start, by_mean.windows_done, by_mean.mean_rows) == before
    assert smr.sum_outcome(CFG, _judged(_sine(2.0, 3), _sine(2.2, 4))) is None
    assert smr.sum_outcome(CFG, _judged(_noise(5), _sine(4.2, 6))) is None
    assert "halves" in smr.describe(CFG, by_mean, summed)
