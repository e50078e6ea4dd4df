"""(13): S sums the power of EVERY spectral peak above P_thr, not of the strongest few; checked
against a NumPy float64 loop over spectra with more than 8 peaks above P_thr."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model import mem
from rhythmjax.model.params import Config, Thresholds
from rhythmjax.model.rhythm import (
    N_FREQS,
    N_PEAKS,
    classify_window,
    match,
    normalise_window,
    spectral_sum,
)


def peaks_reference(psd, freqs):
    """Interior local maxima (p[i] > p[i-1], p[i] >= p[i+1]) refined by a parabola through the
    log-power at i-1, i, i+1, in float64: a list of (freq, power)."""
    p = np.maximum(np.asarray(psd, np.float64), np.finfo(np.float32).tiny)
    f = np.asarray(freqs, np.float64)
    out = []
    for i in range(1, len(p) - 1):
        if p[i] > p[i - 1] and p[i] >= p[i + 1]:
            r0, r2 = math.log(p[i - 1] / p[i]), math.log(p[i + 1] / p[i])
            delta = min(0.5, max(-0.5, 0.5 * (r0 - r2) / (r0 + r2))) if r0 + r2 < 0 else 0.0
            out.append((f[i] + delta * (f[1] - f[0]), p[i] * math.exp(-0.25 * (r0 - r2) * delta)))
    return out


def bumps(n_peaks, seed=0):
    """A spectrum of `n_peaks` Gaussian bumps of 12-80 (white level 1) on a floor of 1."""
    rng = np.random.default_rng(seed)
    f = np.linspace(0.0, 7.5, N_FREQS)
    centres = np.linspace(0.4, 7.1, n_peaks) + rng.uniform(-0.05, 0.05, n_peaks)
    heights = rng.uniform(12.0, 80.0, n_peaks)
    psd = 1.0 + sum(h * np.exp(-((f - c) ** 2) / (2 * 0.06**2)) for c, h in zip(centres, heights))
    return f.astype(np.float32), psd.astype(np.float32)


def test_local_maxima_match_a_numpy_loop():
    f, psd = bumps(13)
    every = jax.jit(mem.local_maxima)(jnp.asarray(psd), jnp.asarray(f))
    m = np.asarray(every.mask)
    ref = peaks_reference(psd, f)
    assert m.sum() == len(ref) == 13
    np.testing.assert_allclose(np.asarray(every.freq)[m], [a for a, _ in ref], atol=1e-4)
    np.testing.assert_allclose(np.asarray(every.power)[m], [b for _, b in ref], rtol=1e-5)
    # find_peaks keeps the 8 strongest of them, sorted
    top = mem.find_peaks(jnp.asarray(psd), jnp.asarray(f), 8)
    strongest = sorted(ref, key=lambda fp: -fp[1])[:8]
    np.testing.assert_allclose(np.asarray(top.power), [b for _, b in strongest], rtol=1e-5)


@pytest.mark.parametrize("n_peaks, p_thr", [(13, 10.0), (11, 30.0), (5, 10.0)])
def test_spectral_sum_is_every_peak_above_p_thr(n_peaks, p_thr):
    f, psd = bumps(n_peaks, seed=n_peaks)
    every = mem.local_maxima(jnp.asarray(psd), jnp.asarray(f))
    ref = sum(b for _, b in peaks_reference(psd, f) if b > p_thr)
    got = float(spectral_sum(every, jnp.float32(p_thr)))
    assert got == pytest.approx(ref, rel=1e-5)
    # the old sum over the 8 strongest misses the rest when there are more than 8
    top8 = float(spectral_sum(mem.find_peaks(jnp.asarray(psd), jnp.asarray(f), 8), p_thr))
    n_strong = sum(b > p_thr for _, b in peaks_reference(psd, f))
    assert (top8 < 0.99 * got) == (n_strong > 8)


def test_ratio_of_15_divides_by_every_peak():
    """match() with S over every peak: R of the strongest peak is its power over the sum of all
    13 (float64 loop), not over the 8 strongest."""
    f, psd = bumps(13, seed=3)
    every = mem.local_maxima(jnp.asarray(psd), jnp.asarray(f))
    top = mem.find_peaks(jnp.asarray(psd), jnp.asarray(f), N_PEAKS)
    thr = Thresholds(harmonic_ratio=0.0, k_sigma3=100.0)  # every peak passes (14)
    ref = peaks_reference(psd, f)
    S = sum(b for _, b in ref if b > 10.0)
    best = max(b for _, b in ref)
    _, _, _, _, ratio = match(top, jnp.float32(1.5), Config().walking, thr,
                              spectral_sum(every, thr.p_thr))
    assert float(ratio) == pytest.approx(best / S, rel=1e-5)
    _, _, _, _, ratio8 = match(top, jnp.float32(1.5), Config().walking, thr)
    assert float(ratio8) > 1.2 * float(ratio)  # what the top-8 sum said


def test_classify_window_sums_every_peak_of_a_high_order_spectrum():
    """An AR(31) spectrum of a 12-tone signal has more than 8 peaks above a low P_thr (0.08 x
    the white level); the window's R is the best peak over the sum of all of them (NumPy loop
    over the same spectrum)."""
    n, m, dt = 128, 31, 1 / 15
    thr = Thresholds(n=n, m=m, p_thr=0.08, harmonic_ratio=0.0, k_sigma3=100.0, r_thr=0.0)
    cfg = Config(thresholds=thr)
    t = np.arange(n) * dt
    tones = np.linspace(0.6, 7.0, 12)
    rng = np.random.default_rng(1)
    x = sum(np.sin(2 * np.pi * fk * t + rng.uniform(0, 6)) for fk in tones)
    x = (x + 0.05 * rng.standard_normal(n)).astype(np.float32)
    xy = np.stack([np.zeros(n), 5.0 + t], -1).astype(np.float32)  # 1 m/s ahead
    res = classify_window(cfg, jnp.asarray(x), jnp.asarray(t, jnp.float32), jnp.asarray(xy),
                          jnp.asarray(True))
    xn, _ = normalise_window(jnp.asarray(x))  # as classify_window does
    spec = mem.spectrum(xn, jnp.float32(dt), m, n_freqs=N_FREQS)
    white = np.asarray(spec.psd, np.float64) / np.float32(dt)
    ref = peaks_reference(white, np.asarray(spec.freqs))
    strong = [b for _, b in ref if b > float(thr.p_thr)]
    assert len(strong) > 8
    assert float(res.ratio) == pytest.approx(float(res.peak_power[0]) / sum(strong), rel=1e-4)
