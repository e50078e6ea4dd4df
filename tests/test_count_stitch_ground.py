"""Stitching gated by the pieces' ground velocities (`stitch.max_dv_mps`,
`count.stitch.ground_velocity`, `ground_dv_misfit`): the inverse projection's velocity against
the velocity the ground points were moved at, and hand-built pieces of a walker and a cyclist
moving in depth, whose image velocities differ by less than the image gate."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rhythmjax.count import CountOptions, Piece, stitch_pieces
from rhythmjax.count.stitch import ground_dv_misfit, ground_velocity
from rhythmjax.track.options import with_changes

from .test_count_reid import CAM, FPS, GATE, SHAPE, duv, uv


def moving_piece(first: int, last: int, start_xy, v_xy, du_error_w: float = 0.0) -> Piece:
    """An object moving from ground point start_xy (m) at v_xy (m/s) between frames first and
    last; its start's image velocity (a line fit over its first second in the tracker) off by
    du_error_w W/s across when given. Its ground velocities as `piece_of` makes them: the start
    fit's through `ground_velocity`, the end's the EKF's (here the truth)."""
    (x0, y0), (vx, vy) = start_xy, v_xy
    t = (last - first) / FPS
    x1, y1 = x0 + vx * t, y0 + vy * t
    w = float(SHAPE.size(*uv(x0, y0))[0])
    du0, dv0 = duv(x0, y0, vx, vy)
    start = (*uv(x0, y0), du0 + du_error_w * w, dv0)
    end = (*uv(x1, y1), *duv(x1, y1, vx, vy))
    size = tuple(float(q) for q in SHAPE.size(*uv(x0, y0)))
    return Piece(first, last, first / FPS, last / FPS, start, end, size, (x1, y1, vx, vy),
                 None, None, ground_velocity(CAM, *start), (vx, vy))


@pytest.mark.parametrize("xy,v", [((0.0, 8.0), (1.4, 0.0)), ((-1.5, 12.0), (-0.9, 1.0)),
                                  ((0.5, 8.0), (0.0, 4.0)), ((2.0, 20.0), (3.0, -3.0))])
def test_ground_velocity_is_the_velocity_the_point_moves_at(xy, v):
    # reference: the image velocity by a central difference of (3) over +-1 us (exact to
    # ~1e-6 px/s); back through the inverse of (3) it must give the ground velocity to 1e-5
    # m/s (the central 1 ms step's error is (dt |v| / y)^2 of |v|: at most 1e-6 m/s here; a
    # forward step's would be 2e-3 m/s for the cyclist at 8 m)
    (x, y), (vx, vy) = xy, v
    a = np.asarray(uv(x - 1e-6 * vx, y - 1e-6 * vy))
    b = np.asarray(uv(x + 1e-6 * vx, y + 1e-6 * vy))
    du, dv = (b - a) / 2e-6
    got = ground_velocity(CAM, *uv(x, y), du, dv)
    assert got == pytest.approx((vx, vy), abs=1e-5)


def test_ground_velocity_unknown():
    assert ground_velocity(CAM, *uv(0.0, 8.0), math.nan, 0.0) is None
    u, v = uv(0.0, 8.0)
    assert ground_velocity(CAM, u, -500.0, 0.0, 1.0) is None  # above the horizon


def test_misfit_by_hand_and_unknown():
    a = moving_piece(0, 30, (0.0, 13.0), (0.0, -1.4))
    b = moving_piece(45, 70, (0.0, 9.3), (0.0, -4.0))
    # 4.0 - 1.4 = 2.6 m/s, the start's image velocity by duv's 10 ms forward difference
    assert ground_dv_misfit(a, b) == pytest.approx(2.6, abs=0.02)
    assert ground_dv_misfit(b, a) == pytest.approx(2.6, abs=0.02)
    assert ground_dv_misfit(dataclasses.replace(a, end_v=None), b) == math.inf
    assert ground_dv_misfit(a, dataclasses.replace(b, start_v=None)) == math.inf


def test_a_cyclist_in_depth_passes_the_image_gate_not_the_ground_one():
    # A walks towards the camera at 1.4 m/s (13 -> 10.2 m over 2 s); 1 s later a cyclist at
    # 4 m/s the same way appears 9.3 m away. In the image their velocities differ by 1.75 W/s
    # (< max_dv_w 2: foreshortened rows), on the ground by 2.6 m/s (> 1.5)
    a = moving_piece(0, 30, (0.0, 13.0), (0.0, -1.4))
    bike = moving_piece(45, 70, (0.0, 9.3), (0.0, -4.0))
    w = bike.size[0]
    assert np.hypot(*np.subtract(a.end[2:], bike.start[2:])) / w == pytest.approx(1.75, abs=0.01)
    assert stitch_pieces([a, bike], **GATE) == [1, -1]
    assert stitch_pieces([a, bike], **GATE, max_dv_mps=1.5) == [-1, -1]
    # the walker itself, stepping out 8.8 m away, is joined both ways, also when its first
    # second's fit is 1.4 W/s off across (0.7 m/s on the ground at 8.8 m)
    for err in (0.0, 1.4):
        walker = moving_piece(45, 90, (0.0, 8.8), (0.0, -1.4), du_error_w=err)
        assert ground_dv_misfit(a, walker) == pytest.approx(0.5 * err, abs=0.02)
        for pieces, want in (([a, bike, walker], [2, -1, -1]), ([a, walker, bike], [1, -1, -1])):
            assert stitch_pieces(pieces, **GATE) == want
            assert stitch_pieces(pieces, **GATE, max_dv_mps=1.5) == want


def test_ground_gate_off_by_default_and_checked():
    assert CountOptions().stitch.max_dv_mps == math.inf
    assert with_changes(CountOptions(), {"stitch.max_dv_mps": 1.5}).stitch.max_dv_mps == 1.5
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(ValueError, match="stitch.max_dv_mps"):
            with_changes(CountOptions(), {"stitch.max_dv_mps": bad})
