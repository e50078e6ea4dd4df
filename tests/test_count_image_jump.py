"""`life.max_dv_w`: the velocity-jump end measured in the image (`track.toolkit.
image_velocity_jump`) on hand-worked velocities, and through the pedestrians level on a far
walker whose ground velocity swings in depth (foot-row noise: metres on the ground, a fraction
of W in the image) against one that turns across the image. Image velocities here come from a
finite difference of the camera's projection (3), independent of `slot_filter.image_velocity`."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from rhythmjax.count import CountOptions
from rhythmjax.count.options import VerdictOptions, with_changes
from rhythmjax.count.patches import ShapeModel
from rhythmjax.count.rows import GroundRow
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import config_from_dict
from rhythmjax.track.toolkit import image_velocity_jump


# the small camera of tests/test_pedestrians.py: 3 m high, 25 deg down, a f = b f = 200 px/m
CFG = config_from_dict({
    "camera": {"f_m": 0.008, "h_m": 3.0, "theta_deg": 25.0, "a_px_per_m": 25000.0,
               "b_px_per_m": 25000.0, "uc_px": 128.0, "vc_px": 96.0, "fps": 15.0,
               "image_width_px": 256, "image_height_px": 192},
    "thresholds": {"range_min_m": 3.0, "range_max_m": 15.0}})


def _v(du, dv):
    return SimpleNamespace(du=du, dv=dv)


def test_image_velocity_jump_by_hand():
    k, W = 7, 20.0  # a limit of 3 W/s = 60 px/s
    steady = [_v(10.0, 0.0)] * 10
    assert image_velocity_jump(steady + [_v(10.0, 0.0)] * 5 + [_v(10.0, 61.0)], W, k, 3.0) == k
    assert image_velocity_jump(steady + [_v(10.0, 0.0)] * 5 + [_v(10.0, 59.0)], W, k, 3.0) == 0
    # 36 + 48 px/s: |(36, 48)| = 60 px/s, not over; 61 with 3 W/s of a 20.1 px patch neither
    assert image_velocity_jump(steady + [_v(46.0, 48.0)], W, k, 3.0) == 0
    assert image_velocity_jump(steady + [_v(10.0, 61.0)], 20.4, k, 3.0) == 0
    # 2k rows or fewer (the filter starts at rest), or no width: never
    assert image_velocity_jump([_v(0.0, 0.0)] * 13 + [_v(0.0, 500.0)], W, k, 3.0) == 0
    assert image_velocity_jump(steady * 2 + [_v(0.0, 500.0)], math.nan, k, 3.0) == 0


def _rows(x, y, vx, vy):
    """A ground row with its image velocity by a 1 mm finite difference of (3) (px/s)."""
    u0, v0 = (float(q) for q in project_3d(CFG.camera, x, y, 0.0))
    e = 1e-3
    u1, v1 = (float(q) for q in project_3d(CFG.camera, x + e * vx, y + e * vy, 0.0))
    return GroundRow(x, y, vx, vy, (u1 - u0) / e, (v1 - v0) / e)


@pytest.mark.parametrize("max_dv_w", [0.0, 3.0])
def test_a_far_walker_swinging_in_depth_is_not_lost_in_the_image(max_dv_w):
    from rhythmjax.count.pedestrian_level import Pedestrian, PedestrianLevel

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"life.max_dv_w": max_dv_w})
    level = PedestrianLevel(CFG, opt)
    k = round(0.5 * 15)
    u, v = (float(q) for q in project_3d(CFG.camera, 0.0, 14.0, 0.0))
    W = float(ShapeModel.from_config(CFG, "3d").size(u, v)[0])  # 7.16 px at 14 m
    box = SimpleNamespace(w=W)
    walk = [_rows(0.1 * i, 14.0, 1.4, 0.0) for i in range(30)]
    p = Pedestrian(slot=0, born=0)
    p.boxes = [box] * 40
    # 14 m away the foot row moves 3.08 px per metre of depth: a 2 m/s swing in depth is
    # 6.2 px/s = 0.86 W/s in the image, over 1.5 m/s on the ground
    p.ground = walk + [_rows(3.0, 14.0, 1.4, 2.0)] * k
    assert abs(p.ground[-1].dv - 2.0 * -3.08) < 0.05
    assert level._velocity_jump(p) == (0 if max_dv_w else k)
    # turning across the image by 2 m/s (28.6 px/s = 4.0 W/s): lost in both
    p.ground = walk + [_rows(3.0, 14.0, 1.4, 0.0)] * (k - 1) + [_rows(3.0, 14.0, 3.4, 0.0)]
    assert level._velocity_jump(p) == k
    # a steady walk: in neither
    p.ground = walk + [_rows(3.0, 14.0, 1.4, 0.0)] * k
    assert level._velocity_jump(p) == 0
