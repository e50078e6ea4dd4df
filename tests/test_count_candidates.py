"""Candidate windows B in counting (issue 16, item 2; `verdicts.window_candidates`): off, count's
outputs carry no candidate columns; on, the tracks hold one column per `io.files.
WINDOW_CANDIDATES` offset, NaN exactly where `intensity` is, equal to window B moved by that
offset on the level's frame difference, aligned through stitching, and the classifier is
given them."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rhythmjax.count import count_frames, window_candidates as wc
from rhythmjax.count.options import CountOptions, VerdictOptions
from rhythmjax.count.patches import ShapeModel
from rhythmjax.io.files import CANDIDATE_COLUMNS, WINDOW_CANDIDATES
from rhythmjax.sim.scene import SceneSpec, render_scene, walker
from rhythmjax.track.options import with_changes
from rhythmjax.vision.detect import frame_difference
from rhythmjax.vision.window_b import window_b_intensity

from .test_pedestrians import CFG, FAST


ON = with_changes(FAST, {"verdicts.window_candidates": True})
TRACK_COLUMNS = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "x_est", "y_est",
                 "v_top", "u_top", "top_at_edge", "state", "vx", "vy", "du", "dv")


@pytest.fixture(scope="module")
def items():
    """One walker crossing; frames 25-44 show the empty background (longer than it coasts), so
    it comes back as a second piece that stitching joins (as test_count's hidden walker);
    frames 12, 13 and 55 are undecodable (None: no frame difference, I(k) NaN)."""
    a = walker(-4.0, 7.0, 0.0, start_frame=3, phase=0.1)
    frames = render_scene(1, SceneSpec(n_frames=72, actors=(a,), camera=CFG.camera)).frames
    return [(k, k / 15.0, None if k in (12, 13, 55) else frames[0] if 25 <= k < 45 else f)
            for k, f in enumerate(frames)]


@pytest.fixture(scope="module")
def runs(items):
    return count_frames(CFG, iter(items), options=FAST), \
        count_frames(CFG, iter(items), options=ON)


def test_the_option_is_off_by_default_and_off_adds_nothing(runs):
    assert CountOptions().verdicts.window_candidates is False
    off, on = runs
    assert off.summary["stitched"] == 1 and off.counts["tracks"] == 1
    assert not set(CANDIDATE_COLUMNS) & set(off.tracks)
    assert "candidate" not in off.verdicts
    assert set(off.tracks) == set(TRACK_COLUMNS)
    # sampling the candidates changes no tracking output
    assert on.counts == off.counts and on.summary == off.summary
    for c in TRACK_COLUMNS:
        np.testing.assert_array_equal(on.tracks[c], off.tracks[c])
    for c in off.mot:
        np.testing.assert_array_equal(on.mot[c], off.mot[c])


def test_on_the_tracks_hold_a_column_per_candidate_nan_where_intensity_is(runs):
    _, on = runs
    inten = on.tracks["intensity"]
    assert on.summary["stitched"] == 1 and len(inten) > 40
    assert np.isnan(inten).sum() == 3 and np.isfinite(inten).any()  # the undecodable frames
    for c in CANDIDATE_COLUMNS:
        col = on.tracks[c]
        assert col.dtype == np.float64 and col.shape == inten.shape
        np.testing.assert_array_equal(np.isnan(col), np.isnan(inten))
        assert not np.array_equal(col, inten, equal_nan=True)  # a moved window is not B
    assert np.array_equal(on.verdicts["candidate"], np.zeros(1, np.int64))  # not judged


def test_a_candidate_is_window_b_moved_by_its_offset_on_the_frame_difference(runs, items):
    """Recomputed independently on the measured rows: window B at (u, v + offset W) with W the
    patch width at the foot point, on the difference of the row's frame and the one before."""
    _, on = runs
    tr = on.tracks
    shape = ShapeModel.from_config(CFG, ON.dynamics)
    rows = np.flatnonzero((tr["state"] == "observe") & np.isfinite(tr["intensity"]))
    assert len(rows) > 20
    gray = {k: f for k, _, f in items if f is not None}
    for i in rows[:: max(1, len(rows) // 12)]:
        k, u, v = int(tr["frame"][i]), float(tr["u"][i]), float(tr["v"][i])
        D = frame_difference(gray[max(j for j in gray if j < k)], gray[k])  # the last decoded
        W = float(shape.size(u, v)[0])
        assert window_b_intensity(D, u, v, W) == tr["intensity"][i]  # the same D and W
        for name, off in WINDOW_CANDIDATES:
            assert tr[name][i] == window_b_intensity(D, u, v + off * W, W), (name, k)


def test_an_offset_of_zero_gives_window_b_bit_for_bit_through_stitching(runs, items,
                                                                        monkeypatch):
    """Offsets patched to (0, 0.1, -0.1): the first candidate column is `intensity` exactly,
    row for row over both stitched pieces (the candidates follow their rows), the second the
    real run's +0.1 W column."""
    monkeypatch.setattr(wc, "OFFSETS", (0.0, 0.1, -0.1))
    res = count_frames(CFG, iter(items), options=ON)
    assert res.summary["stitched"] == 1
    first = res.tracks[CANDIDATE_COLUMNS[0]]
    assert first.tobytes() == res.tracks["intensity"].tobytes()
    assert res.tracks[CANDIDATE_COLUMNS[1]].tobytes() == \
        runs[1].tracks["intensity_down10"].tobytes()


def test_the_classifier_is_given_the_candidates_and_its_choice_is_kept(items, monkeypatch):
    import rhythmjax.count.judge as judge_module

    seen = []
    inner = judge_module.classify_tracks

    def spy(cfg, batch, **kw):
        seen.append(batch)
        out = inner(cfg, batch, **kw)
        out["candidate"] = np.full(len(out["track_id"]), len(CANDIDATE_COLUMNS), np.int64)
        return out

    monkeypatch.setattr(judge_module, "classify_tracks", spy)
    judge = dataclasses.replace(ON, verdicts=dataclasses.replace(
        ON.verdicts, classify=True, online=False))
    res = count_frames(CFG, iter(items), options=judge)
    (batch,) = seen
    cand = batch.candidates
    assert cand is not None and cand.shape == (*batch.intensity.shape, len(CANDIDATE_COLUMNS))
    assert np.isfinite(batch.intensity).sum() > 20
    np.testing.assert_array_equal(np.isfinite(cand),
                                  np.isfinite(batch.intensity)[..., None].repeat(3, -1))
    assert res.verdicts["candidate"].tolist() == [len(CANDIDATE_COLUMNS)]
    off = dataclasses.replace(judge, verdicts=VerdictOptions(classify=True, online=False))
    seen.clear()
    count_frames(CFG, iter(items), options=off)
    assert len(seen) == 1 and seen[0].candidates is None
