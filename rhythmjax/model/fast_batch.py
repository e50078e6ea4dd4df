"""The classification kernel of `batch.classify_tracks`: per Fig. 3 segment the verdict of
`rhythm.classify_track`, computing only the rhythm windows that can decide it.

`rhythm.classify_batch` (the reference, kept for fit/walking and the tests) filters each padded
track and classifies every window slot of it, complete or not, each with two float-sort medians.
Here, in three steps:

1. Filter (`segments.filter_rounds`): the EKF of (4)-(9) with the gates (10), (11) over the
   tracks, in chunks ordered by length and cut to their longest row (rounded to a hop), and
   Fig. 3's ends found on its output. The filter's output over a segment's rows IS the output
   `classify_track` would compute on that segment alone (the filter is causal and a segment's
   filter starts at its first row), so it is not run again.
2. Windows (host, NumPy): a segment tracked over n_tracked frames from its start k0 has
   (n_tracked - N) // hop + 1 complete windows (N frames from k0 + hop j); the others never
   count (`rhythm.track_windows`). Matching stops at the first Pedestrian window (Sec. 4.2),
   so window j is needed only when windows 0 .. j - 1 were not Pedestrian: the windows go in
   phases j in [0, 1), [1, 2), [2, 4), [4, 8), ..., each phase for the segments still
   undecided, gathered from the filter's rows into blocks of `windows.WINDOW_BLOCK`.
3. Each block through `windows.classify_windows_packed`: one program a block
   (`window_block.classify_block`: (12)-(15), the exact fast median), its inputs uploaded as
   one array and its results fetched as one.

Where the batch carries candidate windows B (`TrackBatch.candidates`, `model.candidates`), each
window is classified once per candidate (the paper's window B first) and the candidate whose
strongest peak is highest decides it (`candidate`: 0 the paper's, c the c-th candidate column).

The result per segment is the first Pedestrian window's, else window 0's (`window_row`: that
window's first row in the batch, -1 for none, so the spectra can be drawn); a segment with no
complete window is Unclassified, `too-short` (or `no-measurements` when no row has a finite
measurement), with empty peaks (the reference fills the masked peak slots of such a segment
with the spectrum of an incomplete window; here they are 0).
"""

from __future__ import annotations

import numpy as np

from .candidates import judged, trend_min_hz
from .devices import Placement
from .params import Config
from .rhythm import N_PEAKS
from .segments import filter_rounds
from .status import Reason, Verdict
from .windows import WINDOW_BLOCK, classify_windows_packed_candidates


CODES = ("verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps", "n_samples",
         "peak_freq", "peak_power", "peak_mask", "window_row", "candidate")


class Segments:
    """The segments of a batch after `filter_rounds`, in track order then time order: per
    segment its track (`owner`), the round and row of the round's arrays that hold it, its
    start row k0 (the filter's start), frames tracked and complete windows."""

    def __init__(self, cfg: Config, rounds: list):
        n_win, hop = int(cfg.thresholds.n), int(cfg.thresholds.hop_samples)
        self.rounds = rounds
        cols: dict[str, list] = {k: [] for k in ("owner", "first", "round", "row", "k0",
                                                 "n_tracked", "windows", "measured")}
        for r, rd in enumerate(rounds):
            b, T = rd.started.shape
            inside = np.arange(T)[None, :] < rd.n[:, None]
            started = rd.started & inside
            k0 = np.argmax(started, axis=1)
            has = started[np.arange(b), k0]
            n_tracked = np.sum(started & rd.rest.present, axis=1)
            z = rd.rest.z
            available = rd.rest.present & np.isfinite(z[..., 0]) & np.isfinite(z[..., 1]) & inside
            windows = np.where(has & (n_tracked >= n_win), (n_tracked - n_win) // hop + 1, 0)
            for k, v in (("owner", rd.owner), ("first", rd.first), ("round", np.full(b, r)),
                         ("row", np.arange(b)), ("k0", k0), ("n_tracked", n_tracked),
                         ("windows", windows), ("measured", available.any(axis=1))):
                cols[k].append(np.asarray(v))
        joined = {k: np.concatenate(v).astype(np.int64) for k, v in cols.items()}
        order = np.lexsort((joined["first"], joined["owner"]))
        for k, v in joined.items():
            setattr(self, k, v[order])
        self.n, self.hop = n_win, hop
        extra = rounds[0].rest.candidates if rounds else None
        self.n_candidates = 1 + (0 if extra is None else int(extra.shape[-1]))
        self.pace_window = bool(rounds and rounds[0].rest.pace_window)  # its last column
        self.across = int(rounds[0].rest.across) if rounds else 0  # rule 50b: columns before it

    def __len__(self) -> int:
        return len(self.owner)

    def gather(self, seg: np.ndarray, j: np.ndarray):
        """The rows of window j of segments `seg`: intensity, dt (W, N), xy (m) and observed
        (px, NaN where the filter used no measurement; the row that started it is used)
        (W, N, 2), float32 (views of `gather_packed`'s array)."""
        p = self.gather_packed(seg, j)
        return p[0], p[1], np.moveaxis(p[2:4], 0, -1), np.moveaxis(p[4:6], 0, -1)

    def gather_packed(self, seg: np.ndarray, j: np.ndarray, candidate: int = 0) -> np.ndarray:
        """`gather`'s rows packed as one (6, W, N) float32 array: intensity, dt s, xy m (2),
        observed px (2) (`windows.classify_windows_packed`'s input). `candidate` c > 0: the
        intensity of the c-th candidate window B (`TrackBatch.candidates[..., c - 1]`)."""
        W, N = len(seg), self.n
        out = np.zeros((6, W, N), np.float32)
        rnd = self.round[seg]
        for r in np.unique(rnd):
            w = np.flatnonzero(rnd == r)
            w = slice(None) if len(w) == W else w
            rd = self.rounds[r]
            T = rd.valid.shape[1]
            # each window's rows as flat indices into the round's (B, T) arrays: 1-D takes
            # (the same elements as indexing by (row, column), at a fraction of the cost)
            at = (self.row[seg[w]] * T + self.k0[seg[w]] + self.hop * j[w])[:, None] \
                + np.arange(N)[None, :]
            if candidate:
                K = rd.rest.candidates.shape[-1]
                out[0, w] = np.take(rd.rest.candidates, at * K + (candidate - 1))
            else:
                out[0, w] = np.take(rd.rest.intensity, at)
            out[1, w] = np.take(rd.rest.dt, at)
            seen = np.take(rd.valid, at)
            seen[:, 0] |= j[w] == 0  # window 0's first row started the filter (k0)
            out[2, w], out[3, w] = np.take(rd.xy, 2 * at), np.take(rd.xy, 2 * at + 1)
            out[4, w] = np.where(seen, np.take(rd.rest.z, 2 * at), np.nan)
            out[5, w] = np.where(seen, np.take(rd.rest.z, 2 * at + 1), np.nan)
        return out


def phases(max_windows: int):
    """The window ranges [lo, hi) matched together: [0, 1), [1, 2), [2, 4), [4, 8), ..."""
    lo, hi = 0, 1
    while lo < max_windows:
        yield lo, hi
        lo, hi = hi, 2 * hi


def classify_candidates(cfg: Config, segs: Segments, seg: np.ndarray, j: np.ndarray,
                        place: Placement, block: int, look=None) -> tuple[dict, np.ndarray]:
    """Windows j of segments `seg` classified (`classify_windows_packed_candidates`), once per
    candidate window B when the batch has candidates (each window's speed once for all), the
    strongest kept and looked at by `look` (res, twice=True) -> res (`candidates.judged`, rule
    50b's windows moved across where the batch has them).
    Returns the results and each window's candidate (0: the paper's window B)."""
    packed = segs.gather_packed(seg, j)
    if segs.n_candidates > 1:  # each window's speed once for every signal
        packed = np.concatenate([packed] + [segs.gather_packed(seg, j, c)[:1]
                                            for c in range(1, segs.n_candidates)])
    return judged(classify_windows_packed_candidates(cfg, packed, place, block), look,
                  across=segs.across, pace_last=segs.pace_window, min_hz=trend_min_hz(cfg))


def classify_segments(cfg: Config, segs: Segments, place: Placement | None = None,
                      block: int = WINDOW_BLOCK, second_look=None) -> dict[str, np.ndarray]:
    """Per segment (codes, NumPy columns `CODES`), `rhythm.classify_track`'s result: the first
    complete window that says Pedestrian, else window 0 (module doc, step 2). `second_look`
    (res, track, start, twice=True) -> res, where given, may change the outcomes of windows
    (leading axis) from their rows: window w is rows start[w] .. start[w] + N - 1 of the
    batch's track track[w] (rules 37 and 26, `track.looks.height_looks`; `twice` False on rule
    50b's windows moved across: rule 26 only)."""
    place = place or Placement()
    S = len(segs)
    nan = np.float32(np.nan)
    out = {"verdict": np.full(S, int(Verdict.UNCLASSIFIED), np.int32),
           "reason": np.where(segs.measured > 0, int(Reason.TOO_SHORT),
                              int(Reason.NO_MEASUREMENTS)).astype(np.int32),
           "pace_hz": np.full(S, nan), "stride_m": np.full(S, nan), "ratio": np.full(S, nan),
           "speed_mps": np.full(S, nan), "n_samples": segs.n_tracked.astype(np.int32),
           "peak_freq": np.zeros((S, N_PEAKS), np.float32),
           "peak_power": np.zeros((S, N_PEAKS), np.float32),
           "peak_mask": np.zeros((S, N_PEAKS), bool),
           "window_row": np.full(S, -1, np.int64),  # the deciding window's first batch row
           "candidate": np.zeros(S, np.int64)}  # ... and its window B (0: the paper's)
    fields = [k for k in CODES if k not in ("n_samples", "window_row", "candidate")]
    decided = np.zeros(S, bool)
    block = place.rows(block)
    for lo, hi in phases(int(segs.windows.max(initial=0))):
        todo = np.flatnonzero(~decided & (segs.windows > lo))
        if not todo.size:
            break
        count = np.minimum(segs.windows[todo], hi) - lo
        seg = np.repeat(todo, count)
        j = lo + np.arange(len(seg)) - np.repeat(np.cumsum(count) - count, count)
        start = segs.first[seg] + segs.k0[seg] + segs.hop * j
        look = None if second_look is None else \
            (lambda res, twice=True, track=segs.owner[seg], start=start:
             second_look(res, track, start, twice=twice))
        res, chosen = classify_candidates(cfg, segs, seg, j, place, block, look)
        ped = res["verdict"] == Verdict.PEDESTRIAN
        # per segment, its first Pedestrian window of the phase, else (phase 0) window 0
        take = np.zeros(len(seg), bool)
        hit = np.flatnonzero(ped)
        if hit.size:
            first = np.unique(seg[hit], return_index=True)[1]
            take[hit[first]] = True
        if lo == 0:
            take |= ~ped  # window 0 is the result unless a later window says Pedestrian
        at = seg[take]
        for k in fields:
            out[k][at] = res[k][take]
        out["window_row"][at] = segs.first[at] + segs.k0[at] + segs.hop * j[take]
        out["candidate"][at] = chosen[take]
        decided[seg[ped]] = True
    return out


def classify_fast(cfg: Config, batch, rows: int = 256, place: Placement | None = None,
                  split: bool = True, second_look=None) -> tuple[dict, np.ndarray]:
    """Cut the tracks of a TrackBatch at Fig. 3's ends and classify every segment (steps 1-3
    of the module doc). Returns per-segment codes (`CODES`) and each segment's track, segments
    in track then time order (as `segments.split_tracks` orders them). `split` False: every
    track one segment. `second_look`: `classify_segments`'."""
    place = place or Placement()
    rounds = list(filter_rounds(cfg, batch, rows, place, split))
    segs = Segments(cfg, rounds)
    return classify_segments(cfg, segs, place, second_look=second_look), segs.owner
