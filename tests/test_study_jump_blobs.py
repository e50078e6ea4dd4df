"""benchmarks/study_jump_blobs.py: the placements it watches are restored, and a jump piece's
record (widest blob, shared, worst placed foot point against the truth) on hand-made rows."""

from __future__ import annotations

import os
import sys
from types import SimpleNamespace

import numpy as np
import pytest


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_jump_blobs as sjb  # noqa: E402


def test_watching_restores_the_module():
    mod = SimpleNamespace(place_patch=lambda *a, **k: "placed", gated=lambda *a: "z")
    before = (mod.place_patch, mod.gated)
    log: dict = {}
    with sjb.watched_placements(mod, log):
        shape = SimpleNamespace(size=lambda u, v: (20.0, 50.0))
        assert mod.place_patch(None, None, None, shape, 10.0, 30.0, radius_px=6.0,
                               bbox=(0, 0, 70, 40)) == "placed"
        p, level = object(), SimpleNamespace(n_frames=5)
        assert mod.gated(level, p, SimpleNamespace(u=11.0, v=31.0, w=19.0, h=48.0)) == "z"
    assert (mod.place_patch, mod.gated) == before
    # 70 px of blob box over W = 20 px; radius 6 px < 0.5 W: shared; frame index 4; no labels:
    # no head row
    (entry,) = log[id(p)].values()
    assert list(log[id(p)]) == [4] and entry[:6] == (3.5, True, 11.0, 31.0, 19.0, 48.0)
    assert np.isnan(entry[6])


def test_watching_the_velocity_jumps():
    class Level:
        def _velocity_jump(self, p):
            return 2 if len(p.ground) > 3 else 0

    mod = SimpleNamespace(place_patch=None, gated=None, PedestrianLevel=Level)
    before = Level._velocity_jump
    g = lambda vx, vy: SimpleNamespace(vx=vx, vy=vy)  # noqa: E731
    young = SimpleNamespace(ground=[g(1.0, 0.0)] * 3)
    p = SimpleNamespace(ground=[g(0.0, 0.0), g(1.2, 0.0), g(1.2, 0.5), g(1.0, 0.0),
                                g(-0.6, 0.0)])
    speeds: dict = {}
    with sjb.watched_placements(mod, {}, speeds):
        assert Level()._velocity_jump(young) == 0 and Level()._velocity_jump(p) == 2
    assert Level._velocity_jump is before
    # k = 2: ground[-3] = (1.2, 0.5) -> 1.3 m/s; ground[-1] = (-0.6, 0): 0.6; change (1.8, 0.5)
    assert speeds == {id(p): pytest.approx((1.3, 0.6, float(np.hypot(1.8, 0.5))))}


def _box(frame):
    return SimpleNamespace(frame=frame)


def test_a_jump_piece_record():
    # walker 7's truth box: bottom centre (100 + 2 f, 150) in frame index f (MOT frame f + 1)
    frames = np.arange(0, 30)
    truth = {"frame": frames + 1, "id": np.full(30, 7), "bb_left": 90.0 + 2 * frames,
             "bb_top": np.full(30, 100.0), "bb_width": np.full(30, 20.0),
             "bb_height": np.full(30, 50.0)}
    piece = SimpleNamespace(end_reason="velocity-jump", boxes=[_box(f) for f in range(5, 20)],
                            ground=[SimpleNamespace(y=12.0)])
    # placed on the walker until 19, then (dropped by the jump rule) 9 px right, 25 px low;
    # a head row in frames 20 and 21 implying feet 3 and 5 px low, none elsewhere
    head = {20: 153.0, 21: 155.0}
    log = {id(piece): {f: (1.5 if f < 20 else 4.2, f >= 20, 100.0 + 2 * f + (9 if f >= 20
                                                                              else 0),
                           150.0 + (25 if f >= 20 else 0), 20.0, 50.0, head.get(f, np.nan))
                       for f in range(5, 24)}}
    other = SimpleNamespace(end_reason="timeout", boxes=piece.boxes, ground=piece.ground)
    owner = lambda boxes, tr, off, kinds: (7, "pedestrian")  # noqa: E731
    recs = sjb.jump_pieces([piece, other], log, truth, {7: "pedestrian"}, 0, 8, owner,
                           speeds={id(piece): (1.2, 2.9, 2.1)})
    near = sjb.jump_pieces([piece], log, truth, {7: "pedestrian"}, 0, 0, owner)
    # dropped frames 20-23: the patch 9 px right and 25 px low of the 20 x 50 truth box: IoU
    # (11 x 25) / (2 x 1000 - 275) = 0.159 < 0.3: on nothing; the kept rows 11-19 on the truth;
    # the head rows 3 and 5 px off: median 4; 25 px > 0.1 x the 50 px patch: all 4 rows off
    assert recs == [{"ratio": 4.2, "shared": True, "du": 9.0, "dv": 25.0, "y": 12.0,
                     "dropped_on": "nothing", "dv_kept": 0.0, "du_placed": 9.0,
                     "dv_placed": 25.0, "dv_worst": 25.0, "off_rows": 4, "dv_head": 4.0,
                     "head_frames": 2, "rows": 15, "placed_frames": 4, "speed_before": 1.2,
                     "speed_at": 2.9, "dv_mps": 2.1, "dv_head_off": 4.0, "dv_placed_off": 25.0,
                     "head_off_frames": 2}]
    # only the end frame (19) itself: on the walker, and no dropped frame looked at
    (rec,) = near
    assert {k: rec[k] for k in ("ratio", "shared", "du", "dv", "dropped_on", "dv_kept",
                                "head_frames", "rows", "off_rows", "placed_frames")} == {
        "ratio": 1.5, "shared": False, "du": 0.0, "dv": 0.0, "dropped_on": "not placed",
        "dv_kept": 0.0, "head_frames": 0, "rows": 15, "off_rows": 0, "placed_frames": 0}
    assert all(np.isnan(rec[k]) for k in ("du_placed", "dv_placed", "dv_worst", "dv_head",
                                          "dv_head_off", "dv_placed_off"))
    assert "speed_at" not in rec  # no speeds given


def test_what_the_dropped_frames_stood_on():
    # walker 7 at left 100, walker 8 at left 140, a bicycle 9 at left 180 (20 x 50 boxes,
    # bottom 150) in frame indices 0-9 (truth frames 1-10)
    F = np.arange(10)
    truth = {"frame": np.r_[F, F, F] + 1, "id": np.r_[[7] * 10, [8] * 10, [9] * 10],
             "bb_left": np.r_[[100.0] * 10, [140.0] * 10, [180.0] * 10],
             "bb_top": np.full(30, 100.0), "bb_width": np.full(30, 20.0),
             "bb_height": np.full(30, 50.0)}
    kinds = {7: "pedestrian", 8: "pedestrian", 9: "bicycle"}
    at = lambda f, left: (f, left + 10.0, 150.0, 20.0, 50.0)  # noqa: E731
    on = lambda placed: sjb.dropped_on(placed, truth, kinds, 7, 0)  # noqa: E731
    assert on([at(1, 100.0), at(2, 100.0)]) == "own walker"
    assert on([at(1, 140.0), at(2, 140.0), at(3, 100.0)]) == "another walker"
    assert on([at(1, 180.0)]) == "non-walker"
    assert on([at(1, 300.0)]) == "nothing"
    assert on([at(1, 100.0), at(2, 140.0)]) == "own walker"  # a tie: DROPPED_ON's order
    assert on([at(20, 100.0)]) == "nothing"  # no truth in that frame
    assert on([]) == "not placed"


@pytest.mark.parametrize("frame, found", [(3, (106.0, 150.0)), (40, None)])
def test_truth_foot(frame, found):
    frames = np.arange(0, 30)
    truth = {"frame": frames + 1, "id": np.full(30, 7), "bb_left": 90.0 + 2 * frames,
             "bb_top": np.full(30, 100.0), "bb_width": np.full(30, 20.0),
             "bb_height": np.full(30, 50.0)}
    assert sjb.truth_foot(truth, 7, frame, 0) == found


def test_the_own_walker_line():
    rec = lambda on, dv, head, n: {"dropped_on": on, "rows": n, "du_placed": 2.0,  # noqa: E731
                                   "dv_placed": dv, "dv_worst": 10 * dv, "off_rows": n // 10,
                                   "placed_frames": 8, "dv_kept": 1.0, "dv_head": head,
                                   "head_frames": int(not np.isnan(head)),
                                   "dv_head_off": head + 1.0, "dv_placed_off": 4 * dv,
                                   "head_off_frames": int(not np.isnan(head))}
    assert sjb.own_walker_line([rec("nothing", 9.0, np.nan, 10)]) is None
    line = sjb.own_walker_line([rec("own walker", 1.0, np.nan, 10),
                                rec("own walker", 3.0, 8.0, 20),
                                rec("another walker", 40.0, 1.0, 99)])
    # two own pieces: rows median 15, |dv| median 2.0, upper quartile 1 + 0.75 x 2 = 2.5, worst
    # 10 and 30: 20; off rows 1 and 2: 2 (numpy's median of 1, 2 = 1.5, printed as 2); one
    # with a head row (8 px; placed 3 px there)
    assert line == ("  on its own walker (2 pieces, 15 rows): foot point off the truth in the "
                    "dropped frames by |du| 2.0, |dv| 2.0 px (a quarter of the pieces over 2.5), "
                    "at worst |dv| 20.0 px; dropped frames off by more than 0.1 H: 2 of each "
                    "piece's 8; in its own last rows |dv| 1.0 px; 1 pieces with a head row in "
                    "the dropped frames, the foot row it implies off by 8.0 px (placed, in those: "
                    "3.0); in the off frames (1 pieces with a head row there) 9.0 px (placed "
                    "12.0); medians over pieces")


def test_the_foot_row_from_the_head():
    """A walker standing on row 120 (its patch's top its head) whose blob reaches down to row
    140 (a merged object below): placed on row 140, the head gives back about row 120."""
    from rhythmjax.count.patches import ShapeModel

    from .test_pedestrians import CFG

    shape = ShapeModel.from_config(CFG, "3d")
    w, h = (float(q) for q in shape.size(128.0, 120.0))
    labels = np.zeros((192, 256), np.int32)
    labels[round(120 - h):141, round(128 - w / 2):round(128 + w / 2)] = 3
    w2, h2 = (float(q) for q in shape.size(128.0, 140.0))
    pl = SimpleNamespace(u=128.0, v=140.0, w=w2, h=h2)
    v = sjb.head_foot_row(labels, np.array([3]), None, shape, pl)
    assert abs(v - 120.0) <= 1.0  # the top row is whole: within a row
    assert np.isnan(sjb.head_foot_row(np.zeros_like(labels), np.array([3]), None, shape, pl))
