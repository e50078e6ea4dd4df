"""Rule 35b (issue 16, `body.window_mean_refused`, on with rule 35c): a rhythm window that the
sum I(k) of Sec. 4.1 does not judge Pedestrian is judged again on the same windows' mean of D per
pixel (rule 35's I(k)), whose Pedestrian outcome then decides; a window the sum judges Pedestrian
keeps the sum's outcome.

Rule 35c (`body.mean_refused_gate`, on, with rule 35b): the mean read only where the sum's
strongest peak lies below half the slowest walking pace (a trend), and its Pedestrian outcome
kept only where neither half of the window moves faster than any walk.

References: the rows' samples counted by hand (`window_b_means`); `match_window` on hand-made rows
whose sum and mean channels are chosen apart (a sine at a walker's pace, noise, a dog's pace);
on a drawn scene, the tracker's per-pixel channels against a second run with rule 35 on (every
sample equal to 1e-9 relative: the same float sums divided by the same whole areas)."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import Config, WalkingModel
from rhythmjax.model.status import TrackState, Verdict
from rhythmjax.sim import scene as synth
from rhythmjax.track import track_frames
from rhythmjax.track.options import BodyOptions, TrackerOptions
from rhythmjax.track.recheck import keep_rows
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.toolkit import RESULT_FIELDS, match_window, refused_for_trend
from rhythmjax.track.tracker import OnlineTracker
from rhythmjax.vision.window_b import window_b_means


CFG = Config()
FPS = 15.0
N = CFG.thresholds.n


def test_window_b_means_by_hand():
    """D: ones in rows 21..23, threes in row 24, columns 10..29 (40 x 50); W 10 px at (20, 25).
    Window B: columns 15..24, rows 24..25: 30 over 20 px. The candidate 0.1 W up: rows 23..24,
    40 over 20 px. The pace window at scale 2: columns 10..29, rows 22..25: 100 over 80 px."""
    D = np.zeros((40, 50), np.uint8)
    D[21:24, 10:30] = 1
    D[24, 10:30] = 3
    assert window_b_means(D, 20.0, 25.0, 10.0, (-0.1,), 2.0) == (1.5, 2.0, 1.25)
    assert window_b_means(D, 20.0, 25.0, 10.0, (), 0.0) == (1.5,)
    assert window_b_means(D, 20.0, 25.0, 10.0, (-0.1, 0.1), 0.0) == (1.5, 2.0, 0.0)
    for absdiff, u, sampled in ((None, 20.0, True), (D, 20.0, False), (D, math.nan, True)):
        got = window_b_means(absdiff, u, 25.0, 10.0, (-0.1,), 2.0, sampled)
        assert len(got) == 3 and all(math.isnan(x) for x in got)


def _rows(sum_signal):
    """N rows of a walk away from the camera at 1.4 m/s from 8 m (the paper's camera), every row
    observed, I(k) `sum_signal`."""
    t = np.arange(N) / FPS
    y = 8.0 + 1.4 * t
    u, v = project_3d(CFG.camera, 0.5 + 0 * y, y, 0 * y)
    return [TrackRow(k, float(t[k]), float(u[k]), float(v[k]), 20.0, float(sum_signal[k]), 0.5,
                     float(y[k]), int(TrackState.OBSERVE)) for k in range(N)]


def _sine(pace_hz, seed):
    rng = np.random.default_rng(seed)
    return 20.0 + 5.0 * np.sin(2 * np.pi * pace_hz * np.arange(N) / FPS) \
        + rng.normal(0, 0.1, N)


def _noise(seed):
    return 20.0 + np.random.default_rng(seed).normal(0, 1.0, N)


def _judged(sum_signal, mean_signal=None, candidates=False):
    """`match_window` once on an object of `_rows(sum_signal)`; `mean_signal` its `mean_rows`
    (window B's channel; with `candidates` a second channel, the sum's and the mean's, of noise
    that never decides)."""
    rows = _rows(sum_signal)
    obj = SimpleNamespace(rows=rows, win_start=0, windows_done=0, result=None, decided=False)
    if candidates:
        obj.candidate_rows = [(x,) for x in _noise(7)]
    if mean_signal is not None:
        obj.mean_rows = list(zip(mean_signal, *([_noise(8)] if candidates else [])))
    match_window(CFG, obj)
    return obj


@pytest.mark.parametrize("candidates", [False, True])
def test_the_mean_decides_where_the_sum_refuses(candidates):
    """The sum noise (refused: no peak above P_thr), the mean a sine at 2.0 Hz (a walker's pace
    at 1.4 m/s, stride 0.70 m): Pedestrian at 2.0 Hz with the rule, not Pedestrian without."""
    noise, walk = _noise(1), _sine(2.0, 2)
    off = _judged(noise, None, candidates)
    assert int(off.result["verdict"]) != Verdict.PEDESTRIAN and not off.decided
    on = _judged(noise, walk, candidates)
    assert int(on.result["verdict"]) == Verdict.PEDESTRIAN and on.decided
    assert float(on.result["pace_hz"]) == pytest.approx(2.0, abs=0.05)
    assert on.result["window"] == (0, N) and on.windows_done == 1
    if candidates:  # window B's mean decided, not the noise channel
        assert on.result["candidate"] == 0


def test_a_pedestrian_sum_keeps_its_outcome():
    """The sum a sine at 2.0 Hz (Pedestrian), the mean one at 2.2 Hz (Pedestrian too, alone):
    the sum's pace stands; the mean is not read."""
    assert int(_judged(_sine(2.2, 4)).result["verdict"]) == Verdict.PEDESTRIAN
    alone = _judged(_sine(2.0, 3))
    both = _judged(_sine(2.0, 3), _sine(2.2, 4))
    assert int(both.result["verdict"]) == Verdict.PEDESTRIAN
    assert float(both.result["pace_hz"]) == float(alone.result["pace_hz"])
    assert float(both.result["pace_hz"]) == pytest.approx(2.0, abs=0.05)


def test_a_refused_mean_leaves_the_sums_outcome():
    """The sum noise, the mean a sine at 4.2 Hz (a trotting dog's pace, refused): the outcome is
    the sum's, field by field (its pace is not the mean's 4.2 Hz)."""
    sum_only = _judged(_noise(5))
    both = _judged(_noise(5), _sine(4.2, 6))
    assert int(both.result["verdict"]) != Verdict.PEDESTRIAN
    assert float(_judged(_sine(4.2, 6)).result["pace_hz"]) == pytest.approx(4.2, abs=0.05)
    assert abs(float(both.result["pace_hz"]) - 4.2) > 0.1
    for name in RESULT_FIELDS:
        np.testing.assert_array_equal(both.result[name], sum_only.result[name])


def test_keep_rows_slices_the_mean_rows():
    obj = SimpleNamespace(rows=list(range(10)), vel=list(range(10)), candidate_rows=None,
                          mean_rows=[(float(k),) for k in range(10)], result=None)
    keep_rows(obj, slice(3, 7))
    assert obj.mean_rows == [(3.0,), (4.0,), (5.0,), (6.0,)] and obj.rows == [3, 4, 5, 6]


@pytest.fixture(scope="module")
def walker_scene():
    """One walker coming towards the camera from 14 to 6 m."""
    spec = synth.SceneSpec(n_frames=90, actors=(synth.walker(0.3, 14.0, -math.pi / 2,
                                                             pace_hz=2.0, step_length_m=0.7),))
    return synth.render_scene(5, spec)


def _track(scene, **body):
    opt = TrackerOptions(body=BodyOptions(pace_window_widths=2.0, **body))
    frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
    return track_frames(Config(), frames, progress=False, options=opt)


def test_tracker_mean_rows_equal_rule_35s_samples(walker_scene):
    """With the rule on, each object's `mean_rows` (window B's, the three candidates', the two
    moved across (rule 50b, on) and the pace window's I(k) per pixel) equal, row by row, the
    samples of a run with rule 35 on (I(k) per pixel: the same filter, window B's sampling never
    moves it); the tracks file keeps the sums (equal to a run with the rule off); with rule 35
    on there are no mean rows."""
    tracks_on, _, objs, _ = _track(walker_scene, window_mean_refused=True)
    tracks_off, _, _, _ = _track(walker_scene, window_mean_refused=False)
    per_pixel, _, both, _ = _track(walker_scene, window_per_pixel=True, window_mean_refused=True)
    for k in ("track_id", "frame", "intensity", "intensity_wide"):
        np.testing.assert_array_equal(tracks_on[k], tracks_off[k])
    means = np.asarray([m for o in objs for m in o.mean_rows], np.float64)
    assert means.shape == (len(tracks_on["frame"]), 7) and len(tracks_on["frame"]) > 60
    cols = ("intensity", "intensity_up20", "intensity_up10", "intensity_down10",
            "intensity_left10", "intensity_right10", "intensity_wide")
    want = np.stack([per_pixel[c] for c in cols], axis=1)
    np.testing.assert_array_equal(np.isnan(means), np.isnan(want))
    np.testing.assert_allclose(means, want, rtol=1e-9, equal_nan=True)
    assert all(o.mean_rows is None for o in both)


def test_a_track_cut_at_a_switch_keeps_its_mean_rows(walker_scene, monkeypatch):
    """A cut forced at row 70 (rule 29's `switch_row` made to name it): the new track judged
    afresh (the tracker's `judge_afresh`) and the rows kept both carry their own per-pixel rows,
    one a row, in order."""
    import rhythmjax.track.recheck as recheck

    monkeypatch.setattr(recheck, "switch_row", lambda *a, **k: 70)
    _, _, objs, tracker = _track(walker_scene, window_mean_refused=True)
    assert tracker.switches == 1 and len(objs) == 2
    whole = [m for o in objs for m in o.mean_rows]
    assert [len(o.mean_rows) for o in objs] == [len(o.rows) for o in objs] == [70, 18]
    monkeypatch.undo()
    _, _, (one,), _ = _track(walker_scene, window_mean_refused=True)
    np.testing.assert_array_equal(np.asarray(whole), np.asarray(one.mean_rows))


def test_mean_rows_are_nan_exactly_where_intensity_is():
    """Two walkers crossing: the rows left unsampled (I(k) NaN while the windows mix, the frame
    difference D present) have NaN per-pixel rows too, and only those."""
    spec = synth.SceneSpec(n_frames=90, actors=(
        synth.walker(-1.5, 9.0, 0.0, pace_hz=2.0, step_length_m=0.7),
        synth.walker(1.5, 9.3, math.pi, pace_hz=1.9, step_length_m=0.7)))
    tracks, _, objs, _ = _track(synth.render_scene(7, spec), window_mean_refused=True)
    means = np.asarray([m for o in objs for m in o.mean_rows], np.float64)
    unsampled = np.isnan(tracks["intensity"])
    assert unsampled.sum() >= 5 and (~unsampled).sum() > 100
    np.testing.assert_array_equal(np.isnan(means), np.repeat(unsampled[:, None], 7, axis=1))


def test_a_relinked_track_keeps_its_mean_rows():
    """A walker crossing at 12 m hidden for frames 40..61 (`test_window_candidates_online`'s
    scene): its track times out and is relinked, and the relink's gap rows (no sample) get NaN
    per-pixel rows, one a row, as the sums do."""
    act = synth.walker(-3.4, 12.0, 0.0, pace_hz=1.9, step_length_m=0.62)
    spec = synth.SceneSpec(n_frames=110, actors=(act,), camera=CFG.camera)
    walk = synth.render_scene(3, spec).frames
    empty = synth.render_scene(3, dataclasses.replace(spec, actors=())).frames
    tracker = OnlineTracker(CFG, TrackerOptions(body=BodyOptions(window_mean_refused=True)))
    for k in range(110):
        tracker.update(k, k / FPS, empty[k] if 40 <= k < 62 else walk[k])
    tracks, _, objs = tracker.finish()
    assert tracker.relinked == 1
    means = np.asarray([m for o in objs for m in o.mean_rows], np.float64)
    unsampled = np.isnan(tracks["intensity"])
    assert means.shape == (len(unsampled), 6) and (tracks["state"] == "none").sum() >= 3
    np.testing.assert_array_equal(np.isnan(means), np.repeat(unsampled[:, None], 6, axis=1))


# ----------------------------------------------------------------------------------------------
# rule 35c: the gate


def test_refused_for_trend_by_hand():
    """Table 1: paces 2.05 -+ 3 x 0.183 = 1.501-2.599 Hz, so the bound is 0.7505 Hz; only the
    strongest peak (slot 0) counts, and only where it is a peak (mask)."""
    def outcome(freq, mask=True):
        return {"peak_freq": np.asarray([freq, 0.1]), "peak_mask": np.asarray([mask, True])}

    assert refused_for_trend(CFG, outcome(0.74)) and refused_for_trend(CFG, outcome(0.2))
    assert not refused_for_trend(CFG, outcome(0.76)) and not refused_for_trend(CFG, outcome(2.0))
    assert not refused_for_trend(CFG, outcome(0.2, mask=False))
    slow = Config(walking=WalkingModel(pace_mean=1.8))  # 1.8 - 0.549 = 1.251 Hz: bound 0.6255
    assert refused_for_trend(slow, outcome(0.62)) and not refused_for_trend(slow, outcome(0.63))


def _ramp(seed=1):
    """A walker's I(k) summed while it comes nearer: a ramp of 30 grey levels over the window
    and a weak rhythm at 2.0 Hz (the strongest peak at 0.20 Hz: refused for no model match)."""
    t = np.arange(N) / FPS
    return 10.0 + 30.0 * t / t[-1] + 0.5 * np.sin(2 * np.pi * 2.0 * t) \
        + np.random.default_rng(seed).normal(0, 0.1, N)


def _gated(rows, mean_signal, gate):
    obj = SimpleNamespace(rows=rows, win_start=0, windows_done=0, result=None, decided=False,
                          mean_rows=[(x,) for x in mean_signal], mean_gate=gate)
    match_window(CFG, obj)
    return obj


def test_rule_35c_reads_the_mean_only_behind_a_trend():
    """The sum a ramp (a trend): the mean at 2.0 Hz decides, gate or not. The sum a sine at
    1.0 Hz (refused by (14): not a trend, under the walking paces): without the gate the mean
    decides, with it the outcome is the sum's, field by field."""
    ramp = _ramp()
    assert refused_for_trend(CFG, _judged(ramp).result)
    for gate in (False, True):
        on = _gated(_rows(ramp), _sine(2.0, 2), gate)
        assert int(on.result["verdict"]) == Verdict.PEDESTRIAN
        assert float(on.result["pace_hz"]) == pytest.approx(2.0, abs=0.05)
    slow = _sine(1.0, 3)
    sum_only = _judged(slow)
    assert int(sum_only.result["verdict"]) != Verdict.PEDESTRIAN
    assert not refused_for_trend(CFG, sum_only.result)
    assert int(_gated(_rows(slow), _sine(2.0, 2), False).result["verdict"]) == Verdict.PEDESTRIAN
    gated = _gated(_rows(slow), _sine(2.0, 2), True)
    assert not gated.decided
    for name in RESULT_FIELDS:
        np.testing.assert_array_equal(gated.result[name], sum_only.result[name])


def _rows_halves(sum_signal, first_mps, last_mps):
    """`_rows` walking away at `first_mps` for the first N/2 rows and `last_mps` after."""
    t = np.arange(N) / FPS
    speed = np.where(np.arange(N) < N // 2, first_mps, last_mps)
    y = 8.0 + np.concatenate([[0.0], np.cumsum(speed[1:] / FPS)])
    u, v = project_3d(CFG.camera, 0.5 + 0 * y, y, 0 * y)
    return [TrackRow(k, float(t[k]), float(u[k]), float(v[k]), 20.0, float(sum_signal[k]), 0.5,
                     float(y[k]), int(TrackState.OBSERVE)) for k in range(N)]


@pytest.mark.parametrize("halves", [(1.0, 2.7), (2.7, 1.0)])
def test_rule_35c_keeps_the_mean_only_where_both_halves_walk(halves):
    """A window whose halves move at 1.0 and 2.7 m/s (either order; the whole window's speed
    (12) 1.88 m/s, a walk): the sum a trend, the mean at 2.2 Hz. Rule 35b alone judges it
    Pedestrian; with the gate one half is faster than any walk (2.57 m/s), so the sum's outcome
    stands. At 1.0 and 2.5 m/s both halves walk and the gate keeps the mean's outcome."""
    ramp, walk = _ramp(), _sine(2.2, 2)
    assert int(_gated(_rows_halves(ramp, *halves), walk, False).result["verdict"]) \
        == Verdict.PEDESTRIAN
    gated = _gated(_rows_halves(ramp, *halves), walk, True)
    assert int(gated.result["verdict"]) != Verdict.PEDESTRIAN and not gated.decided
    assert float(gated.result["pace_hz"]) == pytest.approx(0.2, abs=0.05)  # the sum's trend
    both_walk = _gated(_rows_halves(ramp, 1.0, 2.5), walk, True)
    assert int(both_walk.result["verdict"]) == Verdict.PEDESTRIAN


def test_the_tracker_carries_the_gate(walker_scene, monkeypatch):
    """Every object of a run with rule 35c, and both sides of a forced cut (the track judged
    afresh), carry the gate to `match_window`; without it none does."""
    import rhythmjax.track.recheck as recheck

    monkeypatch.setattr(recheck, "switch_row", lambda *a, **k: 70)
    _, _, objs, tracker = _track(walker_scene, window_mean_refused=True, mean_refused_gate=True)
    assert tracker.switches == 1 and len(objs) == 2 and all(o.mean_gate for o in objs)
    _, _, objs, _ = _track(walker_scene, window_mean_refused=True, mean_refused_gate=False)
    assert objs and not any(o.mean_gate for o in objs)
    _, _, objs, _ = _track(walker_scene)  # the defaults: rule 35b with its gate
    assert objs and all(o.mean_gate and o.mean_rows for o in objs)
