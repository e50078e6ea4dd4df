"""Rule 29 (`track.recheck`, on by default): a track judged Pedestrian is cut at its first
later window that is no walker's: faster than any walk (14) accepts or with a peak faster than
its fastest pace. Rules 30a (`recheck.tail`) and 30, 30b (`recheck.earlier`): the same test on
the window of the track's last N rows and on the windows before the deciding one. The window
test's cases, the cut rows on hand-made tracks (a walker, then a bicycle; a bicycle, then a
walker; a fast pace, then a walk; a walker throughout), the rows kept, and the tracker with the
rules on a lone walker. Rule 42 (`recheck.halves`): a window one of whose halves moves faster
than any walk (a walker and a bicycle in one window). Rule 43 (`recheck.low`): rule 26's height
test on the windows the recheck reads (a dog's rows before or after its walker's); rule 30d
(`recheck.earlier` "speed-low", the default): the windows before the verdict by speed or
height. Rule 44 (`recheck.halves_around`): rule 42's halves in the windows before and after the
deciding one only."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from rhythmjax.model.camera_np import project_3d, upright_size
from rhythmjax.model.params import (
    Camera,
    Config,
    walking_pace_band,
    walking_top_pace,
    walking_top_speed,
)
from rhythmjax.model.status import Reason, TrackState, Verdict
from rhythmjax.sim import scene as synth
from rhythmjax.track.options import RecheckOptions, SizeOptions, TrackerOptions, with_changes
from rhythmjax.track.recheck import (
    earlier_switch_row,
    keep_rows,
    low_window,
    mixed_window_row,
    not_a_walk,
    pace_resolved,
    split_at_switches,
    switch_row,
)
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.size import rows_height
from rhythmjax.track.toolkit import fast_half, half_speeds, match_window
from rhythmjax.track.tracker import OnlineTracker


CFG = Config()
FPS = 15.0


def test_the_walking_models_bounds_by_hand():
    """Table 1: pace 2.05 +- 0.183 Hz, stride 0.72 +- 0.09 m, k_sigma3 3: the fastest pace
    2.599 Hz, the fastest walk 2.599 x 0.99 = 2.573 m/s."""
    assert walking_top_pace(CFG) == pytest.approx(2.05 + 3 * 0.183, abs=1e-6)
    assert walking_pace_band(CFG) == pytest.approx((2.05 - 3 * 0.183, 2.05 + 3 * 0.183), abs=1e-6)
    assert walking_top_speed(CFG) == pytest.approx((2.05 + 3 * 0.183) * (0.72 + 3 * 0.09),
                                                   abs=1e-6)


@pytest.mark.parametrize("speed, pace, reason, refused", [
    (1.4, 2.0, Reason.MATCHED, False),          # a walk
    (2.6, 2.0, Reason.NO_MODEL_MATCH, True),    # faster than any walk (2.573 m/s)
    (2.5, 2.0, Reason.NO_MODEL_MATCH, False),
    (1.3, 4.2, Reason.NO_MODEL_MATCH, True),    # a trotting dog's pace (above 2.599 Hz)
    (1.3, 2.55, Reason.NO_MODEL_MATCH, False),
    (1.3, 4.2, Reason.NO_PEAK, False),          # no peak: its pace is no measurement
    (math.nan, math.nan, Reason.NO_PEAK, False),
])
def test_not_a_walk_cases(speed, pace, reason, refused):
    result = {"speed_mps": speed, "pace_hz": pace, "reason": int(reason)}
    assert not_a_walk(result, walking_top_speed(CFG), walking_top_pace(CFG)) is refused


def walk_rows(speeds_mps, seed=0, paces_hz=None):
    """A track's rows on the paper's 1 m camera: one row a frame, the object moving away along
    y from 8 m at speeds_mps[k] m/s in frame k, its I(k) a sine at paces_hz[k] Hz (default 2.0,
    a walker's pace) plus noise of 0.1, every row observed."""
    rng = np.random.default_rng(seed)
    t = np.arange(len(speeds_mps)) / FPS
    y = 8.0 + np.concatenate([[0.0], np.cumsum(np.asarray(speeds_mps)[1:] / FPS)])
    u, v = project_3d(CFG.camera, 0.5 + 0 * y, y, 0 * y)
    paces = np.full(t.size, 2.0) if paces_hz is None else np.asarray(paces_hz, float)
    phase = 2 * np.pi * np.concatenate([[0.0], np.cumsum(paces[1:] / FPS)])
    sig = 20.0 + 5.0 * np.sin(phase) + rng.normal(0, 0.1, t.size)
    rows = [TrackRow(k, float(t[k]), float(u[k]), float(v[k]), 20.0, float(sig[k]), 0.5,
                     float(y[k]), int(TrackState.OBSERVE)) for k in range(t.size)]
    return SimpleNamespace(rows=rows, win_start=0, windows_done=0, result=None, decided=False)


def judged_online(obj):
    """`obj` after the online windows: judged until one says Pedestrian."""
    while not obj.decided and len(obj.rows) >= obj.win_start + CFG.thresholds.n:
        match_window(CFG, obj)
    return obj


def test_a_bicycle_after_the_verdict_is_cut_off():
    """64 rows of a walk at 1.3 m/s (judged Pedestrian in window 0..64) then 96 rows at 4 m/s:
    the first later window (rows 64..128, hop N/2) moves at about 4 m/s and is refused, so the
    cut is at row 64; the same track walking throughout has no cut, and the object itself is
    left as it was."""
    obj = judged_online(walk_rows([1.3] * 64 + [4.0] * 96))
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN and obj.result["window"] == (0, 64)
    before = (obj.win_start, obj.windows_done, obj.result)
    assert switch_row(CFG, obj) == 64
    assert (obj.win_start, obj.windows_done, obj.result) == before
    walker = judged_online(walk_rows([1.3] * 160))
    assert int(walker.result["verdict"]) == Verdict.PEDESTRIAN
    assert switch_row(CFG, walker) is None


def test_no_cut_without_a_pedestrian_verdict_or_later_window():
    """A track judged Non-pedestrian (too fast from the start), and a walker too short for a
    window after its deciding one, are never cut."""
    fast = judged_online(walk_rows([4.0] * 160))
    assert int(fast.result["verdict"]) != Verdict.PEDESTRIAN and switch_row(CFG, fast) is None
    short = judged_online(walk_rows([1.3] * 100))
    assert int(short.result["verdict"]) == Verdict.PEDESTRIAN and switch_row(CFG, short) is None


def test_the_last_window_finds_a_switch_with_no_later_window():
    """64 rows of a walk (judged Pedestrian in 0..64), then 40 rows at 4 m/s: no later window
    fits (64 + N > 104 rows), so rule 29 alone cuts nothing; the window of the last N rows
    (40..104, 40 of its rows at 4 m/s, measured about 3.5 m/s) is refused, and the cut is at the
    deciding window's end (64), not at that window's first row (40). 30 rows at 4 m/s (the last
    window measured about 2.5 m/s, under 2.573) and a walk of 104 rows are not cut."""
    obj = judged_online(walk_rows([1.3] * 64 + [4.0] * 40))
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN and obj.result["window"] == (0, 64)
    assert switch_row(CFG, obj) is None
    assert switch_row(CFG, obj, tail=True) == 64
    assert switch_row(CFG, judged_online(walk_rows([1.3] * 64 + [4.0] * 30)), tail=True) is None
    assert switch_row(CFG, judged_online(walk_rows([1.3] * 104)), tail=True) is None


def test_an_earlier_window_finds_a_bicycle_before_the_walker():
    """64 rows at 4 m/s, then 96 of a walk: the online windows 0..64 (4 m/s) and 32..96 are
    Non-pedestrian, 64..128 says Pedestrian; the first is refused, so the cut is at the
    deciding window's first row, 64. A walk judged in its first window has no earlier one."""
    obj = judged_online(walk_rows([4.0] * 64 + [1.3] * 96))
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN
    assert obj.result["window"] == (64, 128)
    assert earlier_switch_row(CFG, obj) == 64
    walker = judged_online(walk_rows([1.3] * 160))
    assert walker.result["window"] == (0, 64) and earlier_switch_row(CFG, walker) is None


def test_the_speed_alone_leaves_a_fast_pace_before_the_verdict():
    """Rule 30b (`pace=False`): 64 rows at 1.3 m/s with a 3.2 Hz I(k) (a trotting dog's pace,
    above 2.599 Hz), then 96 rows of a 2 Hz walk: the first window is refused by its peak
    (rule 30 cuts at the deciding window's first row) but not by its speed (no cut); the
    bicycle before the walker above is cut either way."""
    obj = judged_online(walk_rows([1.3] * 160, paces_hz=[3.2] * 64 + [2.0] * 96))
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN
    first = int(obj.result["window"][0])
    assert first > 0 and earlier_switch_row(CFG, obj) == first
    assert earlier_switch_row(CFG, obj, pace=False) is None
    bicycle = judged_online(walk_rows([4.0] * 64 + [1.3] * 96))
    assert earlier_switch_row(CFG, bicycle, pace=False) == 64


def test_the_pace_test_needs_a_frame_rate_that_resolves_a_walkers_second_harmonic():
    """Rule 30c by hand: the fastest pace is 2.05 + 3 x 0.183 = 2.599 Hz, its second harmonic
    5.198 Hz, so Nyquist must exceed it: fps > 10.396. PETS09's 7 fps and 10 fps do not, 10.4
    and 15 fps do."""
    for fps, ok in ((7.0, False), (10.0, False), (10.39, False), (10.4, True), (15.0, True)):
        assert pace_resolved(Config(camera=Camera(fps=fps))) is ok


def test_resolved_cuts_a_fast_pace_before_the_verdict_only_at_a_resolving_frame_rate():
    """Rule 30c through `split_at_switches`: the 3.2 Hz window before a 2 Hz walk (above) is cut
    off where the config's frame rate resolves the pace (15 fps: rule 30's test), and not at
    7 fps (rule 30b's speed test alone); the bicycle before the walker is cut either way."""
    opt = with_changes(TrackerOptions(), {"recheck.earlier": "resolved"}).recheck
    slow = Config(camera=Camera(fps=7.0))
    calls = []
    judge = lambda o, rows: calls.append((rows.start, rows.stop))  # noqa: E731
    for cfg, cut in ((CFG, True), (slow, False)):
        calls.clear()
        obj = judged_online(walk_rows([1.3] * 160, paces_hz=[3.2] * 64 + [2.0] * 96))
        obj.vel = list(range(160))
        first = int(obj.result["window"][0])
        split_at_switches(cfg, obj, opt, judge)
        assert calls == ([(None, first)] if cut else [])
    calls.clear()
    bicycle = judged_online(walk_rows([4.0] * 64 + [1.3] * 96))
    bicycle.vel = list(range(160))
    split_at_switches(slow, bicycle, opt, judge)
    assert calls == [(None, 64)]


def test_a_bad_earlier_test_names_the_option():
    with pytest.raises(ValueError, match="recheck.earlier"):
        with_changes(TrackerOptions(), {"recheck.earlier": "yes"})


def test_keep_rows_shifts_the_deciding_window():
    """Rows 64.. of the track above kept: 96 rows, the first is the old row 64, the deciding
    window now rows 0..64, verdict unchanged; keeping rows that cut the window raises, naming
    the track."""
    obj = judged_online(walk_rows([4.0] * 64 + [1.3] * 96))
    obj.vel, obj.track_id = list(range(160)), 7
    old_rows, verdict = list(obj.rows), int(obj.result["verdict"])
    keep_rows(obj, slice(64, None))
    assert obj.rows == old_rows[64:] and obj.vel == list(range(64, 160))
    assert obj.result["window"] == (0, 64) and int(obj.result["verdict"]) == verdict
    with pytest.raises(ValueError, match="track 7"):
        keep_rows(obj, slice(None, 50))


def test_half_speeds_are_each_halfs_own_speed():
    """A constant speed per half comes back as that speed (the foot points taken to the ground
    through (3) and back, float32: within 2 mm/s); a half of one row has no speed."""
    first, last = half_speeds(CFG, walk_rows([1.3] * 32 + [4.0] * 32).rows)
    assert first == pytest.approx(1.3, abs=2e-3) and last == pytest.approx(4.0, abs=2e-3)
    first, last = half_speeds(CFG, walk_rows([1.3] * 3).rows)
    assert math.isnan(first) and last == pytest.approx(1.3, abs=2e-3)


def test_fast_half_reads_each_half_against_the_fastest_walk():
    """Rule 42 on 64 rows: the half at 4 m/s is found (its first row, 0 or 32); a walk is not;
    a half at 2.5 m/s lies under the fastest walk (2.573 m/s), one at 2.65 over it (the
    Theil-Sen speed of a constant speed is that speed)."""
    top = walking_top_speed(CFG)
    assert fast_half(CFG, walk_rows([1.3] * 32 + [4.0] * 32).rows, top) == 32
    assert fast_half(CFG, walk_rows([4.0] * 32 + [1.3] * 32).rows, top) == 0
    assert fast_half(CFG, walk_rows([1.3] * 64).rows, top) is None
    assert fast_half(CFG, walk_rows([1.3] * 32 + [2.5] * 32).rows, top) is None
    assert fast_half(CFG, walk_rows([1.3] * 32 + [2.65] * 32).rows, top) == 32


def test_a_walker_and_a_bicycle_in_the_deciding_window():
    """40 rows of a walk at 1.3 m/s then 24 at 4 m/s: the one window (0..64) says Pedestrian at
    the Theil-Sen speed of about 1.95 m/s (the median slope is the walker's), and rule 29 has no
    later window; its second half (8 rows of walk, 24 at 4 m/s) is no walk, so rule 42 finds
    row 32. The bicycle first (24 rows, then 40 of walk): row 0. A walk: none."""
    obj = judged_online(walk_rows([1.3] * 40 + [4.0] * 24))
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN and obj.result["window"] == (0, 64)
    assert float(obj.result["speed_mps"]) < walking_top_speed(CFG)
    assert switch_row(CFG, obj, tail=True) is None and mixed_window_row(CFG, obj) == 32
    assert mixed_window_row(CFG, judged_online(walk_rows([4.0] * 24 + [1.3] * 40))) == 0
    assert mixed_window_row(CFG, judged_online(walk_rows([1.3] * 64))) is None


def test_a_later_window_cut_at_its_fast_half():
    """104 rows of walk then 24 at 4 m/s (judged in 0..64): the later window 64..128 moves at
    about 1.95 m/s, so rule 29 keeps the track whole; with halves its second half (96..128)
    is no walk and the cut is at row 96."""
    obj = judged_online(walk_rows([1.3] * 104 + [4.0] * 24))
    assert obj.result["window"] == (0, 64)
    assert switch_row(CFG, obj) is None and switch_row(CFG, obj, halves=True) == 96


def test_split_at_switches_cuts_a_mixed_window_at_its_middle():
    """Rule 42 on the walker-then-bicycle window above: the track is cut at row 32, the rows
    32.. (the fast half's side) judged afresh, the track keeping rows ..31 and its verdict with
    the slow half (0..32) as its deciding window; the bicycle first: rows ..31 afresh, the track
    keeps rows 32.. (the first kept row is the old row 32) and the window (0..32); with halves
    off nothing is cut (rules 29 and 30a find no later window); on the later-window case the
    rows 96.. go to a new track and the track keeps rows ..95."""
    calls = []
    judge = lambda obj, rows: calls.append((rows.start, rows.stop))  # noqa: E731
    on, off = (with_changes(TrackerOptions(), {"recheck.halves": h}).recheck
               for h in (True, False))

    def judged(speeds):
        obj = judged_online(walk_rows(speeds))
        obj.vel = list(range(len(obj.rows)))
        return obj

    mixed = judged([1.3] * 40 + [4.0] * 24)
    split_at_switches(CFG, mixed, off, judge)
    assert calls == [] and len(mixed.rows) == 64 and mixed.result["window"] == (0, 64)
    split_at_switches(CFG, mixed, on, judge)
    assert calls == [(32, None)] and mixed.vel == list(range(32))
    assert mixed.result["window"] == (0, 32)
    assert int(mixed.result["verdict"]) == Verdict.PEDESTRIAN
    calls.clear()
    first = judged([4.0] * 24 + [1.3] * 40)
    split_at_switches(CFG, first, on, judge)
    assert calls == [(None, 32)] and first.vel == list(range(32, 64))
    assert first.result["window"] == (0, 32)
    calls.clear()
    later = judged([1.3] * 104 + [4.0] * 24)
    split_at_switches(CFG, later, on, judge)
    assert calls == [(96, None)] and len(later.rows) == 96 and later.result["window"] == (0, 64)


def with_height(obj, rows: slice, height_m: float):
    """`obj` with the top row v_top of its `rows` that of an upright object `height_m` m tall on
    each foot point (`camera_np.upright_size`); NaN where that top would leave the image (a
    walker's head above the view: its row is not read)."""
    for k in range(len(obj.rows))[rows]:
        r = obj.rows[k]
        _, h_px, _ = upright_size(CFG.camera, r.u, r.v, 1.0, height_m)
        top = r.v - float(h_px)
        obj.rows[k] = r._replace(v_top=top if top >= 0 else math.nan)
    return obj


SIZE = SizeOptions()  # rule 26: 0.5 walker heights (0.85 m of 1.7 m) over >= 10 rows


def test_low_window_is_rule_26s_test_on_the_rows_by_hand():
    """Rule 43's window test is rule 26's: rows of an object 0.80 m tall read below 0.5 x 1.7 =
    0.85 m and are refused, 0.90 m not; 9 readable rows (fewer than 10) are never refused; no
    size options, or rule 26 off (0), never refuse. The heights are read back to 1e-3 m."""
    obj = with_height(walk_rows([1.3] * 64), slice(None), 0.80)
    assert low_window(CFG, obj.rows, SIZE)
    assert not low_window(CFG, with_height(walk_rows([1.3] * 64), slice(None), 0.90).rows, SIZE)
    assert not low_window(CFG, obj.rows[:9], SIZE) and low_window(CFG, obj.rows[:10], SIZE)
    assert not low_window(CFG, obj.rows, None)
    assert not low_window(CFG, obj.rows, SizeOptions(min_height_heights=0.0))
    height, n = rows_height(CFG.camera, obj.rows, 1.7, SIZE.top_inside_heights)
    assert height == pytest.approx(0.80, abs=1e-3) and n == 64


def test_a_dogs_rows_before_the_walkers_verdict_are_cut_by_their_height():
    """64 rows of an object 0.6 m tall whose I(k) beats at 3.2 Hz (a trotting dog), then 96 of
    a 2 Hz walk whose head leaves the view (its rows unread): the deciding window is 32..96
    (half of it the walk's), after the dog's window 0..64. Rule 43 alone (`earlier` off: neither
    speed nor pace read) cuts at 32 by the first window's height; the same rows 1.2 m tall are
    not cut; rule 30b's speed test alone does not cut the dog (1.3 m/s), rule 30's pace test
    does (3.2 Hz), and neither reads with `speed` False."""
    paces = [3.2] * 64 + [2.0] * 96
    dog = with_height(walk_rows([1.3] * 160, paces_hz=paces), slice(0, 64), 0.6)
    dog = judged_online(dog)
    assert int(dog.result["verdict"]) == Verdict.PEDESTRIAN
    assert dog.result["window"] == (32, 96)
    assert earlier_switch_row(CFG, dog, speed=False, pace=False, low=SIZE) == 32
    assert earlier_switch_row(CFG, dog, speed=False, pace=False) is None
    assert earlier_switch_row(CFG, dog, pace=False) is None
    assert earlier_switch_row(CFG, dog, speed=False) is None  # speed False: the pace unread too
    assert earlier_switch_row(CFG, dog) == 32  # rule 30 refuses its 3.2 Hz
    tall = judged_online(with_height(walk_rows([1.3] * 160, paces_hz=paces), slice(0, 64), 1.2))
    assert earlier_switch_row(CFG, tall, speed=False, pace=False, low=SIZE) is None


def test_a_dog_after_the_verdict_at_a_walkers_pace_is_cut_by_its_height():
    """64 rows of a walk (judged Pedestrian in 0..64), then 96 rows of an object 0.6 m tall at
    the same 1.3 m/s and 2 Hz (a dog read at its aliased leg cycle): rule 29 finds no later
    window that is no walk; rule 43 cuts at 64; the tail window of a shorter track (64 + 40
    rows, 40 of them the dog's) is refused by height as well."""
    obj = judged_online(with_height(walk_rows([1.3] * 160), slice(64, None), 0.6))
    assert obj.result["window"] == (0, 64)
    assert switch_row(CFG, obj) is None
    assert switch_row(CFG, obj, low=SIZE) == 64
    short = judged_online(with_height(walk_rows([1.3] * 104), slice(64, None), 0.6))
    assert switch_row(CFG, short, tail=True) is None
    assert switch_row(CFG, short, tail=True, low=SIZE) == 64


def test_split_at_switches_reads_heights_only_with_the_rule_on():
    """`split_at_switches` with rule 43 alone (`low`, `earlier` off) and rule 26's options makes
    a new track of the rows before the deciding window (0..32, the dog's), the track keeping
    32..160 with its window shifted to 0..64; with the rules off, or without size options,
    nothing is cut."""
    def fresh():
        paces = [3.2] * 64 + [2.0] * 96
        return judged_online(with_height(walk_rows([1.3] * 160, paces_hz=paces), slice(0, 64), 0.6))

    calls = []

    def judge(o, rows):
        calls.append((rows.start, rows.stop))

    off = RecheckOptions(earlier="off")  # rule 30d (the default "speed-low") reads heights too
    for opt, size in ((off, SIZE), (RecheckOptions(earlier="off", low=True), None)):
        obj = fresh()
        obj.vel = list(range(len(obj.rows)))
        split_at_switches(CFG, obj, opt, judge, size)
        assert calls == [] and len(obj.rows) == 160
    obj = fresh()
    obj.vel = list(range(len(obj.rows)))
    split_at_switches(CFG, obj, RecheckOptions(earlier="off", low=True), judge, SIZE)
    assert calls == [(None, 32)] and obj.vel == list(range(32, 160))
    assert obj.result["window"] == (0, 64)


def test_speed_low_reads_speed_and_height_before_the_verdict_only():
    """Rule 30d (`earlier` "speed-low"): the dog's rows before the walker's verdict (0.6 m,
    3.2 Hz, 1.3 m/s) are cut by their height (at 32), a bicycle's before it (4 m/s) by their
    speed (at 64); a dog after the verdict (0.6 m at a walker's pace and speed) is left on the
    track, the later windows being rule 29's alone; without size options the dog before is
    left too (its pace is not read)."""
    calls = []

    def judge(o, rows):
        calls.append((rows.start, rows.stop))

    opt = RecheckOptions(earlier="speed-low")
    dog_first = [3.2] * 64 + [2.0] * 96
    cases = (
        (lambda: with_height(walk_rows([1.3] * 160, paces_hz=dog_first), slice(0, 64), 0.6),
         SIZE, [(None, 32)]),
        (lambda: walk_rows([4.0] * 64 + [1.3] * 96), SIZE, [(None, 64)]),
        (lambda: with_height(walk_rows([1.3] * 160), slice(64, None), 0.6), SIZE, []),
        (lambda: with_height(walk_rows([1.3] * 160, paces_hz=dog_first), slice(0, 64), 0.6),
         None, []),
    )
    for make, size, cut in cases:
        obj = judged_online(make())
        assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN
        obj.vel = list(range(len(obj.rows)))
        calls.clear()
        split_at_switches(CFG, obj, opt, judge, size)
        assert calls == cut


@pytest.mark.parametrize("changes", [{}, {"recheck.earlier": "any"}, {"recheck.halves": True},
                                     {"recheck.low": True}, {"recheck.pace_tall": True},
                                     {"recheck.fast_stretch": 0.25}])
def test_the_tracker_with_the_rule_leaves_a_lone_walker_alone(changes):
    """One rendered walker going away from 8 m, 180 frames: its track (156 rows, judged
    Pedestrian in rows 0..64) has a later window (rows 64..128), and
    the tracks and verdicts are the same with the rules on as off: the tracker splits nothing."""
    act = synth.walker(-0.5, 8.0, math.pi / 2, pace_hz=1.9, step_length_m=0.62)
    scene = synth.render_scene(5, synth.SceneSpec(n_frames=180, actors=(act,),
                                                  camera=CFG.camera))
    out = []
    for options in (with_changes(TrackerOptions(), {"recheck.enabled": False}),
                    with_changes(TrackerOptions(), changes)):
        tr = OnlineTracker(CFG, options)
        for i, f in enumerate(scene.frames):
            tr.update(i, i / FPS, f)
        out.append((tr.finish()[:2], tr.switches))
    ((tracks_off, off), _), ((tracks_on, on), splits) = out
    assert "pedestrian" in list(off["verdict"]) and splits == 0
    first = off["track_id"][list(off["verdict"]).index("pedestrian")]
    assert np.sum(tracks_off["track_id"] == first) >= 64 + CFG.thresholds.n  # a later window
    assert list(on["verdict"]) == list(off["verdict"])
    np.testing.assert_array_equal(tracks_on["track_id"], tracks_off["track_id"])


def test_rule_44_reads_halves_around_the_deciding_window_only():
    """Rule 44 (`recheck.halves_around`). Before: 36 rows at 3.1 m/s (a pace of 1.0 Hz) then a
    walk; the deciding window is rows 32..96 and the one before it (0..64) measures 2.41 m/s
    whole (under 2.573: rule 30d keeps it), its first half 3.10: cut at row 32. After: 100 rows
    of a walk then 30 at 3.1 m/s; the later window 64..128 is under the bound whole, its second
    half (96..128) is not: cut at row 96. The deciding window itself is never read by halves: 40
    rows of a walk then 24 at 3.1 m/s (one window, its second half fast) keeps its rows, which
    rule 42 cuts at the middle."""
    cuts = []

    def judge(o, rows):
        cuts.append((rows.start, rows.stop))

    def run(speeds, paces, opt):
        obj = judged_online(walk_rows(speeds, paces_hz=paces))
        obj.vel = list(range(len(obj.rows)))
        cuts.clear()
        split_at_switches(CFG, obj, opt, judge)
        return obj, list(cuts)

    on, off = RecheckOptions(halves_around=True), RecheckOptions()
    before = ([3.1] * 36 + [1.3] * 120, [1.0] * 36 + [2.0] * 120)
    obj, _ = run(*before, off)
    assert obj.result["window"] == (32, 96) and earlier_switch_row(CFG, obj, pace=False) is None
    assert run(*before, off)[1] == []
    obj, got = run(*before, on)
    assert got == [(None, 32)] and len(obj.rows) == 124 and obj.result["window"] == (0, 64)
    alone = RecheckOptions(halves_around=True, earlier="off")  # without rule 30d's tests too
    assert run(*before, alone)[1] == [(None, 32)]
    after = ([1.3] * 100 + [3.1] * 30, None)
    assert run(*after, off)[1] == []
    obj, got = run(*after, on)
    assert got == [(96, None)] and len(obj.rows) == 96
    inside = ([1.3] * 40 + [3.1] * 24, None)
    obj, got = run(*inside, on)
    assert got == [] and len(obj.rows) == 64 and obj.result["window"] == (0, 64)
    assert run(*inside, RecheckOptions(halves=True))[1] == [(32, None)]
