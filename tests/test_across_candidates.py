"""Rule 50b (issue 16, fiftieth round; `body.across_candidates`, off): window B moved 0.1 W left
and right on its row as two more candidate windows B, which decide a rhythm window only by
(13)-(15) at their own strongest peak, never through rule 37's second look. Checked against
sums of D over hand-placed windows, the tracker's rows and tracks table with the option on and
off, and `track.toolkit`'s window judgement around a stand-in that records its calls; rule 50
(`benchmarks/eval_rules.py`'s `across`: the same windows through rule 37 too) likewise."""

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


def test_options_switch_the_offsets_and_refuse_the_pace_window():
    assert BodyOptions().candidate_offsets() == ((-0.2, -0.1, 0.1), ())
    assert BodyOptions(across_candidates=True).candidate_offsets() == ((-0.2, -0.1, 0.1),
                                                                       (-0.1, 0.1))
    assert BodyOptions(window_candidates=False, across_candidates=True).candidate_offsets() \
        == (None, (-0.1, 0.1))
    with pytest.raises(ValueError, match="pace_window_widths"):
        BodyOptions(across_candidates=True, pace_window_widths=2.0)


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


def stand_in(outcome, calls):
    """A `toolkit._strongest` that records (channels, candidates) and answers `outcome(n)`:
    (chosen, verdict) for n channels."""
    def strongest(cfg, obj, sigs, rest, candidates):
        calls.append((len(sigs), candidates))
        chosen, verdict = outcome(len(sigs))
        return {"verdict": np.asarray(verdict)}, chosen
    return strongest


PED, NON = int(Verdict.PEDESTRIAN), int(Verdict.NON_PEDESTRIAN)
CFG = Config()  # the judgement's config (not read by the stand-in)


@pytest.mark.parametrize("outcome, calls, chosen, verdict, looked", [
    (lambda n: (5, PED) if n == 6 else (2, NON), [(6, True)], 5, PED, False),  # right, alone
    (lambda n: (4, PED) if n == 6 else (2, NON), [(6, True)], 4, PED, False),  # left, alone
    (lambda n: (4, NON) if n == 6 else (1, PED), [(6, True), (4, True)], 1, PED, True),
    (lambda n: (3, PED), [(6, True), (4, True)], 3, PED, True),  # a vertical candidate
])
def test_across_windows_decide_only_by_their_own_peak(monkeypatch, outcome, calls, chosen,
                                                      verdict, looked):
    import rhythmjax.track.toolkit as tk

    seen, looks = [], []
    monkeypatch.setattr(tk, "_strongest", stand_in(outcome, seen))

    def look(out, window):
        looks.append(int(out["verdict"]))
        return out

    obj = types.SimpleNamespace(second_look=look, across=2)
    out, c = tk._judged(CFG, obj, None, [np.zeros(4)] * 6, (), True)
    assert (c, int(out["verdict"])) == (chosen, verdict)
    assert seen == calls and bool(looks) == looked


def test_without_across_windows_the_judgement_is_the_old_one(monkeypatch):
    import rhythmjax.track.toolkit as tk

    seen = []
    monkeypatch.setattr(tk, "_strongest", stand_in(lambda n: (5, PED), seen))
    looked = []
    obj = types.SimpleNamespace(second_look=lambda out, w: looked.append(1) or out, across=0)
    assert tk._judged(CFG, obj, None, [np.zeros(4)] * 6, (), True)[0]["verdict"] == PED
    assert seen == [(6, True)] and looked == [1]
    seen.clear()  # across windows but no candidates asked for: one channel, as before
    obj.across = 2
    tk._judged(CFG, obj, None, [np.zeros(4)], (), False)
    assert seen == [(1, False)]
    seen.clear()  # across windows alone (no vertical candidates): window B alone after them
    monkeypatch.setattr(tk, "_strongest", stand_in(lambda n: (0, NON), seen))
    tk._judged(CFG, obj, None, [np.zeros(4)] * 3, (), True)
    assert seen == [(3, True), (1, False)]


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
