"""`rhythm.classify_window` for the batch kernel, with the window's sampling interval taken
without a sort: the same operations otherwise, the same results (tests/test_classify_fast.py).

`classify_window` takes the median step dt_med of a window (the PSD's sample interval and the
10 % jitter test of `bad-signal`) as `jnp.median` of its n - 1 steps: an XLA sort per window,
~3 us of the ~15 us that Burg, the PSD, the peaks and (13)-(15) cost a window on one core.
`median_small` finds the same order statistics by ranking every entry against every other
((n - 1)^2 = 3 969 compares at N = 64, vectorised: ~0.5 us).
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from .params import Config
from .rhythm import (
    MAX_DT_JITTER,
    MAX_MISSING_FRACTION,
    RhythmResult,
    judge_window_looks,
)
from .status import Reason, Verdict


def median_small(x: Float[Array, "... m"]) -> Float[Array, "..."]:
    """`jnp.median(x, axis=-1)`, the same floats, for short rows (m up to a few hundred): the
    entry of each rank is found by counting, for every entry, the entries below it (ties
    broken by position), so no sort; the two middle order statistics of rank (m - 1) // 2 and
    m // 2 are combined as `jnp.median` does, (low + high) * 0.5. NaN when any entry is NaN
    (as `jnp.median`)."""
    m = x.shape[-1]
    a, b = x[..., :, None], x[..., None, :]
    i = jnp.arange(m)
    earlier = (i[None, :] < i[:, None]).reshape((1,) * (x.ndim - 1) + (m, m))
    before = (b < a) | ((b == a) & earlier)  # entry j ranks before entry i
    rank = jnp.sum(before, axis=-1)  # a permutation of 0 .. m - 1 for non-NaN rows
    pick = lambda r: jnp.sum(jnp.where(rank == r, x, 0.0), axis=-1)
    low, high = pick((m - 1) // 2), pick(m // 2)
    return jnp.where(jnp.any(jnp.isnan(x), axis=-1), jnp.nan, (low + high) * 0.5)


def classify_window_fast(cfg: Config, intensity: Float[Array, " n"], t: Float[Array, " n"],
                         speed: Float[Array, ""]) -> RhythmResult:
    """`rhythm.classify_window(cfg, intensity, t, xy, True, observed, speed=speed)` of a
    complete window (intensity, may hold NaN; t s from the window's first sample; the speed
    of (12), m/s, given), dt_med by `median_small`: Sec. 4.1's Burg MEM spectrum of the
    normalised window, the peaks, S of (13) over every local maximum, (14) and (15), and
    rule 38 where it is on (`rhythm.judge_window_looks`)."""
    n = intensity.shape[0]
    known = jnp.isfinite(intensity)
    n_missing = n - jnp.sum(known)
    dts = jnp.diff(t)
    dt_med = median_small(dts)
    dt_ok = jnp.all(jnp.abs(dts - dt_med) <= MAX_DT_JITTER * dt_med) & (dt_med > 0)
    signal_ok = (n_missing <= MAX_MISSING_FRACTION * n) & dt_ok
    step = jnp.where(dt_ok, dt_med, 1.0)
    verdict, reason, pace, stride, ratio, peaks = judge_window_looks(cfg, intensity, step, speed)
    bad = ~signal_ok
    nan = jnp.asarray(jnp.nan, pace.dtype)
    return RhythmResult(
        verdict=jnp.where(bad, Verdict.UNCLASSIFIED, verdict).astype(jnp.int32),
        reason=jnp.where(bad, Reason.BAD_SIGNAL, reason).astype(jnp.int32),
        pace_hz=jnp.where(bad, nan, pace), stride_m=jnp.where(bad, nan, stride),
        ratio=jnp.where(bad, nan, ratio), speed_mps=speed,
        n_samples=jnp.asarray(n, jnp.int32),
        peak_freq=peaks.freq, peak_power=peaks.power, peak_mask=peaks.mask & ~bad,
    )
