"""`count.track_speed`: the least-squares and Theil-Sen ground speed of a track, checked
against a hand-worked case and a plain NumPy double loop; `verdicts.speed_fit` validated."""

import math

import numpy as np
import pytest

from rhythmjax.count import CountOptions, track_speed
from rhythmjax.count.options import VerdictOptions
from rhythmjax.count.pedestrian_level import Pedestrian
from rhythmjax.track.rows import TrackRow


def _track(t, x, y, state=2):
    p = Pedestrian(slot=0, born=0)
    p.rows = [TrackRow(k, float(tk), 100.0, 100.0, 20.0, 1.0, float(xk), float(yk), state)
              for k, (tk, xk, yk) in enumerate(zip(t, x, y))]
    return p


def test_hand_worked_outlier():
    # 10 rows at 0.1 s (span 0.9 s) at (1.2, -1.6) m/s = 2 m/s; the first foot point is 5 m
    # too far (a foot point off the feet). Least squares: y slope -1.6 + 5 (0 - 0.45) / 0.825
    # (sum of (t - 0.45)^2 = 0.01 x 82.5) = -4.327 m/s, speed hypot(1.2, 4.327) = 4.49 m/s.
    # Theil-Sen: 9 of the 45 pairs hold the outlier, the 36 others slope exactly -1.6: 2 m/s.
    t = np.arange(10) / 10
    x, y = 1.2 * t, 8 - 1.6 * t
    y[0] += 5
    p = _track(t, x, y)
    assert track_speed(p, "lsq") == pytest.approx(math.hypot(1.2, 1.6 + 5 * 0.45 / 0.825),
                                                  rel=1e-9)
    assert track_speed(p) == track_speed(p, "theil-sen")  # the default (rule 25)
    assert track_speed(p, "lsq") == pytest.approx(4.4905, abs=1e-3)
    assert track_speed(p, "theil-sen") == pytest.approx(2.0, rel=1e-9)


def _theil_sen_loop(t, xy):
    v = []
    for axis in range(2):
        s = [(xy[j, axis] - xy[i, axis]) / (t[j] - t[i])
             for i in range(len(t)) for j in range(i + 1, len(t)) if t[j] > t[i]]
        v.append(np.median(s))
    return math.hypot(*v)


def test_theil_sen_matches_numpy_loop():
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(0, 3, 31))
    t[5] = t[4]  # two rows of one instant: no slope between them
    xy = np.stack([0.9 * t, 10 - 1.1 * t], 1) + rng.normal(0, 0.2, (31, 2))
    xy[[3, 17, 20]] += [0.0, 6.0]  # foot points off the feet
    p = _track(t, xy[:, 0], xy[:, 1])
    p.rows[8] = p.rows[8]._replace(state=3)  # a predicted row is left out
    keep = np.arange(31) != 8
    assert track_speed(p, "theil-sen") == pytest.approx(_theil_sen_loop(t[keep], xy[keep]),
                                                        rel=1e-12)
    tc = t[keep] - t[keep].mean()
    ls = tc @ (xy[keep] - xy[keep].mean(0)) / (tc @ tc)
    assert track_speed(p, "lsq") == pytest.approx(math.hypot(*ls), rel=1e-12)


def test_short_and_unknown_fit():
    t = np.arange(5) / 15  # under 0.5 s: unknown either way
    p = _track(t, t, t)
    assert math.isnan(track_speed(p, "theil-sen")) and math.isnan(track_speed(p))
    with pytest.raises(ValueError, match="speed fit"):
        track_speed(p, "median")


def test_speed_fit_option():
    assert CountOptions().verdicts.speed_fit == "theil-sen"  # since rule 25 (VerdictOptions)
    CountOptions(verdicts=VerdictOptions(speed_fit="lsq"))
    CountOptions(verdicts=VerdictOptions(speed_fit="theil-sen"))
    with pytest.raises(ValueError, match="speed_fit"):
        CountOptions(verdicts=VerdictOptions(speed_fit="median"))


def test_points_speed_of_arrays_leaves_out_non_finite_rows():
    from rhythmjax.count import points_speed

    t = np.arange(10) / 10
    x, y = 1.2 * t, 8 - 1.6 * t
    y[0] += 5
    want = {f: track_speed(_track(t, x, y), f) for f in ("lsq", "theil-sen")}
    t2, x2, y2 = (np.insert(a, 4, v) for a, v in ((t, 0.45), (x, np.nan), (y, 3.0)))
    for fit, w in want.items():
        assert points_speed(t2, x2, y2, fit) == pytest.approx(w, rel=1e-12)


def test_theil_sen_on_a_long_track_reads_evenly_spaced_rows():
    from rhythmjax.count import points_speed
    from rhythmjax.count.counting import THEIL_SEN_ROWS

    rng = np.random.default_rng(5)
    n = 5 * THEIL_SEN_ROWS + 3  # all n rows would make n (n - 1) / 2 pairs
    t = np.arange(n) / 15.0
    x, y = 0.8 * t + rng.normal(0, 0.3, n), 20 - 1.0 * t + rng.normal(0, 0.3, n)
    x[::17] += 8.0  # rows off the feet
    keep = np.linspace(0, n - 1, THEIL_SEN_ROWS).round().astype(np.int64)
    assert points_speed(t, x, y, "theil-sen") == pytest.approx(
        _theil_sen_loop(t[keep], np.stack([x[keep], y[keep]], 1)), rel=1e-12)
    assert points_speed(t, x, y, "theil-sen") == pytest.approx(math.hypot(0.8, 1.0), rel=0.02)
    # at or under the limit every row is read
    assert points_speed(t[:THEIL_SEN_ROWS], x[:THEIL_SEN_ROWS], y[:THEIL_SEN_ROWS],
                        "theil-sen") == pytest.approx(_theil_sen_loop(
                            t[:THEIL_SEN_ROWS], np.stack([x, y], 1)[:THEIL_SEN_ROWS]),
                            rel=1e-12)
