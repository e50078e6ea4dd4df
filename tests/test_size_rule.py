"""Rule 26 (`track.size`, on by default since issue 16's thirty-first round): a track judged
Pedestrian whose median measured height (over its deciding window's rows, 26c) is below
`size.min_height_heights` walker heights is Non-pedestrian (too-low). The height of a top row
(`camera_np.height_of_top`) against a hand-worked level camera, the projection it inverts (with
roll) and the fit's JAX form; the rule's cases; the tracker."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from fit.selfcal_height import height_from_top
from rhythmjax.model.camera_np import HostCamera, height_of_top, project_3d
from rhythmjax.model.params import Camera, Config
from rhythmjax.model.status import Reason, Verdict
from rhythmjax.sim import scene as synth
from rhythmjax.track.options import SizeOptions, TrackerOptions, with_changes
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.size import median_height, refuse_low, too_low
from rhythmjax.track.tracker import OnlineTracker


TILTED = HostCamera(f=0.008, h=7.0, theta=0.4, a=1e5, b=1.1e5, uc=320.0, vc=240.0, roll=0.05)
ON = SizeOptions(min_height_heights=0.5, min_height_rows=10)


def test_level_camera_height_by_hand():
    """theta = roll = 0: a ground row is v = Vc + b f h / (f + y) and a point z m up is at
    Vc + b f (h - z) / (f + y), so z = h (v - v_top) / (v - Vc): h = 2 m, Vc = 240, v = 340,
    v_top = 190 gives 3.0 m."""
    level = HostCamera(f=0.008, h=2.0, theta=0.0, a=1e5, b=1e5, uc=320.0, vc=240.0)
    H, ok = height_of_top(level, 320.0, 340.0, 190.0)
    assert bool(ok) and abs(float(H) - 3.0) < 1e-12


@pytest.mark.parametrize("z", [0.3, 0.6, 1.7, 2.5])
def test_height_inverts_the_projection_with_roll(z):
    """The top of a z m segment projected by (3) with roll (`project_3d`) reads back as z m
    (float64 round trip, 1e-9 m), at three ground points across the image."""
    x, y = np.array([-2.0, 1.0, 3.0]), np.array([8.0, 15.0, 30.0])
    u, v = project_3d(TILTED, x, y, 0.0 * x)
    _, v_top = project_3d(TILTED, x, y, z + 0.0 * x)
    H, ok = height_of_top(TILTED, u, v, v_top)
    assert ok.all() and np.max(np.abs(H - z)) < 1e-9


def test_not_ok_rows_are_left_out():
    """A missing top row, a missing foot point, a foot point above the horizon (row -132 here)
    and a top at the vertical vanishing point give ok False and H = 0."""
    u, v = project_3d(TILTED, 0.0, 10.0, 0.0)
    vanishing = TILTED.vc + TILTED.b * TILTED.f / math.tan(TILTED.theta)  # straight down
    H, ok = height_of_top(TILTED, np.array([u, math.nan, u, u]), np.array([v, v, -200.0, v]),
                          np.array([math.nan, v - 50, -80.0, vanishing]))
    assert not ok.any() and (H == 0).all()
    h, n = median_height(TILTED, [u, u], [v, v], [math.nan, math.nan], 1.7)
    assert math.isnan(h) and n == 0


def test_rows_where_a_walkers_head_leaves_the_image_are_not_read():
    """The paper's 1 m camera (tilted 15 deg, 512 px rows): a 1.7 m walker's head is above the
    image nearer than about 14 m, so a top row read there is not its head. A 0.6 m top at 8 m
    and at 30 m: only the 30 m rows give a height (0.6 m); with a 0.5 m walker every row
    does."""
    cam = Config().camera
    y = np.array([8.0, 8.0, 30.0, 30.0, 30.0])
    u, v = project_3d(cam, 0 * y, y, 0 * y)
    _, v_top = project_3d(cam, 0 * y, y, 0.6 + 0 * y)
    h, n = median_height(cam, u, v, v_top, 1.7)
    assert n == 3 and abs(h - 0.6) < 1e-5  # float32 camera constants
    assert median_height(cam, u, v, v_top, 0.5)[1] == 5


def test_rule_36_reads_a_top_seen_inside_the_image():
    """Rule 36 (`top_inside_heights`): at 8 m the paper's camera puts a 1.7 m walker's head
    34.9 px above the image (foot row 145.5, the walker 180.3 px tall), so rule 26 reads no row
    there. A 0.6 m top seen at row 84.1 is 84.1 / 180.3 = 0.47 walker heights below the edge:
    with 0.1 those rows count and read 0.6 m; a walker's top at the edge (row 1) and a top at
    0.09 walker heights (row 16.2) still do not; at 0.1 walker heights + 0.1 px (row 18.1) it
    counts. Rows at 30 m (the head inside) read as before."""
    cam = Config().camera
    y = np.array([8.0, 8.0, 30.0])
    u, v = project_3d(cam, 0 * y, y, 0 * y)
    _, v_top = project_3d(cam, 0 * y, y, 0.6 + 0 * y)
    assert median_height(cam, u, v, v_top, 1.7)[1] == 1
    h, n = median_height(cam, u, v, v_top, 1.7, 0.1)
    assert n == 3 and abs(h - 0.6) < 1e-5
    walker_px = 180.33557808
    for top, counted in ((1.0, 1), (0.09 * walker_px, 1), (0.1 * walker_px + 0.1, 3)):
        tops = np.array([top, top, v_top[2]])
        assert median_height(cam, u, v, tops, 1.7, 0.1)[1] == counted
    with pytest.raises(ValueError, match="top_inside_heights"):
        SizeOptions(top_inside_heights=-0.1)


def test_the_fit_reads_the_same_height():
    """`fit.selfcal_height.height_from_top` (JAX, float64 data) against `height_of_top` (NumPy,
    float64) on the same float32 camera: within 2e-6 m (the JAX camera's sines and cosines are
    float32, 1e-7 relative; a wrong term would be off by centimetres)."""
    cam = Camera(f=TILTED.f, h=TILTED.h, theta=TILTED.theta, a=TILTED.a, b=TILTED.b,
                 uc=TILTED.uc, vc=TILTED.vc, roll=TILTED.roll)
    u, v = project_3d(TILTED, np.array([-1.0, 2.0]), np.array([9.0, 20.0]), np.zeros(2))
    v_top = v - np.array([120.0, 40.0])
    with jax.enable_x64(True):
        H_fit, ok_fit = height_from_top(cam, jnp.asarray(u), jnp.asarray(v), jnp.asarray(v_top))
    host = TILTED._replace(**{k: float(np.float32(getattr(TILTED, k)))
                              for k in HostCamera._fields})
    H, ok = height_of_top(host, u, v, v_top)  # the float32 camera the JAX one holds
    assert ok.all() and bool(np.all(ok_fit)) and np.max(np.abs(np.asarray(H_fit) - H)) < 2e-6


@pytest.mark.parametrize("verdict, height, rows, options, low", [
    (Verdict.PEDESTRIAN, 0.6, 10, ON, True),           # a dog's height, enough rows
    (Verdict.PEDESTRIAN, 0.85, 50, ON, False),         # exactly half of 1.7 m: not below
    (Verdict.PEDESTRIAN, 0.84, 50, ON, True),
    (Verdict.PEDESTRIAN, 0.6, 9, ON, False),           # too few rows: the verdict stands
    (Verdict.PEDESTRIAN, math.nan, 50, ON, False),
    (Verdict.NON_PEDESTRIAN, 0.6, 50, ON, False),      # only a Pedestrian is turned
    (Verdict.UNCLASSIFIED, 0.6, 50, ON, False),
    (Verdict.PEDESTRIAN, 0.6, 50, SizeOptions(), True),  # on by default (0.5)
    (Verdict.PEDESTRIAN, 0.6, 50, SizeOptions(min_height_heights=0.0), False),  # 0: off
])
def test_too_low_cases(verdict, height, rows, options, low):
    assert too_low(verdict, height, rows, 1.7, options) is low


def _rows(top_m, n, camera=TILTED):
    """n measured rows of a walker at 10-14 m whose top is `top_m` m above its feet, and a
    predicted row (no foot point, no top)."""
    y = np.linspace(10.0, 14.0, n)
    u, v = project_3d(camera, 0.5 + 0 * y, y, 0 * y)
    _, v_top = project_3d(camera, 0.5 + 0 * y, y, top_m + 0 * y)
    rows = [TrackRow(i, i / 15, float(a), float(b), 20.0, 1.0, 0.5, float(c), 2, float(d))
            for i, (a, b, c, d) in enumerate(zip(u, v, y, v_top))]
    return rows + [TrackRow(n, n / 15, math.nan, math.nan, math.nan, math.nan, 0.5, 14.0, 3)]


@pytest.mark.parametrize("top_m, n, turned", [(0.6, 12, True), (1.7, 12, False),
                                              (0.6, 9, False)])
def test_refuse_low_turns_a_low_pedestrian(top_m, n, turned):
    result = {"verdict": int(Verdict.PEDESTRIAN), "reason": int(Reason.MATCHED), "pace_hz": 2.0}
    out = refuse_low(result, TILTED, _rows(top_m, n), 1.7, ON)
    if turned:
        assert out["verdict"] == Verdict.NON_PEDESTRIAN and out["reason"] == Reason.TOO_LOW
        assert out["pace_hz"] == 2.0 and result["verdict"] == Verdict.PEDESTRIAN  # a copy
    else:
        assert out is result
    off = SizeOptions(min_height_heights=0.0)
    assert refuse_low(result, TILTED, _rows(0.6, 12), 1.7, off) is result


def test_window_scope_reads_the_deciding_window_only():
    """Rule 26c: a track whose first 12 rows are a 1.7 m walker (its deciding window, rows
    0..12) and whose next 20 rows are a 0.6 m dog (a re-acquisition onto it) keeps its
    Pedestrian verdict with the window scope (median 1.7 m over the window) and turns
    Non-pedestrian with the track scope (median 0.6 m over all 32 rows); a result with no window
    is read over every row with either scope."""
    walker, dog = _rows(1.7, 12)[:-1], _rows(0.6, 20)[:-1]
    rows = walker + dog
    result = {"verdict": int(Verdict.PEDESTRIAN), "reason": int(Reason.MATCHED),
              "window": (0, 12)}
    track = SizeOptions(min_height_heights=0.5, min_height_scope="track")
    assert refuse_low(result, TILTED, rows, 1.7, ON) is result
    assert refuse_low(result, TILTED, rows, 1.7, track)["reason"] == Reason.TOO_LOW
    no_window = {k: v for k, v in result.items() if k != "window"}
    assert refuse_low(no_window, TILTED, rows, 1.7, ON)["reason"] == Reason.TOO_LOW
    on_dog = {**result, "window": (12, 32)}  # a window judged on the dog: turned
    assert refuse_low(on_dog, TILTED, rows, 1.7, ON)["reason"] == Reason.TOO_LOW
    with pytest.raises(ValueError, match="min_height_scope"):
        SizeOptions(min_height_scope="rows")


def test_window_or_track_scope_reads_the_track_where_the_window_has_too_few_rows():
    """Rule 26f: a track whose deciding window (rows 0..12) has no readable top row (a far
    dog: a walker's head would leave the image there) and whose next 20 rows read a 0.6 m dog
    keeps its Pedestrian verdict with the window scope (0 rows read) and turns Non-pedestrian
    with "window-or-track" (the track's 20 rows). A window with 12 readable rows of a 1.7 m
    walker before the dog's rows keeps Pedestrian with either; one with 9 readable rows (below
    `min_height_rows`) is read over the track, where the dog's 20 rows make the median low."""
    fallback = SizeOptions(min_height_heights=0.5, min_height_scope="window-or-track")
    result = {"verdict": int(Verdict.PEDESTRIAN), "reason": int(Reason.MATCHED),
              "window": (0, 12)}
    dog = _rows(0.6, 20)[:-1]
    unread = [r._replace(v_top=math.nan) for r in _rows(0.6, 12)[:-1]]
    assert refuse_low(result, TILTED, unread + dog, 1.7, ON) is result
    assert refuse_low(result, TILTED, unread + dog, 1.7, fallback)["reason"] == Reason.TOO_LOW
    walker = _rows(1.7, 12)[:-1]
    assert refuse_low(result, TILTED, walker + dog, 1.7, fallback) is result
    few = walker[:9] + unread[9:]
    assert refuse_low(result, TILTED, few + dog, 1.7, ON) is result
    assert refuse_low(result, TILTED, few + dog, 1.7, fallback)["reason"] == Reason.TOO_LOW


def test_the_tracker_applies_the_rule():
    """One rendered walker at 18 m (its head inside the image of this 1 m camera) is judged
    Pedestrian by default and measures 1.7 m (within 0.05 m); with the rule at 2 walker heights
    (3.4 m, taller than anyone) its Pedestrian track turns Non-pedestrian, reason too-low, its
    pace kept."""
    cfg = Config()
    act = synth.walker(-3.4, 18.0, 0.0, pace_hz=1.9, step_length_m=0.62)
    scene = synth.render_scene(3, synth.SceneSpec(n_frames=120, actors=(act,),
                                                  camera=cfg.camera))
    out = []
    for options in (TrackerOptions(), with_changes(TrackerOptions(),
                                                   {"size.min_height_heights": 2.0})):
        tr = OnlineTracker(cfg, options)
        for i, f in enumerate(scene.frames):
            tr.update(i, i / 15.0, f)
        out.append(tr.finish()[:2])
    (tracks, off), (_, on) = out
    ped = [i for i, v in enumerate(off["verdict"]) if v == "pedestrian"]
    assert ped, off["verdict"]
    for i in ped:
        rows = tracks["track_id"] == off["track_id"][i]
        h, n = median_height(cfg.camera, tracks["u"][rows], tracks["v"][rows],
                             tracks["v_top"][rows], 1.7)
        assert n >= 10 and abs(h - 1.7) < 0.05
        assert on["verdict"][i] == "non-pedestrian" and on["reason"][i] == "too-low"
        assert on["pace_hz"][i] == off["pace_hz"][i]
