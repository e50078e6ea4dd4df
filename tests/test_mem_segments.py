"""`mem.burg` with `known` (Burg pooled over the runs of known samples) against the float64
NumPy reference of tests/helpers_mem.py, and the rhythm window's two ways of handling missing
samples (`rhythm.GAPS`)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model import mem, rhythm
from rhythmjax.model.params import Config

from .helpers_mem import segment_burg_reference, simulate_ar, stable_ar


N, M = 64, 15
# |got - ref| <= tol * max(1, max|ref|): float64 measured worst ~1e-13, float32 ~3e-5
TOL = {jnp.float64: 1e-10, jnp.float32: 2e-4}


def _gappy_cases(seed=0, n_cases=12):
    """AR(4) signals of N samples with 1-16 missing, in 1-4 gaps at random places."""
    rng = np.random.default_rng(seed)
    cases = []
    for _ in range(n_cases):
        x = simulate_ar(rng, stable_ar(rng, 4), N)
        known = np.ones(N, bool)
        for _ in range(rng.integers(1, 5)):
            start, length = rng.integers(0, N), rng.integers(1, 5)
            known[start:start + length] = False
        cases.append((x, known))
    return cases


def _fit(x, known, dtype, window, run_taper=False):
    with jax.enable_x64(dtype == jnp.float64):
        r = mem.burg(jnp.asarray(x, dtype), M, window=window, known=jnp.asarray(known),
                     run_taper=run_taper)
        return jax.tree.map(lambda v: np.asarray(v, np.float64 if v.dtype != bool else bool), r)


def _close(got, ref, tol):
    return np.max(np.abs(got - ref)) <= tol * max(1.0, np.max(np.abs(ref)))


@pytest.mark.parametrize("dtype", [jnp.float64, jnp.float32])
@pytest.mark.parametrize("window,run_taper", [("none", False), ("parabolic", False),
                                              ("parabolic", True), ("hamming", True)])
def test_segments_match_float64_reference(dtype, window, run_taper):
    for x, known in _gappy_cases():
        a, s2, s2fb, refl = segment_burg_reference(x, known, M, window, run_taper)
        got = _fit(x, known, dtype, window, run_taper)
        assert got.ok
        for g, r in ((got.reflection, refl), (got.a, a), (got.sigma2, s2),
                     (got.sigma2_fb, s2fb)):
            assert _close(g, r, TOL[dtype]), (window, dtype, np.max(np.abs(g - r)))


def test_all_known_is_the_plain_fit_and_gap_values_do_not_enter():
    x, known = _gappy_cases(seed=1, n_cases=1)[0]
    with jax.enable_x64(True):
        xj = jnp.asarray(x)
        plain = mem.burg(xj, M)
        every = mem.burg(xj, M, known=jnp.ones(N, bool))
        np.testing.assert_array_equal(np.asarray(plain.reflection), np.asarray(every.reflection))
        np.testing.assert_array_equal(np.asarray(plain.sigma2), np.asarray(every.sigma2))
        one_run = mem.burg(xj, M, known=jnp.ones(N, bool), run_taper=True)
        np.testing.assert_array_equal(np.asarray(plain.reflection),
                                      np.asarray(one_run.reflection))
        a = mem.burg(jnp.where(known, xj, jnp.nan), M, known=jnp.asarray(known))
        b = mem.burg(jnp.where(known, xj, 1e6), M, known=jnp.asarray(known))
        assert bool(a.ok) and bool(b.ok)
        np.testing.assert_array_equal(np.asarray(a.reflection), np.asarray(b.reflection))


def test_runs_shorter_than_the_order_and_too_few_samples():
    rng = np.random.default_rng(3)
    x = simulate_ar(rng, stable_ar(rng, 4), N)
    known = np.zeros(N, bool)
    known[2:12] = known[20:30] = known[40:50] = True  # three runs of 10 < M + 1
    a, s2, _, refl = segment_burg_reference(x, known, M)
    got = _fit(x, known, jnp.float64, "none")
    assert got.ok and np.all(refl[9:] == 0.0)  # no run is longer than 10: k_10..k_15 = 0
    assert _close(got.reflection, refl, 1e-10) and _close(got.sigma2, s2, 1e-10)
    few = np.zeros(N, bool)
    few[:M + 1] = True  # M + 1 known samples: fewer than M + 2
    bad = _fit(x, few, jnp.float32, "none")
    assert not bad.ok and np.all(bad.a == 0) and bad.sigma2 == 0


def test_normalise_window_over_known_samples():
    x = jnp.asarray([1.0, jnp.nan, 3.0, 5.0, jnp.nan], jnp.float32)
    known = jnp.isfinite(x)
    got, ok = rhythm.normalise_window(x, known)
    ref = np.array([-2.0, 0.0, 0.0, 2.0, 0.0]) / np.sqrt(8.0 / 3.0)  # mean 3, sd sqrt(8/3)
    assert bool(ok)
    np.testing.assert_allclose(np.asarray(got), ref, rtol=1e-6, atol=1e-7)


def _walking_window(missing):
    """A 1.8 Hz gait-like rhythm at 15 fps (fundamental and a 2nd harmonic, small noise)."""
    t = np.arange(N) / 15.0
    rng = np.random.default_rng(7)
    x = 5 + np.sin(2 * np.pi * 1.8 * t) + 0.3 * np.sin(2 * np.pi * 3.6 * t + 1.0)
    x = x + 0.05 * rng.standard_normal(N)
    x[missing] = np.nan
    return jnp.asarray(x, jnp.float32), jnp.asarray(t, jnp.float32)


@pytest.mark.parametrize("gaps", ["interpolate", "segments", "segments_taper"])
def test_window_spectrum_finds_the_pace_through_a_gap(monkeypatch, gaps):
    monkeypatch.setattr(rhythm, "GAPS", gaps)
    x, t = _walking_window(np.r_[20:30])
    spec, nonconstant = rhythm.window_spectrum(x, jnp.float32(1 / 15), M)
    assert bool(nonconstant) and bool(spec.ok)
    # within the pace MAE target, 0.03 Hz (measured off: interpolate 0.012, segments
    # 0.017, segments_taper 0.008)
    assert abs(float(spec.peaks.freq[0]) - 1.8) <= 0.03, float(spec.peaks.freq[0])


def test_gaps_setting_changes_nothing_on_a_complete_window(monkeypatch):
    cfg = Config()
    x, t = _walking_window(np.array([], int))
    xy = jnp.stack([jnp.zeros(N), 1.2 * t], -1)
    results = []
    for gaps in ("interpolate", "segments", "segments_taper"):
        monkeypatch.setattr(rhythm, "GAPS", gaps)
        results.append(rhythm.classify_window(cfg, x, t, xy, jnp.asarray(True)))
    for other in results[1:]:
        for f in ("verdict", "pace_hz", "peak_power"):
            np.testing.assert_allclose(np.asarray(getattr(results[0], f)),
                                       np.asarray(getattr(other, f)), rtol=1e-5)


def test_unknown_gaps_setting_is_refused(monkeypatch):
    monkeypatch.setattr(rhythm, "GAPS", "spline")
    x, _ = _walking_window(np.array([], int))
    with pytest.raises(ValueError, match="GAPS"):
        rhythm.window_spectrum(x, jnp.float32(1 / 15), M)
