"""Named records shared by the two online trackers (the rhythm paper's `tracker.OnlineTracker` and
the tracking paper's `count.pedestrian_level.PedestrianLevel`): one row of a track, one ground
velocity, and the named column blocks of the packed per-slot arrays their jitted steps exchange
with the device (`Layout`), so no caller reads a row or a device result by position.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np


class TrackRow(NamedTuple):
    """One frame of a track, the tracks format (ARCHITECTURE.md) minus its track_id.

    frame: index; t: s; (u, v): the measured foot point px (NaN when predicted); width_px: the
    measured image width px of the object (NaN when predicted; the W_IMG of gate (10));
    intensity: the rhythm signal I(k) in window B (NaN: no sample); (x_est, y_est): the filter's
    ground estimate m; state: `status.TrackState` as an int; v_top: the top row px of the
    measured moving region (the head; NaN when not measured or clipped by the detection
    window), an optional column of the tracks format; u_top: the head's column px at v_top
    (`count` writes u + the silhouette's lean, `count.widths.measured_lean`; NaN where not
    measured), optional likewise; top_at_edge: the measured moving region reached the image's
    first row, so v_top is NaN and the object goes on above it (`count` and the tracker
    record it; False where not measured), the optional column `top_at_edge` (1/0)."""

    frame: int
    t: float
    u: float
    v: float
    width_px: float
    intensity: float
    x_est: float
    y_est: float
    state: int
    v_top: float = math.nan
    u_top: float = math.nan
    top_at_edge: bool = False


class Velocity(NamedTuple):
    """A filter's ground velocity (m/s) at one row."""

    vx: float
    vy: float


NAN_VELOCITY = Velocity(math.nan, math.nan)


class Layout:
    """Named column blocks of a packed (S, C) per-slot array: one host-device transfer a frame
    instead of one per quantity. `record` is a NamedTuple type whose fields name the blocks, in
    order; `widths` their column counts. `unpack` gives the record of views (a width-1 block as
    an (S,) view, wider ones as (S, w)); on a NumPy array the views are writable."""

    def __init__(self, record: type, widths: Sequence[int]):
        if len(record._fields) != len(widths):
            raise ValueError(f"{record.__name__}: {len(record._fields)} fields, "
                             f"{len(widths)} widths")
        self.record, self.widths = record, tuple(int(w) for w in widths)
        starts = np.concatenate([[0], np.cumsum(self.widths)]).tolist()
        self.columns = int(starts[-1])
        self._index = tuple(a if w == 1 else slice(a, a + w)
                            for a, w in zip(starts, self.widths))

    def unpack(self, packed):
        """The record of column views of `packed` (S, C), NumPy or JAX."""
        return self.record(*(packed[:, i] for i in self._index))

    def pack(self, dtype, **blocks) -> jnp.ndarray:
        """(S, C) array of `dtype` from the blocks by name ((S,) or (S, w) arrays), on device."""
        parts = [blocks[name] for name in self.record._fields]
        return jnp.concatenate([jnp.reshape(p, (p.shape[0], -1)).astype(dtype) for p in parts],
                               axis=1)

    def empty(self, slots: int, dtype=np.float32) -> np.ndarray:
        """(slots, C) host array of NaN, to be filled through `unpack`'s views."""
        return np.full((slots, self.columns), np.nan, dtype)
