"""A long track classified in segments of a bounded number of rows, with the same verdict.

`batch.classify_tracks` pads tracks to one length T and classifies all rhythm windows of a chunk
of tracks in one vmapped program: its memory grows with T (about 30 KB a row for one track:
every window's spectrum and Theil-Sen pairs at once, ~128 KB a window, one window every hop = 32
rows, and the chunk padded to 8 tracks). A track longer than `segment_rows` goes through here
instead:

1. The filter runs over `segment_rows` rows at a time: `lax.scan` of `ekf_fused.step` (the same
   EKF and the same `gates.PaperGates` as the batch path, the gate decision an input of the step)
   with its `ekf.Carry` (state, started) handed from one segment to the next. Kept per row on
   the host: started, valid and the ground position (x, y): 10 bytes.
2. Fig. 3's ends (`segments.end_steps`, the walk of `first_segment_end`: the PREDICT time-out
   and the range exit), walked segment by segment as the filter goes, cut the track into
   pieces, as `segments.split_tracks` does; each piece is filtered afresh from its first row,
   as there, and the filter stops at the piece's end (work linear in the length however many
   pieces).
3. The rhythm windows of a piece (N rows from the start, one every hop rows, complete when
   tracked) are classified `window_chunk` at a time (`windows.classify_window_rows`: the
   per-window code of `rhythm.track_windows`, the speed by the exact fast median; the complete
   windows only) from the rows kept in 1, so a window that straddles two filter
   segments sees the rows of both. Matching stops at the first Pedestrian window (Sec. 4.2),
   which is the window `rhythm.classify_track` picks; else the first window is the result.

The verdict, reason, pace, stride, ratio, speed and n_samples equal the batch path's (the same
operations; float32 values to within compilation differences, tests/test_long_tracks.py: 1e-4
relative). The bound: the work on a long track takes memory proportional to `segment_rows`
(the scan's inputs and outputs, ~30 bytes a row) and `window_chunk` (~128 KB a window), not to
its length: ~16 MB at the defaults. What grows with the length is the track's own rows on the
host (the table as read, the padded batch row, and the 10 bytes a row of step 1). Measured,
`rhythmjax classify` of one track (benchmarks/bench_long_track.py, docs/benchmarks.md "Long
tracks"): peak RSS 0.68-0.69 GB at 1e5 rows and 0.98-1.07 GB at 1e6 rows (about 0.65 GB + 0.4 KB
a row), against 3.2 GB at 1e5 rows through the batch path.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import ekf_fused
from .candidates import judged, trend_min_hz
from .ekf import Carry, empty_carry
from .gates import PaperGates
from .params import Config
from .rhythm import N_PEAKS
from .segments import end_steps
from .status import Reason, Verdict
from .windows import WINDOW_BLOCK, classify_window_rows


SEGMENT_ROWS = 4096  # rows per filter segment; tracks longer than this come here
WINDOW_CHUNK = 128  # rhythm windows classified per call (~128 KB each)


@eqx.filter_jit
def _scan_segment(cfg: Config, carry: Carry, z, width, dt, present):
    """`ekf_fused.step` scanned over one segment's rows from `carry`; the carry after the last
    row and, per row, started, valid and the ground position (x, y) m."""
    gates = PaperGates(cfg.width, cfg.thresholds)

    def body(c, inp):
        c, out = ekf_fused.step(cfg.camera, cfg.noise, gates, c, *inp)
        return c, (out.started, out.valid, out.mean[jnp.array([0, 2])])

    return jax.lax.scan(body, carry, (z, width, dt, present))


def filter_segments(cfg: Config, z: np.ndarray, width: np.ndarray, dt: np.ndarray,
                    present: np.ndarray | None, segment_rows: int = SEGMENT_ROWS,
                    dt0=None):
    """The paper's filter over one track's rows (z (T, 2) px, width, dt (T,) s, present (T,);
    None: all present; `dt0`: dt[0] taken as this), `segment_rows` at a time with the carry
    handed on; the last segment is padded with absent rows (one compiled shape). Yields, per
    segment, its first row s and NumPy started, valid (bool) and xy (float32, (n, 2)) of its
    rows."""
    T = len(dt)
    carry = empty_carry(jnp.float32)
    L = int(segment_rows)
    for s in range(0, T, L):
        e = min(s + L, T)
        pad = lambda a, v, e=e, s=s: np.concatenate(
            [a[s:e], np.full((L - (e - s),) + a.shape[1:], v, a.dtype)])
        d = pad(dt, dt[0] if dt0 is None else dt0)
        if s == 0 and dt0 is not None:
            d[0] = dt0
        p = np.arange(L) < e - s if present is None else pad(present, False)
        carry, out = _scan_segment(cfg, carry, jnp.asarray(pad(z, np.nan)),
                                   jnp.asarray(pad(width, np.nan)), jnp.asarray(d),
                                   jnp.asarray(p))
        yield (s,) + tuple(np.asarray(a)[: e - s] for a in out)


def filter_rows(cfg: Config, z, width, dt, present, segment_rows: int = SEGMENT_ROWS):
    """`filter_segments` joined: started, valid (T,) bool and xy (T, 2) float32."""
    parts = [p[1:] for p in filter_segments(cfg, z, width, dt, present, segment_rows)]
    if not parts:
        return np.zeros(0, bool), np.zeros(0, bool), np.zeros((0, 2), np.float32)
    return tuple(np.concatenate(a) for a in zip(*parts))


def _first_piece(cfg: Config, z, width, dt, dt0, segment_rows: int):
    """Filter rows from the first (its dt taken as `dt0`) until Fig. 3 ends the piece
    (`segments.end_steps`, walked segment by segment, so the rows after the end are not
    filtered here). Returns the piece's row count m and its started, valid, xy."""
    T = len(dt)
    parts = []
    k0, has = np.zeros(1, np.int64), np.zeros(1, bool)
    end, pt = np.full(1, -1, np.int64), np.zeros(1)
    for s, st, va, xy in filter_segments(cfg, z, width, dt, None, segment_rows, dt0):
        parts.append((st, va, xy))
        if not has[0] and st.any():
            k0[0], has[0] = s + int(np.argmax(st)), True
        end, pt = end_steps(cfg, s, va[None], xy[None, :, 1], dt[None, s:s + len(st)],
                            np.array([T]), k0, has, end, pt)
        if end[0] >= 0:
            break
    started, valid, xy = (np.concatenate(a) for a in zip(*parts))
    m = int(end[0]) + 1 if end[0] >= 0 else T
    return m, started[:m], valid[:m], xy[:m]


def _unclassified(reason: int, n_tracked: int) -> dict:
    nan = np.float32(np.nan)
    k = np.zeros(N_PEAKS, np.float32)
    return {"verdict": int(Verdict.UNCLASSIFIED), "reason": int(reason), "pace_hz": nan,
            "stride_m": nan, "ratio": nan, "speed_mps": nan, "n_samples": n_tracked,
            "peak_freq": k, "peak_power": k, "peak_mask": np.zeros(N_PEAKS, bool),
            "window_row": -1, "candidate": 0}


def classify_piece(cfg: Config, z, intensity, dt, present, started, valid, xy,
                   window_chunk: int = WINDOW_CHUNK, pace_last: bool = False,
                   second_look=None, across: int = 0) -> dict:
    """`rhythm.classify_track`'s result for one piece of track (rows not split by Fig. 3) from
    the filter's rows: the first complete window that says Pedestrian, else the first window
    (codes, NumPy scalars). `intensity` (T,), or (T, C) with candidate windows B in columns 1..
    (each window judged by the strongest, `candidates.strongest`; `candidate` its column;
    `pace_last`: the last column is the pace window's, rule 34; `across`: that many columns
    before it are rule 50b's windows moved across, `candidates.judged`). `second_look` (res, start,
    twice=True) -> res, where given, may change the outcomes of windows starting at the
    piece's rows `start` (rules 37 and 26, `fast_batch.classify_segments`)."""
    n, hop = cfg.thresholds.n, cfg.thresholds.hop_samples
    k0 = int(np.argmax(started)) if len(started) else 0
    n_tracked = int(np.sum(present & started))
    if not (len(started) and started[k0]) or n_tracked < n:
        available = present & np.all(np.isfinite(z), axis=-1)
        return _unclassified(Reason.TOO_SHORT if available.any() else Reason.NO_MEASUREMENTS,
                             n_tracked)
    n_windows = (n_tracked - n) // hop + 1
    used = valid.copy()
    used[k0] = True  # the measurement that started the filter (as `rhythm.track_windows`)
    observed = np.where(used[:, None], z, np.nan).astype(np.float32)
    first = None
    for j0 in range(0, n_windows, window_chunk):
        j = np.arange(j0, min(j0 + window_chunk, n_windows))
        rows = (k0 + hop * j)[:, None] + np.arange(n)[None, :]
        signals = intensity[rows] if intensity.ndim == 2 else intensity[rows][..., None]
        look = None if second_look is None else \
            (lambda res, twice=True, at=k0 + hop * j: second_look(res, at, twice=twice))
        res, chosen = judged([
            classify_window_rows(cfg, signals[..., c], dt[rows], xy[rows], observed[rows],
                                 block=min(window_chunk, WINDOW_BLOCK))
            for c in range(signals.shape[-1])], look, across=across, pace_last=pace_last,
            min_hz=trend_min_hz(cfg))
        res["candidate"] = chosen
        res["window_row"] = k0 + hop * j  # the window's first row in the piece
        if first is None:
            first = {k: v[0] for k, v in res.items()}
        hit = np.flatnonzero(res["verdict"] == Verdict.PEDESTRIAN)
        if hit.size:
            pick = {k: v[int(hit[0])] for k, v in res.items()}
            break
    else:
        pick = first
    out = {k: pick[k] for k in ("verdict", "reason", "pace_hz", "stride_m", "ratio",
                                "speed_mps", "peak_freq", "peak_power", "peak_mask",
                                "window_row", "candidate")}
    out["n_samples"] = n_tracked
    return out


def classify_long_track(cfg: Config, z: np.ndarray, width: np.ndarray, intensity: np.ndarray,
                        dt: np.ndarray, *, segment_rows: int = SEGMENT_ROWS,
                        window_chunk: int = WINDOW_CHUNK, pace_last: bool = False,
                        second_look=None, across: int = 0) -> list[dict]:
    """One track's rows (no padding: z (T, 2) px, width, intensity (T,) or (T, C) with candidate
    windows B, the last of them the pace window's where `pace_last`, dt (T,) s, dt[0] the
    nominal step) cut at Fig. 3's ends; per piece, in time order, its `classify_piece` result.
    `batch.pick_segments` then picks the track's verdict as for the batch path. `second_look`
    (res, start, twice=True) -> res: `classify_piece`'s, `start` the windows' first rows in
    the track; `across`: `classify_piece`'s."""
    T = len(dt)
    pieces = []
    first = 0
    dt0 = dt[0]
    while first < T:
        m, started, valid, xy = _first_piece(cfg, z[first:], width[first:], dt[first:], dt0,
                                             segment_rows)
        ds = np.concatenate([[dt0], dt[first + 1:first + m]]).astype(dt.dtype)
        look = None if second_look is None else \
            (lambda res, start, twice=True, at=first: second_look(res, at + start, twice=twice))
        piece = classify_piece(cfg, z[first:first + m], intensity[first:first + m], ds,
                               np.ones(m, bool), started, valid, xy, window_chunk, pace_last,
                               look, across)
        if piece["window_row"] >= 0:  # the deciding window's first row in the track
            piece["window_row"] = first + int(piece["window_row"])
        pieces.append(piece)
        first += m
    return pieces
