"""evaluation.sort_baseline: the Kalman steps against plain float64 loops, the exact assignment
against brute force, and track bookkeeping (short misses, new ids, min_hits) on constructed
detections."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from rhythmjax.evaluation import sort_baseline as sb


def matmul(a, b):
    n, k, m = len(a), len(b), len(b[0])
    return [[sum(a[i][q] * b[q][j] for q in range(k)) for j in range(m)] for i in range(n)]


def transpose(a):
    return [list(r) for r in zip(*a)]


def inverse(a):
    """Gauss-Jordan with partial pivoting, plain Python floats."""
    n = len(a)
    m = [list(map(float, a[i])) + [1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        piv = m[c][c]
        m[c] = [x / piv for x in m[c]]
        for r in range(n):
            if r != c:
                f = m[r][c]
                m[r] = [x - f * y for x, y in zip(m[r], m[c])]
    return [row[n:] for row in m]


def test_kalman_steps_match_hand_loops():
    rng = np.random.default_rng(7)
    x = rng.normal(size=7) * [50, 50, 500, 0.2, 2, 2, 10] + [200, 150, 1500, 0.4, 0, 0, 0]
    L = rng.normal(size=(7, 7))
    P = L @ L.T + 7 * np.eye(7)
    z = sb.box_to_z(np.array([190.0, 120.0, 25.0, 60.0]))
    xp, Pp = sb.kf_predict(x, P)
    F, Q = sb.F_CV.tolist(), sb.Q_BOX.tolist()
    xh = [sum(F[i][j] * x[j] for j in range(7)) for i in range(7)]
    Ph = [[a + b for a, b in zip(ra, rb)]
          for ra, rb in zip(matmul(matmul(F, P.tolist()), transpose(F)), Q)]
    np.testing.assert_allclose(xp, xh, rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(Pp, Ph, rtol=1e-13, atol=1e-10)
    xu, Pu = sb.kf_update(xp, Pp, z)
    H, R = sb.H_BOX.tolist(), sb.R_BOX.tolist()
    S = [[a + b for a, b in zip(ra, rb)] for ra, rb in zip(matmul(matmul(H, Ph), transpose(H)), R)]
    K = matmul(matmul(Ph, transpose(H)), inverse(S))
    innov = [z[i] - sum(H[i][j] * xh[j] for j in range(7)) for i in range(4)]
    x_ref = [xh[i] + sum(K[i][j] * innov[j] for j in range(4)) for i in range(7)]
    IKH = [[(1.0 if i == j else 0.0) - v for j, v in enumerate(row)]
           for i, row in enumerate(matmul(K, H))]
    P_ref = matmul(IKH, Ph)
    np.testing.assert_allclose(xu, x_ref, rtol=1e-11, atol=1e-9)
    np.testing.assert_allclose(Pu, P_ref, rtol=1e-9, atol=1e-9)


def test_box_state_roundtrip():
    b = np.array([12.5, 30.0, 18.0, 44.0])
    z = sb.box_to_z(b)
    np.testing.assert_allclose(z, [21.5, 52.0, 18 * 44, 18 / 44], rtol=1e-15)
    np.testing.assert_allclose(sb.z_to_box(z), b, rtol=1e-13)


@pytest.mark.parametrize("shape", [(1, 1), (3, 3), (2, 5), (5, 2), (4, 4)])
def test_assign_is_exact(shape):
    rng = np.random.default_rng(sum(shape))
    for _ in range(20):
        c = rng.normal(size=shape)
        rows, cols = sb.assign(c)
        n, m = shape
        best = min(
            (sum(c[i, p[i]] for i in range(n)) for p in itertools.permutations(range(m), n)),
            default=None) if n <= m else min(
            sum(c[p[j], j] for j in range(m)) for p in itertools.permutations(range(n), m))
        assert len(rows) == min(n, m) and len(set(cols.tolist())) == len(cols)
        assert np.all(np.diff(rows) > 0)
        assert c[rows, cols].sum() == pytest.approx(best, abs=1e-12)


def moving(f, x0=50.0, vx=4.0, y=100.0, w=20.0, h=50.0):
    return np.array([x0 + vx * f, y, w, h])


def run(tracker, per_frame):
    return [tracker.step(np.asarray(b, float).reshape(-1, 4)) for b in per_frame]


def test_track_survives_short_miss_and_min_hits():
    frames = [[moving(f)] if f != 6 else [] for f in range(12)]
    out = run(sb.SortTracker(max_age=1, min_hits=3), frames)
    ids = [o[0].tolist() for o in out]
    assert ids[6] == []  # not matched in the missing frame -> not reported
    assert {i for row in ids for i in row} == {1}  # one id throughout, kept over the miss
    assert ids[7] == []  # hit streak restarts after the miss: reported again 3 matches later
    assert ids[8] == [] and ids[9] == [1]
    # the estimate follows the box
    np.testing.assert_allclose(out[11][1][0], moving(11), atol=1.0)
    # with max_age = 0 the miss kills the track: a new id afterwards
    out0 = run(sb.SortTracker(max_age=0, min_hits=1), frames)
    assert out0[5][0].tolist() == [1] and out0[7][0].tolist() == [2]


def test_new_objects_get_new_ids():
    frames = []
    for f in range(10):
        b = [moving(f)]
        if f >= 4:
            b.append(moving(f - 4, x0=300.0, vx=-3.0, y=40.0))
        frames.append(b)
    out = run(sb.SortTracker(max_age=1, min_hits=1), frames)
    assert out[3][0].tolist() == [1]
    assert sorted(out[9][0].tolist()) == [1, 2]
    k2 = out[9][0].tolist().index(2)
    np.testing.assert_allclose(out[9][1][k2], moving(5, x0=300.0, vx=-3.0, y=40.0), atol=1.0)


def test_sort_track_columns_and_empty_frames():
    det = {"frame": np.array([1, 2, 3, 5, 6, 7]), "bb_left": np.array([10.0, 12, 14, 18, 20, 22]),
           "bb_top": np.full(6, 5.0), "bb_width": np.full(6, 10.0),
           "bb_height": np.full(6, 30.0)}
    mot = sb.sort_track(det, max_age=1, min_hits=1)
    assert mot["frame"].tolist() == [1, 2, 3, 5, 6, 7] and set(mot["id"].tolist()) == {1}
    assert mot["conf"].shape == (6,)
    mot2 = sb.sort_track(det, frames=range(1, 8), max_age=0, min_hits=1)
    assert set(mot2["id"].tolist()) == {1, 2}  # frame 4 is empty: the track dies
    with pytest.raises(ValueError, match="missing column"):
        sb.sort_track({"frame": [1]})
    det["bb_top"][2] = np.nan
    with pytest.raises(ValueError, match="row 2 \\(frame 3\\)"):
        sb.sort_track(det)


def test_blob_detections_box_of_a_moving_square():
    bg = np.full((60, 80), 100, np.uint8)
    frames = []
    for k in range(4):
        img = bg.copy()
        img[20:32, 10 + 5 * k:22 + 5 * k] = 200
        frames.append((k, k / 10, img if k else bg))
    det = sb.blob_detections(frames, open_px=0, close_px=0, min_area=10)
    assert det["frame"].tolist() == [1, 2, 3]
    assert det["bb_left"].tolist() == [15.0, 20.0, 25.0]
    assert det["bb_top"].tolist() == [20.0] * 3
    assert det["bb_width"].tolist() == [12.0] * 3 and det["bb_height"].tolist() == [12.0] * 3
