"""Ground-plane re-identification of a track ended after the PREDICT time-out
(`count.stitch.reid_distance`, `stitch.reid`): hand-worked cases on the ground plane."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.count import Piece, stitch_pieces
from rhythmjax.count.options import StitchOptions
from rhythmjax.count.patches import ShapeModel
from rhythmjax.count.stitch import reid_distance
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import config_from_dict

from .test_pedestrians import SMALL


CFG = config_from_dict(SMALL)
SHAPE = ShapeModel.from_config(CFG, "3d")
CAM = SHAPE.camera
FPS = 15.0
OPT = StitchOptions()
GATE = {"max_gap_s": OPT.max_gap_s, "gate_w": OPT.gate_w, "gate_h": OPT.gate_h,
        "gate_per_s": OPT.gate_per_s, "max_dv_w": OPT.max_dv_w, "camera": CAM}


def uv(x, y):
    return tuple(float(q) for q in project_3d(CAM, x, y, 0.0))


def duv(x, y, vx, vy):
    """Image velocity (px/s) of a ground point (x, y) m moving at (vx, vy) m/s."""
    a, b = np.asarray(uv(x, y)), np.asarray(uv(x + 0.01 * vx, y + 0.01 * vy))
    return tuple(float(q) for q in (b - a) / 0.01)


def piece(first, last, x0, x1, y, vx, start_du=None):
    """A walker crossing at ground y (m), x0 -> x1 m at vx m/s between frames first and last;
    its start's image velocity replaced by start_du px/s across when given (a walker stepping
    out from behind another: its first second's fit is poor)."""
    s = (*uv(x0, y), *duv(x0, y, vx, 0.0))
    if start_du is not None:
        s = (s[0], s[1], start_du, s[3])
    size = tuple(float(q) for q in SHAPE.size(*uv(x0, y)))
    return Piece(first, last, first / FPS, last / FPS, s, (*uv(x1, y), *duv(x1, y, vx, 0.0)),
                 size, (x1, y, vx, 0.0))


def test_a_walker_hidden_two_seconds_is_one_track():
    # W at y = 8 m; A walks right at 1.4 m/s, x -2.8 -> 0 m over frames 0-30 (2 s), hidden
    # 2 s (30 frames: twice the 1 s PREDICT time-out) behind a nearer walker, B steps out at
    # x = 2.8 m (frame 60) where A's constant ground velocity puts it
    W = float(SHAPE.size(*uv(2.8, 8.0))[0])
    a = piece(0, 30, -2.8, 0.0, 8.0, 1.4)
    b = piece(60, 100, 2.8, 5.5, 8.0, 1.4)
    assert reid_distance(a, b, CAM, gate_w=OPT.gate_w, gate_h=OPT.gate_h,
                         gate_per_s=OPT.gate_per_s) == pytest.approx(0.0, abs=1e-6)
    assert stitch_pieces([a, b], **GATE) == [1, -1]  # a good start fit: the halfway gate too
    # B's first second fitted 1.9 W/s too slow across (its start seen half hidden): taken back
    # 1 s at that velocity it misses A's halfway point by 1.9 W (> 0.9 W x 2 = 1.8 W, the gate
    # after 2 s); its velocity is still within the 2 W/s of max_dv_w
    du = duv(2.8, 8.0, 1.4, 0.0)[0] - 1.9 * W
    slow = piece(60, 100, 2.8, 5.5, 8.0, 1.4, start_du=du)
    assert stitch_pieces([a, slow], **GATE) == [-1, -1]  # two tracks: two walkers counted
    assert stitch_pieces([a, slow], reid=True, reid_max_dv_w=OPT.reid_max_dv_w, **GATE) == [1, -1]


def test_a_different_walker_elsewhere_is_not_joined():
    a = piece(0, 30, -2.8, 0.0, 8.0, 1.4)
    W = float(SHAPE.size(*uv(2.8, 8.0))[0])
    w_m = 2.8 / (uv(2.8, 8.0)[0] - uv(0.0, 8.0)[0]) * W  # ~ metres per W at 8 m
    kw = dict(reid=True, reid_max_dv_w=OPT.reid_max_dv_w, **GATE)
    # 2 s later the gate is 1.8 W across: a walker appearing 2.2 W further on is another one
    far = piece(60, 100, 2.8 + 2.2 * w_m, 6.0, 8.0, 1.4)
    assert stitch_pieces([a, far], **kw) == [-1, -1]
    # ... and one 6 m farther away (16 px higher in the image, 0.4 H at 8 m: the gate after
    # 2 s is 0.9 H up or down, of B's smaller patch there)
    behind = piece(60, 100, 2.8, 5.5, 14.0, 1.4)
    assert stitch_pieces([a, behind], **kw) == [-1, -1]
    # one at the right place walking the other way (velocity 2 x 1.4 m/s off, > 2 W/s)
    back = piece(60, 100, 2.8, 0.5, 8.0, -1.4)
    assert stitch_pieces([a, back], **kw) == [-1, -1]
    # past the 5 s gap: not joined however well it fits
    late = piece(110, 140, 1.4 * 110 / FPS - 2.8, 9.0, 8.0, 1.4)
    assert reid_distance(a, late, CAM, gate_w=OPT.gate_w, gate_h=OPT.gate_h,
                         gate_per_s=OPT.gate_per_s) < 1.0
    assert stitch_pieces([a, late], **kw) == [-1, -1]
    # of two candidates, the one where A's prediction lands wins
    near = piece(60, 100, 2.8 + 0.5 * w_m, 5.5, 8.0, 1.4)
    right = piece(61, 100, 2.8 + 1.4 / FPS, 5.5, 8.0, 1.4)
    assert stitch_pieces([a, near, right], **kw) == [2, -1, -1]


def test_reid_without_a_ground_state_uses_the_image_line():
    a = piece(0, 30, -2.8, 0.0, 8.0, 1.4)
    flat = Piece(a.first, a.last, a.t_first, a.t_last, a.start, a.end, a.size, None)
    b = piece(45, 100, 1.4, 5.5, 8.0, 1.4)
    d = reid_distance(flat, b, None, gate_w=OPT.gate_w, gate_h=OPT.gate_h,
                      gate_per_s=OPT.gate_per_s)
    assert 0.0 <= d < 0.2  # the image line bends off the ground line a little
    nan = Piece(a.first, a.last, a.t_first, a.t_last, a.start, (math.nan,) * 4, a.size, None)
    assert reid_distance(nan, b, None, gate_w=1.0, gate_h=1.0, gate_per_s=0.5) == math.inf


@pytest.mark.parametrize("reid", [False, True])
def test_a_walker_hidden_two_seconds_in_a_video_keeps_its_id(reid):
    """End to end: frames 25-54 show the empty background (2 s, twice the PREDICT time-out):
    one track, one walker, with the halfway stitch alone and with re-identification on."""
    from rhythmjax.count import CountOptions, count_frames
    from rhythmjax.sim.scene import SceneSpec, render_scene, walker
    from rhythmjax.track.options import with_changes

    from .test_pedestrians import QUIET

    a = walker(-4.0, 7.0, 0.0, start_frame=3, phase=0.1)
    frames = render_scene(1, SceneSpec(n_frames=90, actors=(a,), camera=CFG.camera)).frames
    items = [(k, k / FPS, frames[0] if 25 <= k < 55 else f) for k, f in enumerate(frames)]
    opt = with_changes(CountOptions(verdicts=QUIET), {"stitch.reid": reid})
    res = count_frames(CFG, iter(items), options=opt)
    assert res.counts["tracks"] == 1 and res.summary["stitched"] == 1
    assert set(res.mot["id"].tolist()) == {1}
