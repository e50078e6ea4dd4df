"""A block of complete rhythm windows classified in ONE jitted program, the pairs of (12) laid out
with the batch on the minor axis: the fast path of `windows.classify_window_rows`.

`windows.classify_window_rows` used three programs a block: the speeds (`speed_block_select`,
which also wrote every window's 2 x 2016 slopes back, 2 MB a block of 128, for the fallback),
the unresolved medians again by bisection (`speed_from_slopes`), and the windows with their
speeds (`classify_window_block_speed`). Here, in one program (`classify_block`):

1. The slopes of (12) per axis, pair by pair (i, i + lag), lag by lag, as
   `windows.window_slopes` forms them (the same operations on the same operands, so the same
   floats), but with the windows on the minor axis: (P, 2, W), P = n (n - 1) / 2. Each lag's
   pairs are then a contiguous run of rows (the concatenation is a copy of whole rows, where
   with the windows first it was a 63-operand concatenation inside every row), and each of
   the median's counts a sum of whole rows (`medians.nanmedian_select_cols`).
2. The median of each axis by `medians.nanmedian_select_cols`; for the windows it leaves
   unresolved (~4 %, ~5 a block of 128), the median again by bisection
   (`medians.nanmedian_exact`) on their slopes, `FALLBACK` windows a turn of a
   `lax.while_loop` (no turn when none is; a top-level loop, so only the flagged windows pay).
3. `fast_window.classify_window_fast` (`rhythm.classify_window`'s Burg, PSD, peaks and
   (13)-(15), the window's median step without a sort) with those speeds, vmapped.

The packed path (`windows.classify_windows_packed_candidates`, the batch classifier's) runs a
block in one program (`BLOCK_PROGRAM`) where it has one rhythm signal, and with candidate
windows B as two programs, steps 1-2 then step 3 (`BLOCK_SPEEDS`, `BLOCK_CLASSIFY`): candidate
windows B (`model.candidates`) share a window's times and ground track, so its speed, which
takes ~80 % of a block's time on 2 CPU cores; the speeds are computed once and step 3 runs
once per rhythm signal, the same program on the same shapes for every signal (so equal
signals give equal floats).

The speeds are `windows.theil_sen_speed`'s floats (the same slopes, the same order
statistics); the rest is `classify_window`'s operations compiled in another program, equal to
the float32 rounding (tests/test_classify_fast.py).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .camera import ground_from_image
from .fast_window import classify_window_fast
from .medians import nanmedian_exact, nanmedian_select_cols
from .params import Config
from .rhythm import RhythmResult, window_times
from .segments import ParamProgram


FALLBACK = 8  # unresolved windows whose medians a turn of the fallback loop takes again


def window_slopes_cols(cfg: Config, t: Float[Array, "n W"], xy: Float[Array, "n W 2"],
                       observed: Float[Array, "n W 2"]) -> tuple[Float[Array, "p 2 W"], Array]:
    """`windows.window_slopes` of W windows at once, windows on the minor axis: the pair
    slopes of (12) per axis (2, n (n - 1) / 2, W), m/s, NaN where a pair is unused, in the same
    pair order, and per window whether the measured foot points were chosen (W,). `t` s from
    each window's first sample, `xy` m (filtered), `observed` px (NaN where the gates used no
    measurement)."""
    n = t.shape[0]
    seen = jnp.all(jnp.isfinite(observed), axis=-1)
    uv = jnp.where(seen[..., None], observed, 0.0)
    gx, gy, ok = ground_from_image(cfg.camera, uv[..., 0], uv[..., 1])
    use = seen & ok
    enough = 2 * jnp.sum(use, axis=0) >= n  # (W,)
    px = jnp.where(enough, jnp.where(use, gx, 0.0), xy[..., 0])
    py = jnp.where(enough, jnp.where(use, gy, 0.0), xy[..., 1])
    pairs = lambda a, op: jnp.concatenate([op(a[lag:], a[:-lag]) for lag in range(1, n)])
    dt = jnp.maximum(pairs(t, jnp.subtract), jnp.finfo(t.dtype).tiny)
    pair = ~enough[None] | pairs(use, jnp.logical_and)
    slopes = jnp.stack([pairs(px, jnp.subtract) / dt, pairs(py, jnp.subtract) / dt], axis=1)
    return jnp.where(pair[:, None], slopes, jnp.nan), enough


def block_speeds(cfg: Config, dt: Float[Array, "W n"], xy: Float[Array, "W n 2"],
                 observed: Float[Array, "W n 2"], fallback: int = FALLBACK
                 ) -> tuple[Float[Array, " W"], Int[Array, ""]]:
    """The speed of (12), m/s, of W complete windows (`windows.theil_sen_speed`'s floats) and
    the number of windows whose median `nanmedian_select_cols` left unresolved and the
    bisection gave (`fallback` windows a turn of a `lax.while_loop`, no turn when none)."""
    W, n = dt.shape
    t = jax.vmap(window_times)(dt)  # (W, n): the per-window cumsum, as the reference's
    slopes, enough = window_slopes_cols(cfg, t.T, jnp.swapaxes(xy, 0, 1),
                                        jnp.swapaxes(observed, 0, 1))
    slopes = jax.lax.optimization_barrier(slopes)  # built once, read by every count
    vel, ok, count = nanmedian_select_cols(slopes)  # (2, W)
    bad = ~jnp.all(ok, axis=0)

    def exact(state):  # the next `fallback` unresolved windows by bisection
        v, todo = state
        redo = jnp.nonzero(todo, size=fallback, fill_value=W)[0]
        s = jnp.transpose(slopes[:, :, jnp.minimum(redo, W - 1)], (2, 1, 0))  # (F, 2, P)
        again = jax.vmap(nanmedian_exact)(s).T  # (2, F)
        return v.at[:, redo].set(again, mode="drop"), todo.at[redo].set(False, mode="drop")

    vel = jax.lax.while_loop(lambda state: jnp.any(state[1]), exact, (vel, bad))[0]
    # the filtered set goes through jnp.median in the reference: any NaN slope gives NaN
    vel = jnp.where(~enough[None] & (count < slopes.shape[0]), jnp.nan, vel)
    return jnp.sqrt(jnp.sum(vel**2, axis=0)), jnp.sum(bad)


@eqx.filter_jit
def classify_block(cfg: Config, intensity: Float[Array, "W n"], dt: Float[Array, "W n"],
                   xy: Float[Array, "W n 2"], observed: Float[Array, "W n 2"]
                   ) -> tuple[RhythmResult, Int[Array, ""]]:
    """`windows.classify_window_block` of W complete windows (intensity, dt s with dt[0]
    unused, xy m, observed px) in one program (module doc), and the number of windows whose
    median `nanmedian_select_cols` left to the bisection."""
    speed, unresolved = block_speeds(cfg, dt, xy, observed)

    one = lambda i, d, v: classify_window_fast(cfg, i, window_times(d), v)
    return jax.vmap(one)(intensity, dt, speed), unresolved


# the fields of a packed block result (`BLOCK_CLASSIFY`), in column order: name, columns, dtype
PACKED_FIELDS = (("verdict", 1, "int32"), ("reason", 1, "int32"), ("pace_hz", 1, "float32"),
                 ("stride_m", 1, "float32"), ("ratio", 1, "float32"),
                 ("speed_mps", 1, "float32"), ("n_samples", 1, "int32"),
                 ("peak_freq", None, "float32"), ("peak_power", None, "float32"),
                 ("peak_mask", None, "bool"))


def _block_speeds(cfg: Config, track: Float[Array, "5 W n"]) -> Float[Array, "1 W"]:
    """Steps 1-2 (`block_speeds`) of W windows packed as (5, W, n) float32 (dt s, xy m,
    observed px): the speeds (1, W) m/s."""
    return block_speeds(cfg, track[0], jnp.moveaxis(track[1:3], 0, -1),
                        jnp.moveaxis(track[3:5], 0, -1))[0][None]


def _block_classify(cfg: Config, signal: Float[Array, "2 W n"],
                    speed: Float[Array, "1 W"]) -> Float[Array, "c W"]:
    """Step 3 of W windows (`signal`: a rhythm signal and dt s, (2, W, n) float32) with their
    speeds: the `RhythmResult` packed as (c, W) float32 in `PACKED_FIELDS` order (the
    integers' bits as they are, `lax.bitcast_convert_type`; the mask 0/1), so it comes back
    as one array."""
    one = lambda i, d, v: classify_window_fast(cfg, i, window_times(d), v)
    res = jax.vmap(one)(signal[0], signal[1], speed[0])
    cols = []
    for name, _, kind in PACKED_FIELDS:
        a = getattr(res, name)
        a = a.reshape(a.shape[0], -1)
        if kind == "bool":
            a = a.astype(jnp.float32)
        elif kind == "int32":
            a = jax.lax.bitcast_convert_type(a.astype(jnp.int32), jnp.float32)
        cols.append(a)
    return jnp.concatenate(cols, axis=1).T


def _block_packed(cfg: Config, packed: Float[Array, "6 W n"]) -> Float[Array, "c W"]:
    """Steps 1-3 of W windows packed as (6, W, n) float32 (intensity, dt s, xy m, observed px)
    in one program: `_block_classify` of `_block_speeds`, the same floats as those two programs
    run one after the other (and as `classify_block`), one program a block where there is one
    signal."""
    return _block_classify(cfg, packed[:2], _block_speeds(cfg, packed[1:6]))


BLOCK_PROGRAM = ParamProgram(_block_packed)
BLOCK_SPEEDS = ParamProgram(_block_speeds)
BLOCK_CLASSIFY = ParamProgram(_block_classify)


def unpack_block(packed, k: int) -> dict:
    """The `RhythmResult` fields (NumPy, one row per window) of `_block_classify`'s (c, W)
    float32 output (blocks joined along axis 1); `k` the peaks a window."""
    out, c = {}, 0
    for name, width, kind in PACKED_FIELDS:
        w = k if width is None else 1
        a = packed[c:c + w].T
        c += w
        if kind == "bool":
            a = a > 0.5
        elif kind == "int32":
            a = a.view(np.int32)
        out[name] = np.ascontiguousarray(a if width is None else a[:, 0])
    return out
