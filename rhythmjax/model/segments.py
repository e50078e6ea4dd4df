"""Fig. 3's PREDICT time-out and range exit on stored tracks (the batch path of `classify`).

The online tracker (track/tracker.py) ends a track (PREDICT -> NONE) when the estimate has been
predicted, with no measurement used, for more than `thresholds.predict_timeout` s, or when the
estimate leaves the detection range [range_min, range_max] (ground y, m); a later detection
starts a new track with a new filter. A stored track can hold such an end: a run of missing
rows (NaN measurement), a gap in its frame numbers longer than `to_batch`'s `max_gap_frames`
(one step of the real duration), measurements the gates (10), (11) refuse, or an estimate that
walks out of the range. `split_tracks` cuts every track at these ends into segments, each filtered
from its own start as the online tracker would (DETECT -> OBSERVE on the first measurement in
range), so a segment is classified exactly as the same rows would be on their own.

The state machine per step k after the start, with pt the time predicted since the last used
measurement (s): elapsed = pt + dt[k]; elapsed > predict_timeout ends the segment, at row k
when row k is a prediction (the online tracker records it, then ends), before row k when row k
is a used measurement (reached only after the time-out, by a long frame gap); else an estimate
outside the range ends it at row k; else pt = 0 when row k is used, elapsed otherwise.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .devices import AXIS, Placement
from .ekf_fused import filter_batch
from .gates import PaperGates
from .params import Config


# Steps stored in float32 (1/15 s rounds up by 4.5e-9 s): 15 of them must still be 1 s, "not more
# than" a 1 s time-out, as the online tracker's float64 clock says.
TIME_TOLERANCE_S = 1e-5


def first_segment_end(cfg: Config, started, valid, y, dt, length) -> np.ndarray:
    """Per track (B,), the last row (inclusive) of the first segment, -1 when it runs to the end.

    `started`, `valid` (B, T) bool and `y` (B, T) m are the filter's outputs over the track
    (`ekf.StepOutput`: started, valid, mean[..., 2]), `dt` (B, T) s, `length` (B,) rows."""
    started, valid = np.asarray(started, bool), np.asarray(valid, bool)
    B, T = started.shape
    k0 = np.argmax(started, axis=1)
    has = started[np.arange(B), k0]
    end, _ = end_steps(cfg, 1, valid[:, 1:], np.asarray(y)[:, 1:], np.asarray(dt)[:, 1:],
                       length, k0, has, np.full(B, -1, np.int64), np.zeros(B))
    return end


def end_steps(cfg: Config, k_first: int, valid, y, dt, length, k0, has, end, pt):
    """The rows k_first .. k_first + n - 1 of `first_segment_end`'s walk (valid, y, dt: (B, n),
    those rows), from its state: `end` (B,) (-1: none yet) and `pt` (B,) s, the time since the
    last used measurement; `k0`, `has`: each track's start row and whether it has one. Returns
    the new (end, pt). The walk over a track given in pieces of rows, piece after piece (with
    `k0` and `has` known once the start is seen), is the walk over the whole track."""
    thr = cfg.thresholds
    timeout, lo, hi = (float(a) for a in (thr.predict_timeout, thr.range_min, thr.range_max))
    valid, y, dt = np.asarray(valid, bool), np.asarray(y, np.float64), np.asarray(dt, np.float64)
    # no track is live at or past its length: the walk stops at the longest open one's
    stop = int(np.max(np.where(has & (end < 0), length, 0), initial=0)) - k_first
    for i in range(min(valid.shape[1], max(stop, 0))):
        k = k_first + i
        live = has & (k > k0) & (k < length) & (end < 0)
        if not live.any():
            continue
        elapsed = pt + dt[:, i]
        timed_out = live & (elapsed > timeout + TIME_TOLERANCE_S)
        left = live & ~timed_out & ~((y[:, i] >= lo) & (y[:, i] <= hi))
        end = np.where(timed_out, np.where(valid[:, i], k - 1, k), end)
        end = np.where(left, k, end)
        pt = np.where(live, np.where(valid[:, i], 0.0, elapsed), pt)
    return end, pt


class ParamProgram:
    """`fn(params, *arrays)` jitted with the parameters' arrays as arguments and their other
    leaves static (as `eqx.filter_jit` splits them), one compiled program per parameter
    structure and array shapes: `eqx.filter_jit`'s program, called for a fraction of its
    per-call host cost (the parameters are split and hashed once per structure, not per
    call). `program(params)` gives a callable of the arrays."""

    def __init__(self, fn):
        self.fn = fn
        self.cache: dict = {}

    def __call__(self, params):
        dyn, static = eqx.partition(params, eqx.is_array)
        leaves, tree = jax.tree_util.tree_flatten(dyn)
        key = (tree, static)
        jitted = self.cache.get(key)
        if jitted is None:
            fn = self.fn
            jitted = jax.jit(lambda lv, *a: fn(eqx.combine(
                jax.tree_util.tree_unflatten(tree, lv), static), *a))
            self.cache[key] = jitted
        return lambda *arrays: jitted(leaves, *arrays)


def put_packed(place: Placement, packed: np.ndarray):
    """A packed array (quantities on axis 0, the batch rows on axis 1) for a program: as it
    is with no mesh (the jitted call uploads it), else on the mesh split along axis 1."""
    if place.mesh is None:
        return packed
    return jax.device_put(packed, jax.sharding.NamedSharding(
        place.mesh, jax.sharding.PartitionSpec(None, AXIS)))


def _filter_packed(params, packed):
    """`filter_batch` of a chunk packed as (5, B, T) float32 (z's two coordinates px, width
    px, dt s, present 0/1), its outputs packed as (4, B, T) float32: started, valid (0/1),
    x, y (m). Only these outputs are kept, so the program does not write the covariances and
    the other fields."""
    camera, noise, gates = params
    out = filter_batch(camera, noise, gates, jnp.moveaxis(packed[:2], 0, -1), packed[2],
                       packed[3], packed[4] > 0.5).steps
    return jnp.stack([out.started.astype(jnp.float32), out.valid.astype(jnp.float32),
                      out.mean[..., 0], out.mean[..., 2]])


FILTER_PROGRAM = ParamProgram(_filter_packed)


def filter_chunks(cfg: Config, batch, rows: int, place: Placement | None = None):
    """`ekf_fused.filter_batch` with the paper's gates over a TrackBatch; returns started,
    valid (B, T) bool and xy (B, T, 2) m (the filtered ground position) as NumPy.

    The tracks go in chunks of `rows` (fewer when the batch is smaller: the next power of two,
    at least 8) ordered by length, each chunk cut to its longest track rounded up to a multiple
    of `thresholds.hop_samples` (the filter is causal: the rows of a track are filtered as in
    the whole batch); the columns past a chunk's cut repeat `started`'s last and hold no
    `valid` row. `place` puts a chunk's inputs on the devices (`devices.Placement`: the rows
    a multiple of the device count). A chunk goes up as one packed array and comes back as
    one (`FILTER_PROGRAM`: started, valid and the ground position only); every chunk is
    dispatched before the first is fetched."""
    gates = PaperGates(cfg.width, cfg.thresholds)
    place = place or Placement()
    B, T = batch.z.shape[:2]
    hop = int(cfg.thresholds.hop_samples)
    rows = place.rows(min(rows, max(8, 1 << max(0, B - 1).bit_length())))
    order = np.argsort(np.asarray(batch.length), kind="stable")
    started, valid = np.zeros((B, T), bool), np.zeros((B, T), bool)
    xy = np.full((B, T, 2), np.nan, np.float32)
    run = FILTER_PROGRAM((cfg.camera, cfg.noise, gates))
    pending = []
    for s in range(0, B, rows):
        idx = order[s:s + rows]
        Tc = min(T, max(hop, -(-int(np.max(batch.length[idx])) // hop) * hop))
        packed = np.empty((5, rows, Tc), np.float32)
        packed[:, len(idx):] = np.asarray([np.nan, np.nan, np.nan, 1.0, 0.0])[:, None, None]
        z = batch.z[idx, :Tc]
        packed[0, :len(idx)], packed[1, :len(idx)] = z[..., 0], z[..., 1]
        packed[2, :len(idx)] = batch.width[idx, :Tc]
        packed[3, :len(idx)] = batch.dt[idx, :Tc]
        packed[4, :len(idx)] = batch.present[idx, :Tc]
        pending.append((idx, Tc, run(put_packed(place, packed))))
    for idx, Tc, out in pending:
        out = np.asarray(out)[:, : len(idx)]
        st = out[0] > 0.5
        started[idx, :Tc], started[idx, Tc:] = st, st[:, -1:]
        valid[idx, :Tc] = out[1] > 0.5
        xy[idx, :Tc, 0], xy[idx, :Tc, 1] = out[2], out[3]
    return started, valid, xy


def _rows(batch, which: np.ndarray, first: np.ndarray, n: np.ndarray):
    """A TrackBatch of rows first[i] .. first[i] + n[i] - 1 of tracks `which`, shifted to row 0
    and padded as `io.files.to_batch` pads (NaN, absent, t going on by the nominal step)."""
    T = batch.z.shape[1]
    idx = np.arange(T)[None, :]
    src = np.minimum(first[:, None] + idx, T - 1)
    inside = idx < n[:, None]
    take = lambda a: a[which[:, None], src]
    dt0 = batch.dt[which, :1]

    def masked(a, fill):
        if a is None:
            return None
        a = take(a)
        shape = inside.shape + (1,) * (a.ndim - 2)
        return np.where(inside.reshape(shape), a, fill).astype(a.dtype)

    t = take(batch.t)
    t_last = t[np.arange(len(which)), np.maximum(n - 1, 0)][:, None]
    t = np.where(inside, t, t_last + dt0 * (idx - n[:, None] + 1)).astype(batch.t.dtype)
    # the steps between the rows as stored (not re-derived from float32 t): bit for bit those
    # `to_batch` gives the rows on their own
    dt = np.where(inside & (idx > 0), take(batch.dt), dt0).astype(batch.dt.dtype)
    return dataclasses.replace(
        batch, ids=[batch.ids[i] for i in which], z=masked(batch.z, np.nan),
        width=masked(batch.width, np.nan), intensity=masked(batch.intensity, np.nan), t=t,
        dt=dt, present=inside, length=n.astype(np.int32),
        labels=None if batch.labels is None else [batch.labels[i] for i in which],
        xy=masked(batch.xy, np.nan),
        candidates=None if batch.candidates is None else masked(batch.candidates, np.nan))


class Round(NamedTuple):
    """One pass of `filter_rounds`: the rows `rest` (a TrackBatch: rows first[i] on of track
    owner[i], shifted to row 0), their filter outputs (`filter_chunks`) and n[i], the rows of
    each one's first segment (its rows 0 .. n[i] - 1 are that segment, filtered as on their
    own)."""

    owner: np.ndarray
    first: np.ndarray
    n: np.ndarray
    rest: object
    started: np.ndarray
    valid: np.ndarray
    xy: np.ndarray


def filter_rounds(cfg: Config, batch, rows: int = 256, place: Placement | None = None,
                  split: bool = True):
    """Yield the `Round`s that cut every track of a TrackBatch at its Fig. 3 ends (module doc):
    the first round filters every track and ends its first segment; each next round filters
    again, from the row after an end, the tracks that go on, until none does. `split` False:
    one round, every track one segment. `rows`, `place`: `filter_chunks`."""
    B = len(batch.ids)
    rest = batch
    owner, first = np.arange(B), np.zeros(B, np.int64)  # the rest's track and its first row
    while len(owner):
        started, valid, xy = filter_chunks(cfg, rest, rows, place)
        end = first_segment_end(cfg, started, valid, xy[..., 1], rest.dt, rest.length) \
            if split else np.full(len(owner), -1, np.int64)
        n = np.where(end >= 0, end + 1, rest.length).astype(np.int64)
        yield Round(owner, first, n, rest, started, valid, xy)
        more = (end >= 0) & (rest.length > n)
        owner, first = owner[more], first[more] + n[more]
        rest = _rows(batch, owner, first, batch.length[owner] - first)


def split_tracks(cfg: Config, batch, rows: int = 256):
    """Cut every track of a TrackBatch at its Fig. 3 ends (module doc). Returns the segments as
    a TrackBatch (each padded to the same T, ids and labels of their track) and, per segment,
    the index of its track; segments are in track order, then time order. A track without an
    end is one segment equal to itself."""
    B = len(batch.ids)
    if B == 0:
        return batch, np.zeros(0, np.int64)
    pieces = [(r.owner, r.first, r.n) for r in filter_rounds(cfg, batch, rows)]
    track = np.concatenate([p[0] for p in pieces])
    start = np.concatenate([p[1] for p in pieces])
    count = np.concatenate([p[2] for p in pieces])
    order = np.lexsort((start, track))
    return _rows(batch, track[order], start[order], count[order]), track[order]
