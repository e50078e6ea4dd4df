"""Rule 46 (`recheck.pace_tall`, on by default): a later or tail window that rule 29's pace
test alone refuses is kept where its rows are as tall as a walker by rule 37's height test
(`recheck.walker_tall`). Hand-made tracks on the paper's camera (`test_recheck`'s helpers): a
walker judged Pedestrian, then read at three times its pace; the same rows as tall as a dog; a
bicycle's speed; unreadable heights; rows at the image's edge; the two halves of `not_a_walk`;
the height test by hand."""

import math

import numpy as np
import pytest

from rhythmjax.model.camera_np import camera_tuple, height_of_top
from rhythmjax.model.params import Config, walking_top_pace, walking_top_speed
from rhythmjax.model.status import Reason, Verdict
from rhythmjax.track.options import RecheckOptions, SizeOptions
from rhythmjax.track.recheck import (
    not_a_walk,
    split_at_switches,
    switch_row,
    too_fast,
    too_quick,
    walker_tall,
)

from .test_recheck import judged_online, walk_rows, with_height


CFG = Config()
SIZE = SizeOptions()  # rule 37: 0.57 walker heights (0.969 m of 1.7 m) over >= 10 rows
THRICE = [2.0] * 64 + [5.4] * 96  # a walk, then the window's strongest peak at three times it


@pytest.mark.parametrize("speed, pace, reason, fast, quick", [
    (1.4, 2.0, Reason.MATCHED, False, False),
    (2.6, 2.0, Reason.NO_MODEL_MATCH, True, False),     # above 2.573 m/s
    (1.3, 5.4, Reason.NO_MODEL_MATCH, False, True),     # above 2.599 Hz
    (2.6, 5.4, Reason.NO_MODEL_MATCH, True, True),
    (1.3, 5.4, Reason.NO_PEAK, False, False),           # no peak: no pace
    (math.nan, math.nan, Reason.NO_PEAK, False, False),
])
def test_the_two_tests_of_not_a_walk(speed, pace, reason, fast, quick):
    result = {"speed_mps": speed, "pace_hz": pace, "reason": int(reason)}
    top_speed, top_pace = walking_top_speed(CFG), walking_top_pace(CFG)
    assert too_fast(result, top_speed) is fast and too_quick(result, top_pace) is quick
    assert not_a_walk(result, top_speed, top_pace) is (fast or quick)


def test_walker_tall_is_rule_37s_height_test_by_hand():
    """0.57 x 1.7 = 0.969 m over at least 10 rows: 1.00 m is a walker's height, 0.95 m is not;
    9 readable rows never are; no size options, or rule 37 off (0), never."""
    tall = with_height(walk_rows([1.3] * 64), slice(None), 1.00).rows
    assert walker_tall(CFG, tall, SIZE)
    assert not walker_tall(CFG, with_height(walk_rows([1.3] * 64), slice(None), 0.95).rows, SIZE)
    assert not walker_tall(CFG, tall[:9], SIZE) and walker_tall(CFG, tall[:10], SIZE)
    assert not walker_tall(CFG, tall, None)
    assert not walker_tall(CFG, tall, SizeOptions(twice_pace_heights=0.0))


def test_a_walker_read_at_three_times_its_pace_is_kept_only_when_tall():
    """64 rows of a walk (Pedestrian in 0..64), then 96 rows at 5.4 Hz at the same 1.3 m/s: the
    later window 64..128 peaks above the fastest pace and rule 29 cuts at 64. With rule 46 the
    rows 1.6 m tall keep it (no cut); 0.6 m tall (a dog) or unreadable (no top row), the cut
    stays."""
    walker = judged_online(with_height(walk_rows([1.3] * 160, paces_hz=THRICE), slice(None), 1.6))
    assert int(walker.result["verdict"]) == Verdict.PEDESTRIAN
    assert walker.result["window"] == (0, 64)
    assert switch_row(CFG, walker) == 64
    assert switch_row(CFG, walker, tall=SIZE) is None
    dog = judged_online(with_height(walk_rows([1.3] * 160, paces_hz=THRICE), slice(64, None), 0.6))
    assert switch_row(CFG, dog, tall=SIZE) == 64
    unread = judged_online(walk_rows([1.3] * 160, paces_hz=THRICE))
    assert switch_row(CFG, unread, tall=SIZE) == 64


def test_the_speed_test_is_left_as_it_was():
    """A walk, then 96 rows at 4 m/s as tall as a walker: the speed test cuts at 64 with the
    rule as without it."""
    bike = judged_online(with_height(walk_rows([1.3] * 64 + [4.0] * 96), slice(None), 1.6))
    assert switch_row(CFG, bike) == 64 and switch_row(CFG, bike, tall=SIZE) == 64


def test_the_tail_window_is_read_the_same_way():
    """64 rows of a walk then 40 at 5.4 Hz: no later window fits, the tail window 40..104 is
    refused by its pace and cut at 64; rule 46 keeps it where the rows are 1.6 m tall."""
    rows = walk_rows([1.3] * 104, paces_hz=THRICE[:104])
    obj = judged_online(with_height(rows, slice(None), 1.6))
    assert switch_row(CFG, obj, tail=True) == 64
    assert switch_row(CFG, obj, tail=True, tall=SIZE) is None


def test_split_at_switches_reads_the_option():
    """`split_at_switches` cuts the tall walker's later rows into a new track with rule 46
    off, and leaves the track whole with it on (the default; without size options it cuts
    again)."""
    calls = []

    def judge(o, rows):
        calls.append((rows.start, rows.stop))

    for opt, size, cut in ((RecheckOptions(pace_tall=False), SIZE, [(64, None)]),
                           (RecheckOptions(pace_tall=True), SIZE, []),
                           (RecheckOptions(pace_tall=True), None, [(64, None)])):
        obj = judged_online(with_height(walk_rows([1.3] * 160, paces_hz=THRICE), slice(None), 1.6))
        obj.vel = list(range(len(obj.rows)))
        calls.clear()
        split_at_switches(CFG, obj, opt, judge, size)
        assert calls == cut
        assert len(obj.rows) == (64 if cut else 160)


def test_rows_at_the_images_edge_count_as_lower_bounds():
    """Rows whose moving region reached the image's first row (no top row, `top_at_edge`) are
    read at the height up to that row (rule 37b, `size.twice_pace_edge`): at 8-13 m from the
    paper's camera that bound is above 0.969 m, so the rows are a walker's height; with rule 37b
    off no row is read and they are not."""
    rows = [r._replace(v_top=math.nan, top_at_edge=True) for r in walk_rows([1.3] * 64).rows]
    bound, ok = height_of_top(camera_tuple(CFG.camera), np.array([r.u for r in rows]),
                              np.array([r.v for r in rows]), np.zeros(len(rows)))
    assert np.all(ok) and np.min(bound) > 0.57 * 1.7
    assert walker_tall(CFG, rows, SIZE)
    assert not walker_tall(CFG, rows, SizeOptions(twice_pace_edge=False))
