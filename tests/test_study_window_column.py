"""benchmarks/study_window_column.py: the column estimates it tries for window B and how it picks
a window among candidates, on hand-made images, columns and rhythm signals."""

from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest

from rhythmjax.model.params import Config


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_window_column as swc  # noqa: E402


def test_mass_column_is_the_mean_column_of_the_motion_in_its_rows():
    """W 10 px, so a body 34 px tall above v 100 and a box of columns 40-60: motion (grey 40)
    in columns 52-55 at rows 80-89 (0.32-0.59 of the body above v) and in column 40 at row 99
    (the feet). The body's band (0-1) counts all 41 pixels, (10 x (52 + 53 + 54 + 55) + 40) /
    41; the band 0.3-0.6 (rows 79-90) only the block, 53.5. Grey 15 is no motion (the band
    0-0.25, rows 91-100, then holds none: NaN); no motion, no image or a foot point that is
    not finite give NaN."""
    D = np.zeros((200, 200), np.uint8)
    D[80:90, 52:56] = 40
    D[99, 40] = 40
    body = (52 * 10 + 53 * 10 + 54 * 10 + 55 * 10 + 40) / 41
    assert swc.mass_column(D, 50.0, 100.0, 10.0, (0.0, 1.0)) == pytest.approx(body, abs=1e-9)
    assert swc.mass_column(D, 50.0, 100.0, 10.0, (0.3, 0.6)) == pytest.approx(53.5, abs=1e-9)
    assert swc.mass_column(D, 50.0, 100.0, 10.0, (0.0, 0.25)) == 40.0
    D[99, 40] = 15
    assert math.isnan(swc.mass_column(D, 50.0, 100.0, 10.0, (0.0, 0.25)))
    assert math.isnan(swc.mass_column(np.zeros((200, 200), np.uint8), 50.0, 100.0, 10.0,
                                      (0.0, 1.0)))
    assert math.isnan(swc.mass_column(D, math.nan, 100.0, 10.0, (0.0, 1.0)))
    assert math.isnan(swc.mass_column(None, 50.0, 100.0, 10.0, (0.0, 1.0)))


def test_line_column_reads_a_line_through_the_rows_around_each():
    """Columns on the line 3 + 2 f with row 5 6 px off. At row 5 the centred fit of rows 3-7
    moves by 6 px times its leverage there, 1/5 + 0 = 1.2 px; the causal fit of rows 1-5 by
    6 x (1/5 + (5 - 3)^2 / 10) = 3.6 px. A NaN row stays NaN and is left out of the others'
    fits; fewer than 3 finite columns give the column itself."""
    f = np.arange(12, dtype=float)
    u = 3 + 2 * f
    u[5] += 6.0
    u[9] = math.nan
    centred, causal = swc.line_column(f, u, 2, 2), swc.line_column(f, u, 4, 0)
    assert centred[5] == pytest.approx(3 + 2 * 5 + 1.2, abs=1e-9)
    assert causal[5] == pytest.approx(3 + 2 * 5 + 3.6, abs=1e-9)
    assert math.isnan(centred[9]) and math.isnan(causal[9])
    assert centred[11] == pytest.approx(3 + 2 * 11, abs=1e-9)  # rows 9 (NaN) .. 11: 10, 11 only
    lone = np.array([1.0, math.nan, math.nan, 7.0])
    assert swc.line_column(np.arange(4.0), lone, 1, 1)[3] == 7.0


def test_column_offsets_sign_by_motion_and_side():
    """A walker right of the centre column (uc 100) moving right, its columns 2 px ahead of
    the truth with W 10: ahead +0.2, outwards +0.2, spread 0; moving left with the same +2 px:
    ahead -0.2; left of the centre: outwards -0.2; spread the std of the offsets; fewer than 6
    rows with both: NaN."""
    t = np.arange(10) / 15.0
    right = 150 + 30 * t
    assert swc.column_offsets(t, right + 2, right, 100.0, 10.0) == pytest.approx((0.2, 0.2, 0.0))
    left = 150 - 30 * t
    assert swc.column_offsets(t, left + 2, left, 100.0, 10.0)[0] == pytest.approx(-0.2)
    assert swc.column_offsets(t, 40 + 30 * t + 2, 40 + 30 * t, 100.0, 10.0)[1] == \
        pytest.approx(-0.2)
    wobble = right + np.where(np.arange(10) % 2, 3.0, 1.0)
    assert swc.column_offsets(t, wobble, right, 100.0, 10.0)[2] == pytest.approx(0.1)
    short = right.copy()
    short[5:] = math.nan
    assert all(math.isnan(x) for x in swc.column_offsets(t, short, right, 100.0, 10.0))


def test_first_pedestrian_pace_takes_the_window_with_the_highest_peak():
    """64 rows at 15 fps, an object walking at 1.3 m/s from 8 m on the paper's camera: a
    walker's sine at 2.0 Hz is judged Pedestrian at 2.0 Hz (within 0.03 Hz); listed before or
    after noise, its peak is the higher and it decides; the noise alone gives NaN."""
    cfg = Config()
    t = np.arange(64) / 15.0
    xy = np.stack([0.5 + 0 * t, 8.0 + 1.3 * t], 1)
    rng = np.random.default_rng(3)
    sine = 20 + 5 * np.sin(2 * np.pi * 2.0 * t) + rng.normal(0, 0.1, t.size)
    noise = 20 + rng.normal(0, 1.0, t.size)
    assert swc.first_pedestrian_pace(cfg, t, [sine], xy) == pytest.approx(2.0, abs=0.03)
    assert swc.first_pedestrian_pace(cfg, t, [noise, sine], xy) == pytest.approx(2.0, abs=0.03)
    assert swc.first_pedestrian_pace(cfg, t, [sine, noise], xy) == pytest.approx(2.0, abs=0.03)
    assert math.isnan(swc.first_pedestrian_pace(cfg, t, [noise], xy))
