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

3. Faster still, with the same floats: `nanmedian_select` takes its trial keys from the data
   (a sorted sample's bracket, then interpolation passes) and resolves the median as the
   smallest or largest key of the last interval: ~14 counts instead of 33, ~2x faster per
   window (benchmarks/bench_median.py). Where a median is left unresolved (~3 % of the
   windows of simulated walkers) it says so and that median is taken again by bisection; no
   data-dependent control flow inside the jitted kernels.

`classify_window_block` classifies a block of complete windows given by their rows in one
program (bisection median). `classify_window_rows`, which the chunked driver (`fast_batch`)
sends the windows that can decide a verdict in blocks of `WINDOW_BLOCK`, gives the same results
per block in three programs: the speeds by `nanmedian_select` (`speed_block_select`, which also
returns the slopes), the unresolved ones again by bisection from those slopes
(`speed_from_slopes`, the flagged windows only), then the windows with their speeds
(`classify_window_block_speed`): a fallback costs a median, not a window, and compiles a small
program.
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
FALLBACK_BLOCK = 8  # windows per call of the exact fallback (`classify_window_rows`)
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
    x = jnp.where(jnp.isnan(x), jnp.nan, x)  # +NaN: last in the key order
    keys = float_keys(x)
    p = x.shape[-1]
    acc = jnp.int16 if p < 2**15 else jnp.int32
    count = lambda b: jnp.sum(b, axis=-1, dtype=acc).astype(jnp.int32)
    # the trial keys through a barrier: fused into the count, their arithmetic would be
    # recomputed for every entry
    bar = jax.lax.optimization_barrier
    le = lambda k: count(keys <= bar(k)[..., None])
    c = count(~jnp.isnan(x))
    r = jnp.maximum((c - 1) // 2, 0)
    r_hi = jnp.clip(c // 2, 0, jnp.maximum(c - 1, 0))
    sample = jax.lax.sort(keys[..., ::stride])  # NaN keys last
    m = sample.shape[-1]
    ms = count(sample <= _KEY_INF)
    centre = (r * ms) // jnp.maximum(c, 1)  # r * ms < 2**31: p * p / stride
    at = lambda j: jnp.take_along_axis(sample, jnp.clip(j, 0, m - 1)[..., None], -1)[..., 0]
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
    inside = (keys > L[..., None]) & (keys <= H[..., None])
    v_small = jnp.min(jnp.where(inside, x, jnp.inf), axis=-1)
    v_large = jnp.max(jnp.where(inside, x, -jnp.inf), axis=-1)
    small = float_keys(jnp.where(v_small == 0, -0.0, v_small).astype(x.dtype))
    large = float_keys(jnp.where(v_large == 0, 0.0, v_large).astype(x.dtype))
    small, large = jnp.maximum(small, L + 1), jnp.minimum(large, H)  # still bounds
    le_small = le(small)
    lt_large = count(keys < bar(large)[..., None])
    at_small = r < le_small
    ok = at_small | (r >= lt_large)
    low = jnp.where(at_small, small, large)
    at_or_below = jnp.where(at_small, le_small, nH)
    low_ = bar(low)[..., None]
    above = jnp.min(jnp.where((keys > low_) & (keys <= _KEY_INF), x, jnp.inf), axis=-1)
    low = from_keys(low)
    high = jnp.where(at_or_below >= r_hi + 1, low, above)
    return jnp.where(c > 0, (low + high) * 0.5, jnp.nan), ok | (c == 0)


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


def theil_sen_speed_select(cfg: Config, t: Float[Array, " n"], xy: Float[Array, "n 2"],
                           observed: Float[Array, "n 2"]) -> tuple[Float[Array, ""], Array]:
    """`theil_sen_speed` with the median of `nanmedian_select`: (speed, ok); where ok is False
    (a median left unresolved) the speed is not the median's and must be recomputed by
    `theil_sen_speed`; where True it is `theil_sen_speed`'s, bit for bit."""
    slopes, enough = window_slopes(cfg, t, xy, observed)
    vel, ok = nanmedian_select(slopes)
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
    sharded over devices, `devices.local_mesh`), the median by bisection alone (one program;
    `classify_window_rows` gives the same results in three)."""
    return jax.vmap(lambda *a: classify_complete_window(cfg, *a))(intensity, dt, xy, observed)


@eqx.filter_jit
def speed_block_select(cfg: Config, dt: Float[Array, "W n"], xy: Float[Array, "W n 2"],
                       observed: Float[Array, "W n 2"]):
    """`theil_sen_speed_select` over a block of W complete windows: speed (W,), ok (W,), and
    for the fallback (`speed_from_slopes`) the slopes (W, 2, P) and which set was used (W,)."""
    def one(d, p, o):
        slopes, enough = window_slopes(cfg, window_times(d), p, o)
        vel, ok = nanmedian_select(slopes)
        return _speed(slopes, enough, vel), jnp.all(ok), slopes, enough
    return jax.vmap(one)(dt, xy, observed)


@jax.jit
def speed_from_slopes(speed: Float[Array, " W"], slopes: Float[Array, "W 2 p"], enough: Array,
                      redo: Int[Array, " k"]) -> Float[Array, " W"]:
    """`speed` with the windows `redo` (indices; repeats allowed) given `theil_sen_speed`'s
    speed from `speed_block_select`'s slopes, the median by bisection (`nanmedian_exact`): the
    fallback of the windows it left unresolved."""
    vel = jax.vmap(lambda s, e: _speed(s, e, nanmedian_exact(s)))(slopes[redo], enough[redo])
    return speed.at[redo].set(vel)


@eqx.filter_jit
def classify_window_block_speed(cfg: Config, intensity: Float[Array, "W n"],
                                dt: Float[Array, "W n"], xy: Float[Array, "W n 2"],
                                observed: Float[Array, "W n 2"], speed: Float[Array, " W"]
                                ) -> RhythmResult:
    """`rhythm.classify_window` over a block of W complete windows with their given speeds."""
    def one(i, d, p, o, v):
        return classify_window(cfg, i, window_times(d), p, jnp.asarray(True), o, speed=v)
    return jax.vmap(one)(intensity, dt, xy, observed, speed)


def classify_window_rows(cfg: Config, intensity: np.ndarray, dt: np.ndarray, xy: np.ndarray,
                         observed: np.ndarray, put=None, block: int = WINDOW_BLOCK,
                         fallback_block: int | None = None) -> dict[str, np.ndarray]:
    """`classify_window_block`'s results over any number of complete windows (NumPy rows:
    intensity, dt (W, n), xy, observed (W, n, 2)), `block` at a time (the last block padded with
    copies of the first window), each block in three programs: the speeds by
    `speed_block_select`; those it left unresolved again from its slopes by
    `speed_from_slopes` (bisection), `fallback_block` windows at a time (default
    `FALLBACK_BLOCK`); the windows with their speeds by `classify_window_block_speed`. `put`
    places each block's arrays (`devices.Placement.put`). Returns the `RhythmResult` fields as
    NumPy arrays, one row per window."""
    put = put or (lambda *a: tuple(jnp.asarray(x) for x in a))
    fallback_block = min(block, fallback_block or FALLBACK_BLOCK)
    W = len(intensity)
    parts: list[tuple[int, RhythmResult]] = []
    for s in range(0, W, block):
        e = min(s + block, W)
        rows = np.r_[np.arange(s, e), np.zeros(block - (e - s), np.int64)]
        args = put(intensity[rows], dt[rows], xy[rows], observed[rows])
        speed, ok, slopes, enough = speed_block_select(cfg, *args[1:])
        redo = np.flatnonzero(~np.asarray(ok)[:e - s])
        for f in range(0, redo.size, fallback_block):
            k = redo[f:f + fallback_block]
            k = np.r_[k, np.full(fallback_block - k.size, k[0])].astype(np.int32)
            speed = speed_from_slopes(speed, slopes, enough, jnp.asarray(k))
        parts.append((e - s, classify_window_block_speed(cfg, *args, speed)))
    fields = [f for f in RhythmResult.__dataclass_fields__]
    if not parts:
        empty = classify_window_block_speed(cfg, *put(*(
            np.zeros((block,) + a.shape[1:], np.float32)
            for a in (intensity, dt, xy, observed, np.zeros(0)))))
        return {f: np.asarray(getattr(empty, f))[:0] for f in fields}
    return {f: np.concatenate([np.asarray(getattr(r, f))[:m] for m, r in parts])
            for f in fields}
