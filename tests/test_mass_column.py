"""Rule 48 (`body.mass_column`, `track.lean.motion_column`): window B's column on a measured
frame the mean column of the motion over the body.

Reference: a float64 loop over every pixel, written here: the columns x with
floor(u - W) <= x <= floor(u + W) and the rows y with floor(v - H) <= y <= floor(v), both
inside the image; the pixels with D > threshold are motion; their mean x is the column. Through
the tracker, every I(k) of a measured frame must be summed at that column of the frame's own
difference (and at the measured foot column with the rule off), at the measured row."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.track.lean import motion_column, window_b_foot


def column_by_loop(D, u, v, W, H, threshold):
    """The reference: the mean column of D > threshold in the box, NaN where it holds none."""
    total = count = 0.0
    for y in range(max(0, math.floor(v - H)), min(D.shape[0] - 1, math.floor(v)) + 1):
        for x in range(max(0, math.floor(u - W)), min(D.shape[1] - 1, math.floor(u + W)) + 1):
            if float(D[y, x]) > threshold:
                total, count = total + x, count + 1
    return total / count if count else math.nan


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_motion_column_is_the_loop_on_random_images(seed):
    rng = np.random.default_rng(seed)
    D = (rng.random((90, 140)) ** 4 * 60).astype(np.uint8)  # mostly below 15, some above
    for _ in range(25):
        u, v = rng.uniform(-10, 150), rng.uniform(-5, 100)
        W, H = rng.uniform(1, 25), rng.uniform(2, 70)
        got, want = motion_column(D, u, v, W, H, 15.0), column_by_loop(D, u, v, W, H, 15.0)
        assert (math.isnan(got) and math.isnan(want)) or got == pytest.approx(want, abs=1e-9)


def test_motion_column_by_hand():
    D = np.zeros((100, 200), np.uint8)
    D[50:60, 30] = 40
    D[50:60, 36] = 40
    D[40, 33] = 15  # at the threshold: not motion
    assert motion_column(D, 33.0, 70.0, 5.0, 30.0, 15.0) == 33.0
    D[55, 38] = 40  # one pixel more on the right
    assert motion_column(D, 33.0, 70.0, 5.0, 30.0, 15.0) == pytest.approx(
        (10 * 30 + 10 * 36 + 38) / 21, abs=1e-12)
    D[20, 38] = 200  # above the body's rows: left out
    D[71, 31] = 200  # below the foot row: left out
    assert motion_column(D, 33.0, 70.0, 5.0, 30.0, 15.0) == pytest.approx(
        (10 * 30 + 10 * 36 + 38) / 21, abs=1e-12)


def test_motion_column_is_nan_without_motion_or_inputs_and_window_b_keeps_u_p():
    from rhythmjax.model.params import Config
    from rhythmjax.track.options import TrackerOptions, with_changes

    D = np.zeros((50, 50), np.uint8)
    D[10, 10] = 99
    assert math.isnan(motion_column(D, 30.0, 40.0, 3.0, 10.0, 15.0))  # no motion in the box
    assert math.isnan(motion_column(None, 30.0, 40.0, 3.0, 10.0, 15.0))
    assert math.isnan(motion_column(D, 30.0, 40.0, math.nan, 10.0, 15.0))
    assert math.isnan(motion_column(D, 30.0, math.inf, 3.0, 10.0, 15.0))
    assert math.isnan(motion_column(D, 300.0, 40.0, 3.0, 10.0, 15.0))  # the box outside
    on = with_changes(TrackerOptions(), {"body.mass_column": True})
    z = (30.0, 40.0)
    assert window_b_foot(z, (29.0, 39.0), True, 0.0, on, Config().camera, 1.7, D,
                         (3.0, 10.0)) == z  # none in the box: the paper's u_p


def test_window_b_foot_reads_the_mass_only_on_a_measured_frame():
    from rhythmjax.model.params import Camera
    from rhythmjax.track.options import TrackerOptions, with_changes

    camera = Camera(f=0.008, h=3.0, theta=math.radians(20.0), a=1.0e5, b=1.0e5, uc=256.0,
                    vc=256.0)
    D = np.zeros((400, 500), np.uint8)
    D[250:320, 292:297] = 60  # the body's motion, left of the measured column 300
    z, est = (300.0, 320.0), (297.5, 318.0)
    on = with_changes(TrackerOptions(), {"body.mass_column": True})
    assert window_b_foot(z, est, True, 0.0, on, camera, 1.7, D, (10.0, 34.0)) == (294.0, 320.0)
    # rule 16's side shift moves the box: its motion still in it, the column the same
    assert window_b_foot(z, est, True, 2.0, on, camera, 1.7, D, (10.0, 34.0)) == (294.0, 320.0)
    assert window_b_foot(z, est, False, 0.0, on, camera, 1.7, D, (10.0, 34.0)) == est
    off = TrackerOptions()
    assert window_b_foot(z, est, True, 0.0, off, camera, 1.7, D, (10.0, 34.0)) == z
    threshold_high = with_changes(on, {"motion.diff_threshold": 60.0})
    assert window_b_foot(z, est, True, 0.0, threshold_high, camera, 1.7, D, (10.0, 34.0)) == z


@pytest.mark.parametrize("way", ["off", "on", "gated, across", "gated, along"])
def test_tracker_sums_window_b_at_the_motion_column(monkeypatch, way):
    """A walker crossing the view (or, `along`, coming nearer): every I(k) of a measured row
    summed at the reference column of that frame's difference D where the rule applies (on;
    gated, across) or at the measured foot column (off; gated, along: rule 48b leaves a walker
    on the line of sight alone), the measured row either way; the EKF's measurement (the tracks'
    u, v) is the detection's every way."""
    import equinox as eqx
    import jax.numpy as jnp

    from rhythmjax.model.params import Config
    from rhythmjax.sim import scene as synth
    from rhythmjax.track import lean, track_frames, tracker as trk
    from rhythmjax.track.options import TrackerOptions, with_changes

    # walkers 1.5 m tall in the config: the box's height is the config's, not a fixed 3.4 W
    cfg = eqx.tree_at(lambda c: c.width.height, Config(), jnp.asarray(1.5, jnp.float32))
    act = (synth.walker(0.4, 15.0, -math.pi / 2, pace_hz=1.9, step_length_m=0.65)
           if way.endswith("along") else
           synth.walker(-2.0, 11.0, 0.0, pace_hz=1.9, step_length_m=0.65))
    sc = synth.render_scene(7, synth.SceneSpec(n_frames=48, actors=(act,), camera=cfg.camera))
    calls = []
    inner = trk.detect.window_b_intensity

    def record(D, u, v, W, **kw):
        calls.append((D.copy(), float(u), float(v), float(W)))
        return inner(D, u, v, W, **kw)

    monkeypatch.setattr(trk.detect, "window_b_intensity", record)
    sines = []
    inner_sine = lean.crossing_sine

    def record_sine(*args):
        sines.append(inner_sine(*args))
        return sines[-1]

    monkeypatch.setattr(lean, "crossing_sine", record_sine)
    # rule 54's upper-body column off: with it window B stays on the slice extent where the
    # track's u moves (`test_column_filter.py`), and this test reads window B against that u
    opt = with_changes(TrackerOptions(), {"body.mass_column": way != "off",
                                          "body.mass_crossing": 0.7071 if "gated" in way else 0.0,
                                          "body.window_candidates": False,
                                          "body.column_rows": None})
    tracks = track_frames(cfg, ((i, i / sc.fps, f) for i, f in enumerate(sc.frames)),
                          progress=False, options=opt)[0]
    rows = np.isfinite(tracks["intensity"])
    assert rows.sum() >= 25 and len(calls) == rows.sum()
    u, v = tracks["u"][rows], tracks["v"][rows]
    measured = np.isfinite(u)
    assert measured.sum() >= 25
    per_W = float(cfg.width.height_per_width())
    if "gated" in way:  # one angle per measured row, the EKF's: across the view or along it
        assert len(sines) == measured.sum()
        crossing = np.array(sines) >= 0.7071
        assert crossing.mean() > 0.8 if way.endswith("across") else crossing.mean() < 0.2
    else:
        assert not sines
        crossing = np.full(measured.sum(), way == "on")
    moved = 0
    for (D, cu, cv, W), a, b, applies in zip([c for c, m in zip(calls, measured) if m],
                                             u[measured], v[measured], crossing):
        mass = column_by_loop(D, a, b, W, W * per_W, 15.0)
        expected = mass if applies and math.isfinite(mass) else a
        assert cu == pytest.approx(expected, abs=1e-6)
        assert cv == pytest.approx(b, abs=1e-9)
        moved += abs(mass - a) > 0.25
    assert moved >= 10  # the mass column lies elsewhere on most rows: the test can tell


def sine_by_hand(cam, x, vx, y, vy):
    """(3) without roll, u = uc + a f x / d with d = f + y cos(theta) + h sin(theta): grad u is
    a f (d, -x cos(theta)) / d^2, and the sine is |grad u . v| / (|grad u| |v|)."""
    f, h, th = float(cam.f), float(cam.h), float(cam.theta)
    d = f + y * math.cos(th) + h * math.sin(th)
    g = (d, -x * math.cos(th))
    return abs(g[0] * vx + g[1] * vy) / (math.hypot(*g) * math.hypot(vx, vy))


@pytest.mark.parametrize("x, vx, y, vy", [(2.0, 1.0, 10.0, 0.0), (-3.0, 0.3, 6.0, -1.2),
                                          (4.0, 0.0, 5.0, 1.4), (0.5, -0.9, 18.0, 0.9),
                                          (-1.5, 1.1, 3.0, 0.2)])
def test_crossing_sine_is_the_angle_to_the_line_of_sight(x, vx, y, vy):
    from rhythmjax.model.params import Camera
    from rhythmjax.track.lean import crossing_sine

    cam = Camera(f=0.008, h=3.0, theta=math.radians(20.0), a=1.0e5, b=1.0e5, uc=256.0,
                 vc=256.0)
    # 1 cm central differences: a truncation error of ~1e-6 near the camera; a wrong axis or
    # sign is off by > 0.01
    assert crossing_sine(cam, x, vx, y, vy) == pytest.approx(sine_by_hand(cam, x, vx, y, vy),
                                                             abs=1e-5)


def test_crossing_sine_ends():
    from rhythmjax.model.camera_np import ground_of_pixels, project_3d
    from rhythmjax.model.params import Config
    from rhythmjax.track.lean import crossing_sine

    cam = Config().camera
    u, v = project_3d(cam, 2.0, 10.0, 0.0)
    x2, y2, _ = ground_of_pixels(cam, float(u), float(v) - 30.0)  # further along one column
    assert crossing_sine(cam, 2.0, x2 - 2.0, 10.0, y2 - 10.0) == pytest.approx(0.0, abs=1e-5)
    assert crossing_sine(cam, 0.0, 1.3, 10.0, 0.0) == pytest.approx(1.0, abs=1e-9)
    assert math.isnan(crossing_sine(cam, 1.0, 0.0, 5.0, 0.0))


def test_window_b_foot_gates_the_mass_by_the_crossing_angle():
    from rhythmjax.model.params import Config
    from rhythmjax.track.options import TrackerOptions, with_changes

    cam = Config().camera
    D = np.zeros((400, 500), np.uint8)
    D[250:320, 292:297] = 60
    z, est = (300.0, 320.0), (297.5, 318.0)
    gated = with_changes(TrackerOptions(), {"body.mass_column": True,
                                            "body.mass_crossing": 0.7071})
    across, along = (0.0, 1.3, 10.0, 0.0), (0.0, 0.0, 10.0, 1.3)  # (x, vx, y, vy)
    args = (z, est, True, 0.0, gated, cam, 1.7, D, (10.0, 34.0))
    assert window_b_foot(*args, np.array(across)) == (294.0, 320.0)
    assert window_b_foot(*args, np.array(along)) == z
    assert window_b_foot(*args, np.array((0.0, 0.0, 10.0, 0.0))) == z  # standing: no angle
    assert window_b_foot(*args, None) == z
    # at 50 degrees to the line of sight (sine 0.77) in, at 40 (0.64) out; on the centre
    # column the line of sight is the y axis
    for deg, expected in ((50, (294.0, 320.0)), (40, z), (60, (294.0, 320.0)), (30, z)):
        state = (0.0, 1.3 * math.sin(math.radians(deg)), 10.0, 1.3 * math.cos(math.radians(deg)))
        assert window_b_foot(*args, np.array(state)) == expected, deg
