"""benchmarks/reclassify_dumps.py: a saved counting record judged again. A walker's track whose
rhythm rides on a slow trend: judged Non-pedestrian with the paper's mean removal (its strongest
peak is the trend's), Pedestrian with the line removed (`rhythm.DETREND`), the verdicts'
other columns kept and `counted` recomputed; a short track stays unclassified and counted."""

from __future__ import annotations

import os
import sys

import jax
import numpy as np
import pytest

from rhythmjax.model import rhythm
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import config_from_dict


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import reclassify_dumps as rc  # noqa: E402


CFG = config_from_dict({})


def _record(trend: float) -> dict:
    """Track 1: 96 frames of a walker at 1.4 m/s across at 8 m, I(k) a 1.9 Hz rhythm of 10 grey
    levels (step 0.74 m: inside the walking model), noise of 5 and a rise of `trend` grey
    levels per 64 frames; track 2: 12 frames (too short to judge)."""
    fps = float(CFG.camera.fps)
    rng = np.random.default_rng(2)
    rows = []
    for tid, n in ((1, 96), (2, 12)):
        t = np.arange(n) / fps
        u, v = np.asarray(project_3d(CFG.camera, -2.0 + 1.4 * t, np.full(n, 8.0), 0.0))
        inten = 100.0 + 10.0 * np.sin(2 * np.pi * 1.9 * t) + trend * np.arange(n) / 63.0
        inten = inten + rng.normal(0.0, 5.0, n)  # the frame difference's noise
        rows.append({"track_id": np.full(n, tid), "frame": np.arange(n), "t": t, "u": u, "v": v,
                     "width_px": np.full(n, 20.0), "intensity": inten})
    tracks = {k: np.concatenate([r[k] for r in rows]) for k in rows[0]}
    verdicts = {"track_id": np.array([1, 2]), "verdict": np.array(["x", "x"], dtype=object),
                "too_fast": np.array([False, False]), "explained_by": np.array([0, 0]),
                "width_m": np.array([0.5, 0.5]), "counted": np.array([False, False])}
    return {"clip": "hand/0", "tracks": tracks, "verdicts": verdicts}


@pytest.fixture
def fresh_traces():
    jax.clear_caches()  # DETREND is read when traced
    yield
    jax.clear_caches()


@pytest.mark.parametrize("detrend, want", [("mean", "non-pedestrian"), ("line", "pedestrian")])
def test_a_trended_walker_judged_again(monkeypatch, fresh_traces, detrend, want):
    monkeypatch.setattr(rhythm, "DETREND", detrend)
    v = rc.rejudged(_record(trend=300.0), CFG)
    assert list(v["verdict"]) == [want, "unclassified"]
    assert list(v["counted"]) == [want == "pedestrian", True]
    assert list(v["width_m"]) == [0.5, 0.5]  # not judged columns as saved
    if want == "pedestrian":
        assert abs(float(v["pace_hz"][0]) - 1.9) <= 0.03
    else:
        assert float(v["pace_hz"][0]) < 0.5  # the trend's peak


def test_mismatched_ids_are_refused():
    r = _record(trend=0.0)
    r["verdicts"]["track_id"] = np.array([1, 3])
    with pytest.raises(ValueError, match="hand/0"):
        rc.rejudged(r, CFG)


def test_width_patch_lets_the_width_gate_pass(fresh_traces):
    """A walker's rows measured 200 px wide (a blob of several people; (10) refuses every row, so
    the paper's filter never observes it) stays unjudged with the measured width and is judged
    Pedestrian with an average walker's width at its foot points (`--width patch`)."""
    r = _record(trend=0.0)
    r["tracks"]["width_px"] = np.full(len(r["tracks"]["frame"]), 200.0)
    measured = rc.rejudged(r, CFG)
    patch = rc.rejudged(r, CFG, width="patch")
    assert measured["verdict"][0] == "unclassified"
    assert patch["verdict"][0] == "pedestrian"
    assert abs(float(patch["pace_hz"][0]) - 1.9) <= 0.03
    assert list(r["tracks"]["width_px"][:1]) == [200.0]  # the record itself untouched
