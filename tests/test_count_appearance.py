"""The appearance descriptor (`count.appearance`) against pixel loops, its distance by hand, and
stitching by appearance (`count.stitch.stitch_pieces` with `AppearanceOptions`) on hand-built
pieces."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.count.appearance import (
    Appearance,
    appearance_distance,
    hellinger,
    look_of_frame,
    patch_histograms,
)
from rhythmjax.count.options import AppearanceOptions
from rhythmjax.count.stitch import Piece, reach_misfit, stitch_pieces


def loop_histograms(gray, fg, u, v, w, h, bins, min_fill):
    """Reference: every pixel visited in Python; the patch's columns round(u - w/2) to
    round(u + w/2), upper rows round(v - h) to round(v - h/2), lower ones to round(v + 1)."""
    x0, x1 = int(round(u - w / 2)), int(round(u + w / 2))
    y0, ym, y1 = int(round(v - h)), int(round(v - h / 2)), int(round(v + 1))
    out = np.full((2, bins), np.nan)
    for k, (r0, r1) in enumerate(((y0, ym), (ym, y1))):
        counts, n = [0] * bins, 0
        for y in range(r0, r1):
            for x in range(x0, x1):
                if 0 <= y < gray.shape[0] and 0 <= x < gray.shape[1] and fg[y][x]:
                    counts[min(bins - 1, int(gray[y][x]) * bins // 256)] += 1
                    n += 1
        if n >= max(1, min_fill * (r1 - r0) * (x1 - x0)):
            out[k] = [c / n for c in counts]
    return out


@pytest.fixture
def frame():
    rng = np.random.default_rng(3)
    gray = rng.integers(0, 256, size=(40, 50)).astype(np.uint8)
    labels = rng.integers(0, 4, size=(40, 50))
    return gray, labels


@pytest.mark.parametrize("u,v,w,h", [(20.3, 30.6, 9.2, 21.7), (3.0, 12.0, 11.0, 25.0),
                                      (47.5, 39.2, 8.0, 16.4)])
def test_histograms_match_pixel_loop(frame, u, v, w, h):
    gray, labels = frame
    fg = labels >= 2
    got = patch_histograms(gray, fg, u, v, w, h, bins=8, min_fill=0.1)
    ref = loop_histograms(gray, fg, u, v, w, h, 8, 0.1)
    assert np.array_equal(np.isnan(got), np.isnan(ref))
    np.testing.assert_allclose(got[~np.isnan(ref)], ref[~np.isnan(ref)], rtol=0, atol=1e-12)


def test_histograms_sparse_half_is_nan():
    gray = np.full((30, 30), 200, np.uint8)
    fg = np.zeros((30, 30), bool)
    fg[20:26, 10:20] = True  # lower half only (rows 16..25)
    got = patch_histograms(gray, fg, 15.0, 25.0, 10.0, 20.0, bins=4, min_fill=0.1)
    assert np.all(np.isnan(got[0]))
    np.testing.assert_allclose(got[1], [0, 0, 0, 1], atol=1e-12)


@pytest.mark.parametrize("u,v,w,h", [(20.3, 30.6, 9.2, 21.7), (2.4, 12.5, 11.0, 25.0),
                                      (47.5, 39.2, 8.0, 16.4), (80.0, 20.0, 8.0, 16.0)])
def test_look_of_frame_uses_labels_minus_claimed(frame, u, v, w, h):
    gray, labels = frame
    claimed = np.zeros(labels.shape, bool)
    claimed[10:25, 15:22] = True
    look = look_of_frame(None, gray, labels, [1, 3], claimed, u, v, w, h, 8, 0.05)
    fg = np.isin(labels, [1, 3]) & ~claimed
    ref = loop_histograms(gray, fg, u, v, w, h, 8, 0.05)
    np.testing.assert_allclose(look.mean(), ref, rtol=0, atol=1e-12)
    assert list(look.n) == (~np.isnan(ref[:, 0])).astype(int).tolist()


def test_running_mean_skips_missing_halves():
    a = Appearance(bins=2)
    a.add(np.array([[1.0, 0.0], [0.5, 0.5]]))
    a.add(np.array([[np.nan, np.nan], [0.0, 1.0]]))
    a.add(np.array([[0.0, 1.0], [0.25, 0.75]]))
    np.testing.assert_allclose(a.mean(), [[0.5, 0.5], [0.25, 0.75]], atol=1e-12)
    assert list(a.n) == [2, 3]
    b = Appearance(bins=2)
    b.add(np.array([[0.0, 1.0], [np.nan, np.nan]]))
    a.merge(b)
    np.testing.assert_allclose(a.mean()[0], [1 / 3, 2 / 3], atol=1e-12)
    assert np.all(np.isnan(Appearance(bins=2).mean()))


def test_distance_by_hand():
    p, q = np.array([0.5, 0.5, 0.0]), np.array([0.25, 0.75, 0.0])
    bc = math.sqrt(0.5 * 0.25) + math.sqrt(0.5 * 0.75)
    assert hellinger(p, q) == pytest.approx(math.sqrt(1 - bc), abs=1e-12)
    assert hellinger(p, p) == pytest.approx(0.0, abs=1e-7)
    assert hellinger(np.array([1.0, 0]), np.array([0, 1.0])) == pytest.approx(1.0, abs=1e-12)
    a = np.array([p, [1.0, 0.0, 0.0]])
    b = np.array([q, [np.nan] * 3])  # the lower half unseen: the upper one alone
    assert appearance_distance(a, b) == pytest.approx(math.sqrt(1 - bc), abs=1e-12)
    c = np.array([q, [0.0, 0.0, 1.0]])
    assert appearance_distance(a, c) == pytest.approx(0.5 * (math.sqrt(1 - bc) + 1.0),
                                                      abs=1e-12)
    assert math.isnan(appearance_distance(a, None))


SHIRT = np.array([[0.9, 0.1, 0.0, 0.0], [0.0, 0.0, 0.2, 0.8]])
OTHER = np.array([[0.0, 0.1, 0.9, 0.0], [0.8, 0.2, 0.0, 0.0]])
GATE = dict(max_gap_s=5.0, gate_w=0.9, gate_h=0.45, gate_per_s=0.5, max_dv_w=2.0)


def pieces(look_b, gap=3.0, du_px=60.0, dx_m=1.5):
    """A standing still at (100, 200) px / (0, 10) m until t = 1 s; B starting `gap` s later
    du_px px (dx_m m) to its right: beyond the halfway gate (60 px / (0.9 x 10 px x 2.5)), within
    reach (1.5 m <= 2 x 0.5 m + 2 m/s x gap)."""
    A = Piece(0, 10, 0.0, 1.0, (100.0, 200.0, 0.0, 0.0), (100.0, 200.0, 0.0, 0.0), (10.0, 30.0),
              (0.0, 10.0, 0.0, 0.0), (0.0, 10.0), SHIRT)
    t0 = 1.0 + gap
    B = Piece(10 + round(gap * 10), 50 + round(gap * 10), t0, t0 + 4.0,
              (100.0 + du_px, 200.0, 0.0, 0.0), (100.0 + du_px, 200.0, 0.0, 0.0),
              (10.0, 30.0), (dx_m, 10.0, 0.0, 0.0), (dx_m, 10.0), look_b)
    return [A, B]


def test_reach_misfit_by_hand():
    A, B = pieces(SHIRT)
    assert reach_misfit(A, B, None, 1.0, 2.0) == pytest.approx(1.5 / (1.0 + 2.0 * 3.0),
                                                               abs=1e-12)


def test_same_appearance_joined_beyond_tight_gate():
    on = AppearanceOptions(enabled=True, max_distance=0.15)
    assert stitch_pieces(pieces(SHIRT), **GATE) == [-1, -1]  # geometry alone: not joined
    assert stitch_pieces(pieces(SHIRT), **GATE, look=on) == [1, -1]
    assert stitch_pieces(pieces(OTHER), **GATE, look=on) == [-1, -1]
    off = AppearanceOptions(enabled=False, max_distance=0.15)
    assert stitch_pieces(pieces(SHIRT), **GATE, look=off) == [-1, -1]
    # past the geometric max_gap_s (5 s), within appearance.max_gap_s (10 s)
    assert stitch_pieces(pieces(SHIRT, gap=6.0), **GATE, look=on) == [1, -1]
    # out of reach: 8 m in 3 s
    assert stitch_pieces(pieces(SHIRT, dx_m=8.0), **GATE, look=on) == [-1, -1]
    # unknown appearance: not joined
    assert stitch_pieces(pieces(None), **GATE, look=on) == [-1, -1]


def test_veto_refuses_geometric_join_of_different_look():
    near = dict(du_px=2.0, dx_m=0.05)
    assert stitch_pieces(pieces(OTHER, **near), **GATE) == [1, -1]
    on = AppearanceOptions(enabled=True)
    assert stitch_pieces(pieces(OTHER, **near), **GATE, look=on) == [1, -1]  # veto off
    veto = AppearanceOptions(enabled=True, veto_distance=0.5)
    assert stitch_pieces(pieces(OTHER, **near), **GATE, look=veto) == [-1, -1]
    assert stitch_pieces(pieces(SHIRT, **near), **GATE, look=veto) == [1, -1]
    # descriptors for the veto only: no join by appearance alone, even of identical looks
    veto_only = AppearanceOptions(enabled=True, max_distance=0.0, veto_distance=0.5)
    assert stitch_pieces(pieces(SHIRT), **GATE, look=on) == [1, -1]  # 0.387: joined
    assert stitch_pieces(pieces(SHIRT), **GATE, look=veto_only) == [-1, -1]
    assert stitch_pieces(pieces(OTHER, **near), **GATE, look=veto_only) == [-1, -1]
    assert stitch_pieces(pieces(SHIRT, **near), **GATE, look=veto_only) == [1, -1]
