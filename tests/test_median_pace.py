"""Rule 47 (`recheck.median_pace`, off by default; in place of rule 55 where on): a Pedestrian
track's pace F and stride T are the medians over its windows judged Pedestrian (the deciding one and
the later ones), its verdict the deciding window's. Hand-made tracks on the paper's camera
(`test_recheck`'s helpers: I(k) a sine at a set pace, the object moving at a set speed): the medians
by hand over odd and even window counts, windows not judged Pedestrian left out, the option off, a
track not judged Pedestrian, and the tracker on a rendered lone walker."""

import math

import numpy as np
import pytest

from rhythmjax.model.params import Config
from rhythmjax.model.status import Verdict
from rhythmjax.sim import scene as synth
from rhythmjax.track.options import RecheckOptions, TrackerOptions, with_changes
from rhythmjax.track.recheck import later_windows, median_pace
from rhythmjax.track.tracker import OnlineTracker

from .test_recheck import FPS, judged_online, walk_rows


CFG = Config()
ON = RecheckOptions(median_pace=True)
SPEED = 1.3  # m/s
# MEM's peak on a 64-sample sine at 15 fps, noise 0.1 of amplitude 5: within 0.03 Hz of its
# frequency (measured 0.000-0.012 Hz on these tracks); a pace error of 0.03 Hz moves T =
# 1.3 / F by under 0.012 m at 1.7-2.0 Hz
PACE_TOL, STRIDE_TOL = 0.03, 0.012


def later_paces(obj) -> list[float]:
    return [float(r["pace_hz"]) for r in later_windows(CFG, obj, tail=True)
            if int(r["verdict"]) == Verdict.PEDESTRIAN]


def test_three_later_windows_at_another_pace_give_the_median():
    """64 rows at 2.0 Hz (the deciding window 0..64), then 128 at 1.7 Hz: the later windows
    64..128, 96..160 and 128..192 (hop N/2) read 1.7 Hz, at least two of them judged
    Pedestrian (this noise: the first and the last), so the median of {2.0, 1.7, 1.7(, 1.7)}
    is 1.7 Hz and T = 1.3 / 1.7 = 0.765 m; off, the deciding window's 2.0 Hz and 0.65 m.
    The verdict, reason, speed and window stay the deciding window's."""
    obj = judged_online(walk_rows([SPEED] * 192, paces_hz=[2.0] * 64 + [1.7] * 128))
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN and obj.result["window"] == (0, 64)
    assert len(later_paces(obj)) >= 2
    off = median_pace(CFG, obj, RecheckOptions(strongest_pace=False))
    assert off is obj.result
    assert off["pace_hz"] == pytest.approx(2.0, abs=PACE_TOL)
    on = median_pace(CFG, obj, ON)
    assert on["pace_hz"] == pytest.approx(1.7, abs=PACE_TOL)
    assert on["stride_m"] == pytest.approx(SPEED / 1.7, abs=STRIDE_TOL)
    assert_verdict_kept(on, obj.result)


def assert_verdict_kept(result: dict, deciding: dict) -> None:
    """The verdict, reason, speed, ratio and window are the deciding window's."""
    for key in ("verdict", "reason", "speed_mps", "ratio", "window"):
        assert result[key] == deciding[key], key


def test_an_even_count_averages_the_two_middle_windows():
    """96 rows at 2.0 Hz, then 32 at 1.7 Hz: the deciding window 0..64 and one later window
    64..128, whose pace lies between (its I(k) half at each pace); the median of two is their
    mean, by hand from the two windows' own paces."""
    obj = judged_online(walk_rows([SPEED] * 128, paces_hz=[2.0] * 96 + [1.7] * 32))
    later = later_paces(obj)
    assert len(later) == 1
    first = float(obj.result["pace_hz"])
    on = median_pace(CFG, obj, ON)
    assert on["pace_hz"] == pytest.approx((first + later[0]) / 2, abs=1e-6)
    assert abs(later[0] - first) > 0.02  # the case differs from the deciding window's


def test_windows_not_judged_pedestrian_are_left_out():
    """64 rows at 2.0 Hz then 128 at 3.5 Hz (a pace no walk has, (14)): the later windows are
    judged Non-pedestrian and the median is the deciding window's alone."""
    obj = judged_online(walk_rows([SPEED] * 192, paces_hz=[2.0] * 64 + [3.5] * 128))
    assert later_paces(obj) == []
    assert len(list(later_windows(CFG, obj, tail=True))) >= 3
    on = median_pace(CFG, obj, ON)
    assert on["pace_hz"] == obj.result["pace_hz"] and on["stride_m"] == obj.result["stride_m"]


def test_off_disabled_or_not_pedestrian_leaves_the_result():
    obj = judged_online(walk_rows([SPEED] * 192, paces_hz=[2.0] * 64 + [1.7] * 128))
    assert median_pace(CFG, obj, RecheckOptions(enabled=False, median_pace=True)) is obj.result
    fast = judged_online(walk_rows([4.0] * 192))  # faster than any walk: Non-pedestrian
    assert int(fast.result["verdict"]) != Verdict.PEDESTRIAN
    assert median_pace(CFG, fast, ON) is fast.result
    short = walk_rows([SPEED] * 40)  # too short for a window: no result
    assert median_pace(CFG, short, ON) is None


def lone_walker_tracked(key: str):
    """One rendered walker at 1.9 Hz going away from 8 m, 180 frames, tracked with the tracker's
    option `key` False (rule 55 off too: its objects' results are the deciding windows') and
    True. The tracks and verdicts must be the same both ways; returns (the pace of its
    Pedestrian track with `key` True, that track's object with `key` False)."""
    act = synth.walker(-0.5, 8.0, math.pi / 2, pace_hz=1.9, step_length_m=0.62)
    scene = synth.render_scene(5, synth.SceneSpec(n_frames=180, actors=(act,),
                                                  camera=CFG.camera))
    out = []
    for changes in ({key: False, "recheck.strongest_pace": False}, {key: True}):
        tr = OnlineTracker(CFG, with_changes(TrackerOptions(), changes))
        for i, f in enumerate(scene.frames):
            tr.update(i, i / FPS, f)
        out.append(tr.finish())
    (tracks_off, off, objs), (tracks_on, on, _) = out
    np.testing.assert_array_equal(tracks_on["track_id"], tracks_off["track_id"])
    assert list(on["verdict"]) == list(off["verdict"])
    i = list(off["verdict"]).index("pedestrian")
    return float(on["pace_hz"][i]), next(o for o in objs if o.track_id == off["track_id"][i])


def test_the_tracker_reports_the_median_over_a_lone_walkers_windows():
    """With the rule on, the lone walker's Pedestrian track's pace is the median over its
    deciding window's and its later windows' paces (read on the objects the tracker returns
    off) and lies within 0.05 Hz of 1.9."""
    pace, obj = lone_walker_tracked("recheck.median_pace")
    paces = [float(obj.result["pace_hz"])] + later_paces(obj)
    assert len(paces) >= 2
    assert pace == pytest.approx(float(np.median(paces)), abs=1e-6)
    assert pace == pytest.approx(1.9, abs=0.05)
