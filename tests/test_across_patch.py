"""Rule 50 (issue 16, fiftieth round; off): window B moved 0.1 W left and right as two more
candidate windows B, measured as a tracker patch (`benchmarks/eval_rules.py`'s
`_patch_across`, the rule `across`). Checked against sums of D over hand-placed windows, the
tracker's rows with the patch, and the tracks table it writes (the tracker's own candidate
columns only). The patch is undone after each test."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest


BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import eval_rules  # noqa: E402


@pytest.fixture
def patched():
    """The tracker module with rule 50's patch on; its four names restored afterwards."""
    import rhythmjax.track.tracker as trk

    saved = (trk.window_b_extras, trk.window_b_means, trk.OnlineTracker.__init__,
             trk.tracks_columns)
    eval_rules._patch_across()
    try:
        yield trk
    finally:
        (trk.window_b_extras, trk.window_b_means, trk.OnlineTracker.__init__,
         trk.tracks_columns) = saved


def window_sum(D, u, v, W, mean=False):
    """Window B by hand (Sec. 4.1, the rounding round(x) = floor(x + 0.5)): round(W) columns
    from floor(u - round(W) / 2 + 0.5), round(W / 5) rows ending at row round(v), clipped at
    the image; the sum of D over it (or its mean)."""
    wb, hb = math.floor(W + 0.5), max(1, math.floor(W / 5 + 0.5))
    x0 = math.floor(u - wb / 2 + 0.5)
    y1 = math.floor(v + 0.5) + 1
    h, w = D.shape
    x0, x1, y0, y1 = max(0, x0), min(w, x0 + wb), max(0, y1 - hb), min(h, y1)
    part = D[y0:y1, x0:x1].astype(np.float64)
    return float(part.mean() if mean else part.sum())


def test_across_windows_are_window_b_moved_a_tenth_of_W(patched):
    from rhythmjax.vision.window_b import window_b_intensity

    rng = np.random.default_rng(50)
    D = rng.integers(0, 256, (120, 160)).astype(np.uint8)
    for u, v, W in ((80.0, 90.0, 40.0), (30.5, 60.2, 25.0), (150.0, 118.0, 30.0)):
        assert window_b_intensity(D, u, v, W) == window_sum(D, u, v, W)
        offsets = (-0.2, -0.1, 0.1)
        got = patched.window_b_extras(D, u, v, W, offsets, 0.0)
        assert len(got) == 5
        for off, g in zip(offsets, got[:3]):  # the tracker's own candidates, unchanged
            assert g == pytest.approx(window_sum(D, u, v + off * W, W), abs=0)
        assert got[3] == pytest.approx(window_sum(D, u - 0.1 * W, v, W), abs=0)  # left
        assert got[4] == pytest.approx(window_sum(D, u + 0.1 * W, v, W), abs=0)  # right
        assert got[3] != got[4]  # random D: the two sides differ, the test can tell them
        means = patched.window_b_means(D, u, v, W, offsets, 0.0, True)
        assert len(means) == 6  # window B, three candidates, two across, per pixel
        assert means[4] == pytest.approx(window_sum(D, u - 0.1 * W, v, W, mean=True), rel=1e-12)
        assert means[5] == pytest.approx(window_sum(D, u + 0.1 * W, v, W, mean=True), rel=1e-12)
    nan_means = patched.window_b_means(D, 80.0, 90.0, 40.0, (-0.2, -0.1, 0.1), 0.0, False)
    assert len(nan_means) == 6 and all(math.isnan(x) for x in nan_means)
    assert all(math.isnan(x) for x in
               patched.window_b_means(None, 80.0, 90.0, 40.0, (-0.2, -0.1, 0.1), 0.0))


def test_tracker_rows_carry_the_across_windows_and_the_table_keeps_its_columns(patched):
    from rhythmjax.io.files import CANDIDATE_COLUMNS
    from rhythmjax.model.params import Config
    from rhythmjax.sim import scene as synth
    from rhythmjax.track import track_frames
    from rhythmjax.track.options import TrackerOptions

    cfg = Config()  # frames 20 and 21 undecodable: rows with no sample, every window NaN
    act = synth.walker(-2.0, 11.0, 0.0, pace_hz=1.9, step_length_m=0.65)
    sc = synth.render_scene(7, synth.SceneSpec(n_frames=40, actors=(act,), camera=cfg.camera))
    frames = ((i, i / sc.fps, None if i in (20, 21) else f) for i, f in enumerate(sc.frames))
    tracks, _, objs = track_frames(cfg, frames, progress=False, options=TrackerOptions())[:3]
    assert objs and all(len(c) == 5 for o in objs for c in o.candidate_rows)
    rows = [c for o in objs for c in o.candidate_rows]
    assert any(all(math.isnan(x) for x in c) for c in rows)  # the undecodable frames' rows
    sampled = [c for c in rows if math.isfinite(c[0])]
    assert len(sampled) >= 20
    assert sum(c[3] != c[4] for c in sampled) >= 10  # left and right windows read differently
    for name, j in zip(CANDIDATE_COLUMNS, range(3)):
        np.testing.assert_array_equal(tracks[name], np.asarray([c[j] for c in rows]))
    assert not any(k.startswith("intensity_") and k not in CANDIDATE_COLUMNS for k in tracks)
    with pytest.raises(ValueError, match="window_candidates"):
        from rhythmjax.track.options import with_changes

        track_frames(cfg, ((i, i / sc.fps, f) for i, f in enumerate(sc.frames[:3])),
                     progress=False,
                     options=with_changes(TrackerOptions(), {"body.window_candidates": False}))


def test_across_solo_keeps_rule_37_off_the_across_candidates(monkeypatch):
    """Rule 50b (`_patch_across_solo`) around a stand-in for `track.toolkit`'s window judgement
    that records its calls: an across candidate (the last two channels) that is the strongest
    decides only with a Pedestrian outcome read without the second look; otherwise the window
    is judged on the first channels with the look restored."""
    import types

    import rhythmjax.track.toolkit as tk
    from rhythmjax.model.status import Verdict

    calls = []

    def stand_in(outcome):
        def judged(cfg, obj, window, sigs, rest, candidates):
            calls.append((len(sigs), obj.second_look, candidates))
            c, verdict = outcome(len(sigs))
            return {"verdict": np.asarray(verdict)}, c
        return judged

    look = object()
    six = [np.zeros(4)] * 6
    ped, non = int(Verdict.PEDESTRIAN), int(Verdict.NON_PEDESTRIAN)
    cases = [  # (chosen, verdict) over all six; expected (calls' lengths and looks, result)
        (lambda n: (5, ped) if n == 6 else (2, non), [(6, None)], (5, ped)),
        (lambda n: (4, ped) if n == 6 else (2, non), [(6, None)], (4, ped)),
        (lambda n: (4, non) if n == 6 else (1, ped), [(6, None), (4, look)], (1, ped)),
        (lambda n: (3, ped), [(6, None), (4, look)], (3, ped)),  # a vertical candidate
    ]
    for outcome, expected_calls, (chosen, verdict) in cases:
        calls.clear()
        monkeypatch.setattr(tk, "_judged", stand_in(outcome))
        eval_rules._patch_across_solo()
        obj = types.SimpleNamespace(second_look=look)
        out, c = tk._judged(None, obj, None, six, (), True)
        assert (c, int(out["verdict"])) == (chosen, verdict)
        assert [(n, lk) for n, lk, _ in calls] == expected_calls
        assert obj.second_look is look  # restored
    calls.clear()  # no candidates: passed through untouched
    monkeypatch.setattr(tk, "_judged", stand_in(lambda n: (None, non)))
    eval_rules._patch_across_solo()
    obj = types.SimpleNamespace(second_look=look)
    assert tk._judged(None, obj, None, six[:1], (), False)[1] is None
    assert calls == [(1, look, False)]
