"""`count.head_feet` (`new.head_feet`): a walker's foot row from its head row, against the
pin-hole of (3) written out here in NumPy float64 (the dev set README's form for a point z m
above the ground: depth = f + y cos(theta) + (h - z) sin(theta), v = Vc - b f (y sin(theta) -
(h - z) cos(theta)) / depth), and the start of a walker whose legs the mask lost, on a rendered
scene."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.count import count_frames
from rhythmjax.count.head_feet import MIN_SLOPE, TALL_HEIGHTS, head_foot_row, too_tall
from rhythmjax.count.options import CountOptions, VerdictOptions, with_changes
from rhythmjax.count.patches import ShapeModel
from rhythmjax.model.params import Camera, Config, config_from_dict
from rhythmjax.sim.scene import SceneSpec, render_scene, walker


WALKER_M = 1.7  # Config's width.height


def row_of(cam: Camera, y: float, z: float) -> float:
    """Image row (px) of the point y m ahead, z m above the ground, on the optical column."""
    f, h, th = float(cam.f), float(cam.h), float(cam.theta)
    depth = f + y * math.cos(th) + (h - z) * math.sin(th)
    return float(cam.vc) - float(cam.b) * f * (y * math.sin(th) - (h - z) * math.cos(th)) / depth


def shape_of(cam: Camera) -> ShapeModel:
    return ShapeModel.from_config(Config(camera=cam), "3d")


LOW = Camera()  # 1 m high, 15 deg, a f = b f = 800 px, 512 x 512: the head above the horizon
HIGH = Camera(h=7.0, theta=math.radians(16.5), f=0.008, a=742 / 0.008, b=742 / 0.008,
              uc=384.0, vc=288.0, image_width=768, image_height=576)  # PETS09-like


@pytest.mark.parametrize("cam,y", [(LOW, 16.0), (LOW, 25.0), (LOW, 40.0), (HIGH, 10.0),
                                   (HIGH, 25.0)])
def test_foot_row_from_the_head_row(cam, y):
    """The head row of a 1.7 m walker y m ahead gives back its foot row (linear between image
    rows: within 0.02 px)."""
    v_head, v_foot = row_of(cam, y, WALKER_M), row_of(cam, y, 0.0)
    got = head_foot_row(shape_of(cam), float(cam.uc), v_head, cam.image_height)
    assert got == pytest.approx(v_foot, abs=0.02)


def test_slope_of_the_head_row():
    """d(head row)/d(foot row) tends to (camera height - walker height) / camera height far
    away, -0.7 for the 1 m camera, and is -0.76 at 10 m (the module's figures; finite
    differences of the reference rows, 0.1 m apart)."""
    def slope(y):
        return ((row_of(LOW, y + 0.1, WALKER_M) - row_of(LOW, y, WALKER_M))
                / (row_of(LOW, y + 0.1, 0.0) - row_of(LOW, y, 0.0)))
    assert slope(10.0) == pytest.approx(-0.762, abs=0.001)
    assert slope(500.0) == pytest.approx(-0.7, abs=0.005)


@pytest.mark.parametrize("h,given", [(1.7, False), (1.9, False), (2.4, True)])
def test_no_foot_row_where_the_head_row_hardly_moves(h, given):
    """Slope (h - 1.7) / h: 0 and 0.105 are below MIN_SLOPE (0.25): no row; 0.29 gives one."""
    cam = Camera(h=h)
    assert (abs(h - WALKER_M) / h >= MIN_SLOPE) == given
    got = head_foot_row(shape_of(cam), 256.0, row_of(cam, 20.0, WALKER_M), 512)
    assert (got is not None) == given
    if given:
        assert got == pytest.approx(row_of(cam, 20.0, 0.0), abs=0.02)


def test_too_tall():
    shape = shape_of(LOW)
    v = row_of(LOW, 20.0, 0.0)
    h = v - row_of(LOW, 20.0, WALKER_M)
    assert not too_tall(shape, 256.0, v, 1.2 * h, TALL_HEIGHTS)
    assert too_tall(shape, 256.0, v, 1.3 * h, TALL_HEIGHTS)
    horizon = float(LOW.vc) - 800.0 * math.tan(float(LOW.theta))  # row 41.6
    assert too_tall(shape, 256.0, math.floor(horizon) - 1.0, 5.0, TALL_HEIGHTS)


def test_option_is_off_by_default_and_on_at_the_a_priori_value():
    assert CountOptions().new.head_feet == 0.0
    assert TALL_HEIGHTS == 1.25


LOW_SMALL = {"camera": {"f_m": 0.008, "h_m": 1.0, "theta_deg": 10.0, "a_px_per_m": 25000.0,
                        "b_px_per_m": 25000.0, "uc_px": 128.0, "vc_px": 96.0, "fps": 15.0,
                        "image_width_px": 256, "image_height_px": 192},
             "thresholds": {"range_min_m": 2.0, "range_max_m": 20.0}}


def trousers_scene(shoes: int):
    """The walker of the test below: 8 m ahead, trousers of the ground's grey (120), torso 40."""
    cfg = config_from_dict(LOW_SMALL)
    a = walker(-3.0, 8.0, 0.0, start_frame=3, grey_legs=120, grey_torso=40, grey_feet=shoes)
    return cfg, render_scene(1, SceneSpec(n_frames=60, actors=(a,), camera=cfg.camera))


def test_a_walker_with_trousers_of_the_ground_grey_is_counted():
    """A rendered walker 8 m ahead of a 1 m camera (focal 200 px), trousers of the ground's
    grey (120), dark shoes (30): the mask holds its head and torso, and its shoes apart, below
    the hips, in blobs too small to start a walker. Off (the paper's foot row: the hips', 0.85-
    0.9 m up, 3.9-2.6 px below the horizon, whose ground point lies 53-80 m away, beyond the
    20 m range): no track. On: one walker counted, started where its head
    puts its feet, then placed on its shoes by the paper's rule to the last frame; its patch's
    foot row within 1 px of the true one and its ground distance within 3 % of 8 m (measured
    -0.2 px and 8.00 m). Shoes of the ground's grey too leave nothing to follow: no track
    either way."""
    quiet = CountOptions(verdicts=VerdictOptions(classify=False, online=False))
    on_opt = with_changes(quiet, {"new.head_feet": TALL_HEIGHTS})
    for shoes in (30, 118):
        cfg, scene = trousers_scene(shoes)
        items = [(k, k / scene.fps, f) for k, f in enumerate(scene.frames)]
        assert count_frames(cfg, iter(items), options=quiet).counts["tracks"] == 0
        on = count_frames(cfg, iter(items), options=on_opt)
        if shoes == 118:
            assert on.counts["tracks"] == 0
            continue
        assert on.counts["tracks"] == on.counts["walkers"] == 1
        m = on.mot
        frames = m["frame"] - 1  # MOT frames are 1-based
        assert frames.max() >= 57 and frames.size >= 30  # to the end (of 60 frames)
        foot = m["bb_top"] + m["bb_height"]
        assert np.median(np.abs(foot - scene.truth[0].v[frames])) <= 1.0
        assert np.median(m["y"]) == pytest.approx(8.0, rel=0.03)


def test_the_count_command_takes_feet_from_head(tmp_path, capsys):
    """`rhythmjax count --feet-from-head` counts that walker; without it, nothing."""
    _, scene = trousers_scene(30)
    frames = tmp_path / "frames"
    frames.mkdir()
    for k, f in enumerate(scene.frames):
        assert cv2.imwrite(str(frames / f"f{k:03d}.png"), f)
    cfg = tmp_path / "low.json"
    cfg.write_text(json.dumps(LOW_SMALL))
    walkers = []
    for flag in ([], ["--feet-from-head"]):
        capsys.readouterr()
        rc = main(["count", str(frames), "-c", str(cfg), "-o", str(tmp_path / f"o{len(flag)}"),
                   "--fps", "15", "--json", "--no-report", *flag])
        assert rc == 0
        walkers.append(json.loads(capsys.readouterr().out)["counts"]["walkers"])
    assert walkers == [0, 1]


def free_run_of(mask_rows: tuple[int, int], out_of_range: bool):
    """The one free run of a hand-made blob (columns 120-135, rows mask_rows[0] to
    mask_rows[1] - 1) under LOW_SMALL's camera, `new.head_feet` on, with or without
    `new.head_feet_out_of_range`, no pedestrian tracked."""
    from rhythmjax.count.pedestrian_level import PedestrianLevel
    from rhythmjax.count.refinement import free_runs
    from rhythmjax.vision.blobs import find_blobs

    cfg = config_from_dict(LOW_SMALL)
    opt = with_changes(CountOptions(), {"new.head_feet": TALL_HEIGHTS,
                                        "new.head_feet_out_of_range": out_of_range})
    mask = np.zeros((192, 256), np.uint8)
    mask[mask_rows[0]:mask_rows[1], 120:136] = 1
    blobs, labels = find_blobs(mask, min_area=30)
    (run,) = free_runs(PedestrianLevel(cfg, opt), blobs, labels)
    return cfg, run


def test_out_of_range_variant_leaves_a_tall_run_standing_in_range_on_its_bottom():
    """A blob standing on the row of a point 6 m ahead (in the 2-20 m range), 1.5 walker heights
    tall there (above 1.25): `new.head_feet` alone takes its feet from its top row (at a 1 m
    camera a nearer walker whose legs the mask lost, its feet 35 px below the bottom; (3) solved
    here by bisection for the distance whose head row is the top); with
    `new.head_feet_out_of_range` the bottom, which starts a walker in range, stays its foot row.
    A blob whose bottom is 1 px below the horizon (the hips of a walker whose legs the mask
    lost: a ground point far beyond 20 m), topped where a 1.7 m walker 8 m ahead has its head,
    takes its feet from the head either way, within 1 px of that walker's foot row (pin-hole of
    (3) above)."""
    from scipy.optimize import brentq

    from rhythmjax.count.refinement import starts_on

    cam = config_from_dict(LOW_SMALL).camera
    bottom = round(row_of(cam, 6.0, 0.0))
    h = float(shape_of(cam).size(128.0, float(bottom))[1])
    top = bottom - round(1.5 * h)
    for out_of_range, feet_from_head in ((False, True), (True, False)):
        cfg, run = free_run_of((top, bottom + 1), out_of_range)
        assert run.from_head is feet_from_head
        if feet_from_head:  # where (3) puts the feet of a 1.7 m walker with its head on `top`
            y = brentq(lambda d: row_of(cam, d, WALKER_M) - top, 0.5, 50.0)
            assert run.vb == pytest.approx(row_of(cam, y, 0.0), abs=1.0)  # 128.85 px
        else:
            assert run.vb == bottom and run.refused == ""
    horizon = float(cam.vc) - 200.0 * math.tan(float(cam.theta))
    hips, head = math.floor(horizon) + 1, round(row_of(cam, 8.0, WALKER_M))
    for out_of_range in (False, True):
        cfg, run = free_run_of((head, hips + 1), out_of_range)
        assert not starts_on_row(cfg, hips)
        assert run.from_head
        assert run.vb == pytest.approx(row_of(cam, 8.0, 0.0), abs=1.0)
    assert starts_on_row(cfg, bottom)
    assert not starts_on(_level(cfg), (128.0, math.floor(horizon) - 1.0))  # above the horizon


def _level(cfg):
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    return PedestrianLevel(cfg, CountOptions())


def starts_on_row(cfg, row: float) -> bool:
    from rhythmjax.count.refinement import starts_on

    return starts_on(_level(cfg), (128.0, float(row)))


def test_out_of_range_variant_still_counts_the_walker_without_trousers():
    """The rendered walker of `test_a_walker_with_trousers_of_the_ground_grey_is_counted`,
    whose blob ends at the hips beyond the range: with `new.head_feet_out_of_range` too, one
    walker counted, its patch's foot row within 1 px of the true one."""
    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"new.head_feet": TALL_HEIGHTS, "new.head_feet_out_of_range": True})
    cfg, scene = trousers_scene(30)
    items = [(k, k / scene.fps, f) for k, f in enumerate(scene.frames)]
    on = count_frames(cfg, iter(items), options=opt)
    assert on.counts["tracks"] == on.counts["walkers"] == 1
    frames = on.mot["frame"] - 1
    foot = on.mot["bb_top"] + on.mot["bb_height"]
    assert np.median(np.abs(foot - scene.truth[0].v[frames])) <= 1.0
