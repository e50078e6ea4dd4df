"""`count.foot_gate`: options (a) (`placement.in_range`, `placement.gate_heights`) and (b)
(`placement.lift_heights`) on hand-worked foot points of the default camera.

Default camera: focal f*b = 800 px, height 1 m, tilt 15 deg, image centre row 256. A foot row v
looks 15 deg + atan((v - 256) / 800) below the horizontal, its ground point lies
y = 1 m / tan(that angle) ahead: row 256 -> 1 / tan 15 deg = 3.732 m; row 200 -> 15 - 4.004 =
10.996 deg -> 5.149 m; row 60 -> 15 - 13.77 = 1.23 deg -> 46.5 m (beyond range_max 20 m); the
horizon is row 256 - 800 tan 15 deg = 41.6, so row 30 has no ground point."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from rhythmjax.count.foot_gate import foot_gate, gated
from rhythmjax.count.options import CountOptions, with_changes
from rhythmjax.count.patches import ShapeModel
from rhythmjax.model.params import Config


@pytest.fixture(scope="module")
def camera():
    return ShapeModel.from_config(Config(), "3d").camera


KW = {"range_max": 20.0, "walker_m": 1.7}


def test_defaults_gate_nothing(camera):
    o = CountOptions().placement
    assert (o.in_range, o.gate_heights, o.lift_heights) == (False, 0.0, 0.0)
    for v in (30.0, 60.0, 200.0):
        assert foot_gate(camera, (256.0, 256.0), 100.0, (256.0, v), **KW) is None


def test_a_range_and_horizon(camera):
    pred = (256.0, 256.0)
    assert foot_gate(camera, pred, 100.0, (256.0, 256.0), in_range=True, **KW) is None
    assert foot_gate(camera, pred, 100.0, (256.0, 200.0), in_range=True, **KW) is None  # 5.1 m
    assert foot_gate(camera, pred, 100.0, (256.0, 60.0), in_range=True, **KW) == "range"  # 46 m
    assert foot_gate(camera, pred, 100.0, (256.0, 30.0), in_range=True, **KW) == "horizon"


def test_a_ground_jump(camera):
    # predicted 3.732 m, measured 5.149 m: 1.417 m apart = 0.833 walker heights of 1.7 m
    pred, z = (256.0, 256.0), (256.0, 200.0)
    assert foot_gate(camera, pred, 100.0, z, gate_heights=1.0, **KW) is None
    assert foot_gate(camera, pred, 100.0, z, gate_heights=0.8, **KW) == "jump"


def test_b_lift():
    # patch 100 px tall predicted with its feet on row 200: a blob bottom 20 px higher (0.2 H)
    # shows no legs at 0.15 H, 10 px (0.1 H) does; lower than predicted is never lifted
    cam = None  # (b) alone needs no ground point
    assert foot_gate(cam, (100.0, 200.0), 100.0, (100.0, 180.0), lift_heights=0.15, **KW) == "lift"
    assert foot_gate(cam, (100.0, 200.0), 100.0, (100.0, 190.0), lift_heights=0.15, **KW) is None
    assert foot_gate(cam, (100.0, 200.0), 100.0, (100.0, 230.0), lift_heights=0.15, **KW) is None
    assert foot_gate(cam, (100.0, 200.0), 100.0, (100.0, 180.0), lift_heights=0.25, **KW) is None


@pytest.mark.parametrize("changes, z, why", [
    ({}, (256.0, 60.0), None),
    ({"placement.in_range": True}, (256.0, 60.0), "range"),
    ({"placement.lift_heights": 0.15}, (256.0, 256.0 - 0.2 * 382.8), "lift"),
    ({"placement.lift_heights": 0.15}, (256.0, 256.0 - 0.1 * 382.8), None),
])
def test_gated_wiring(changes, z, why):
    """`gated` reads the level's options, camera, config; counts the reason. The default
    camera's patch at (256, 256) is 382.8 px tall (1.7 m at 3.732 m)."""
    cfg = Config()
    level = SimpleNamespace(opt=with_changes(CountOptions(), changes), cfg=cfg,
                            shape=ShapeModel.from_config(cfg, "3d"), gated={})
    p = SimpleNamespace(next_uv=(256.0, 256.0))
    pl = SimpleNamespace(u=z[0], v=z[1])
    assert gated(level, p, pl) == (z if why is None else None)
    assert level.gated == ({} if why is None else {why: 1})


def test_b_lift_keep_u():
    """(b) with `placement.lift_keep_u`: the lifted placement measures u only, at the
    predicted foot row."""
    cfg = Config()
    opt = with_changes(CountOptions(), {"placement.lift_heights": 0.15,
                                        "placement.lift_keep_u": True})
    level = SimpleNamespace(opt=opt, cfg=cfg, shape=ShapeModel.from_config(cfg, "3d"), gated={})
    pl = SimpleNamespace(u=250.0, v=256.0 - 0.2 * 382.8)
    assert gated(level, SimpleNamespace(next_uv=(256.0, 256.0)), pl) == (250.0, 256.0)
    assert level.gated == {"lift": 1}
