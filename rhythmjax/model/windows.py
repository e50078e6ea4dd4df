"""The fast rhythm-window classifier of batch classification: `rhythm.classify_window` with the
speed of (12) from an exact selection median instead of a float sort.

`rhythm.window_speed` (the reference, as the paper reads) takes the Theil-Sen speed as
`jnp.median` / `jnp.nanmedian` of the n (n - 1) / 2 pair slopes per axis (2016 at N = 64), for
the measured AND for the filtered positions, then keeps one. On XLA's CPU backend the float sort
behind those medians (a total-order comparator) was ~97 % of `classify_batch`'s time
(docs/benchmarks.md, "classify_batch"). Here:

1. The position set is chosen first (the measured foot points when at least half the window has
   one, else the filtered positions: `window_speed`'s rule), so one median per axis is taken.
2. The median is an exact order statistic found by bisection on int32 keys of the float bits
   (`float_keys`: a monotone map of IEEE-754 floats to integers, the order of `lax.sort`'s
   total order: -NaN < -inf < ... < -0 < +0 < ... < inf < NaN). 32 passes, each a count of the
   keys at or below a trial key, vectorised over the pairs (`rank_key`), give the key of a
   given rank; the midpoint of the two middle order statistics is then formed exactly as
   `jnp.median` does, `(low + high) * 0.5`. So the median is the same float as the reference's
   on the same slopes (tests/test_classify_fast.py), not an approximation.

`classify_window_block` classifies a block of complete windows given by their rows; the chunked
driver (`fast_batch`) gathers the windows that can decide a verdict and sends them here in
blocks of `WINDOW_BLOCK`.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .camera import ground_from_image
from .params import Config
from .rhythm import RhythmResult, classify_window, window_times


WINDOW_BLOCK = 128  # windows per jitted call (fixed: one compiled shape per N)
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


def nanmedian_bracketed(x: Float[Array, "... p"], stride: int = 32, spread: int = 4,
                        k: int = 256) -> tuple[Float[Array, "..."], Array]:
    """`nanmedian_exact(x)`, the same floats, by bracket, compact and sort: (median, ok).

    1. Bracket: the keys of every `stride`-th entry (a sample spread over the whole row) are
       sorted; the sample's order statistics `spread` places either side of the median's
       rank scaled to the sample, lo and hi, bracket it (lo the smallest key, hi +inf's key,
       where the sample runs out).
    2. Four counts over the row (one fused pass) place lo and hi among all keys: a = #(< lo),
       a2 = #(<= lo), b1 = #(< hi), b = #(<= hi). A middle rank r in [a, a2) is lo, in
       [b1, b) hi, in [a2, b1) the (r - a2)-th of the entries strictly inside.
    3. The `k` smallest entries strictly inside, ascending, by `lax.top_k` of their negated
       values (outside ones -inf). Float order is the keys' order but for -0 == +0: a zero
       picked is -0 when fewer than r + 1 keys are negative (`neg`), as the keys order them.

    ok is False where a middle rank falls outside [a, b) or past the k inside: the value is
    then not the median (the caller recomputes it with `nanmedian_exact`). All-NaN rows give
    NaN, ok. No data-dependent control flow: fixed shapes under jit and vmap."""
    x = jnp.where(jnp.isnan(x), jnp.nan, x)  # +NaN: last in the key order
    keys = float_keys(x)
    p = x.shape[-1]
    k = min(k, p)
    c = jnp.sum(~jnp.isnan(x), axis=-1, dtype=jnp.int32)
    r_lo = jnp.maximum((c - 1) // 2, 0)
    r_hi = jnp.clip(c // 2, 0, jnp.maximum(c - 1, 0))
    sample = jax.lax.sort(keys[..., ::stride])  # NaN keys last
    m = sample.shape[-1]
    ms = jnp.sum(sample <= _KEY_INF, axis=-1, dtype=jnp.int32)  # the sample's non-NaN
    centre = (r_lo * ms) // jnp.maximum(c, 1)  # r_lo * ms < 2**31 for p < 2**15 / stride
    j_lo, j_hi = centre - spread, centre + spread + 1
    at = lambda j: jnp.take_along_axis(sample, jnp.clip(j, 0, m - 1)[..., None], -1)[..., 0]
    lo = jnp.where(j_lo >= 0, at(j_lo), _SIGN)  # _SIGN: below every key (no -NaN here)
    hi = jnp.where(j_hi < ms, at(j_hi), _KEY_INF)
    acc = jnp.int16 if p < 2**15 else jnp.int32
    count = lambda b: jnp.sum(b, axis=-1, dtype=acc).astype(jnp.int32)
    lo_, hi_ = lo[..., None], hi[..., None]
    a, a2 = count(keys < lo_), count(keys <= lo_)
    b1, b = count(keys < hi_), count(keys <= hi_)
    neg = count(keys < 0)  # keys of -0 and below
    inside = (keys > lo_) & (keys < hi_)
    ascending = -jax.lax.top_k(jnp.where(inside, -x, -jnp.inf), k)[0]

    def pick(r):
        v = jnp.take_along_axis(ascending, jnp.clip(r - a2, 0, k - 1)[..., None], -1)[..., 0]
        v = jnp.where(v == 0, jnp.where(r < neg, -0.0, 0.0).astype(x.dtype), v)
        v = jnp.where(r < a2, from_keys(lo), jnp.where(r < b1, v, from_keys(hi)))
        return v, (r >= a) & (r < b) & ((r < a2) | (r >= b1) | (r - a2 < k))

    (low, ok_lo), (high, ok_hi) = pick(r_lo), pick(r_hi)
    return (jnp.where(c > 0, (low + high) * 0.5, jnp.nan).astype(x.dtype),
            (ok_lo & ok_hi) | (c == 0))


def window_slopes(cfg: Config, t: Float[Array, " n"], xy: Float[Array, "n 2"],
                  observed: Float[Array, "n 2"]) -> tuple[Float[Array, "2 p"], Array]:
    """The pair slopes of (12) per axis (2, n (n - 1) / 2), NaN where a pair is unused, of the
    position set `window_speed` chooses (the measured foot points on the ground when half the
    window has one, else the filtered positions), and whether the measured set was chosen."""
    n = t.shape[0]
    seen = jnp.all(jnp.isfinite(observed), axis=-1)
    uv = jnp.where(seen[:, None], observed, 0.0)
    gx, gy, ok = ground_from_image(cfg.camera, uv[:, 0], uv[:, 1])
    use = seen & ok
    enough = 2 * jnp.sum(use) >= n
    px = jnp.where(enough, jnp.where(use, gx, 0.0), xy[:, 0])
    py = jnp.where(enough, jnp.where(use, gy, 0.0), xy[:, 1])
    # the pairs (i, i + lag), lag by lag: static slices, where an index gather of the
    # n (n - 1) / 2 pairs costs 3.6x as much (the median does not depend on the pairs' order)
    pairs = lambda a, op: jnp.concatenate([op(a[lag:], a[:-lag]) for lag in range(1, n)])
    dt = jnp.maximum(pairs(t, jnp.subtract), jnp.finfo(t.dtype).tiny)
    pair = ~enough | pairs(use, jnp.logical_and)
    slopes = jnp.stack([pairs(px, jnp.subtract) / dt, pairs(py, jnp.subtract) / dt])
    return jnp.where(pair[None, :], slopes, jnp.nan), enough  # (2, P)


def _speed(slopes: Float[Array, "2 p"], enough: Array, vel: Float[Array, " 2"]
           ) -> Float[Array, ""]:
    # the filtered set goes through jnp.median in the reference: any NaN slope gives NaN
    vel = jnp.where(~enough & jnp.any(jnp.isnan(slopes), axis=-1), jnp.nan, vel)
    return jnp.sqrt(jnp.sum(vel**2))


def theil_sen_speed(cfg: Config, t: Float[Array, " n"], xy: Float[Array, "n 2"],
                    observed: Float[Array, "n 2"]) -> Float[Array, ""]:
    """The speed of (12), m/s: `rhythm.window_speed` (the norm of the Theil-Sen velocity of the
    measured foot points `observed` (px, NaN where the gates accepted none) on the ground when
    half the window has one, else of the filtered positions `xy`, m), with the position set
    chosen before the median and the median taken by `nanmedian_exact`. The slopes are the
    reference's operations on the same operands and the median the same order statistics; the
    speed differs from the reference's only where XLA compiles the inverse perspective or a
    division of the two programs differently (1 ulp: measured 1.6e-7 relative at most)."""
    slopes, enough = window_slopes(cfg, t, xy, observed)
    return _speed(slopes, enough, nanmedian_exact(slopes))


def theil_sen_speed_bracketed(cfg: Config, t: Float[Array, " n"], xy: Float[Array, "n 2"],
                              observed: Float[Array, "n 2"]
                              ) -> tuple[Float[Array, ""], Array]:
    """`theil_sen_speed` with the median of `nanmedian_bracketed`: (speed, ok); where ok is
    False (a bracket missed) the speed is not the median's and must be recomputed by
    `theil_sen_speed`; where True it is `theil_sen_speed`'s, bit for bit."""
    slopes, enough = window_slopes(cfg, t, xy, observed)
    vel, ok = nanmedian_bracketed(slopes)
    return _speed(slopes, enough, vel), jnp.all(ok)


def classify_complete_window(cfg: Config, intensity: Float[Array, " n"], dt: Float[Array, " n"],
                             xy: Float[Array, "n 2"], observed: Float[Array, "n 2"]
                             ) -> RhythmResult:
    """`rhythm.classify_window` of one complete window given by its rows (intensity, dt s with
    dt[0] unused, xy m, observed px), its speed by `theil_sen_speed`."""
    t = window_times(dt)
    return classify_window(cfg, intensity, t, xy, jnp.asarray(True), observed,
                           speed=theil_sen_speed(cfg, t, xy, observed))


@eqx.filter_jit
def classify_window_block(cfg: Config, intensity: Float[Array, "W n"], dt: Float[Array, "W n"],
                          xy: Float[Array, "W n 2"], observed: Float[Array, "W n 2"]
                          ) -> RhythmResult:
    """`classify_complete_window` over a block of W complete windows (the batch axis may be
    sharded over devices, `devices.local_mesh`)."""
    return jax.vmap(lambda *a: classify_complete_window(cfg, *a))(intensity, dt, xy, observed)


def classify_window_rows(cfg: Config, intensity: np.ndarray, dt: np.ndarray, xy: np.ndarray,
                         observed: np.ndarray, put=None,
                         block: int = WINDOW_BLOCK) -> dict[str, np.ndarray]:
    """`classify_window_block` over any number of complete windows (NumPy rows: intensity, dt
    (W, n), xy, observed (W, n, 2)), `block` at a time (the last block padded with copies of the
    first window); `put` places each block's arrays (`devices.Placement.put`). Returns the
    `RhythmResult` fields as NumPy arrays, one row per window."""
    put = put or (lambda *a: tuple(jnp.asarray(x) for x in a))
    W = len(intensity)
    parts: list[RhythmResult] = []
    for s in range(0, W, block):
        e = min(s + block, W)
        rows = np.r_[np.arange(s, e), np.zeros(block - (e - s), np.int64)]
        args = put(intensity[rows], dt[rows], xy[rows], observed[rows])
        parts.append((e - s, classify_window_block(cfg, *args)))
    fields = [f for f in RhythmResult.__dataclass_fields__]
    if not parts:
        empty = classify_window_block(cfg, *put(*(np.zeros((block,) + a.shape[1:], np.float32)
                                                  for a in (intensity, dt, xy, observed))))
        return {f: np.asarray(getattr(empty, f))[:0] for f in fields}
    return {f: np.concatenate([np.asarray(getattr(r, f))[:m] for m, r in parts])
            for f in fields}

