"""The fast rhythm-window classifier of batch classification: `rhythm.classify_window` with the
speed of (12) from an exact selection median instead of a float sort.

`rhythm.window_speed` (the reference, as the paper reads) takes the Theil-Sen speed as
`jnp.median` / `jnp.nanmedian` of the n (n - 1) / 2 pair slopes per axis (2016 at N = 64), for
the measured AND for the filtered positions, then keeps one. On XLA's CPU backend the float sort
behind those medians (a total-order comparator) was ~97 % of `classify_batch`'s time
(docs/benchmarks.md, "classify_batch"). Here:

1. The position set is chosen first (the measured foot points when at least half the window has
   one, else the filtered positions: `window_speed`'s rule), so one median per axis is taken.
2. The median is an exact order statistic found by counting int32 keys of the float bits
   (`medians`: `nanmedian_exact` by a 32-level bisection, `nanmedian_select` in ~14 counts with
   trial keys from the data, flagging the ~3 % of windows it leaves unresolved), the same
   float as `jnp.nanmedian` on the same slopes (tests/test_classify_fast.py).

`classify_window_block` classifies a block of complete windows given by their rows in one
program (bisection median). `classify_window_rows`, which the chunked driver (`fast_batch`)
sends the windows that can decide a verdict in blocks of `WINDOW_BLOCK`, gives the same results
per block in one program, `window_block.classify_block` (the slopes with the windows on the
minor axis, `nanmedian_select_cols`, the medians it leaves unresolved again by bisection
inside the program, then the windows). It replaced three programs a block (the speeds, which
also wrote back every window's slopes; the unresolved medians from those slopes; the windows
with their speeds): 65 -> 40 us a window on one block of 128
(benchmarks/bench_classify_kernel.py).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .camera import ground_from_image
from .devices import Placement
from .medians import (  # noqa: F401 (re-exported: the tests and benchmarks' names)
    float_keys,
    from_keys,
    nanmedian_exact,
    nanmedian_select,
    nanmedian_select_cols,
    rank_key,
)
from .params import Config
from .rhythm import N_PEAKS, RhythmResult, classify_window, window_times
from .segments import put_packed
from .window_block import (
    BLOCK_CLASSIFY,
    BLOCK_PROGRAM,
    BLOCK_SPEEDS,
    classify_block,
    unpack_block,
)


WINDOW_BLOCK = 128  # windows per jitted call (fixed: one compiled shape per N)


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


def classify_window_rows(cfg: Config, intensity: np.ndarray, dt: np.ndarray, xy: np.ndarray,
                         observed: np.ndarray, put=None, block: int = WINDOW_BLOCK
                         ) -> dict[str, np.ndarray]:
    """`classify_window_block`'s results over any number of complete windows (NumPy rows:
    intensity, dt (W, n), xy, observed (W, n, 2)), `block` at a time (the last block padded with
    copies of the first window), each block in one program (`window_block.classify_block`:
    the speeds by `nanmedian_select_cols`, the medians it leaves unresolved again by
    bisection, then the windows). `put` places each block's arrays
    (`devices.Placement.put`). Returns the `RhythmResult` fields as NumPy arrays, one row per
    window."""
    put = put or (lambda *a: tuple(jnp.asarray(x) for x in a))
    W = len(intensity)
    parts: list[tuple[int, RhythmResult]] = []
    for s in range(0, W, block):
        e = min(s + block, W)
        rows = np.r_[np.arange(s, e), np.zeros(block - (e - s), np.int64)]
        args = put(intensity[rows], dt[rows], xy[rows], observed[rows])
        parts.append((e - s, classify_block(cfg, *args)[0]))
    fields = [f for f in RhythmResult.__dataclass_fields__]
    if not parts:
        empty = classify_block(cfg, *put(*(np.zeros((block,) + a.shape[1:], np.float32)
                                           for a in (intensity, dt, xy, observed))))[0]
        return {f: np.asarray(getattr(empty, f))[:0] for f in fields}
    return {f: np.concatenate([np.asarray(getattr(r, f))[:m] for m, r in parts])
            for f in fields}


def classify_windows_packed(cfg: Config, packed: np.ndarray, place: Placement | None = None,
                            block: int = WINDOW_BLOCK) -> dict[str, np.ndarray]:
    """`classify_window_rows` of windows packed as (6, W, n) float32 (intensity, dt s, xy m,
    observed px: `fast_batch.Segments.gather_packed`), the same results with less host work a
    block (`place`: where the blocks go, `devices.Placement`):
    each block (the last padded with copies of the first window) goes up as one array and
    comes back as one (`window_block.BLOCK_PROGRAM`), every block dispatched before the first
    is fetched. Returns the `RhythmResult` fields as NumPy arrays, one row per window."""
    return classify_windows_packed_candidates(cfg, packed, place, block)[0]


def classify_windows_packed_candidates(cfg: Config, packed: np.ndarray,
                                       place: Placement | None = None,
                                       block: int = WINDOW_BLOCK) -> list[dict[str, np.ndarray]]:
    """`classify_windows_packed` of windows packed as (5 + C, W, n) float32: window B's
    intensity, dt, xy, observed as there, then C - 1 more rhythm signals of the same windows
    (candidate windows B). One result per signal (as `classify_windows_packed` gives for that
    signal alone): with one signal a block is one program (`window_block.BLOCK_PROGRAM`), with
    more each window's speed is computed once for all (`BLOCK_SPEEDS`), then each signal by
    `BLOCK_CLASSIFY`."""
    place = place or Placement()
    W = packed.shape[1]
    rows_of = [0] + list(range(6, packed.shape[0]))  # each signal's row: window B, candidates
    if len(rows_of) == 1:
        whole = BLOCK_PROGRAM(cfg)
    else:
        speeds, classify = BLOCK_SPEEDS(cfg), BLOCK_CLASSIFY(cfg)
    pending = []
    for s in range(0, max(W, 1), block):
        e = min(s + block, W)
        rows = np.r_[np.arange(s, e), np.zeros(block - (e - s), np.int64)]
        src = (packed[:, rows] if W
               else np.zeros((packed.shape[0], block, packed.shape[2]), np.float32))
        if len(rows_of) == 1:
            pending.append((e - s, [whole(put_packed(place, src))]))
            continue
        speed = speeds(put_packed(place, src[1:6]))
        pending.append((e - s, [classify(put_packed(place, src[[r, 1]]), speed)
                                for r in rows_of]))
    return [unpack_block(np.concatenate([np.asarray(r[c])[:, :m] for m, r in pending], axis=1),
                         N_PEAKS) for c in range(len(rows_of))]
