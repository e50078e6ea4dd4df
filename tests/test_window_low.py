"""Rule 45 (issue 16, `size.every_window`, on): the tracker applies rule 26 to each rhythm window
as it completes (`looks.tracker_look`, the object's second look after rule 37), so a window judged
Pedestrian but lower than half a walker is refused (too-low) and the next window is judged, as
the batch classifier does (`size.batch_size_look`).

References: hand-made rows whose top rows put the object at a chosen height through the camera
(`camera_np.project_3d`), judged by `toolkit.match_window` with and without the rule; the
tracker's look spied on a drawn scene."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from rhythmjax.model.camera_np import camera_tuple, project_3d
from rhythmjax.model.params import Config
from rhythmjax.model.status import Reason, TrackState, Verdict
from rhythmjax.sim import scene as synth
from rhythmjax.track import looks, track_frames
from rhythmjax.track.options import SizeOptions, TrackerOptions
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.toolkit import match_window


CFG = Config()
FPS = 15.0
N = CFG.thresholds.n
HOP = CFG.thresholds.hop_samples
CAMERA = camera_tuple(CFG.camera)


def _rows(heights_m, pace_hz=2.0, start_m=8.0):
    """Rows of a walk away from the camera at 1.4 m/s from `start_m`, every row observed, I(k) a
    `pace_hz` sine in noise (at 2.0 Hz each window Pedestrian on its own), the top row of an
    object `heights_m[k]` m tall."""
    k = np.arange(len(heights_m))
    t = k / FPS
    y = start_m + 1.4 * t
    x = 0.5 + 0 * y
    u, v = project_3d(CFG.camera, x, y, 0 * y)
    _, top = project_3d(CFG.camera, x, y, np.asarray(heights_m, np.float64))
    signal = 20.0 + 5.0 * np.sin(2 * np.pi * pace_hz * t) \
        + np.random.default_rng(3).normal(0, 1.0, len(k))
    return [TrackRow(int(i), float(t[i]), float(u[i]), float(v[i]), 20.0, float(signal[i]),
                     float(x[i]), float(y[i]), int(TrackState.OBSERVE), float(top[i]))
            for i in k]


def _matched(rows, every_window):
    """`match_window` over every window of `rows` until one says Pedestrian, with the tracker's
    look for `SizeOptions(every_window=...)` (rule 37 and rule 26 at their defaults)."""
    look = looks.tracker_look(CFG, CAMERA, SizeOptions(every_window=every_window))
    obj = SimpleNamespace(rows=rows, win_start=0, windows_done=0, result=None, decided=False,
                          second_look=look)
    while not obj.decided and len(rows) >= obj.win_start + N:
        match_window(CFG, obj)
    return obj


def test_a_low_first_window_is_refused_and_the_next_decides():
    """Rows 0..47 of an object 0.6 m tall (below 0.5 x 1.7 m), rows 48..95 1.7 m: the first
    window's median height is 0.6 m, the second's (rows 32..95) 1.7 m. Without rule 45 the first
    window decides (rule 26 reads it only at the track's end); with it, the first is refused
    too-low and the second decides."""
    assert HOP == 32
    rows = _rows([0.6] * 48 + [1.7] * 48)
    off = _matched(rows, False)
    assert off.decided and off.result["window"] == (0, N) and off.windows_done == 1
    on = _matched(rows, True)
    assert on.decided and on.result["window"] == (HOP, HOP + N) and on.windows_done == 2
    assert int(on.result["verdict"]) == Verdict.PEDESTRIAN


def test_every_window_low_keeps_the_first_outcome_too_low():
    """An object 0.6 m tall throughout: no window stands, and the track's outcome is the first
    window's, Non-pedestrian with reason too-low."""
    on = _matched(_rows([0.6] * 96), True)
    assert not on.decided and on.windows_done == 2 and on.result["window"] == (0, N)
    assert int(on.result["verdict"]) == Verdict.NON_PEDESTRIAN
    assert int(on.result["reason"]) == Reason.TOO_LOW


@pytest.mark.parametrize("height", [0.9, 1.7])
def test_a_window_tall_enough_is_left_alone(height):
    """0.9 m (read, above 0.85) and 1.7 m (its head above the view this near: too few rows read
    for rule 26): the first window decides with or without the rule, with the same outcome."""
    rows = _rows([height] * 96)
    off, on = _matched(rows, False), _matched(rows, True)
    assert on.result["window"] == off.result["window"] == (0, N)
    assert int(on.result["verdict"]) == int(off.result["verdict"]) == Verdict.PEDESTRIAN
    assert float(on.result["pace_hz"]) == float(off.result["pace_hz"])


def test_the_look_is_rule_37s_when_rule_45_or_26_is_off():
    """A low window judged Pedestrian (0.6 m): the look of rule 45 with rule 26 on refuses it
    too-low; with rule 45 off, or rule 26 off, it is rule 37's look (`twice.second_look`) and
    the window stays Pedestrian."""
    from rhythmjax.track.twice import second_look

    rows = _rows([0.6] * N)
    plain = SimpleNamespace(rows=rows, win_start=0, windows_done=0, result=None, decided=False)
    match_window(CFG, plain)
    out = {k: v for k, v in plain.result.items() if k != "window"}
    assert int(out["verdict"]) == Verdict.PEDESTRIAN
    for size in (SizeOptions(every_window=False),
                 SizeOptions(every_window=True, min_height_heights=0.0)):
        look = looks.tracker_look(CFG, CAMERA, size)
        assert int(look(out, rows)["verdict"]) == Verdict.PEDESTRIAN
        assert int(second_look(CFG, CAMERA, size)(out, rows)["verdict"]) == Verdict.PEDESTRIAN
    refused = looks.tracker_look(CFG, CAMERA, SizeOptions(every_window=True))(out, rows)
    assert int(refused["verdict"]) == Verdict.NON_PEDESTRIAN
    assert int(refused["reason"]) == Reason.TOO_LOW
    alone = looks.tracker_look(CFG, CAMERA, SizeOptions(every_window=True,
                                                        twice_pace_heights=0.0))  # rule 26 alone
    assert int(alone(out, rows)["reason"]) == Reason.TOO_LOW
    neither = SizeOptions(every_window=False, twice_pace_heights=0.0)
    assert looks.tracker_look(CFG, CAMERA, neither) is None


def test_the_tracker_reads_every_window_with_the_rule(monkeypatch):
    """A walker coming nearer (90 frames): with rule 45 the tracker's look calls rule 26 on each
    window it judges, online and in the recheck's windows; without it, never (rule 26 then runs
    once at the track's end, from `track.size`)."""
    calls = []
    inner = looks.refuse_low
    monkeypatch.setattr(looks, "refuse_low", lambda out, *a: calls.append(1) or inner(out, *a))
    spec = synth.SceneSpec(n_frames=90, actors=(synth.walker(0.3, 14.0, -math.pi / 2,
                                                             pace_hz=2.0, step_length_m=0.7),))
    scene = synth.render_scene(5, spec)

    def run(every):
        opt = TrackerOptions()
        opt = dataclasses.replace(opt, size=dataclasses.replace(opt.size, every_window=every))
        frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
        _, verdicts, objs, _ = track_frames(CFG, frames, progress=False, options=opt)
        return verdicts, objs

    run(False)
    assert calls == []
    _, objs = run(True)
    assert len(calls) >= sum(o.windows_done for o in objs) >= 1  # the recheck reads more


def test_rule_37_still_looks_first():
    """I(k) at 4.0 Hz, 1.4 m/s (a walker seen from behind, two bursts a step: (14) refuses 4.0 Hz
    and 0.35 m) on an object 1.7 m tall from 13 m (its head inside the view): rule 37 judges it
    Pedestrian at 2.0 Hz through the look with rule 45 as without it; 0.6 m tall, neither
    says Pedestrian."""
    for every in (False, True):
        tall = _matched(_rows([1.7] * N, pace_hz=4.0, start_m=13.0), every)
        assert int(tall.result["reason"]) == Reason.MATCHED_TWICE and tall.decided
        assert float(tall.result["pace_hz"]) == pytest.approx(2.0, abs=0.05)
        assert not _matched(_rows([0.6] * N, pace_hz=4.0, start_m=13.0), every).decided
