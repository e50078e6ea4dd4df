"""The lean of a pedestrian's silhouette (`count.widths.measured_lean`: the tracks' `u_top` is
the foot point's u plus it): hand-worked cases (an upright bar, a slanted bar whose slant the
line recovers) and a plain-loop reference on random label images."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.count.widths import measured_lean


def _reference(labels, related, claimed, u, v, w, v_top, reach):
    """Row by row in plain Python, then the least-squares line by the normal equations."""
    H, W = labels.shape
    y0, y1 = max(0, math.floor(v_top)), min(H, math.floor(v) + 1)
    a0 = max(0, math.floor(u - w / 2 - reach + 0.5))
    a1 = min(W, math.floor(u + w / 2 + reach + 0.5))
    rows, means = [], []
    for y in range(y0, y1):
        cols = [x for x in range(a0, a1) if int(labels[y, x]) in related
                and not (claimed is not None and claimed[y, x])]
        if cols:
            rows.append(float(y))
            means.append(sum(cols) / len(cols))
    if len(rows) < max(3, (y1 - y0) / 3):
        return math.nan
    n = len(rows)
    sr, sm = sum(rows), sum(means)
    srr = sum(r * r for r in rows)
    srm = sum(r * m for r, m in zip(rows, means))
    slope = (n * srm - sr * sm) / (n * srr - sr * sr)
    return slope * (v_top - (y1 - 1))


def test_an_upright_bar():
    """A bar of columns 10-13 from row 5 to row 40: no lean, whatever the top row."""
    lab = np.zeros((50, 40), np.int32)
    lab[5:41, 10:14] = 3
    for v_top in (5.0, 20.0):
        assert measured_lean(lab, [3], None, 11.5, 40.0, 6.0, v_top, 3.0) == pytest.approx(
            0.0, abs=1e-12)


def test_a_slanted_bar_gives_its_top_column():
    """Rows 10..50, each a 5-px run starting at round(20 + 0.25 (50 - row)): the line through
    the row means reads the top's column less the feet's (+10 px from row 50 to row 10) to
    within the rounding (0.3 px), wherever the patch stands while its columns hold the bar."""
    lab = np.zeros((60, 60), np.int32)
    for r in range(10, 51):
        s = int(round(20 + 0.25 * (50 - r)))
        lab[r, s:s + 5] = 7
    got = measured_lean(lab, [7], None, 24.0, 50.0, 8.0, 10.0, 8.0)
    assert got == pytest.approx(10.0, abs=0.3)
    assert measured_lean(lab, [7], None, 26.0, 50.0, 8.0, 10.0, 8.0) == pytest.approx(got)


def test_claimed_other_labels_and_bad_input():
    lab = np.zeros((50, 40), np.int32)
    lab[5:41, 10:14] = 3
    lab[5:41, 15:18] = 4  # another object's blob beside it: not related
    claimed = np.zeros(lab.shape, bool)
    assert measured_lean(lab, [3], None, 11.5, 40.0, 6.0, 5.0, 3.0) == pytest.approx(0.0)
    claimed[5:23, 13] = True  # the bar's right column taken by an older patch in the top half:
    # the upper rows' means 11.0, the lower 11.5, a lean to the left
    got = measured_lean(lab, [3], claimed, 11.5, 40.0, 6.0, 5.0, 3.0)
    assert got < -0.3 and got == pytest.approx(_reference(lab, [3], claimed, 11.5, 40.0, 6.0,
                                                          5.0, 3.0), abs=1e-12)
    assert math.isnan(measured_lean(lab, [9], None, 11.5, 40.0, 6.0, 5.0, 3.0))  # none
    assert math.isnan(measured_lean(lab, [3], None, 11.5, 40.0, 6.0, math.nan, 3.0))
    assert math.isnan(measured_lean(lab, [3], None, 11.5, 40.0, 6.0, 45.0, 3.0))  # top below feet
    lab2 = np.zeros((50, 40), np.int32)
    lab2[38:41, 10:14] = 3  # pixels on 3 of 36 rows: too few for a line
    assert math.isnan(measured_lean(lab2, [3], None, 11.5, 40.0, 6.0, 5.0, 3.0))


def test_matches_the_plain_loop_on_random_images():
    rng = np.random.default_rng(11)
    done = 0
    for _ in range(200):
        H, W = rng.integers(20, 60, 2)
        lab = rng.integers(0, 4, (H, W)).astype(np.int32)
        lab[rng.random((H, W)) < 0.5] = 0
        claimed = rng.random((H, W)) < 0.1 if rng.random() < 0.5 else None
        related = [int(q) for q in rng.choice([1, 2, 3], rng.integers(1, 3), replace=False)]
        u, v = float(rng.uniform(-5, W + 5)), float(rng.uniform(0, H + 5))
        w, reach = float(rng.uniform(1, 15)), float(rng.uniform(0, 8))
        v_top = v - float(rng.uniform(0, 40))
        got = measured_lean(lab, related, claimed, u, v, w, v_top, reach)
        want = _reference(lab, related, claimed, u, v, w, v_top, reach)
        if math.isnan(want):
            assert math.isnan(got)
        else:
            done += 1
            assert got == pytest.approx(want, abs=1e-9)
    assert done > 50
