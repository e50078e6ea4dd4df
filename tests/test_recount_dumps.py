"""benchmarks/recount_dumps.py: the speed's standard error against a hand-worked fit, and both
recount rules on a hand-made clip record."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import recount_dumps as rd  # noqa: E402


def test_speed_and_se_by_hand():
    t = np.array([0.0, 0.5, 1.0, 1.5])
    # x: slope 2 m/s with residuals +-0.1 (+, -, -, +): sum (t - 0.75)^2 = 1.25, residual
    # squares 0.04 over n - 2 = 2: slope variance 0.02 / 1.25 = 0.016; y constant: slope 0
    x = 2.0 * t + np.array([0.1, -0.1, -0.1, 0.1])
    s, se = rd.speed_and_se(t, x, np.full(4, 5.0))
    assert s == pytest.approx(2.0, abs=1e-12) and se == pytest.approx(np.sqrt(0.016), abs=1e-12)
    assert np.isnan(rd.speed_and_se(t[:2], x[:2], x[:2])[0])  # fewer than 3 points
    assert np.isnan(rd.speed_and_se(t * 0.1, x, x)[0])  # a 0.15 s span


def _record():
    t = np.arange(20) / 10.0  # 1.9 s
    fast = 3.0 * t  # 3 m/s exactly: too fast, se 0
    noisy = 2.8 * t + np.where(np.arange(20) % 2, 0.6, -0.6)  # fits 2.89 m/s, se 0.24
    rows = {"track_id": np.repeat([1, 2], 20), "state": np.array(["observe"] * 40),
            "t": np.tile(t, 2), "x_est": np.concatenate([fast, noisy]), "y_est": np.zeros(40)}
    verdicts = {"track_id": np.array([1, 2, 3, 4]),
                "verdict": np.array(["unclassified", "unclassified", "non-pedestrian",
                                     "non-pedestrian"], dtype=object),
                "reason": np.array(["too-short", "too-short", "no-peak", "no-model-match"],
                                   dtype=object),
                "too_fast": np.array([True, True, False, False]),
                "counted": np.array([False, False, False, False])}
    return {"tracks": rows, "verdicts": verdicts}


def test_the_recount_rules():
    r = _record()
    assert rd.recounted(r, "no-peak").tolist() == [False, False, True, False]
    s, se = rd.speed_and_se(r["tracks"]["t"][20:], r["tracks"]["x_est"][20:], np.zeros(20))
    assert s - 1.0 * se > rd.top_speed() > s - 2.0 * se  # the noisy one: uncut at z = 2
    assert rd.recounted(r, "speed-se:1").tolist() == [False, False, False, False]
    assert rd.recounted(r, "speed-se:2").tolist() == [False, True, False, False]
    with pytest.raises(SystemExit, match="unknown rule"):
        rd.recounted(r, "other")


def test_the_speed_fit_recount():
    r = _record()
    # track 1 at 3 m/s is too fast whatever the fit; track 2's least squares is 2.89 m/s
    assert rd.recounted(r, "speed-fit:lsq").tolist() == [False, False, False, False]
    # track 1 at 1 m/s with its last row 15 m ahead (a foot point off the feet): least
    # squares 1 + 15 x (1.9 - 0.95) / 6.65 = 3.14 m/s (sum of (t - 0.95)^2 = 6.65 s^2), too
    # fast; Theil-Sen: 19 of the 190 pairs hold the row, the median slope stays 1 m/s
    t = r["tracks"]["t"][:20]
    x = 1.0 * t
    x[-1] += 15.0
    r["tracks"]["x_est"][:20] = x
    from rhythmjax.count import points_speed

    assert points_speed(t, x, np.zeros(20), "lsq") == pytest.approx(1 + 15 * 0.95 / 6.65,
                                                                    rel=1e-12)
    assert points_speed(t, x, np.zeros(20), "theil-sen") == pytest.approx(1.0, rel=1e-12)
    assert rd.recounted(r, "speed-fit:lsq").tolist() == [False, False, False, False]
    # counted by the Theil-Sen speed; judged tracks and track 2 untouched
    assert rd.recounted(r, "speed-fit:theil-sen").tolist() == [True, False, False, False]


def test_the_head_speed_recount_reproduces_the_library():
    """`head-speed` on a saved tracks table (state names as strings): a walker tracked on its
    hips at 20 m (`tests/test_count_head_speed.walker_rows`) whose foot-row speed read too fast
    is counted, as `count.faster_than` with `count.head_speed` decides; a track on its feet
    keeps its verdict."""
    sys.path.insert(0, os.path.dirname(__file__))
    from test_count_head_speed import HIPS_M, walker_rows

    from rhythmjax.count.counting import faster_than, head_speed
    from rhythmjax.count.patches import ShapeModel

    cfg = rd.config_of("count:800")  # the own scenes' preset at 800 px: the default camera
    hips, _ = walker_rows(foot_z=np.full(30, HIPS_M))
    feet, _ = walker_rows()
    tracks = {"track_id": np.repeat([1, 2], 30), "state": np.array(["observe"] * 60),
              **{c: np.array([getattr(q, c) for q in hips + feet], float)
                 for c in ("t", "u", "v", "v_top")}}
    verdicts = {"track_id": np.array([1, 2]),
                "verdict": np.array(["unclassified"] * 2, dtype=object),
                "reason": np.array(["too-short"] * 2, dtype=object),
                "too_fast": np.array([True, True]), "counted": np.array([False, False]),
                "track_speed_mps": np.array([9.0, 9.0])}
    record = {"tracks": tracks, "verdicts": verdicts, "image_size": (512, 512)}
    assert rd.recounted(record, "head-speed", cfg).tolist() == [True, False]
    shape = ShapeModel.from_config(cfg, "3d")
    heads = [head_speed(shape, rows, 512) for rows in (hips, feet)]
    assert faster_than([9.0, 9.0], heads, rd.top_speed()).tolist() == [False, True]
