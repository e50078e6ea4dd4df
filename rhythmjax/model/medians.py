"""Exact medians of float32 values along an axis by counting int32 keys of their bits: the
median of the Theil-Sen speed (12) of the rhythm paper without a float sort (`windows`).

`float_keys` maps IEEE-754 float32 to int32 in the order of `lax.sort`'s total order (-NaN <
-inf < ... < -0 < +0 < ... < inf < NaN). `rank_key` finds the key of a given rank by a 32-level
bisection of vectorised counts; `nanmedian_exact` is `jnp.nanmedian` through it (the same
floats). `nanmedian_select` (along the last axis) and `nanmedian_select_cols` (along the first,
the batch on the minor axis, where XLA's CPU counts vectorise best) take ~14 counts with trial
keys drawn from the data and say where they left the median unresolved (the caller then takes
`nanmedian_exact`). Measured in benchmarks/bench_median.py; tested bit for bit against
`jnp.nanmedian` in tests/test_classify_fast.py.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int


_SIGN = np.int32(-(2**31))
_LOW31 = np.int32(0x7FFFFFFF)


def float_keys(x: Float[Array, "..."]) -> Int[Array, "..."]:
    """int32 keys of float32 values, in the same order as the floats' total order: the bits
    with the 31 low bits flipped for negative values (an involution: `float_keys` of the keys'
    bits gives the bits back, `from_keys`). NaN should be made +NaN first (it then sorts last,
    as `jnp.nanmedian` sorts it)."""
    b = jax.lax.bitcast_convert_type(x.astype(jnp.float32), jnp.int32)
    return b ^ ((b >> 31) & _LOW31)


def from_keys(k: Int[Array, "..."]) -> Float[Array, "..."]:
    """The float32 values of `float_keys`' keys."""
    return jax.lax.bitcast_convert_type(k ^ ((k >> 31) & _LOW31), jnp.float32)


def rank_key(keys: Int[Array, "... p"], rank: Int[Array, "..."]) -> Int[Array, "..."]:
    """The key of 0-based `rank` in the ascending order of `keys` along the last axis: the
    smallest v with #{keys <= v} >= rank + 1, built bit by bit from the top (32 passes of a
    vectorised count). A rank outside [0, p) gives the largest (rank >= p) or smallest key."""
    p = keys.shape[-1]
    acc = jnp.int16 if p < 2**15 else jnp.int32  # the counts fit: twice the lanes per vector
    need = (jnp.clip(rank, 0, p - 1) + 1).astype(acc)

    def body(i, ans):  # `ans`: the answer's bits above bit b, in the order-preserving biased form
        bit = jnp.left_shift(jnp.int32(1), (31 - i).astype(jnp.int32))
        trial = (ans | (bit - 1)) ^ _SIGN  # signed key with bit b clear and the rest set
        count = jnp.sum((keys <= trial[..., None]).astype(acc), axis=-1, dtype=acc)
        return jnp.where(count >= need, ans, ans | bit)

    ans = jax.lax.fori_loop(0, 32, body, jnp.zeros(keys.shape[:-1], jnp.int32))
    return ans ^ _SIGN


def nanmedian_exact(x: Float[Array, "... p"]) -> Float[Array, "..."]:
    """`jnp.nanmedian(x, axis=-1)` (float32), the same value, by `rank_key` instead of a sort:
    the two middle order statistics of the non-NaN entries, low = floor((c - 1) / 2) and high =
    ceil((c - 1) / 2) of c, and (low + high) * 0.5; NaN when every entry is NaN."""
    x = jnp.where(jnp.isnan(x), jnp.nan, x)  # +NaN: last in the key order, as in nanmedian
    keys = float_keys(x)
    c = jnp.sum(~jnp.isnan(x), axis=-1)
    lo_rank = jnp.maximum((c - 1) // 2, 0)
    hi_rank = jnp.clip(c // 2, 0, jnp.maximum(c - 1, 0))
    lo = rank_key(keys, lo_rank)
    at_or_below = jnp.sum(keys <= lo[..., None], axis=-1)
    above = jnp.min(jnp.where(keys > lo[..., None], keys, _LOW31), axis=-1)
    hi = jnp.where(at_or_below >= hi_rank + 1, lo, above)
    return (from_keys(lo) + from_keys(hi)) * 0.5


_KEY_INF = np.int32(0x7F800000)  # float_keys(+inf): every non-NaN key is at or below it
_KEY_MAX = np.int32(2**31 - 1)


def nanmedian_select(x: Float[Array, "... p"], stride: int = 64, spread: int = 3,
                     steps: int = 8) -> tuple[Float[Array, "..."], Array]:
    """`nanmedian_exact(x)`, the same floats, in fewer passes over the entries (14 counts and 3
    float min / max where `nanmedian_exact` has 33 counts and an int32 min; ~2x faster per
    window, benchmarks/bench_median.py): (median, ok). Each pass counts the keys at or below a
    trial key (as `rank_key`), but the trial keys are data values where `rank_key` walks all 32
    key bits:

    1. Bracket: a sample (every `stride`-th key, sorted); its entries `spread` places either
       side of the lower middle rank r scaled to the sample, L and H, and their counts
       nL = #(<= L), nH = #(<= H) (one pass each). Where nL > r or nH <= r that end is
       replaced by one below every key (count 0) or +inf's key (count c): nL <= r < nH.
    2. `steps` interpolation passes: the trial value at the share (r - nL + 1/2) / (nH - nL)
       between the values of L and H (the key midpoint where that is not finite), counted,
       replaces L or H.
    3. The smallest and largest value in (L, H] (float min and max: XLA's int32 min is 5x
       slower on CPU; a zero taken as -0 for the smallest, +0 for the largest, then clipped to
       (L, H], so that their keys bound the keys in (L, H]) and the counts #(<= smallest),
       #(< largest): the rank-r key is the smallest when r < #(<= smallest), the largest
       when r >= #(< largest) (ties included); else r is unresolved. The upper middle (even
       counts) is the rank-r value or the smallest value with a key above it (one pass: a
       zero found there is +0, or the lower middle is nonzero and the zero's sign does not
       change the sum); the median (low + high) * 0.5.

    ok is False only where r is unresolved (the value is then not the median: the caller
    recomputes it with `nanmedian_exact`). Correctness rests on the integer counts alone, not
    on the trial values. All-NaN rows give NaN, ok. Fixed shapes, no data-dependent control
    flow."""
    return nanmedian_select_cols(jnp.moveaxis(x, -1, 0), stride, spread, steps)[:2]


def nanmedian_select_cols(x: Float[Array, "p ..."], stride: int = 64, spread: int = 3,
                          steps: int = 8) -> tuple[Float[Array, "..."], Array, Array]:
    """`nanmedian_select` along the FIRST axis: (median, ok, count of non-NaN entries). The
    same algorithm and the same floats; with the entries on the major axis and the batch on
    the minor one, each count is a sum of whole rows (vectorised over the batch, no
    horizontal reduction: 0.36 against 0.60 us a window-pass, int16 counts, 2 x 2016 keys)."""
    x = jnp.where(jnp.isnan(x), jnp.nan, x)  # +NaN: last in the key order
    keys = float_keys(x)
    p = x.shape[0]
    acc = jnp.int16 if p < 2**15 else jnp.int32
    count = lambda b: jnp.sum(b, axis=0, dtype=acc).astype(jnp.int32)
    # the trial keys through a barrier: fused into the count, their arithmetic would be
    # recomputed for every entry
    bar = jax.lax.optimization_barrier
    le = lambda k: count(keys <= bar(k)[None])
    c = count(~jnp.isnan(x))
    r = jnp.maximum((c - 1) // 2, 0)
    r_hi = jnp.clip(c // 2, 0, jnp.maximum(c - 1, 0))
    sample = jax.lax.sort(keys[::stride], dimension=0)  # NaN keys last
    m = sample.shape[0]
    ms = count(sample <= _KEY_INF)
    centre = (r * ms) // jnp.maximum(c, 1)  # r * ms < 2**31: p * p / stride
    at = lambda j: jnp.take_along_axis(sample, jnp.clip(j, 0, m - 1)[None], 0)[0]
    j_lo, j_hi = centre - spread, centre + spread + 1
    L = jnp.where(j_lo >= 0, at(j_lo), _SIGN)  # _SIGN: below every key (no -NaN here)
    H = jnp.where(j_hi < ms, at(j_hi), _KEY_INF)
    nL, nH = le(L), le(H)
    j_lo, j_hi = jnp.maximum(j_lo, -1), jnp.minimum(j_hi, ms)
    j_lo = jnp.where(nL > r, -1, j_lo)  # the sample indices of L and H (-1, ms: the ends)
    j_hi = jnp.where(nH <= r, ms, j_hi)
    L, nL = jnp.where(nL > r, _SIGN, L), jnp.where(nL > r, 0, nL)
    H, nH = jnp.where(nH <= r, _KEY_INF, H), jnp.where(nH <= r, c, nH)
    for _ in range(steps):
        share = ((r - nL).astype(jnp.float32) + 0.5) / (nH - nL).astype(jnp.float32)
        # a sample entry strictly inside (L, H) where there is one (at the share between
        # the ends' sample indices), else a value at the share between L's and H's values
        j = j_lo + jnp.floor(share * (j_hi - j_lo).astype(jnp.float32) + 0.5).astype(c.dtype)
        j = jnp.clip(j, j_lo + 1, j_hi - 1)
        vL, vH = from_keys(L), from_keys(H)
        guess = vL + (vH - vL) * share
        t = jnp.where(jnp.isfinite(guess), float_keys(guess),
                      (L >> 1) + (H >> 1) + (L & H & 1))
        from_sample = j_hi - j_lo >= 2
        t = jnp.where(from_sample, at(j), t)
        t = jnp.clip(t, L + 1, jnp.maximum(H - 1, L + 1))
        n = le(t)
        down, up = (n > r) & (t < H), (n <= r) & (t < H)
        H, nH = jnp.where(down, t, H), jnp.where(down, n, nH)
        L, nL = jnp.where(up, t, L), jnp.where(up, n, nL)
        j_hi = jnp.where(down & from_sample, j, j_hi)
        j_lo = jnp.where(up & from_sample, j, j_lo)
    L, H = bar((L, H))
    inside = (keys > L[None]) & (keys <= H[None])
    v_small = jnp.min(jnp.where(inside, x, jnp.inf), axis=0)
    v_large = jnp.max(jnp.where(inside, x, -jnp.inf), axis=0)
    small = float_keys(jnp.where(v_small == 0, -0.0, v_small).astype(x.dtype))
    large = float_keys(jnp.where(v_large == 0, 0.0, v_large).astype(x.dtype))
    small, large = jnp.maximum(small, L + 1), jnp.minimum(large, H)  # still bounds
    le_small = le(small)
    lt_large = count(keys < bar(large)[None])
    at_small = r < le_small
    ok = at_small | (r >= lt_large)
    low = jnp.where(at_small, small, large)
    at_or_below = jnp.where(at_small, le_small, nH)
    low_ = bar(low)[None]
    above = jnp.min(jnp.where((keys > low_) & (keys <= _KEY_INF), x, jnp.inf), axis=0)
    low = from_keys(low)
    high = jnp.where(at_or_below >= r_hi + 1, low, above)
    return jnp.where(c > 0, (low + high) * 0.5, jnp.nan), ok | (c == 0), c
