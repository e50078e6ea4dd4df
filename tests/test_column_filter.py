"""Rules 54 and 54b (`body.column_filter_only` with `body.column_rows` 0.5, on by default since
decision 55; `body.column_everywhere`, off): rule 33's
upper-body column as the filter's measurement only, window B left on the paper's column.

Reference: the detections the tracker makes and the foot points it gives window B, read
through spies on `detect.detect_in_window` and `lean.window_b_foot` (the tracker's own calls),
on a walker pulling a suitcase across the view. For every measured row whose detection the
rule moved, window B's column must be the slice extent's centre (the paper's u_p) with rule 54
and the moved column without it (rule 33 alone); the tracks' foot points are the moved
columns either way. The detection arithmetic itself is worked by hand in `test_detect.py`.
"""

import math

import numpy as np
import pytest

import rhythmjax.track.split as split_module
import rhythmjax.track.tracker as tracker_module
from rhythmjax.model.params import Config
from rhythmjax.sim import scene as synth
from rhythmjax.track.options import TrackerOptions, with_changes
from rhythmjax.vision import detect


def track_with_spies(monkeypatch, changes: dict):
    """Track a walker with a trailing suitcase crossing at 9 m; returns (tracks, detections by
    their foot point (u, v), None where two detections share one, [(z, window B's (u, v))] of
    every measured row)."""
    cfg = Config()
    act = synth.walker(-2.5, 9.0, 0.0, pace_hz=2.0, step_length_m=0.7, suitcase=True)
    sc = synth.render_scene(5, synth.SceneSpec(n_frames=40, actors=(act,), camera=cfg.camera))
    found, windows = {}, []
    inner_detect, inner_window = detect.detect_in_window, tracker_module.window_b_foot

    def spy_detect(*a, **k):
        det = inner_detect(*a, **k)
        if det is not None:
            found[(det.u, det.v)] = None if (det.u, det.v) in found else det
        return det

    def spy_window(z, est_uv, measured, *a, **k):
        out = inner_window(z, est_uv, measured, *a, **k)
        if measured:
            windows.append(((float(z[0]), float(z[1])), out))
        return out

    def spy_split(*a, **k):  # a shared blob's re-detections: measured as they are, no rule
        det = inner_detect(*a, **k)
        if det is not None:
            found[(det.u, det.v)] = None  # so a row there is left out (ambiguous)
        return det

    monkeypatch.setattr(detect, "detect_in_window", spy_detect)
    monkeypatch.setattr(split_module, "detect_in_window", spy_split)
    monkeypatch.setattr(tracker_module, "window_b_foot", spy_window)
    tr = tracker_module.OnlineTracker(cfg, with_changes(TrackerOptions(), changes))
    for i, f in enumerate(sc.frames):
        tr.update(i, i / sc.fps, f)
    tracks, _, _ = tr.finish()
    return tracks, found, windows


@pytest.mark.parametrize("filter_only", [False, True])
def test_window_b_on_the_extent_only_with_rule_54(monkeypatch, filter_only):
    tracks, found, windows = track_with_spies(
        monkeypatch, {"body.column_rows": 0.5, "body.column_filter_only": filter_only})
    moved = [(z, out, found[z]) for z, out in windows
             if found.get(z) is not None and math.isfinite(found[z].u_extent)]
    assert len(moved) >= 5  # the suitcase widens the detection past its body box
    for z, (fu, fv), det in moved:
        assert fv == z[1]
        assert fu == (det.u_extent if filter_only else det.u)
    apart = [det for _, _, det in moved if abs(det.u - det.u_extent) >= 2.0]
    assert len(apart) >= 3  # the upper body's column >= 2 px off the extent's centre
    measured = np.isfinite(np.asarray(tracks["u"]))
    rows = set(zip(np.asarray(tracks["u"])[measured].tolist(),
                   np.asarray(tracks["v"])[measured].tolist()))
    assert {z for z, _, _ in moved} <= rows  # the tracks' foot points: the moved columns
    # rule 54's box stays the extent's, rule 33's spans the moved columns
    for det in apart:
        x0, _, w, _ = det.box
        assert (abs(x0 + (w - 1) / 2 - det.u_extent) < 1e-9) == filter_only


def test_rule_54b_moves_narrow_detections_too(monkeypatch):
    """With `column_everywhere` the column rule acts on detections no wider than their body box
    as well: more rows moved than with the width gate, on the same scene."""
    counts = {}
    for everywhere in (False, True):
        _, found, windows = track_with_spies(
            monkeypatch, {"body.column_rows": 0.5, "body.column_filter_only": True,
                          "body.column_everywhere": everywhere})
        counts[everywhere] = sum(1 for z, _ in windows if found.get(z) is not None
                                 and math.isfinite(found[z].u_extent))
    assert counts[True] > counts[False]


def test_rules_54_without_a_column_rule_change_nothing(monkeypatch):
    """Rule 54 and 54b move nothing unless a column rule is on: the tracks are identical."""
    base, _, _ = track_with_spies(monkeypatch, {"body.column_rows": None,
                                                "body.column_filter_only": False})
    both, _, _ = track_with_spies(monkeypatch, {"body.column_rows": None,
                                               "body.column_filter_only": True,
                                               "body.column_everywhere": True})
    for key in ("frame", "u", "v", "intensity", "x_est", "y_est"):
        np.testing.assert_array_equal(np.asarray(base[key]), np.asarray(both[key]))
