"""The defaults that follow the video (`model.config_setup`) and what a camera sees
(`model.view`), against hand-worked pin-hole geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.model.camera import horizon_v
from rhythmjax.model.config_setup import config_for
from rhythmjax.model.params import Camera, ConfigError, config_from_dict
from rhythmjax.model.view import (
    MIN_PERSON_PX,
    camera_report,
    format_report,
    ground_distance_at_row,
    horizon_row,
    person_height_px,
    visible_range,
)


def test_window_is_a_duration_and_n_follows_the_fps():
    n = lambda d: config_from_dict(d).thresholds.n  # noqa: E731
    assert n({}) == 64  # Table 1: 64 samples at 15 fps
    assert n({"camera": {"fps": 25}}) == 107  # 64 / 15 s * 25 = 106.7
    assert n({"camera": {"fps": 7}}) == 30  # 29.9
    assert n({"camera": {"fps": 25}, "thresholds": {"window_s": 2.0}}) == 50
    assert n({"camera": {"fps": 25}, "thresholds": {"n_samples": 48}}) == 48  # given wins
    with pytest.raises(ConfigError, match="thresholds.window_s"):
        config_from_dict({"thresholds": {"window_s": 2.0, "n_samples": 48}})
    with pytest.raises(ConfigError, match="thresholds.window_s"):
        config_from_dict({"thresholds": {"window_s": -1}})


def test_principal_point_defaults_to_the_image_centre():
    c = config_from_dict({"camera": {"image_width_px": 640, "image_height_px": 480}}).camera
    assert (float(c.uc), float(c.vc)) == (320.0, 240.0)
    c = config_for({}, image_size=(1920, 1080)).camera
    assert (float(c.uc), float(c.vc), c.image_width, c.image_height) == (960.0, 540.0, 1920, 1080)
    c = config_for({"camera": {"uc_px": 100.0}}, image_size=(640, 480)).camera
    assert (float(c.uc), float(c.vc)) == (100.0, 240.0)


def test_video_facts_fill_only_what_the_config_leaves_out():
    cfg = config_for({"camera": {"fps": 7}}, image_size=(480, 360), fps=10.0)
    assert cfg.camera.fps == 7.0 and (cfg.camera.image_width, cfg.camera.image_height) == (480, 360)
    assert config_for({}, fps=25.0).camera.fps == 25.0


def test_the_paper_camera_keeps_table_1_range_and_others_derive_it():
    thr = config_for({}).thresholds
    assert (float(thr.range_min), float(thr.range_max)) == (3.0, 20.0)
    d = {"camera": {"h_m": 5.0, "theta_deg": 20.0}}
    cfg = config_for(d)
    near, far = visible_range(cfg.camera)
    assert float(cfg.thresholds.range_min) == pytest.approx(near, rel=1e-6)
    assert float(cfg.thresholds.range_max) == pytest.approx(far, rel=1e-6)
    half = config_for({**d, "thresholds": {"range_max_m": 30.0}}).thresholds
    assert float(half.range_min) == pytest.approx(near, rel=1e-6) and float(half.range_max) == 30
    # another image size alone derives it too (the paper's camera on a 320 x 240 video)
    small = config_for({}, image_size=(320, 240)).thresholds
    assert float(small.range_max) < 20.0


# A camera with a negligible f (1 um): (3) is then the textbook pin-hole at height h, and the
# geometry below is exact to ~1e-6 relative.
F = 1e-6


def _cam(bf=600.0, h=4.0, theta_deg=20.0, w=640, hgt=480, roll_deg=0.0) -> Camera:
    return Camera(f=F, a=bf / F, b=bf / F, h=h, theta=math.radians(theta_deg), uc=w / 2,
                  vc=hgt / 2, roll=math.radians(roll_deg), image_width=w, image_height=hgt)


@pytest.mark.parametrize("bf,h,theta", [
    (600.0, 4.0, 20.0), (1200.0, 1.5, 8.0), (400.0, 9.0, 35.0)])
def test_rows_distances_and_person_heights_by_hand(bf, h, theta):
    cam = _cam(bf, h, theta)
    th = math.radians(theta)
    for v in (479.0, 400.0, 300.0):
        below = th + math.atan((v - 240.0) / bf)  # the ray's angle below the horizontal
        assert ground_distance_at_row(cam, v) == pytest.approx(h / math.tan(below), rel=1e-5)
    assert horizon_row(cam) == pytest.approx(240.0 - bf * math.tan(th), rel=1e-6)  # float32 camera
    assert horizon_row(cam) == pytest.approx(float(horizon_v(cam)), abs=1e-3)
    for y in (5.0, 12.0, 30.0):
        feet = math.tan(math.atan2(h, y) - th)
        head = math.tan(math.atan2(h - 1.7, y) - th)
        assert person_height_px(cam, y) == pytest.approx(bf * (feet - head), rel=1e-5)


def test_visible_range_is_bottom_row_to_top_row_or_the_smallest_person():
    cam = _cam(600.0, 4.0, 20.0)  # the top row sees beyond the horizon: the person cap applies
    near, far = visible_range(cam)
    assert near == pytest.approx(ground_distance_at_row(cam, 480.0), rel=1e-9)
    assert person_height_px(cam, far) == pytest.approx(MIN_PERSON_PX, rel=1e-6)
    steep = _cam(600.0, 4.0, 60.0)  # looking down steeply: the top row's ground is the far end
    near, far = visible_range(steep)
    assert far == pytest.approx(ground_distance_at_row(steep, 0.0), rel=1e-9)
    with pytest.raises(ValueError, match="above the horizon"):
        visible_range(Camera(vc=2000.0))  # the horizon below the image


def test_report_names_the_facts():
    r = camera_report(_cam(600.0, 4.0, 20.0, roll_deg=2.0))
    assert r["focal_px"] == pytest.approx([600.0, 600.0])
    assert r["tilt_deg"] == pytest.approx(20.0) and r["roll_deg"] == pytest.approx(2.0)
    assert r["hfov_deg"] == pytest.approx(math.degrees(2 * math.atan(320 / 600)))
    assert np.isfinite(r["ground_m_at_bottom_row"]) and r["detection_range_m"] is not None
    text = format_report(r)
    for word in ("focal length", "camera height", "tilt", "horizon", "detection range",
                 "px at 5 m", "px at 20 m"):
        assert word in text
    sky = camera_report(Camera(vc=2000.0))
    assert sky["detection_range_m"] is None and "BELOW" in format_report(sky)


def test_range_of_a_high_camera_looking_down():
    """Seen from 30 m up, a person's image height first grows with distance, then falls: the
    far end is where it falls below MIN_PERSON_PX, not the first distance where it is small."""
    cam = Camera(f=0.008, a=700 / 0.008, b=700 / 0.008, h=30.0, theta=math.radians(20.0),
                 uc=320.0, vc=240.0, image_width=640, image_height=480)
    near, far = visible_range(cam)
    assert near == pytest.approx(ground_distance_at_row(cam, 480.0), rel=1e-9)  # 37.1 m
    assert ground_distance_at_row(cam, 0.0) > 1000.0  # the top row sees the far distance
    assert far > near and person_height_px(cam, far) == pytest.approx(MIN_PERSON_PX, rel=1e-6)
    ys = np.linspace(far * 1.001, 3 * far, 50)
    assert all(person_height_px(cam, float(y)) < MIN_PERSON_PX for y in ys)


def test_range_of_a_camera_looking_almost_straight_down():
    """82 deg down (ETH seq_hotel): the bottom row sees the ground behind the camera's foot
    (y < 0); the derived range starts at NEAR_FLOOR_M, the config's range being y > 0."""
    from rhythmjax.model.view import NEAR_FLOOR_M

    cam = _cam(500.0, 10.0, 82.0, w=720, hgt=576)
    assert ground_distance_at_row(cam, 576.0) < 0
    near, far = visible_range(cam)
    assert near == NEAR_FLOOR_M and far == pytest.approx(ground_distance_at_row(cam, 0.0))
    cfg = config_for({"camera": {"h_m": 10.0, "theta_deg": 82.0}}, image_size=(720, 576))
    assert float(cfg.thresholds.range_min) == pytest.approx(NEAR_FLOOR_M)
