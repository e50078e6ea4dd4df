"""Rule 50b (issue 16, fiftieth round; `body.across_candidates`, off): window B moved 0.1 W left
and right on its row as two more candidate windows B, which decide a rhythm window only by
(13)-(15) at their own strongest peak, never through rule 37's second look. Checked against
sums of D over hand-placed windows, the tracker's rows and tracks table with the option on and
off, and the shared judgement (`model.candidates.judged`, the tracker's `toolkit._judged`) on
hand-built window results; rule 50 (`benchmarks/eval_rules.py`'s `across`: the same windows
through rule 37 too) likewise. The batch classifier: tests/test_across_batch.py."""

from __future__ import annotations

import csv
import math
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from rhythmjax.io.files import ACROSS_COLUMNS, CANDIDATE_COLUMNS
from rhythmjax.model.params import Config
from rhythmjax.model.status import Verdict
from rhythmjax.track.options import BodyOptions, TrackerOptions, with_changes
from rhythmjax.vision.window_b import window_b_across, window_b_extras, window_b_means


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


def test_across_windows_are_window_b_moved_along_its_row():
    rng = np.random.default_rng(50)
    D = rng.integers(0, 256, (120, 160)).astype(np.uint8)
    down, across = (-0.2, -0.1, 0.1), (-0.1, 0.1)
    for u, v, W in ((80.0, 90.0, 40.0), (30.5, 60.2, 25.0), (150.0, 118.0, 30.0)):
        left, right = (window_sum(D, u + s * 0.1 * W, v, W) for s in (-1, 1))
        assert window_b_across(D, u, v, W, across) == (left, right)
        assert left != right  # random D: the two sides differ, the test can tell them apart
        got = window_b_extras(D, u, v, W, down, 2.0, across=across)
        assert got[:3] == tuple(window_sum(D, u, v + off * W, W) for off in down)
        assert got[3:5] == (left, right)  # after the candidates, before the pace window
        assert got[5] == window_sum(D, u, v, 2.0 * W)
        assert window_b_extras(D, u, v, W, down, 0.0) == got[:3]  # none by default
        means = window_b_means(D, u, v, W, down, 0.0, True, across)
        assert len(means) == 6  # window B, three candidates, two across, per pixel
        assert means[4] == pytest.approx(window_sum(D, u - 0.1 * W, v, W, mean=True), rel=1e-12)
        assert means[5] == pytest.approx(window_sum(D, u + 0.1 * W, v, W, mean=True), rel=1e-12)
    for absent in (window_b_means(D, 80.0, 90.0, 40.0, down, 0.0, False, across),
                   window_b_means(None, 80.0, 90.0, 40.0, down, 2.0, True, across)):
        assert len(absent) in (6, 7) and all(math.isnan(x) for x in absent)
    assert all(math.isnan(x) for x in window_b_across(D, math.nan, 90.0, 40.0, across))


def test_options_switch_the_offsets():
    assert BodyOptions().candidate_offsets() == ((-0.2, -0.1, 0.1), (-0.1, 0.1))  # on
    assert BodyOptions(across_candidates=False).candidate_offsets() == ((-0.2, -0.1, 0.1), ())
    assert BodyOptions(window_candidates=False).candidate_offsets() == (None, (-0.1, 0.1))
    assert BodyOptions(pace_window_widths=2.0).candidate_offsets()[1] == (-0.1, 0.1)


@pytest.mark.parametrize("on", [False, True])
def test_tracker_rows_and_table_carry_the_across_windows(on, tmp_path):
    from rhythmjax.sim import scene as synth
    from rhythmjax.track import track_frames

    cfg = Config()  # frames 20 and 21 undecodable: rows with no sample, every window NaN
    act = synth.walker(-2.0, 11.0, 0.0, pace_hz=1.9, step_length_m=0.65)
    sc = synth.render_scene(7, synth.SceneSpec(n_frames=40, actors=(act,), camera=cfg.camera))
    frames = ((i, i / sc.fps, None if i in (20, 21) else f) for i, f in enumerate(sc.frames))
    opt = with_changes(TrackerOptions(), {"body.across_candidates": on})
    tracks, _, objs, tracker = track_frames(cfg, frames, progress=False, options=opt)
    width = 5 if on else 3
    assert objs and all(len(c) == width for o in objs for c in o.candidate_rows)
    assert all(len(m) == width + 1 for o in objs for m in o.mean_rows)  # rule 35b's, per pixel
    assert all(o.across == (2 if on else 0) for o in objs)
    tracker._judge_afresh(objs[0], slice(0, len(objs[0].rows)))  # a track split by rule 29
    assert tracker.switches == 1 and tracker._finished[-1].across == objs[0].across
    rows = [c for o in objs for c in o.candidate_rows]
    assert any(all(math.isnan(x) for x in c) for c in rows)  # the undecodable frames' rows
    names = CANDIDATE_COLUMNS + (ACROSS_COLUMNS if on else ())
    assert [k for k in tracks if k.startswith("intensity_")] == list(names)
    for j, name in enumerate(names):
        np.testing.assert_array_equal(tracks[name], np.asarray([c[j] for c in rows]))
    if on:
        sampled = [c for c in rows if math.isfinite(c[0])]
        assert len(sampled) >= 20 and sum(c[3] != c[4] for c in sampled) >= 10
    # the writers' order keeps them (`candidate_columns`), the reader checks them
    from rhythmjax.cli.common import TRACK_ORDER
    from rhythmjax.io import read_tracks, write_table
    from rhythmjax.io.errors import BadInput
    from rhythmjax.track.columns import candidate_columns

    order = TRACK_ORDER + candidate_columns(tracks)
    assert order[-len(names):] == list(names)
    path = tmp_path / "tracks.csv"
    write_table(str(path), tracks, order)
    with open(path, newline="") as fh:
        back = list(csv.DictReader(fh))
    for name in names:
        got = [float(r[name]) if r[name] else math.nan for r in back]
        np.testing.assert_allclose(got, tracks[name], rtol=1e-6, equal_nan=True)
    read_tracks(str(path))
    back[0][names[-1]] = "-1"
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(back[0]))
        w.writeheader()
        w.writerows(back)
    with pytest.raises(BadInput, match=names[-1]):
        read_tracks(str(path))


PED, NON = int(Verdict.PEDESTRIAN), int(Verdict.NON_PEDESTRIAN)
CFG = Config()  # the judgement's config (its trend rule 38b read by `judged`)
# six candidates (window B, three moved vertically, left, right) over four windows: candidate
# c's window w has one peak at 1.8 Hz of power POWERS[c][w]; its pace 1 + c Hz names it
POWERS = [[1, 1, 1, 1], [2, 2, 2, 2], [3, 5, 3, 3], [4, 4, 8, 4], [5, 9, 5, 9], [9, 6, 6, 6]]
VERDICTS = [[PED] * 4] * 4 + [[PED, NON, PED, PED], [PED] * 4]


def window_results(powers=POWERS, verdicts=VERDICTS, window=None):
    """Per candidate, `classify_window`-like results (leading window axis; `window` w: that
    window alone, kept as an axis of 1)."""
    out = []
    for c, (p, v) in enumerate(zip(powers, verdicts)):
        p, v = np.asarray(p, np.float32), np.asarray(v, np.int32)
        if window is not None:
            p, v = p[[window]], v[[window]]
        W = len(p)
        out.append({"verdict": v, "reason": np.zeros(W, np.int32),
                    "pace_hz": np.full(W, 1.0 + c, np.float32),
                    "stride_m": np.full(W, 0.7, np.float32), "ratio": np.ones(W, np.float32),
                    "speed_mps": np.ones(W, np.float32),
                    "peak_freq": np.tile(np.float32([1.8, 0.0]), (W, 1)),
                    "peak_power": np.stack([p, np.zeros_like(p)], 1),
                    "peak_mask": np.tile([True, False], (W, 1))})
    return out


def recording_look(calls):
    """A second look that records `twice` and marks the windows it saw: reason 1 with rule
    37 (twice), 2 without; without it a window paced 5 Hz (the left window) is refused, as
    rule 26 refuses a window too low for a walker."""
    def look(res, twice=True):
        calls.append(twice)
        res = {k: np.array(v) for k, v in res.items()}
        res["reason"][:] = 1 if twice else 2
        if not twice:
            res["verdict"] = np.where(res["pace_hz"] == 5.0, NON, res["verdict"])
        return res
    return look


def test_across_windows_decide_only_by_their_own_peak():
    from rhythmjax.model.candidates import judged, strongest

    calls = []
    got, chosen = judged(window_results(), recording_look(calls), across=2)
    # w0: the right window strongest and Pedestrian, decides unlooked by rule 37; w1: the left
    # strongest but refused: judged on the four before it (candidate 2), rule 37 looking; w2:
    # a vertical candidate strongest; w3: the left window decides, refused by the height look
    np.testing.assert_array_equal(chosen, [5, 2, 3, 4])
    np.testing.assert_array_equal(got["verdict"], [PED, PED, PED, NON])
    np.testing.assert_array_equal(got["pace_hz"], [6.0, 3.0, 4.0, 5.0])
    np.testing.assert_array_equal(got["reason"], [2, 1, 1, 2])
    assert calls == [True, False]
    again, chosen = judged(window_results(), None, across=2)  # no look: w3 stays Pedestrian
    np.testing.assert_array_equal(again["verdict"], [PED] * 4)
    np.testing.assert_array_equal(chosen, [5, 2, 3, 4])
    calls.clear()  # across 0: the strongest of all six, then the look, as before rule 50b
    plain, chosen = judged(window_results(), recording_look(calls))
    merged, best = strongest(window_results())
    np.testing.assert_array_equal(chosen, best)
    np.testing.assert_array_equal(chosen, [5, 4, 3, 4])
    np.testing.assert_array_equal(plain["reason"], [1] * 4)
    np.testing.assert_array_equal(plain["pace_hz"], merged["pace_hz"])
    assert calls == [True]
    calls.clear()  # no across window strongest and Pedestrian: one look only
    inner, chosen = judged(window_results(), recording_look(calls), across=2)
    assert calls.count(False) == 1


def test_with_the_pace_window_last_it_is_no_candidate():
    """Rule 34's pace window after the across windows (the tracker's and the tracks file's
    order): it never decides, gives a Pedestrian window's pace where it says Pedestrian too,
    and the across windows are still the two before it."""
    from rhythmjax.model.candidates import judged

    pace = window_results([[99] * 4], [[PED] * 4])[0]  # strongest of all, yet never chosen
    pace["pace_hz"][:] = 42.0
    got, chosen = judged(window_results() + [pace], None, across=2, pace_last=True)
    np.testing.assert_array_equal(chosen, [5, 2, 3, 4])
    np.testing.assert_array_equal(got["pace_hz"], [42.0] * 4)  # every window Pedestrian
    pace["verdict"][:] = NON
    got, chosen = judged(window_results() + [pace], None, across=2, pace_last=True)
    np.testing.assert_array_equal(chosen, [5, 2, 3, 4])
    np.testing.assert_array_equal(got["pace_hz"], [6.0, 3.0, 4.0, 5.0])


@pytest.mark.parametrize("window", [0, 1, 2, 3])
def test_the_trackers_judgement_is_the_shared_one_in_one_call(monkeypatch, window):
    """`toolkit._judged` judges all six channels in one call (no second call for the channels
    before the across windows) and agrees with `candidates.judged` window by window."""
    import rhythmjax.track.toolkit as tk
    from rhythmjax.model.candidates import judged

    res = window_results(window=window)
    stacked = {k: np.stack([r[k][0] for r in res]) for k in res[0]}
    classified = []
    monkeypatch.setattr(tk, "classify_window_candidates_jit", lambda cfg, sigs, *rest: (
        classified.append(len(sigs)) or types.SimpleNamespace(**stacked)))
    seen = []

    def look(out, rows, twice=True):
        seen.append(rows)
        return recording_look([])({k: np.asarray(v)[None] for k, v in out.items()}, twice)

    obj = types.SimpleNamespace(second_look=lambda out, rows, twice=True: {
        k: v[0] for k, v in look(out, rows, twice).items()}, across=2)
    out, c = tk._judged(CFG, obj, "rows", [np.zeros(4)] * 6, (), True)
    want, best = judged(window_results(window=window), recording_look([]), across=2)
    assert classified == [6] and set(seen) == {"rows"}
    assert c == int(best[0]) == [5, 2, 3, 4][window]
    for k in ("verdict", "reason", "pace_hz"):
        assert out[k] == want[k][0], k


def test_one_channel_is_judged_alone_and_looked_at(monkeypatch):
    import rhythmjax.track.toolkit as tk

    one = {k: v[0] for k, v in window_results(window=0)[0].items()}
    monkeypatch.setattr(tk, "classify_window_jit",
                        lambda cfg, sig, *rest: types.SimpleNamespace(**one))
    looked = []
    obj = types.SimpleNamespace(second_look=lambda out, w, twice=True: looked.append(twice)
                                or out, across=2)
    out, c = tk._judged(CFG, obj, None, [np.zeros(4)] * 3, (), False)  # candidates not asked
    assert c is None and looked == [True] and int(out["verdict"]) == PED


def test_rule_50_patch_lets_rule_37_read_the_across_windows(monkeypatch):
    """`eval_rules._patch_across_any`: the judgement sees `across` 0 (rule 50: every channel
    decides the old way, the look on any), restored afterwards."""
    import rhythmjax.track.toolkit as tk

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import eval_rules

    seen = []
    monkeypatch.setattr(tk, "_judged", lambda cfg, obj, *a: seen.append(obj.across) or ({}, 0))
    eval_rules._patch_across_any()
    obj = types.SimpleNamespace(across=2)
    tk._judged(CFG, obj, None, [], (), True)
    assert seen == [0] and obj.across == 2
