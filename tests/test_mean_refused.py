"""Rule 35b (issue 16, `body.window_mean_refused`, off): a rhythm window that the sum I(k) of
Sec. 4.1 does not judge Pedestrian is judged again on the same windows' mean of D per pixel
(rule 35's I(k)), whose Pedestrian outcome then decides; a window the sum judges Pedestrian keeps
the sum's outcome.

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
from rhythmjax.model.params import Config
from rhythmjax.model.status import TrackState, Verdict
from rhythmjax.sim import scene as synth
from rhythmjax.track import track_frames
from rhythmjax.track.options import BodyOptions, TrackerOptions
from rhythmjax.track.recheck import keep_rows
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.toolkit import RESULT_FIELDS, match_window
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
    """With the rule on, each object's `mean_rows` (window B's, the three candidates' and the
    pace window's I(k) per pixel) equal, row by row, the samples of a run with rule 35 on (I(k)
    per pixel: the same filter, window B's sampling never moves it); the tracks file keeps the
    sums (equal to a run with the rule off); with rule 35 on there are no mean rows."""
    tracks_on, _, objs, _ = _track(walker_scene, window_mean_refused=True)
    tracks_off, _, _, _ = _track(walker_scene)
    per_pixel, _, both, _ = _track(walker_scene, window_per_pixel=True, window_mean_refused=True)
    for k in ("track_id", "frame", "intensity", "intensity_wide"):
        np.testing.assert_array_equal(tracks_on[k], tracks_off[k])
    means = np.asarray([m for o in objs for m in o.mean_rows], np.float64)
    assert means.shape == (len(tracks_on["frame"]), 5) and len(tracks_on["frame"]) > 60
    cols = ("intensity", "intensity_up20", "intensity_up10", "intensity_down10", "intensity_wide")
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
    np.testing.assert_array_equal(np.isnan(means), np.repeat(unsampled[:, None], 5, axis=1))


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
    assert means.shape == (len(unsampled), 4) and (tracks["state"] == "none").sum() >= 3
    np.testing.assert_array_equal(np.isnan(means), np.repeat(unsampled[:, None], 4, axis=1))
