"""The top row of the moving region (the head): `Detection.top`, the tracker's `v_top` column,
the tracks format's optional `v_top`, and `rhythmjax.sim.tracks`' synthetic top rows (issue 19's
height cue). References: hand-drawn motion images, the renderer's true head row, a NumPy
projection of (3), files with and without the column."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.io import read_tracks, to_batch, write_table
from rhythmjax.model.params import Camera, Config
from rhythmjax.sim.scene import SceneSpec, render_scene, walker
from rhythmjax.sim.tracks import HEIGHT_M, make_tracks
from rhythmjax.track.tracker import OnlineTracker
from rhythmjax.vision.detect import detect_in_window


def test_detection_top_row_of_a_block():
    m = np.zeros((200, 200), np.uint8)
    m[60:150, 90:110] = 1  # rows 60-149
    d = detect_in_window(m, (100, 120), (80, 160), fraction=0.1)  # window rows 40-199
    assert d is not None and d.v == 149 and d.top == 60.0
    # the window's top cuts the block: the head may lie above it, no top row
    d = detect_in_window(m, (100, 150), (80, 160), fraction=0.1)  # window rows 70-229
    assert d is not None and d.v == 149 and math.isnan(d.top) and not d.top_at_edge
    # a block from the image's first row: cut there, at the edge (rule 37b's lower bound)
    m[0:60, 90:110] = 1
    d = detect_in_window(m, (100, 100), (80, 240), fraction=0.1)  # window rows -20-219
    assert d is not None and d.v == 149 and math.isnan(d.top) and d.top_at_edge
    d = detect_in_window(m, (100, 120), (80, 240), fraction=0.1)  # window rows 0-239
    assert d is not None and math.isnan(d.top) and d.top_at_edge


def _cols(with_top: bool) -> dict:
    k = np.arange(6)
    cols = {"track_id": np.array(["a"] * 3 + ["b"] * 3), "frame": np.r_[0, 1, 3, 0, 1, 2],
            "t": np.r_[0, 1, 3, 0, 1, 2] / 15.0, "u": 100.0 + k, "v": 200.0 + k,
            "width_px": np.full(6, 20.0), "intensity": np.full(6, 5.0)}
    if with_top:
        cols["v_top"] = np.r_[120.0, np.nan, 122.0, 90.0, 91.0, 92.0]
    return cols


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_tracks_format_v_top_is_optional(tmp_path, suffix):
    p = tmp_path / f"with{suffix}"
    cols = _cols(True)
    write_table(p, cols, list(cols))
    tr = read_tracks(p)
    np.testing.assert_array_equal(tr.v_top, cols["v_top"])
    b = to_batch(tr, max_gap_frames=5, min_len=4, bucket=False)
    # track a: frames 0, 1, (2 inserted), 3 -> v_top 120, NaN, NaN, 122
    np.testing.assert_array_equal(b.v_top[0], np.array([120, np.nan, np.nan, 122], np.float32))
    np.testing.assert_array_equal(b.v_top[1, :3], np.array([90, 91, 92], np.float32))
    q = tmp_path / f"without{suffix}"
    cols = _cols(False)
    write_table(q, cols, list(cols))
    tr = read_tracks(q)
    assert tr.v_top is None
    assert to_batch(tr, max_gap_frames=5, min_len=4).v_top is None


def test_synthetic_top_rows_project_the_heads():
    cam = Camera()
    cols, truth = make_tracks(n_walkers=6, n_bicycles=0, n_dogs=2, n_cars=0, seed=3, camera=cam,
                              r_std_px=0.0, gap_rate=0.0)
    f, h, th = float(cam.f), float(cam.h), float(cam.theta)
    bf = float(cam.b) * f
    checked = 0
    for tid in np.unique(cols["track_id"]):
        s = cols["track_id"] == tid
        ok = np.isfinite(cols["v_top"][s])  # NaN: the head above the image
        assert np.all(cols["v_top"][s][ok] >= 0)
        if ok.sum() < 2:
            continue
        checked += 1
        y = cols["y"][s][ok]
        # the height implied by foot and top rows through (3) (NumPy, level of the camera's
        # own formula: d(z) = f + y cos + (h - z) sin, Vc - v = b f (y sin - (h - z) cos) / d)
        q = float(cam.vc) - cols["v_top"][s][ok]
        d0 = f + y * math.cos(th) + h * math.sin(th)
        z = (q * d0 - bf * (y * math.sin(th) - h * math.cos(th))) / (bf * math.cos(th)
                                                                     + q * math.sin(th))
        label = str(cols["label"][s][0])
        mu, sd = HEIGHT_M[label]
        assert np.ptp(z) < 1e-4 and abs(z[0] - mu) < 4 * sd
    assert checked >= 6
    # the other columns do not depend on the top rows' draws: the same as without them
    v = cols["v"][cols["track_id"] == "ped000"]
    assert np.all(np.isfinite(v))


def test_tracker_top_row_near_the_true_head():
    cam = Camera(f=0.008, h=4.0, theta=math.radians(20.0), a=700 / 0.008, b=700 / 0.008, uc=320,
                 vc=240, fps=15.0, image_width=640, image_height=480)  # heads in view
    cfg = Config(camera=cam)
    act = walker(-1.5, 11.0, 0.1, pace_hz=2.0, step_length_m=0.7, height_m=1.75)
    scene = render_scene(2, SceneSpec(n_frames=40, actors=(act,), camera=cam))
    tr = OnlineTracker(cfg)
    for k, fr in enumerate(scene.frames):
        tr.update(k, k / scene.fps, fr)
    cols, _, _ = tr.finish()
    truth = scene.truth[0]
    from rhythmjax.model.camera_np import project_3d

    _, head = project_3d(cam, truth.body_x, truth.body_y, np.full(truth.body_x.shape, 1.75))
    fr = cols["frame"]
    ok = np.isfinite(cols["v_top"]) & np.isfinite(cols["v"])
    assert ok.sum() >= 20
    err = cols["v_top"][ok] - np.asarray(head)[fr[ok]]
    # the motion's top is the head's top: within 2 px (median), 6 px (all but a tenth)
    assert abs(np.median(err)) <= 2.0 and np.percentile(np.abs(err), 90) <= 6.0, err
    assert np.all(np.isnan(cols["v_top"][~np.isfinite(cols["v"])]))
    assert not cols["top_at_edge"].any()  # every head in view


def test_tracker_rows_at_the_image_edge():
    """The paper's camera, a walker at 8-10 m: its head is above the image's first row on every
    frame (a 1.7 m walker's top is inside only from 15 m on), so its measured rows have no top
    row and are marked at the edge (rule 37b's rows); predicted rows are not."""
    cfg = Config()
    act = walker(-1.5, 8.0, 0.1, pace_hz=2.0, step_length_m=0.7, height_m=1.7)
    scene = render_scene(2, SceneSpec(n_frames=40, actors=(act,), camera=cfg.camera))
    tr = OnlineTracker(cfg)
    for k, fr in enumerate(scene.frames):
        tr.update(k, k / scene.fps, fr)
    cols, _, _ = tr.finish()
    measured = np.isfinite(cols["v"])
    assert measured.sum() >= 20
    assert np.all(np.isnan(cols["v_top"]))
    assert cols["top_at_edge"][measured].mean() >= 0.9
    assert not cols["top_at_edge"][~measured].any()
