"""Rule 53 (`size.twice_pace_quantile`): rule 37's height is a quantile of the heights its rows
read (`track.twice.twice_height`), the median by default. A dog (0.6 m) whose moving region
merges, for 40 of its window's 64 rows, with a walker just behind it (its top read as the
walker's 1.7 m head): the median reads 1.7 m and rule 37 judges the window at half its peak; the
lower quartile reads 0.6 m and refuses it. Hand-worked quantiles, the tracker's look and the
batch classifier's look alike, and rule 46's test (`recheck.walker_tall`) with the same rows."""

import numpy as np
import pytest

from rhythmjax.model.camera_np import camera_tuple
from rhythmjax.model.params import Config
from rhythmjax.model.status import Reason, Verdict
from rhythmjax.track.options import SizeOptions
from rhythmjax.track.recheck import walker_tall
from rhythmjax.track.twice import batch_second_look, judge_at_half, rows_tall_enough, twice_height

from .test_twice_pace_batch import _object, _out, _rows


CFG = Config()
N = CFG.thresholds.n  # 64
MEDIAN = SizeOptions(twice_pace_heights=0.75, twice_pace_edge=False)  # 1.275 m for 1.7 m
QUARTILE = SizeOptions(twice_pace_heights=0.75, twice_pace_edge=False, twice_pace_quantile=0.25)


def merged_dog(merged: int = 40) -> dict:
    """A 0.6 m dog's rows going away from 22 m (every top row inside the image) whose top rows
    are, in `merged` of its first N rows (every other row first, then the rest), those of a
    1.7 m walker on the same foot points."""
    dog, walker = _object(0.6), _object(1.7)
    rows = np.r_[np.arange(0, N, 2), np.arange(1, N, 2)][:merged]
    dog["v_top"][rows] = walker["v_top"][rows]
    return dog


def window_heights(obj: dict, q: float) -> tuple[float, int]:
    return twice_height(camera_tuple(CFG.camera), obj["u"][:N], obj["v"][:N], obj["v_top"][:N],
                        None, 1.7, 0.0, q)


def test_the_quantiles_by_hand():
    """24 rows at 0.6 m, 40 at 1.7 m sorted: the median (index 31.5) and index 40 are 1.7 m, the
    lower quartile (index 15.75) 0.6 m, and index 23.5 halfway between them: 1.15 m."""
    dog = merged_dog()
    for q, want in ((0.5, 1.7), (40 / 63, 1.7), (0.25, 0.6), (23.5 / 63, 1.15), (0.0, 0.6)):
        height, n = window_heights(dog, q)
        assert n == N and height == pytest.approx(want, abs=1e-4), q


def test_the_median_judges_the_merged_dog_at_half_its_peak_the_quartile_does_not():
    """The window's outcome: 4.0 Hz at 1.4 m/s, refused by (14) and accepted at 2.0 Hz, 0.7 m.
    A whole walker (1.7 m in every row) is judged at half by both; a dog never merged by neither;
    the merged dog by the median only."""
    cases = ((_object(1.7), True, True), (_object(0.6), False, False),
             (merged_dog(), True, False))
    for obj, at_median, at_quartile in cases:
        rows = _rows(obj, 0, N)
        for options, want in ((MEDIAN, at_median), (QUARTILE, at_quartile)):
            out = judge_at_half(_out(), CFG, rows, CFG.camera, 1.7, options)
            assert (int(out["verdict"]) == Verdict.PEDESTRIAN) is want
            assert (int(out["reason"]) == Reason.MATCHED_TWICE) is want
            assert rows_tall_enough(rows, camera_tuple(CFG.camera), 1.7, options) is want
            assert walker_tall(CFG, rows, options) is want  # rule 46 reads the same height


@pytest.mark.parametrize("merged", [0, 16, 32, 33, 40, 47, 48, 64])
def test_the_batch_look_reads_the_same_quantile(merged):
    """The batch classifier's look on the merged dog's first window equals the tracker's
    (`judge_at_half` on the same rows), at the median and the quartile. The median needs 33
    merged rows of 64 (with 32 it lies halfway between 0.6 and 1.7 m: 1.15 m, under 1.275); the
    quartile needs 48 (its index 15.75 then lies between the last 0.6 m and the first 1.7 m:
    0.6 + 0.75 x 1.1 = 1.425 m; with 47, 0.6 m)."""
    dog = merged_dog(merged)
    res = {k: np.stack([v]) for k, v in _out().items()}
    batch = type("B", (), {"z": np.stack([np.stack([dog["u"], dog["v"]], -1)]),
                           "v_top": np.stack([dog["v_top"]])})()
    for options in (MEDIAN, QUARTILE):
        got = batch_second_look(CFG, batch, options)(res, np.zeros(1, int), np.zeros(1, int))
        want = judge_at_half(_out(), CFG, _rows(dog, 0, N), CFG.camera, 1.7, options)
        assert int(got["verdict"][0]) == int(want["verdict"])
        assert float(got["pace_hz"][0]) == pytest.approx(float(want["pace_hz"]), rel=1e-6)
    tall = {q: window_heights(dog, q)[0] >= 0.75 * 1.7 - 1e-9 for q in (0.5, 0.25)}
    assert tall == {0.5: merged >= 33, 0.25: merged >= 48}


@pytest.mark.parametrize("bad", [-0.1, 1.2, float("nan")])
def test_a_bad_quantile_names_the_option(bad):
    with pytest.raises(ValueError, match="size.twice_pace_quantile"):
        SizeOptions(twice_pace_quantile=bad)
