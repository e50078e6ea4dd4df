"""`verdicts.head_speed` (rule 31): an unjudged counting track whose foot rows are mostly a
walker's hips is timed under its heads. The rows of a walker are written out here from the
pin-hole of (3) in NumPy float64 (the dev set README's form for a point z m above the ground,
as in tests/test_count_head_feet.py); the ground points and speed under the heads are checked
against the walker's own, and the counting option on a dev crowd clip where present."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from rhythmjax.count import CountOptions, count_frames, points_speed
from rhythmjax.count.counting import faster_than, head_speed
from rhythmjax.count.head_feet import head_ground_points
from rhythmjax.count.options import with_changes
from rhythmjax.count.patches import ShapeModel, ground_point
from rhythmjax.model.params import Camera, Config, walking_top_speed
from rhythmjax.model.status import TrackState
from rhythmjax.track.rows import TrackRow


CAM = Camera()  # 1 m high, 15 deg down, a f = b f = 800 px, 512 x 512 (the library default)
FPS = 15.0
WALKER_M, HIPS_M = 1.7, 0.9


def pixel(x: float, y: float, z: float) -> tuple[float, float]:
    """(u, v) px of the point (x, y, z) m (eq. (3) with the point z m above the ground)."""
    f, h, th = float(CAM.f), float(CAM.h), float(CAM.theta)
    depth = f + y * math.cos(th) + (h - z) * math.sin(th)
    u = float(CAM.uc) + float(CAM.a) * f * x / depth
    v = float(CAM.vc) - float(CAM.b) * f * (y * math.sin(th) - (h - z) * math.cos(th)) / depth
    return u, v


def walker_rows(n=30, y=20.0, vx=1.4, foot_z=None, state=TrackState.OBSERVE):
    """A walker y m ahead (20 m: its head inside the default camera's image, which cuts those
    nearer than about 15 m) crossing at vx m/s from x = -1 m: per row the foot column, the row
    of the point `foot_z[k]` m up (0: the feet; 0.9: the hips, where the mask lost the legs)
    and the head's row (1.7 m); t, x, y of the truth."""
    foot_z = np.zeros(n) if foot_z is None else np.asarray(foot_z, float)
    rows, truth = [], []
    for k in range(n):
        t, x = k / FPS, -1.0 + vx * k / FPS
        u, v = pixel(x, y, float(foot_z[k]))
        v_top = pixel(x, y, WALKER_M)[1]
        rows.append(TrackRow(k, t, u, v, 20.0, 1.0, math.nan, math.nan, int(state),
                             v_top=v_top))
        truth.append((t, x, y))
    return rows, np.asarray(truth)


def shape() -> ShapeModel:
    return ShapeModel.from_config(Config(camera=CAM), "3d")


def test_a_walker_tracked_on_its_hips_is_placed_under_its_head():
    """Hips 0.9 m up, 20 m ahead: the hip row is 4.4 px below the horizon, whose ground point
    lies 196 m away (the foot rows' speed is meaningless); the heads give back the walker's
    distance within 1 mm and its x and speed (1.4 m/s) within 1.5 %: the column given is the
    hips', 1.20 % farther from the centre column than the feet's at 20 m (the tilted camera's
    depth (3) at 0.9 m against 0 m), measured +1.20 %."""
    rows, truth = walker_rows(foot_z=np.full(30, HIPS_M))
    _, y_hips, ok = ground_point(CAM, rows[0].u, rows[0].v)
    assert not (bool(ok) and float(y_hips) < 100.0)
    pts = head_ground_points(shape(), rows, CAM.image_height)
    assert pts is not None and pts.shape == (30, 3)
    assert np.allclose(pts[:, 0], truth[:, 0])
    assert np.max(np.abs(pts[:, 2] - truth[:, 2])) < 0.001
    assert np.allclose(pts[:, 1], truth[:, 1], rtol=0.015, atol=0.0)
    assert points_speed(pts[:, 0], pts[:, 1], pts[:, 2]) == pytest.approx(1.4, rel=0.015)


def test_a_track_on_its_feet_keeps_its_own_ground_points():
    """Foot rows on the feet: no head points (None), so the track's own speed stands; with
    fewer than half of its rows on the hips likewise; from half on, the heads are read."""
    s = shape()
    assert head_ground_points(s, walker_rows()[0], CAM.image_height) is None
    for hips, read in ((14, False), (15, True)):
        z = np.where(np.arange(30) < hips, HIPS_M, 0.0)
        assert (head_ground_points(s, walker_rows(foot_z=z)[0], CAM.image_height)
                is not None) == read


def test_rows_without_a_head_or_not_observed_are_left_out():
    """Predicted rows and rows whose top row is unmeasured (NaN) give no point; a track with
    none left gives None."""
    s = shape()
    rows, _ = walker_rows(foot_z=np.full(30, HIPS_M))
    rows = [r._replace(v_top=math.nan) if k % 3 == 0 else r for k, r in enumerate(rows)]
    rows[1] = rows[1]._replace(state=int(TrackState.PREDICT))
    pts = head_ground_points(s, rows, CAM.image_height)
    assert pts.shape == (30 - 10 - 1, 3)
    assert head_ground_points(s, [r._replace(v_top=math.nan) for r in rows],
                              CAM.image_height) is None


def test_head_speed_of_a_pedestrian_and_the_too_fast_test():
    """`head_speed` of a track's rows; `faster_than` takes the head speed where there is
    one (both ways), else the track's own."""
    hips, _ = walker_rows(foot_z=np.full(30, HIPS_M))
    assert head_speed(shape(), hips, CAM.image_height) == pytest.approx(1.4, rel=0.015)
    assert math.isnan(head_speed(shape(), walker_rows()[0], CAM.image_height))
    top = walking_top_speed(Config())
    got = faster_than([5.0, 5.0, 1.0, 1.0, math.nan], [1.4, math.nan, 4.0, math.nan, math.nan],
                      top)
    assert got.tolist() == [False, True, True, False, False]


def test_option_is_on_by_default():
    assert CountOptions().verdicts.head_speed is True  # since issue 16's thirty-second round


DEV = Path(os.environ.get("RHYTHMJAX_DATA", Path(__file__).resolve().parents[2] / "shared"
                          / "data")) / "dev"
CROWD = DEV / "dev_crowd_03.avi"


@pytest.mark.skipif(not CROWD.exists(), reason="dev clips not present")
def test_dev_crowd_counts_walkers_tracked_on_their_upper_bodies():
    """dev_crowd_03 (8 walkers, trousers near the road's grey): without the option 4 are
    counted; with it (the default) two more tracks count (measured 2026-12-05: 4 -> 6), each
    with a head speed of a walk (1.85 and 2.00 m/s) where its foot rows read 4.2 and 5.8 m/s.
    The rule only re-times tracks: the tracks are the same either way."""
    from rhythmjax.model.config_setup import config_for
    from rhythmjax.vision.video import VideoSource

    truth = json.loads((DEV / "dev_crowd_03.json").read_text())
    cam = truth["camera"]
    camera = {k: cam[k] for k in ("f_m", "h_m", "theta_deg", "a_px_per_m", "b_px_per_m",
                                  "uc_px", "vc_px")}  # the folder README's camera
    frames = list(VideoSource(str(CROWD), fps=truth["fps"]))
    cfg = config_for({"camera": camera}, image_size=(cam["width_px"], cam["height_px"]),
                     fps=truth["fps"])
    off = count_frames(cfg, iter(frames), n_frames=len(frames),
                       options=with_changes(CountOptions(), {"verdicts.head_speed": False}))
    on = count_frames(cfg, iter(frames), n_frames=len(frames))
    assert np.array_equal(off.tracks["u"], on.tracks["u"], equal_nan=True)
    assert (off.counts["walkers"], on.counts["walkers"]) == (4, 6)
    head = np.asarray(on.verdicts["head_speed_mps"], float)
    gained = np.asarray(on.verdicts["counted"]) & ~np.asarray(off.verdicts["counted"])
    assert gained.sum() == 2 and np.all(head[gained] < 2.1)
    assert np.all(np.asarray(off.verdicts["track_speed_mps"], float)[gained] > 4.0)
