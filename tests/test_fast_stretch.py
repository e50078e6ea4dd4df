"""Rule 52 (`track.recheck.fast_stretch_row`, `RecheckOptions.fast_stretch`): after a Pedestrian
track's deciding window, stretches of N/4 rows (one every N/8 rows, and the track's last N/4)
are read by the filter's ground speed (the median of |(vx, vy)| over the stretch); the first
above the fastest walk (14) accepts cuts the track at its first row. The stretches' first rows
and the median speed by hand, the cut row on hand-made tracks (a walker whose last rows a
bicycle took over; a walker throughout; a stretch just under and just over 2.573 m/s), against
a brute-force reference over random velocity sequences, and `split_at_switches` with the rule
on and off (rules 29 and 30a alone leave such a tail on the walker)."""

import math

import numpy as np
import pytest

from rhythmjax.model.params import Config, walking_top_speed
from rhythmjax.model.status import Verdict
from rhythmjax.track.options import RecheckOptions
from rhythmjax.track.recheck import (
    fast_stretch_row,
    split_at_switches,
    stretch_speed,
    stretch_starts,
    switch_row,
)
from rhythmjax.track.rows import NAN_VELOCITY, Velocity

from .test_recheck import judged_online, walk_rows


CFG = Config()
TOP = walking_top_speed(CFG)  # 2.573 m/s (Table 1 at +3 sigma)


@pytest.mark.parametrize("start, end, m, starts", [
    (64, 100, 16, [64, 72, 80, 84]),  # one every 8 rows, then the last 16 (84..99)
    (64, 96, 16, [64, 72, 80]),       # the last 16 rows already a stretch
    (64, 80, 16, [64]),
    (64, 79, 16, []),                 # fewer than 16 rows after the window
    (0, 5, 2, [0, 1, 2, 3]),          # m // 2 = 1
])
def test_stretch_starts_by_hand(start, end, m, starts):
    assert stretch_starts(start, end, m) == starts


def test_stretch_speed_is_the_median_filter_speed_by_hand():
    """Speeds 5 (3, 4), 1, NaN (left out), 2 -> the median of {5, 1, 2} is 2 m/s; a stretch with
    no finite velocity is NaN; only rows start..start+m-1 are read."""
    obj = walk_rows([1.0] * 5)
    obj.vel = [Velocity(3.0, 4.0), Velocity(0.0, -1.0), NAN_VELOCITY, Velocity(2.0, 0.0),
               Velocity(30.0, 0.0)]
    assert stretch_speed(obj, 0, 4) == pytest.approx(2.0, abs=1e-12)
    assert stretch_speed(obj, 1, 2) == pytest.approx(1.0, abs=1e-12)
    assert math.isnan(stretch_speed(obj, 2, 1))


def with_velocity(obj, speeds):
    """`obj` (a `walk_rows` track, judged) given the filter velocity (0, speeds[k]) m/s at row
    k: the object moves along y."""
    obj.vel = [Velocity(0.0, float(s)) for s in speeds]
    return obj


def test_a_bicycle_taking_over_the_last_rows_is_cut_at_its_first_full_stretch():
    """Walker rows (1.4 m/s) 0..79, bicycle rows (3.1 m/s) 80..99; judged Pedestrian in 0..64.
    Stretches 64..80 (1.4), 72..88 (8 rows of each: median 2.25) and 80..96 (3.1 > 2.573): cut
    at row 80. Off (0), a walker throughout and a Non-pedestrian track: no cut."""
    speeds = [1.4] * 80 + [3.1] * 20
    obj = with_velocity(judged_online(walk_rows([1.4] * 100)), speeds)
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN and obj.result["window"] == (0, 64)
    assert fast_stretch_row(CFG, obj, 0.25) == 80
    assert fast_stretch_row(CFG, obj, 0.0) is None
    walker = with_velocity(judged_online(walk_rows([1.4] * 100)), [1.4] * 100)
    assert fast_stretch_row(CFG, walker, 0.25) is None
    fast = with_velocity(judged_online(walk_rows([4.0] * 100)), [4.0] * 100)
    assert int(fast.result["verdict"]) != Verdict.PEDESTRIAN
    assert fast_stretch_row(CFG, fast, 0.25) is None


@pytest.mark.parametrize("tail, cut", [(TOP - 0.01, None), (TOP + 0.01, 80)])
def test_the_bound_is_the_fastest_walk(tail, cut):
    """The last 16 of 100 rows at just under / just over the fastest walk: the stretch 80..95
    holds 12 of them, so its median is theirs (72..87 holds 4)."""
    obj = with_velocity(judged_online(walk_rows([1.4] * 100)), [1.4] * 84 + [tail] * 16)
    assert fast_stretch_row(CFG, obj, 0.25) == cut


def reference_row(speeds, k1, m, top):
    """Brute force: every start s in k1..len-m, kept where s - k1 is a multiple of m // 2 or s
    is the last start; the first whose rows' median speed (NaN left out) exceeds `top`."""
    n = len(speeds)
    for s in range(k1, n - m + 1):
        if (s - k1) % (m // 2) and s != n - m:
            continue
        part = np.asarray(speeds[s:s + m], float)
        part = part[np.isfinite(part)]
        if part.size and np.median(part) > top:
            return s
    return None


@pytest.mark.parametrize("seed", range(20))
def test_against_a_brute_force_reference(seed):
    """Random filter speeds (a walk at 0.5-2.5 m/s with bursts at 2-4 m/s and NaN rows) over a
    judged track of 64-140 rows, stretch fractions 0.125-0.5: the same cut row."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(64, 141))
    speeds = rng.uniform(0.5, 2.5, n)
    for _ in range(int(rng.integers(0, 3))):
        a = int(rng.integers(0, n))
        speeds[a:a + int(rng.integers(4, 30))] = rng.uniform(2.0, 4.0)
    speeds[rng.random(n) < 0.1] = np.nan
    obj = judged_online(walk_rows([1.4] * n))
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN
    obj.vel = [Velocity(0.0, float(s)) if np.isfinite(s) else NAN_VELOCITY for s in speeds]
    fraction = float(rng.choice([0.125, 0.25, 0.5]))
    m = round(fraction * CFG.thresholds.n)
    k1 = int(obj.result["window"][1])
    assert fast_stretch_row(CFG, obj, fraction) == reference_row(speeds, k1, m, TOP)


def test_split_at_switches_cuts_the_tail_only_with_the_rule():
    """A walk at 1.3 m/s for 144 rows, then 20 rows at 3.1 m/s (foot points and filter alike):
    rule 29 and 30a's tail window (rows 100..163, 44 walker rows) keep its Theil-Sen speed under
    the fastest walk, so without rule 52 nothing is cut; with it the rows from 144 are a new
    track and the walker keeps rows 0..143 and its verdict."""
    speeds = [1.3] * 144 + [3.1] * 20
    calls = []

    def judge(obj, rows):
        calls.append((rows.start, rows.stop))

    for fraction, cut in ((0.0, []), (0.25, [(144, None)])):
        obj = with_velocity(judged_online(walk_rows(speeds)), speeds)
        assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN
        calls.clear()
        split_at_switches(CFG, obj, RecheckOptions(fast_stretch=fraction), judge)
        assert calls == cut
        assert len(obj.rows) == (164 if not cut else 144) == len(obj.vel)
        assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN


@pytest.mark.parametrize("bad", [-0.1, 1.5])
def test_a_bad_fraction_names_the_option(bad):
    with pytest.raises(ValueError, match="recheck.fast_stretch"):
        RecheckOptions(fast_stretch=bad)


def test_the_earlier_of_a_refused_window_and_a_fast_stretch_cuts():
    """Foot points at 1.3 m/s for 100 rows, then 4.0 m/s: rule 29 refuses a later window and
    cuts at its first row (after row 72). The filter's speed 3.1 m/s from row 72 on: rule 52's
    stretch 72..88 cuts earlier, and the earlier cut is the one made; without rule 52 the later
    one."""
    feet = [1.3] * 100 + [4.0] * 100
    filt = [1.3] * 72 + [3.1] * 128
    later = switch_row(CFG, with_velocity(judged_online(walk_rows(feet)), filt), tail=True)
    assert later is not None and later > 72
    calls = []
    for fraction, cut in ((0.0, later), (0.25, 72)):
        calls.clear()
        obj = with_velocity(judged_online(walk_rows(feet)), filt)
        split_at_switches(CFG, obj, RecheckOptions(fast_stretch=fraction),
                          lambda o, rows: calls.append(rows.start))
        assert calls == [cut] and len(obj.rows) == cut
