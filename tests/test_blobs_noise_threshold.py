"""The noise-adaptive foreground threshold (`vision.fg_threshold`, `blobs.BackgroundModel`
noise_k / noise_floor / hysteresis / hysteresis_px) against float64 NumPy references with
loops, on synthetic frames with known Gaussian noise; and the options' validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.count.options import BlobOptions, CountOptions
from rhythmjax.track.options import with_changes
from rhythmjax.vision.blobs import BackgroundModel
from rhythmjax.vision.fg_threshold import MAD_SIGMA, NOISE_STEP, noise_sigma, tail_k


def _scene(rng, h: int, w: int, sigma: float, bg: np.ndarray | None = None):
    """A float32 background in multiples of 1/8 grey level (so I - B is exact in float32) and a
    uint8 frame = round(B + N(0, sigma^2)) with a bright 'walker' rectangle and a faint one."""
    if bg is None:
        bg = (rng.integers(60, 180, (h, w)) + rng.integers(0, 8, (h, w)) / 8.0
              ).astype(np.float32)
    img = np.clip(np.rint(bg + rng.normal(0.0, sigma, (h, w))), 0, 255)
    img[h // 4:h // 2, w // 5:w // 5 + w // 10] += 60.0  # strong object
    img[h // 2:3 * h // 4, w // 5:w // 5 + w // 10] += 3.0 * sigma  # faint legs below it
    return bg, np.clip(img, 0, 255).astype(np.uint8)


def _ref_sigma(d: np.ndarray, bgmask: np.ndarray | None) -> float:
    """Float64 loop reference of `noise_sigma`: sub-grid samples, upper middle medians."""
    s = []
    for r in range(0, d.shape[0], NOISE_STEP):
        for c in range(0, d.shape[1], NOISE_STEP):
            if bgmask is None or bgmask[r, c]:
                s.append(float(d[r, c]))
    s = sorted(s)
    med = s[len(s) // 2]
    dev = sorted(abs(x - med) for x in s)
    return MAD_SIGMA * dev[len(dev) // 2]


def _ref_mask(d: np.ndarray, t: float, h: float, r: int) -> np.ndarray:
    """Float64 loop reference of the raw mask: |d| > t, or with hysteresis h > 0 |d| > h t
    within r px (Chebyshev) of a pixel with |d| > t."""
    H, W = d.shape
    out = np.zeros((H, W), np.uint8)
    for y in range(H):
        for x in range(W):
            if h == 0.0:
                out[y, x] = abs(d[y, x]) > t
            elif abs(d[y, x]) > h * t:
                win = d[max(0, y - r):y + r + 1, max(0, x - r):x + r + 1]
                out[y, x] = bool((np.abs(win) > t).any())
    return out


def test_tail_k_two_sided_gaussian():
    assert tail_k(1e-4) == pytest.approx(3.8906, abs=1e-4)
    assert math.erfc(tail_k(1e-3) / math.sqrt(2.0)) == pytest.approx(1e-3, rel=1e-9)
    with pytest.raises(ValueError):
        tail_k(0.0)


@pytest.mark.parametrize("sigma", [2.0, 4.0, 8.0])
def test_sigma_estimate_within_4_percent_of_the_known_noise(sigma):
    rng = np.random.default_rng(7)
    bg, img = _scene(rng, 480, 640, sigma)
    d = img.astype(np.float32) - bg
    # rounding to integers adds a uniform error of variance 1/12
    want = math.sqrt(sigma ** 2 + 1.0 / 12.0)
    truth_bg = np.ones(d.shape, np.uint8)
    truth_bg[480 // 4:3 * 480 // 4, 640 // 5:640 // 5 + 64] = 0  # the objects
    assert noise_sigma(d, truth_bg) == pytest.approx(want, rel=0.04)
    # over the whole frame the objects (5 % of it) inflate the estimate by up to ~10 %
    assert noise_sigma(d) == pytest.approx(want, rel=0.15)


@pytest.mark.parametrize("hyst, reach", [(0.0, 2), (0.5, 2), (0.6, 0)])
def test_adaptive_mask_identical_to_numpy_loop(hyst, reach):
    rng = np.random.default_rng(11)
    h, w, k, floor = 48, 64, 3.89, 2.0
    first = rng.integers(60, 180, (h, w)).astype(np.uint8)
    bg = first.astype(np.float32)
    _, img1 = _scene(rng, h, w, 4.0, bg)
    _, img2 = _scene(rng, h, w, 4.0, bg)
    model = BackgroundModel(first, alpha=0.0, slow_alpha=0.0,  # B = first, kept
                            open_px=0, close_px=0, noise_k=k, noise_floor=floor,
                            hysteresis=hyst, hysteresis_px=reach)
    prev = None
    for img in (img1, img2):
        d = img.astype(np.float64) - bg.astype(np.float64)
        s = _ref_sigma(d, None if prev is None else prev == 0)
        t = max(floor, k * s)
        want = _ref_mask(d, t, hyst, reach)
        got = model.apply(img)
        assert model.last_sigma == pytest.approx(s, rel=1e-12)
        assert model.last_threshold == pytest.approx(t, rel=1e-12)
        np.testing.assert_array_equal(got, want)
        assert 0 < int(want.sum()) < h * w
        prev = want


def test_floor_holds_on_a_noise_free_frame_and_off_is_fixed():
    bg = np.full((32, 32), 100, np.uint8)
    img = bg.copy()
    img[10:20, 10:14] = 108  # 8 grey levels: under the fixed 20, over a floor of 6
    on = BackgroundModel(bg, open_px=0, close_px=0, noise_k=3.89, noise_floor=6.0)
    assert on.foreground(img).sum() == 40 and on.last_sigma == 0.0 and on.last_threshold == 6.0
    off = BackgroundModel(bg, open_px=0, close_px=0)
    assert off.foreground(img).sum() == 0 and off.last_threshold == 20.0
    assert math.isnan(off.last_sigma)


@pytest.mark.parametrize("field, value", [("noise_k", -1.0), ("noise_floor", 255.0),
                                          ("noise_floor", -0.5), ("hysteresis", 1.0),
                                          ("hysteresis", -0.1),
                                          ("hysteresis_px", -1), ("noise_k", math.nan)])
def test_options_validated(field, value):
    with pytest.raises(ValueError, match=field):
        BlobOptions(**{field: value})
    with pytest.raises(ValueError, match=field):
        with_changes(CountOptions(), {f"blobs.{field}": value})
    with pytest.raises(ValueError, match=field):
        BackgroundModel(np.zeros((4, 4), np.uint8), **{field: value})


def test_hysteresis_px_must_be_an_integer():
    # the tests' runtime type check (TypeError) or the model's own check (ValueError)
    with pytest.raises((TypeError, ValueError)):
        BackgroundModel(np.zeros((4, 4), np.uint8), hysteresis_px=1.5)
    with pytest.raises((TypeError, ValueError)):
        BlobOptions(hysteresis_px=1.5)


def test_blob_options_give_the_model_its_settings():
    b = BlobOptions(noise_k=4.0, noise_floor=5.0, hysteresis=0.5, hysteresis_px=3)
    m = BackgroundModel(np.zeros((4, 4), np.uint8), **b.model_kwargs())
    assert (m.noise_k, m.noise_floor, m.hysteresis, m.hysteresis_px) == (4.0, 5.0, 0.5, 3)
    assert (m.alpha, m.threshold, m.open_px, m.close_px) == (0.05, 20.0, 1, 2)
