"""vision.camera_check: the sanity check of a camera against the first frames of a video.

References: the implied height against the closed-form inverse of (3) (roll 0) and against an
OpenCV pin-hole (`cv2.projectPoints`) with roll; `sees_ground` against a dense pixel grid;
`check_camera` on frames drawn here (rectangle "people" of the px height a known camera gives,
moving over a static texture), on the demo's synthetic scene, and on PETS09 (skipped when the
data are absent).

Measured cost (`test_cost_is_seconds` prints it; a shared 2-core machine): 80 frames of a
720 x 576 drawn scene in 0.38-0.42 s (about 5 ms a frame, the 25-frame median a third of it),
0.74 s once under load; the first 80 frames of PETS09 (480 x 360) in 0.36-0.42 s, decoding
(0.12 s) included.
"""

from __future__ import annotations

import math
import time

import cv2
import numpy as np
import pytest

from rhythmjax.evaluation import datasets as D
from rhythmjax.model.camera_np import ground_of_pixels, image_width_of, project_3d
from rhythmjax.model.config_setup import config_for
from rhythmjax.model.params import Camera, Config, Thresholds, config_from_dict
from rhythmjax.model.view import visible_range
from rhythmjax.sim.presets import SCENE_OPTIONS, SYNTHETIC_CONFIG
from rhythmjax.sim.scene import random_spec, render_scene
from rhythmjax.vision.camera_check import (
    HEIGHT_LIMITS_M,
    check_camera,
    implied_height_m,
    judge_regions,
    moving_regions,
    sees_ground,
    stack_boxes,
)
from rhythmjax.vision.video import open_video


FPS = 15.0


def street_camera(**kw) -> Camera:
    """A surveillance camera: 3 m up, 20 deg down, focal length 700 px, 640 x 480."""
    d = dict(f=0.008, h=3.0, theta=math.radians(20.0), a=700 / 0.008, b=700 / 0.008, uc=320.0,
             vc=240.0, image_width=640, image_height=480, fps=FPS)
    d.update(kw)
    return Camera(**d)


def config_of(camera: Camera, rng: tuple[float, float] | None = None) -> Config:
    """A config with `camera` and the range derived from it (as `config_for`), or `rng`."""
    near, far = rng if rng is not None else visible_range(camera)
    return Config(camera=camera, thresholds=Thresholds(range_min=near, range_max=far))


# walkers (x0 m, y m ahead, speed m/s along x), 1.7 m tall, 0.5 m wide
WALKERS = ((-2.5, 8.0, 1.0), (2.0, 12.0, -0.9), (-2.0, 17.0, 0.8))


def draw_frames(camera: Camera, n: int = 80, *, walkers=WALKERS, height_m: float = 1.7,
                seed: int = 0, bgr: bool = False):
    """(index, t, frame) of `n` frames: a static random texture (grey 40-170) with sensor
    noise (std 2), and upright rectangles of grey 235, `height_m` x 0.5 m as `camera` sees
    them (rows from the top's projection to the foot's), moving along x."""
    rng = np.random.default_rng(seed)
    H, W = camera.image_height, camera.image_width
    texture = rng.integers(40, 171, (H, W)).astype(np.float64)
    for k in range(n):
        img = texture + rng.normal(0.0, 2.0, (H, W))
        for x0, y, speed in walkers:
            x = x0 + speed * k / FPS
            u, v = project_3d(camera, x, y, 0.0)
            _, v_top = project_3d(camera, x, y, height_m)
            half = 0.5 * float(image_width_of(camera, 0.5, y))
            r0, r1 = max(0, round(v_top)), min(H, round(v) + 1)
            c0, c1 = max(0, round(u - half)), min(W, round(u + half) + 1)
            img[r0:r1, c0:c1] = 235.0
        frame = np.clip(img.round(), 0, 255).astype(np.uint8)
        yield k, k / FPS, (cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if bgr else frame)


# ----------------------------------------------------------------------------------------------
# the geometry

def closed_form_height(cam: Camera, u, v, height_px):
    """The real height (m) of an upright object at foot (u, v) px, height_px tall, by inverting
    (3) for roll 0 by hand: with r = (Vc - v_top) / (b f) and g = h - z, (3) reads
    r (f + y cos + g sin) = y sin - g cos, so g = (y sin - r (f + y cos)) / (r sin + cos)."""
    c = [float(np.asarray(getattr(cam, k))) for k in ("f", "h", "theta", "b", "vc")]
    f, h, th, b, vc = c
    _, y, _ = ground_of_pixels(cam, u, v)
    r = (vc - (v - height_px)) / (b * f)
    s, co = math.sin(th), math.cos(th)
    return h - (y * s - r * (f + y * co)) / (r * s + co)


def test_implied_height_matches_closed_form():
    rng = np.random.default_rng(1)
    for _ in range(20):
        cam = street_camera(h=rng.uniform(1, 10), theta=math.radians(rng.uniform(2, 40)),
                            a=rng.uniform(300, 1500) / 0.008, b=rng.uniform(300, 1500) / 0.008)
        x = rng.uniform(-3, 3, 50)
        y = rng.uniform(3, 40, 50)
        z = rng.uniform(0.2, 6.0, 50)
        u, v = project_3d(cam, x, y, 0.0)
        _, vt = project_3d(cam, x, y, z)
        got = implied_height_m(cam, u, v, v - vt)
        np.testing.assert_allclose(got, closed_form_height(cam, u, v, v - vt), rtol=1e-9,
                                   atol=1e-9)
        np.testing.assert_allclose(got, z, rtol=1e-8)


def opencv_pinhole(cam: Camera):
    """(rvec, tvec, K) of the pin-hole (3) is (centre (0, -f cos theta, h + f sin theta) in
    its ground frame; x right, y ahead, z up), rolled about the optical axis (a = b)."""
    f, h, th, a, uc, vc, roll = (float(np.asarray(getattr(cam, k)))
                                 for k in ("f", "h", "theta", "a", "uc", "vc", "roll"))
    s, c, sr, cr = math.sin(th), math.cos(th), math.sin(roll), math.cos(roll)
    right, down, ahead = np.array([1.0, 0, 0]), np.array([0, -s, -c]), np.array([0, c, -s])
    R = np.stack([cr * right - sr * down, sr * right + cr * down, ahead])
    centre = np.array([0.0, -f * c, h + f * s])
    K = np.array([[a * f, 0, uc], [0, a * f, vc], [0, 0, 1.0]])
    return cv2.Rodrigues(R)[0], -R @ centre, K


def test_implied_height_with_roll_against_opencv():
    rng = np.random.default_rng(2)
    for _ in range(10):
        fpx = rng.uniform(400, 1200)
        cam = street_camera(h=rng.uniform(1, 8), theta=math.radians(rng.uniform(5, 35)),
                            a=fpx / 0.008, b=fpx / 0.008, roll=math.radians(rng.uniform(-8, 8)))
        rvec, tvec, K = opencv_pinhole(cam)
        n = 40
        x, y, z = rng.uniform(-3, 3, n), rng.uniform(4, 30, n), rng.uniform(0.3, 4.0, n)
        feet = np.stack([x, y, np.zeros(n)], 1)
        tops = np.stack([x, y, z], 1)
        pf = cv2.projectPoints(feet, rvec, tvec, K, None)[0].reshape(n, 2)
        pt = cv2.projectPoints(tops, rvec, tvec, K, None)[0].reshape(n, 2)
        np.testing.assert_allclose(pf, np.stack(project_3d(cam, x, y, 0.0), 1), atol=1e-6)
        got = implied_height_m(cam, pf[:, 0], pf[:, 1], pf[:, 1] - pt[:, 1])
        np.testing.assert_allclose(got, z, atol=1e-6)


def test_implied_height_edges():
    cam = street_camera()
    low = street_camera(theta=math.radians(8.0))  # horizon at 240 - 700 tan 8 deg = row 141.6
    got = implied_height_m(low, 320.0, np.array([141.0, 142.0]), 30.0)
    assert np.isnan(got[0]) and np.isfinite(got[1])
    level = street_camera(theta=0.0, h=1.5)  # looking level: px grow linearly with z, bounded
    assert np.isinf(implied_height_m(level, 320.0, 400.0, 1e7))  # by the 1 km cap
    # a camera tilted down: any px height is reached before the top passes behind the camera
    assert np.isfinite(implied_height_m(cam, 320.0, 400.0, 5000.0))


def test_sees_ground_against_a_pixel_grid():
    rng = np.random.default_rng(3)
    seen = {True: 0, False: 0}
    for _ in range(300):
        cam = street_camera(theta=math.radians(rng.uniform(-45, 45)),
                            roll=math.radians(rng.uniform(-30, 30)),
                            vc=rng.uniform(0, 480), uc=rng.uniform(0, 640))
        uu, vv = np.meshgrid(np.linspace(0, 640, 161), np.linspace(0, 480, 121))
        want = bool(ground_of_pixels(cam, uu.ravel(), vv.ravel())[2].any())
        assert sees_ground(cam, 640, 480) == want
        seen[want] += 1
    assert min(seen.values()) > 30  # both cases drawn


def test_stack_boxes():
    # head (rows 10-25) and legs (40-100) of one walker: a 15-row gap, under half of 60
    # a second walker apart; and a box 30 rows above an 80-row one (30 <= 40): joined
    boxes = [(100, 10, 112, 25), (98, 40, 114, 100), (200, 40, 216, 100),
             (300, 10, 316, 50), (300, 80, 316, 160)]
    assert stack_boxes(boxes).tolist() == [0, 0, 1, 2, 2]
    # side by side (no column overlap) or too far apart in rows: kept apart
    assert stack_boxes([(0, 0, 10, 50), (12, 0, 22, 50)]).tolist() == [0, 1]
    assert stack_boxes([(0, 0, 10, 20), (0, 60, 10, 100)]).tolist() == [0, 1]  # gap 40 > 20
    # transitive: a chain of three
    assert stack_boxes([(0, 0, 10, 20), (0, 25, 10, 45), (0, 50, 10, 70)]).tolist() == [0, 0, 0]


# ----------------------------------------------------------------------------------------------
# drawn scenes

def test_right_camera_no_warning():
    cam = street_camera()
    got = check_camera(config_of(cam), draw_frames(cam))
    assert got.warnings == () and got.notes == ()
    assert got.n_frames == 80 and got.n_regions >= 200  # three walkers in most frames
    assert got.share_outside == 0.0
    # box heights are the drawn rows + the morphology: within 5 % of the drawn 1.7 m
    assert abs(got.median_height_m - 1.7) < 0.085
    assert 7.5 < got.foot_range_m[0] < got.foot_range_m[1] < 17.5


def test_camera_shake_no_warning():
    """Each frame moved by a random whole-pixel shift of up to 2 px (camera shake): the frames
    are aligned onto the first (vision.stabilise), so the shake's edges are no moving regions."""
    cam = street_camera()
    rng = np.random.default_rng(7)
    shaken = ((k, t, np.roll(f, tuple(rng.integers(-2, 3, 2)), axis=(0, 1)))
              for k, t, f in draw_frames(cam))
    got = check_camera(config_of(cam), shaken)
    assert got.warnings == ()
    assert abs(got.median_height_m - 1.7) < 0.17


def test_bgr_frames_as_grey():
    cam = street_camera()
    a = check_camera(config_of(cam), draw_frames(cam, 30))
    b = check_camera(config_of(cam), draw_frames(cam, 30, bgr=True))
    assert (a.median_height_m, a.n_regions) == (b.median_height_m, b.n_regions)


def test_camera_ten_times_too_high_warns():
    cam = street_camera()
    wrong = street_camera(h=30.0)  # the range kept (view.visible_range refuses h = 30 m here)
    got = check_camera(config_of(wrong, visible_range(cam)), draw_frames(cam), video="street.mp4")
    assert got.median_height_m > HEIGHT_LIMITS_M[1]
    assert any("m tall" in w for w in got.warnings)
    assert all(w.endswith("(see README, Your own camera)") and "street.mp4" in w
               for w in got.warnings)


def test_camera_ten_times_too_low_warns():
    cam = street_camera()
    got = check_camera(config_of(street_camera(h=0.3)), draw_frames(cam))
    assert got.median_height_m < HEIGHT_LIMITS_M[0]
    assert len(got.warnings) == 1 and "m tall" in got.warnings[0]


def test_horizon_below_the_image_warns_without_reading():
    looking_up = street_camera(theta=math.radians(-30.0))  # horizon at 240 + 404 = row 644

    def frames():
        raise AssertionError("frames read")
        yield

    got = check_camera(Config(camera=looking_up), frames())
    assert len(got.warnings) == 1
    assert "sees no ground" in got.warnings[0] and "row 644" in got.warnings[0]
    assert got.n_frames == 0


def test_range_elsewhere_warns():
    cam = street_camera()
    got = check_camera(config_of(cam, (40.0, 80.0)), draw_frames(cam))
    assert len(got.warnings) == 1
    w = got.warnings[0]
    assert "100% of" in w and "outside the detection range 40.0-80.0 m" in w
    assert "range_min_m" in w


def test_feet_above_the_horizon_count_as_outside():
    cam = street_camera()
    raised = street_camera(theta=math.radians(8.0))  # horizon at row 142: the far walkers' feet
    got = check_camera(config_of(raised), draw_frames(cam))  # (rows 131-184) straddle it
    assert 0.0 < got.share_above_horizon < 1.0


def test_no_motion_is_a_note_not_a_warning():
    cam = street_camera()
    got = check_camera(config_of(cam), draw_frames(cam, walkers=()))
    assert got.warnings == ()
    assert len(got.notes) == 1 and "nothing to judge" in got.notes[0]


def test_reads_at_most_max_frames():
    cam = street_camera()
    seen = []

    def frames():
        for item in draw_frames(cam, 200):
            seen.append(item[0])
            yield item

    got = check_camera(config_of(cam), frames(), max_frames=25)
    assert got.n_frames == 25 and seen == list(range(25))
    regions = moving_regions(iter([(0, 0.0, None), *draw_frames(cam, 5)]), max_frames=4)
    assert regions.n_frames == 3  # the None frame counts against max_frames, is not used


def test_cost_is_seconds():
    cam = street_camera(image_width=720, image_height=576, uc=360.0, vc=288.0)
    frames = list(draw_frames(cam, 80))
    t0 = time.perf_counter()
    got = check_camera(config_of(cam), frames)
    dt = time.perf_counter() - t0
    print(f"camera check, 80 frames of 720 x 576: {dt:.2f} s ({1000 * dt / 80:.1f} ms/frame)")
    assert got.warnings == ()
    assert dt < 10.0  # seconds, not minutes, even on a loaded machine


# ----------------------------------------------------------------------------------------------
# the demo's scene and real data

def test_demo_scene_default_camera_no_warning():
    cfg = config_from_dict(SYNTHETIC_CONFIG)  # the demo's config: the paper's camera
    spec = random_spec(4, n_walkers=4, n_bicycles=1, n_dogs=1, n_frames=180, camera=cfg.camera,
                       **SCENE_OPTIONS)  # `rhythmjax demo`'s scene (seed 4, 4 walkers)
    scene = render_scene(4, spec)
    got = check_camera(cfg, ((i, i / scene.fps, f) for i, f in enumerate(scene.frames)))
    assert got.warnings == () and got.notes == ()
    assert got.n_regions > 100


need_pets = pytest.mark.skipif(D.pets_root() is None, reason="PETS 2009 data absent")


def _pets_box_heights_m(cam) -> np.ndarray:
    """Heights (m) of PETS's annotated people by the pin-hole alone (camera_np, float64): each
    box's bottom centre to the ground, then the height z whose projection (3) at that ground
    point reaches the box's top row (interpolated on a 1 cm grid up to 3 m)."""
    from rhythmjax.model.camera_np import camera_tuple, ground_of_pixels, project_3d

    host, b = camera_tuple(cam), D.pets_boxes()
    x, y, _ = ground_of_pixels(host, b["foot_u"], b["foot_v"])
    z = np.linspace(0.0, 3.0, 301)
    out = []
    for xi, yi, top in zip(x, y, b["bb_top"]):
        if np.isfinite(yi) and yi > 0:
            v = np.asarray(project_3d(host, np.full_like(z, xi), np.full_like(z, yi), z)[1])
            out.append(np.interp(-top, -v, z))  # v falls as z rises
    return np.asarray(out)


@need_pets
def test_pets_tsai_camera_no_warning():
    """The Tsai camera: no warning, the moving things as tall as the annotated people (their
    boxes' median height through the camera, 1.74 m; the check's regions give 1.76 m: within
    5 %). The implied height comes from the camera, not from the frames alone: the same
    regions judged by the camera raised to twice its height are twice as tall (a pin-hole's
    ground-plane scale is proportional to h; 0.5 % for the f of (3) in the depth)."""
    import equinox as eqx

    cam = D.pets_camera()
    regions = moving_regions(open_video(D.pets_video(), fps=D.PETS_FPS))
    got = judge_regions(config_of(cam), regions)
    assert got.warnings == ()
    truth = float(np.median(_pets_box_heights_m(cam)))
    assert got.median_height_m == pytest.approx(truth, rel=0.05)
    assert got.share_outside < 0.1
    high = eqx.tree_at(lambda c: c.h, cam, 2.0 * cam.h)
    twice = judge_regions(config_of(high), regions)
    assert twice.median_height_m == pytest.approx(2.0 * got.median_height_m, rel=5e-3)
    assert twice.warnings == ()  # 3.5 m: within the 0.5-5 m a crowd's regions may span


@need_pets
@pytest.mark.parametrize("which", ["paper", "default for the video"])
def test_pets_default_camera_warns(which):
    cfg = (Config() if which == "paper"
           else config_for({}, image_size=D.PETS_SIZE, fps=D.PETS_FPS))
    got = check_camera(cfg, open_video(D.pets_video(), fps=D.PETS_FPS))
    assert len(got.warnings) == 1 and "m tall" in got.warnings[0]
    assert got.median_height_m < HEIGHT_LIMITS_M[0]  # 0.40 m and 0.26 m measured
