"""The frame-difference union correction of self-calibration (`fit.selfcal_union`,
`fit_selfcal(..., frame_union=True)`).

References, built here independently of the module: (1) the slope of `numpy.polyfit` (degree 1)
through each row's window of values, tolerance 1e-9 px/s; (2) a walk at constant ground speed
projected by a known camera (`rhythmjax.model.camera_np.project_3d`, a 1.75 m person) at 7 fps,
measured as the union of frames k-1 and k (lowest foot row, highest top row, centre of the
horizontal extent, width + |du|), written out here from the frames' true positions; the
correction must give back the true frame-k values within TOL_PX = 0.2 px, widths 0.4 px (they
take the whole |du| where u takes half; the image path's
curvature over the 1 s window, one-sided at a track's ends; the union offsets are 1-10 px),
and leave rows without a velocity (fewer than 3 values in their window) and missing values as
they are. The wiring: `fit_selfcal` calls the correction (at the config's fps) only with
`frame_union=True`, and `rhythmjax-fit selfcal --frame-union` asks for it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fit.selfcal_union import HALF_WINDOW_S, local_velocity, undo_union, undo_union_track
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import Camera


F = 0.008
CAM = Camera(f=F, h=7.0, theta=math.radians(16.5), a=740 / F, b=740 / F, uc=240, vc=180,
             fps=7.0, image_width=480, image_height=360)
FPS = 7.0
TOL_PX = 0.2


def walk(n: int, towards: bool, k0: float = 0.0):
    """Frame k's foot column, foot row, head row (px) of a walk at 1.3 m/s, frames k0..k0+n-1."""
    t = (k0 + np.arange(n)) / FPS
    x = -3.0 + (0.4 if towards else 1.2) * t
    y = (30.0 - 1.2 * t) if towards else (14.0 + 1.2 * t)  # approaching / receding
    u, v = (np.asarray(q) for q in project_3d(CAM, x, y, np.zeros(n)))
    _, top = project_3d(CAM, x, y, np.full(n, 1.75))
    return t, u, v, np.asarray(top)


def test_local_velocity_is_the_windowed_least_squares_slope():
    rng = np.random.default_rng(0)
    t = np.sort(rng.uniform(0.0, 6.0, 50))
    y = 3.0 + 2.0 * t - 0.4 * t**2 + rng.normal(0.0, 1.0, t.size)
    y[[5, 17, 30]] = np.nan
    got = local_velocity(t, y)
    for i in range(t.size):
        w = (np.abs(t - t[i]) <= HALF_WINDOW_S) & np.isfinite(y)
        if w.sum() < 3:
            assert np.isnan(got[i])
            continue
        ref = np.polyfit(t[w], y[w], 1)[0]
        assert got[i] == pytest.approx(ref, abs=1e-9)


@pytest.mark.parametrize("towards", [True, False])
def test_the_union_of_two_frames_is_undone(towards):
    n = 40
    t, u, v, top = walk(n, towards)
    _, u0, v0, top0 = walk(n, towards, k0=-1.0)  # the same walker one frame earlier
    width = np.full(n, 20.0)
    um = 0.5 * (u + u0)
    vm = np.maximum(v, v0)
    tm = np.minimum(top, top0)
    wm = width + np.abs(u - u0)
    shift = np.max(np.abs(np.c_[um - u, vm - v, tm - top]))
    assert shift > 1.0  # the union moves the points by pixels (7 fps)
    u2, v2, w2, t2 = undo_union_track(t, um, vm, wm, tm, FPS)
    for got, ref, tol in ((u2, u, TOL_PX), (v2, v, TOL_PX), (w2, width, 2 * TOL_PX),
                          (t2, top, TOL_PX)):
        assert np.max(np.abs(got - ref)) < tol


def test_rows_without_a_velocity_and_missing_values_are_left_alone():
    t = np.array([0.0, 2.0, 4.0, 6.0])  # one row per window: no velocity anywhere
    u, v = np.array([1.0, 2.0, 3.0, 4.0]), np.array([9.0, 8.0, 7.0, 6.0])
    w = np.array([10.0, np.nan, 10.0, 10.0])
    u2, v2, w2, t2 = undo_union_track(t, u, v, w, None, FPS)
    assert np.array_equal(u2, u) and np.array_equal(v2, v) and t2 is None
    assert np.array_equal(w2, w, equal_nan=True)


def test_the_batch_is_corrected_track_by_track_and_keeps_its_rhythm():
    from rhythmjax.io import TrackBatch

    n, T = 30, 32
    t, u, v, top = walk(n, False)
    _, u0, v0, top0 = walk(n, False, k0=-1.0)
    pad = lambda a, fill=np.nan: np.concatenate([a, np.full(T - n, fill)])  # noqa: E731
    z = np.stack([pad(0.5 * (u + u0)), pad(np.maximum(v, v0))], -1)[None].astype(np.float32)
    tb = TrackBatch(ids=["a"], z=z, width=pad(np.full(n, 25.0))[None].astype(np.float32),
                    intensity=np.ones((1, T), np.float32), t=pad(t, 0.0)[None].astype(np.float32),
                    dt=np.full((1, T), 1 / FPS, np.float32),
                    present=(np.arange(T) < n)[None], length=np.array([n], np.int32),
                    v_top=pad(np.minimum(top, top0))[None].astype(np.float32),
                    u_top=pad(0.5 * (u + u0) + 3.0)[None].astype(np.float32))  # a lean of 3 px
    out, moved = undo_union(tb, FPS)
    assert moved == n
    # the head column moves with the foot column: the lean stays 3 px
    np.testing.assert_allclose(out.u_top[0, :n] - out.z[0, :n, 0], 3.0, atol=1e-4)
    assert np.max(np.abs(out.z[0, :n, 1] - v)) < TOL_PX
    assert np.max(np.abs(out.z[0, :n, 0] - u)) < TOL_PX
    assert np.max(np.abs(out.v_top[0, :n] - top)) < TOL_PX
    assert np.isnan(out.z[0, n:]).all() and np.array_equal(out.intensity, tb.intensity)
    assert out.z.dtype == tb.z.dtype


def test_fit_selfcal_undoes_the_union_only_when_asked(monkeypatch):
    import fit.selfcal as sc
    from rhythmjax.io import TrackBatch
    from rhythmjax.model.params import Config

    n = 40
    t, u, v, _ = walk(n, True)
    tb = TrackBatch(ids=["a"], z=np.stack([u, v], -1)[None].astype(np.float32),
                    width=np.full((1, n), 25.0, np.float32),
                    intensity=np.ones((1, n), np.float32), t=t[None].astype(np.float32),
                    dt=np.full((1, n), 1 / FPS, np.float32), present=np.ones((1, n), bool),
                    length=np.array([n], np.int32), v_top=None)
    calls = []
    monkeypatch.setattr(sc, "undo_union", lambda b, fps: (calls.append(fps), (b, 0))[1])
    cfg = Config(camera=CAM)
    assert sc.fit_selfcal(cfg, tb).camera is None  # one track: refused either way
    assert calls == []
    assert sc.fit_selfcal(cfg, tb, frame_union=True).camera is None
    assert calls == [FPS]  # at the config's frame rate


def test_the_command_passes_frame_union(tmp_path, selfcal_calls, capsys):
    import json

    from fit.cli import main as fit_main
    from rhythmjax.io import write_table

    n = 40
    t, u, v, _ = walk(n, True)
    cols = {"track_id": np.array(["a"] * n), "frame": np.arange(n), "t": t, "u": u, "v": v,
            "width_px": np.full(n, 25.0), "intensity": np.ones(n)}
    tracks = tmp_path / "tracks.csv"
    write_table(tracks, cols, list(cols))
    start = tmp_path / "start.json"
    start.write_text(json.dumps({"camera": {"image_width_px": 480, "image_height_px": 360,
                                            "fps": FPS}}))
    for extra, want in (((), False), (("--frame-union",), True)):
        rc = fit_main(["selfcal", str(tracks), "-c", str(start), "-o",
                       str(tmp_path / "cam.json"), *extra])
        # one track: refused, after the fit was asked
        assert rc == 1 and selfcal_calls[-1].get("frame_union") is want
    capsys.readouterr()
