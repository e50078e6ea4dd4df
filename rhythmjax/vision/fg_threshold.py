"""The foreground threshold of the counting front end (`blobs.BackgroundModel`, step 1): fixed, or
noise-adaptive, optionally with hysteresis. D = I - B is float32, grey levels.

- Fixed: R = [|D| > threshold].
- Noise-adaptive (`noise_k` > 0): per frame, the noise sigma of D is estimated robustly,
  sigma = 1.4826 x median |D - median D| (the MAD, in grey levels; 1.4826 makes it the sigma of
  a Gaussian) over a sub-grid of the frame (every `NOISE_STEP`-th row and column) restricted to
  the pixels the previous mask called background (all pixels when that leaves fewer than
  `MIN_NOISE_PIXELS`); the threshold is t = max(floor, noise_k x sigma). `tail_k(p)` gives the
  k of a two-sided Gaussian false-alarm rate p per pixel (before morphology): 1e-4 -> 3.89.
- Hysteresis (`hysteresis` h in (0, 1)): high = [|D| > t], low = [|D| > h t]; R = low pixels
  within `hysteresis_px` px (Chebyshev distance: a (2 r + 1)^2 square) of a high pixel. A
  bounded version of Canny's hysteresis (one dilation instead of connected components, which
  cost ~10x more on a noisy low mask): it keeps a low-contrast walker's legs joined to the
  brighter body they touch without accepting noise far from any strong pixel.
"""

from __future__ import annotations

from statistics import NormalDist

import cv2
import numpy as np


MAD_SIGMA = 1.4826  # sigma of a Gaussian per median absolute deviation
NOISE_STEP = 4  # sub-grid of the noise estimate: every 4th row and column (1/16 of the pixels)
MIN_NOISE_PIXELS = 64  # fewer background pixels on the sub-grid: estimate on all of them


def tail_k(p: float) -> float:
    """k with P(|Z| > k) = p for a standard Gaussian Z (two-sided tail; p in (0, 1))."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must lie in (0, 1), got {p}")
    return NormalDist().inv_cdf(1.0 - 0.5 * p)


def noise_sigma(diff: np.ndarray, background: np.ndarray | None = None,
                step: int = NOISE_STEP) -> float:
    """Robust noise sigma of the float32 difference image `diff` (grey levels): 1.4826 x the
    median absolute deviation from the median over diff[::step, ::step], only where the
    optional uint8 0/1 `background` mask (same shape) is non-zero if that leaves at least
    `MIN_NOISE_PIXELS` samples. Medians of an even count: the upper middle value (np.partition),
    computed in float64."""
    s = diff[::step, ::step]
    if background is not None:
        keep = background[::step, ::step] != 0
        if int(np.count_nonzero(keep)) >= MIN_NOISE_PIXELS:
            s = s[keep]
    s = s.astype(np.float64).ravel()
    n = s.size // 2
    med = np.partition(s, n)[n]
    dev = np.abs(s - med)
    return float(MAD_SIGMA * np.partition(dev, n)[n])


def above(diff: np.ndarray, t: float) -> np.ndarray:
    """uint8 0/1 mask of |diff| > t (strictly; float32 diff, t grey levels)."""
    still = cv2.inRange(diff, -t, t)  # 255: |D| <= t
    return cv2.threshold(still, 0, 1, cv2.THRESH_BINARY_INV)[1]


def hysteresis_mask(diff: np.ndarray, high: float, low: float, reach_px: int) -> np.ndarray:
    """uint8 0/1: pixels with |diff| > low within `reach_px` px (Chebyshev) of a pixel with
    |diff| > high (module doc; low <= high, grey levels)."""
    strong = above(diff, high)
    weak = above(diff, low)
    if reach_px > 0:
        strong = cv2.dilate(strong, np.ones((2 * reach_px + 1, 2 * reach_px + 1), np.uint8))
    return cv2.bitwise_and(weak, strong)


def check_noise_options(noise_k: float, noise_floor: float, hysteresis: float,
                        hysteresis_px: int) -> None:
    """ValueError unless noise_k >= 0, 0 <= noise_floor < 255, hysteresis in [0, 1) (0: off)
    and hysteresis_px an integer >= 0."""
    if not noise_k >= 0.0:
        raise ValueError(f"noise_k must be >= 0 (0: fixed threshold), got {noise_k}")
    if not 0.0 <= noise_floor < 255.0:
        raise ValueError(f"noise_floor must lie in [0, 255), got {noise_floor}")
    if not 0.0 <= hysteresis < 1.0:
        raise ValueError(f"hysteresis must lie in [0, 1) (0: off), got {hysteresis}")
    if int(hysteresis_px) != hysteresis_px or hysteresis_px < 0:
        raise ValueError(f"hysteresis_px must be an integer >= 0, got {hysteresis_px}")
