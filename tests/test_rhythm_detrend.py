"""`rhythm.DETREND` "line" (issue 16, twenty-fourth round): a rhythm window's least-squares line
removed before Burg. `remove_line` against NumPy's float64 polyfit, and the spectrum of a
walker's rhythm on a slow trend with and without it."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model import rhythm


N, M, FPS = 64, 15, 15.0


def test_remove_line_against_polyfit():
    rng = np.random.default_rng(11)
    x = 3.0 + 0.7 * np.arange(N) + rng.normal(0, 2.0, N)
    k = np.arange(N)
    want = x - np.polyval(np.polyfit(k, x, 1), k)
    got = np.asarray(rhythm.remove_line(jnp.asarray(x, jnp.float32)), np.float64)
    np.testing.assert_allclose(got, want, atol=2e-4 * np.abs(x).max())  # float32 rounding
    known = rng.random(N) > 0.3
    want_k = x - np.polyval(np.polyfit(k[known], x[known], 1), k)
    got_k = np.asarray(rhythm.remove_line(jnp.asarray(x, jnp.float32), jnp.asarray(known)))
    np.testing.assert_allclose(got_k[known], want_k[known], atol=2e-4 * np.abs(x).max())
    np.testing.assert_array_equal(got_k[~known], np.float32(x[~known]))  # left as they were


def test_remove_line_with_one_known_sample_removes_its_value():
    x = jnp.asarray([5.0, 7.0, 9.0], jnp.float32)
    got = rhythm.remove_line(x, jnp.asarray([False, True, False]))
    np.testing.assert_array_equal(np.asarray(got), [5.0, 0.0, 9.0])


def _walker_on_a_trend(trend_per_window: float):
    """A 1.9 Hz gait-like rhythm of amplitude 1 plus a line rising by `trend_per_window` over
    the window (small noise)."""
    t = np.arange(N) / FPS
    rng = np.random.default_rng(5)
    x = 10 + np.sin(2 * np.pi * 1.9 * t) + trend_per_window * np.arange(N) / (N - 1)
    return jnp.asarray(x + 0.05 * rng.standard_normal(N), jnp.float32)


def _peak_near(spec, f0=1.9, tol=0.1) -> float:
    freq, power = np.asarray(spec.peaks.freq), np.asarray(spec.peaks.power)
    near = np.abs(freq - f0) <= tol
    return float(power[near].max()) if near.any() else 0.0


def test_a_trend_hides_the_pace_peak_unless_the_line_is_removed(monkeypatch):
    """P relative to white noise of the window's variance is power x FPS (unit variance): the
    clean rhythm's pace peak is over P_thr = 10 (measured 17.1); a rise of 8 amplitudes over the
    window (the line's variance 8^2 / 12 = 5.3 against the rhythm's 0.5) moves the strongest
    peak to ~0.2 Hz and the pace peak under P_thr (8.4): the no-model-match walkers of the
    counting pools. With the line removed an exact line changes nothing (15.05 for 0, 4, 8)."""
    step = jnp.float32(1 / FPS)
    base, _ = rhythm.window_spectrum(_walker_on_a_trend(0.0), step, M)
    trended, _ = rhythm.window_spectrum(_walker_on_a_trend(8.0), step, M)
    assert _peak_near(base) * FPS > 10.0 > _peak_near(trended) * FPS
    assert float(trended.peaks.freq[0]) < 0.5
    monkeypatch.setattr(rhythm, "DETREND", "line")
    removed = [rhythm.window_spectrum(_walker_on_a_trend(r), step, M)[0] for r in (0.0, 4.0, 8.0)]
    for spec in removed:
        assert abs(float(spec.peaks.freq[0]) - 1.9) <= 0.03
        assert _peak_near(spec) == pytest.approx(_peak_near(removed[0]), rel=1e-3)
    assert _peak_near(removed[0]) * FPS > 10.0


def test_unknown_detrend_setting_is_refused(monkeypatch):
    monkeypatch.setattr(rhythm, "DETREND", "parabola")
    with pytest.raises(ValueError, match="DETREND"):
        rhythm.window_spectrum(_walker_on_a_trend(0.0), jnp.float32(1 / FPS), M)
