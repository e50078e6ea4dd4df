"""Batch classification of stored tracks in fixed-shape jitted chunks (no recompilation per track).

Each track is first cut at Fig. 3's ends (the PREDICT time-out and the exit from the detection
range, as the online tracker ends a track); every segment is classified on its own, and a
track's verdict is its first segment that says Pedestrian, else its first classified segment,
else its first (matching goes on until Pedestrian, Sec. 4.2).

`classify_tracks` runs the kernel of `fast_batch` (the filter once, only the complete windows
that can decide, the exact fast median of `windows`). `classify_tracks_reference` is the same
classification the way the paper reads (`segments.split_tracks`, then `classify_each`:
`rhythm.classify_batch` on every window slot of tracks padded to a bucketed length T, in chunks
of a fixed number of tracks, the last padded with empty tracks); they give the same verdicts
(tests/test_classify_fast.py).
"""

from __future__ import annotations

import dataclasses
import sys

import jax.numpy as jnp
import numpy as np

from .devices import placement
from .fast_batch import CODES, classify_fast
from .long_tracks import SEGMENT_ROWS, classify_long_track
from .params import Config
from .rhythm import classify_batch
from .segments import split_tracks
from .status import REASON_LABELS, VERDICT_LABELS, Verdict


VERDICT_COLUMNS = ["track_id", "verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps",
                   "n_samples"]


def _chunk_size(n_tracks: int, chunk: int) -> int:
    """Chunk rows: `chunk`, or the next power of two >= n_tracks when that is smaller."""
    return min(chunk, max(8, 1 << max(0, int(n_tracks - 1).bit_length())))


# Rhythm windows classified at once in one chunk, at most (about 128 KB each: ~1 GB): a chunk
# of tracks of T rows holds rows x ((T - N) / hop + 1) windows. Tracks of up to 256 rows (7
# windows) keep chunks of 256; 256 tracks of 4096 rows went from 32 512 windows (~4 GB) to 64
# tracks a chunk. Measured on 40 tracks of 4000 rows: 1372 MiB with 64 a chunk, 1101 MiB with 32
# (and 1.4x the time), hence 8192 rather than 4096.
WINDOW_BUDGET = 8192


def _window_rows(cfg: Config, T: int, rows: int) -> int:
    """`rows` halved until the chunk's windows fit `WINDOW_BUDGET` (at least 8 rows)."""
    thr = cfg.thresholds
    windows = max(1, (T - thr.n) // thr.hop_samples + 1)
    while rows > 8 and rows * windows > WINDOW_BUDGET:
        rows //= 2
    return rows


def padded_chunks(cfg: Config, batch, chunk: int):
    """Yield (start, end, (z, width, intensity, dt, present)) over the tracks of a `TrackBatch`
    in chunks of one fixed row count (`_chunk_size`, fewer for long T: `_window_rows`); the last
    chunk is padded with empty tracks (no measurement, NaN intensity, dt = 1 / fps), so one
    compilation serves every chunk."""
    B = len(batch.ids)
    rows = _window_rows(cfg, batch.z.shape[1], _chunk_size(B, chunk))
    for s in range(0, B, rows):
        e = min(s + rows, B)
        arrays = []
        for a in (batch.z, batch.width, batch.intensity, batch.dt, batch.present):
            pad = np.zeros((rows - (e - s),) + a.shape[1:], a.dtype)
            if a.dtype.kind == "f":
                pad[...] = np.nan if a is not batch.dt else 1.0 / cfg.camera.fps
            arrays.append(jnp.asarray(np.concatenate([a[s:e], pad])))
        yield s, e, tuple(arrays)


def _progress(total: int, enabled: bool):
    if enabled and sys.stderr.isatty():
        from tqdm import tqdm

        return tqdm(total=total, unit="track", desc="classify", file=sys.stderr)
    return None


def classify_each(cfg: Config, batch, chunk: int, progress: bool) -> dict:
    """`classify_batch` over the tracks of a TrackBatch as they are (no Fig. 3 split), codes
    not labels: NumPy columns, one row per track."""
    B = len(batch.ids)
    fields = ("verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps", "n_samples",
              "peak_freq", "peak_power", "peak_mask")
    parts: dict[str, list[np.ndarray]] = {k: [] for k in fields}
    bar = _progress(B, progress)
    for s, e, arrays in padded_chunks(cfg, batch, chunk):
        res = classify_batch(cfg, *arrays)
        for k in fields:
            parts[k].append(np.asarray(getattr(res, k))[: e - s])
        if bar is not None:
            bar.update(e - s)
    if bar is not None:
        bar.close()
    return {k: (np.concatenate(v) if v else np.zeros((0,))) for k, v in parts.items()}


def pick_segments(verdict: np.ndarray, owner: np.ndarray, n_tracks: int) -> np.ndarray:
    """Per track, the index of the segment that gives its verdict: the first (in time) whose
    verdict is Pedestrian, else the first not Unclassified, else the first. `owner` (sorted)
    is each segment's track."""
    rank = np.where(verdict == Verdict.PEDESTRIAN, 0,
                    np.where(verdict == Verdict.UNCLASSIFIED, 2, 1))
    order = np.lexsort((np.arange(len(owner)), rank, owner))  # by track, rank, time
    first = np.r_[True, owner[order][1:] != owner[order][:-1]] if len(order) else order
    pick = np.full(n_tracks, -1, np.int64)
    pick[owner[order][first]] = order[first]
    return pick


def classify_tracks(cfg: Config, batch, *, chunk: int = 256, progress: bool = True,
                    split: bool = True, segment_rows: int = SEGMENT_ROWS,
                    devices=None, second_look=None) -> dict:
    """Classify every track of a `TrackBatch`; returns NumPy columns of the verdicts table
    (`VERDICT_COLUMNS`, verdict and reason as labels) plus `peak_*` arrays for plots and
    `n_segments` (Fig. 3 segments per track; `split` False: every track whole, one segment,
    the behaviour before the time-out and the range exit were applied). `n_samples` counts
    the frames tracked over all of a track's segments.

    The kernel is `fast_batch.classify_fast` (the filter once, only the windows that can
    decide, the exact fast median): per segment the verdict of `rhythm.classify_track`
    (`classify_each` on `segments.split_tracks`' segments, the reference; tested equal).
    `chunk` is the filter's rows per jitted call (256 measured best: 1024 cost 1.6x the EKF
    time); `progress` is no longer drawn by the kernel (callers report by chunk). `devices`
    (None, a device count or a `jax.sharding.Mesh`) shards every jitted call's batch axis
    over the local devices (`devices.local_mesh`; on this 2-core CPU two CPU devices gave the
    same verdicts and no speed-up).

    A track longer than `segment_rows` rows is classified by `long_tracks.classify_long_track`
    (its filter in segments of that many rows, the carry handed on; the same verdicts), so its
    memory does not grow with its length; the others as before, padded only to their own
    longest (rounded up to a power of two).

    `second_look` (res, track, start, twice=True) -> res, where given, may change the outcome
    of each window classified (window w: rows start[w] .. start[w] + N - 1 of track track[w] of
    `batch`) before it decides, as the tracker's does (rules 37 and 26: `track.looks.
    height_looks`; `twice` False on rule 50b's windows moved across, `batch.across`;
    `fast_batch.classify_segments`)."""
    B = len(batch.ids)
    place = placement(devices)
    long = np.flatnonzero(np.asarray(batch.length) > segment_rows) if split and B else \
        np.zeros(0, np.int64)
    if long.size:
        return _with_long_tracks(cfg, batch, long, chunk=chunk, progress=progress,
                                 segment_rows=segment_rows, place=place,
                                 second_look=second_look)
    if B == 0:
        return verdict_columns(batch, {k: np.zeros(0) for k in CODES}, np.zeros(0, np.int64))
    res, owner = classify_fast(cfg, batch, chunk, place, split=split, second_look=second_look)
    return verdict_columns(batch, res, owner)


def classify_tracks_reference(cfg: Config, batch, *, chunk: int = 256, progress: bool = False,
                              split: bool = True) -> dict:
    """`classify_tracks` (tracks up to `segment_rows` long) the way the paper reads, for the
    tests and benchmarks: `segments.split_tracks`, then `classify_each` (`rhythm.classify_batch`:
    every window slot of every segment, the float-sort medians). Slow; the same verdicts."""
    B = len(batch.ids)
    if split and B:
        segs, owner = split_tracks(cfg, batch, _chunk_size(B, chunk))
    else:
        segs, owner = batch, np.arange(B)
    return verdict_columns(batch, classify_each(cfg, segs, chunk, progress), owner)


def verdict_columns(batch, res: dict, owner: np.ndarray) -> dict:
    """The verdicts table from per-segment results `res` (codes) and each segment's track."""
    B = len(batch.ids)
    pick = pick_segments(res["verdict"], owner, B) if B else np.zeros(0, np.int64)
    out = {k: v[pick] for k, v in res.items()}
    out["n_samples"] = np.bincount(owner, res["n_samples"], minlength=B) if B else \
        np.zeros(0, np.int64)
    out["n_segments"] = np.bincount(owner, minlength=B).astype(np.int64)
    out["track_id"] = np.asarray(batch.ids, dtype=object)
    out["verdict"] = np.asarray([VERDICT_LABELS[int(c)] for c in out["verdict"]], dtype=object)
    out["reason"] = np.asarray([REASON_LABELS[int(c)] for c in out["reason"]], dtype=object)
    out["n_samples"] = out["n_samples"].astype(np.int64)
    return out


def _with_long_tracks(cfg: Config, batch, long: np.ndarray, *, chunk: int, progress: bool,
                      segment_rows: int, place, second_look=None) -> dict:
    """`classify_tracks` when the tracks `long` are longer than `segment_rows`: those one by one
    in segments, the others as a batch truncated to their own length."""
    B = len(batch.ids)
    short = np.setdiff1d(np.arange(B), long)
    n = cfg.thresholds.n
    parts, owners = [], []
    if short.size:
        T = max(n, int(np.max(batch.length[short])))
        T = 1 << (T - 1).bit_length()
        take = lambda a: None if a is None else a[short, :T]
        sub = dataclasses.replace(
            batch, ids=[batch.ids[i] for i in short], z=take(batch.z), width=take(batch.width),
            intensity=take(batch.intensity), t=take(batch.t), dt=take(batch.dt),
            present=take(batch.present), length=batch.length[short],
            labels=None if batch.labels is None else [batch.labels[i] for i in short],
            xy=take(batch.xy), candidates=take(batch.candidates))
        look = None if second_look is None else \
            (lambda res, track, start, twice=True: second_look(res, short[track], start,
                                                               twice=twice))
        res, owner = classify_fast(cfg, sub, chunk, place, second_look=look)
        parts.append({k: res[k] for k in CODES})
        owners.append(short[owner])
    for i in long:
        L = int(batch.length[i])
        signal = batch.intensity[i, :L]
        if batch.candidates is not None:
            signal = np.concatenate([signal[:, None], batch.candidates[i, :L]], axis=1)
        look = None if second_look is None else \
            (lambda res, start, twice=True, i=i: second_look(res, np.full(len(start), i), start,
                                                             twice=twice))
        pieces = classify_long_track(cfg, batch.z[i, :L], batch.width[i, :L], signal,
                                     batch.dt[i, :L], segment_rows=segment_rows,
                                     pace_last=batch.pace_window, second_look=look,
                                     across=batch.across)
        parts.append({k: np.asarray([p[k] for p in pieces]) for k in CODES})
        owners.append(np.full(len(pieces), i))
    owner = np.concatenate(owners)
    order = np.argsort(owner, kind="stable")  # by track, pieces in time order
    res = {k: np.concatenate([p[k] for p in parts])[order] for k in CODES}
    return verdict_columns(batch, res, owner[order])


def merge_verdicts(parts: list[dict], ids: list[str]) -> dict:
    """The verdict columns of `classify_tracks` on groups of a file's tracks (`Tracks.by_span`)
    as one table in the order of `ids` (the file's)."""
    if len(parts) == 1:
        return parts[0]
    cols = {k: np.concatenate([np.asarray(p[k]) for p in parts]) for k in parts[0]}
    where = {str(t): i for i, t in enumerate(cols["track_id"])}
    order = np.asarray([where[str(t)] for t in ids], np.int64)
    return {k: v[order] for k, v in cols.items()}


def summarise(verdicts: dict, labels: np.ndarray | None = None) -> dict:
    """Counts per verdict and reason; agreement with labels (walker vs not) where known."""
    summary = {
        "n_tracks": int(len(verdicts["track_id"])),
        "verdicts": {v: int(np.sum(verdicts["verdict"] == v)) for v in VERDICT_LABELS.values()},
        "reasons": {r: int(np.sum(verdicts["reason"] == r)) for r in REASON_LABELS.values()},
    }
    if labels is not None and len(labels):
        judged = verdicts["verdict"] != "unclassified"
        walker = labels == "pedestrian"
        said = verdicts["verdict"] == "pedestrian"
        summary["labels"] = {
            "walkers_judged_pedestrian": int(np.sum(walker & judged & said)),
            "walkers_judged": int(np.sum(walker & judged)),
            "others_judged_non_pedestrian": int(np.sum(~walker & judged & ~said)),
            "others_judged": int(np.sum(~walker & judged)),
        }
    return summary
