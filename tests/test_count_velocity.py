"""Per-frame velocities of count's pedestrians (the tracking paper's velocity output) and the
measured width of (10) in count's tracks: `slot_filter.image_velocity` against finite differences of
a float64 projection, MOT extra columns round trip, and a walker's tracks."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.count import CountOptions, count_frames
from rhythmjax.count.patches import ShapeModel
from rhythmjax.count.slot_filter import image_velocity
from rhythmjax.io import BadInput
from rhythmjax.io.mot import MOT_COLUMNS, VELOCITY_COLUMNS, read_mot, write_mot
from rhythmjax.model.camera_np import camera_tuple, project_3d
from rhythmjax.sim.scene import SceneSpec, render_scene, walker

from .test_pedestrians import CFG, QUIET


def test_image_velocity_is_the_projection_derivative():
    """d(u, v)/dt of a ground state moving at (vx, vy): central differences (+-1 ms) of the
    float64 projection (3) (`camera_np.project_3d`) of (x + vx t, y + vy t); float32 JAX,
    so within 1e-3 relative."""
    rng = np.random.default_rng(5)
    cam = camera_tuple(CFG.camera)
    for _ in range(20):
        x, y = rng.uniform(-3, 3), rng.uniform(4, 14)
        vx, vy = rng.uniform(-2, 2, 2)
        got = np.asarray(image_velocity(CFG.camera, jnp.asarray([x, vx, y, vy], jnp.float32)))
        h = 1e-3
        a = np.asarray(project_3d(cam, x + vx * h, y + vy * h, 0.0), np.float64)
        b = np.asarray(project_3d(cam, x - vx * h, y - vy * h, 0.0), np.float64)
        want = (a - b) / (2 * h)
        np.testing.assert_allclose(got, want, rtol=1e-3, atol=1e-2)


def test_mot_extra_columns_round_trip(tmp_path):
    cols = {"frame": np.array([2, 1, 1]), "id": np.array([1, 2, 1]),
            "bb_left": np.array([10.0, 50.0, 12.5]), "bb_top": np.array([20.0, 20.0, 21.0]),
            "bb_width": np.array([30.0, 30.0, 30.0]), "bb_height": np.array([40.0, 40, 40]),
            "conf": np.array([1.0, 0.5, 1.0]), "x": np.array([2.5, -1.0, 2.6]),
            "y": np.array([8.0, -1.0, 8.1]), "z": np.array([0.0, -1.0, 0.0]),
            "vx": np.array([1.25, np.nan, 1.5]), "vy": np.array([-0.25, np.nan, 0.0]),
            "du": np.array([15.5, 3.0, -2.0]), "dv": np.array([np.nan, 4.0, 0.125])}
    p = tmp_path / "mot_velocity.txt"
    write_mot(p, cols, VELOCITY_COLUMNS)
    lines = p.read_text().splitlines()
    assert lines[0] == "1,1,12.5,21,30,40,1,2.6,8.1,0,1.5,0,-2,0.125"  # sorted by frame, id
    assert lines[1] == "1,2,50,20,30,40,0.5,-1,-1,-1,nan,nan,3,4"
    back = read_mot(p, extra=VELOCITY_COLUMNS)
    order = [2, 1, 0]
    for c in (*MOT_COLUMNS, *VELOCITY_COLUMNS):
        np.testing.assert_array_equal(back[c], cols[c][order])
    with pytest.raises(BadInput, match="expected 6 to 10"):
        read_mot(p)  # the extras must be asked for
    std = tmp_path / "mot.txt"
    write_mot(std, cols)  # without extra: the ten standard columns only
    assert all(len(line.split(",")) == 10 for line in std.read_text().splitlines())
    assert np.isnan(read_mot(std, extra=VELOCITY_COLUMNS)["vx"]).all()
    with pytest.raises(ValueError, match="extra column"):
        write_mot(std, cols, ("x",))


@pytest.fixture(scope="module")
def walker_counts():
    """One walker crossing 8 m ahead (pace 2.05 Hz x step 0.72 m = 1.476 m/s), counted with
    both dynamics families."""
    a = walker(-3.0, 8.0, 0.0, start_frame=2, phase=0.2)
    frames = render_scene(3, SceneSpec(n_frames=60, actors=(a,), camera=CFG.camera)).frames
    items = [(k, k / 15.0, f) for k, f in enumerate(frames)]
    opt = {dyn: CountOptions(dynamics=dyn, verdicts=QUIET)
           for dyn in ("3d", "2d")}
    return {dyn: count_frames(CFG, iter(items), options=o) for dyn, o in opt.items()}


def test_count_writes_ground_and_image_velocities(walker_counts):
    """"3d": vx, vy are the EKF's (finite); their median speed over the last two thirds of the
    measured rows is the walker's 1.476 m/s within 0.15 m/s (1.54 measured); du, dv agree with
    the frame-to-frame motion of the box's foot point (median within 15 px/s; 0.01 measured).
    "2d": no ground velocity (NaN), du, dv finite. The MOT columns carry the tracks' values."""
    res = walker_counts["3d"]
    tr, mot = res.tracks, res.mot
    assert res.counts["tracks"] == 1
    meas = tr["state"] == "observe"
    assert np.isfinite(tr["vx"]).all() and np.isfinite(tr["du"]).all()
    speed = np.hypot(tr["vx"][meas], tr["vy"][meas])
    assert abs(np.median(speed[len(speed) // 3:]) - 2.05 * 0.72) < 0.15
    u = mot["bb_left"] + 0.5 * mot["bb_width"]
    du_seen = np.diff(u) * 15.0
    assert abs(np.median(du_seen[10:] - mot["du"][11:])) < 15.0
    for c in VELOCITY_COLUMNS:
        np.testing.assert_array_equal(mot[c], tr[c])
    res2 = walker_counts["2d"]
    assert np.isnan(res2.tracks["vx"]).all() and np.isnan(res2.tracks["vy"]).all()
    assert np.isfinite(res2.tracks["du"]).all() and np.isfinite(res2.tracks["dv"]).all()


def test_count_tracks_measure_the_width(walker_counts):
    """width_px of a measured row is the blob's measured width, not the model patch width:
    it varies with the stride (the patch width at a foot row does not) and stays NaN when
    predicted. Measured: 9 to 26 px against a model width of 12 px, median ratio 1.95 (the
    drawn walker's extent with legs and arms apart is wider than the 0.5 m model)."""
    tr = walker_counts["3d"].tracks
    meas = tr["state"] == "observe"
    w = tr["width_px"][meas]
    assert np.isfinite(w).all() and np.isnan(tr["width_px"][~meas]).all()
    shape = ShapeModel.from_config(CFG, "3d")
    model = np.asarray([float(shape.size(u, v)[0]) for u, v in zip(tr["u"][meas],
                                                                    tr["v"][meas])])
    ratio = w / model
    assert np.std(ratio) > 0.2 and 1.2 < np.median(ratio) < 2.6
