"""Batch classification of stored tracks in fixed-shape jitted chunks (no recompilation per track).

Tracks are padded to a bucketed length T (by `io.to_batch`) and cut into chunks of a fixed number
of tracks; the last chunk is padded with empty tracks. One compilation serves every chunk of a
bucket. A progress bar is shown on a terminal.

Each track is first cut at Fig. 3's ends (`segments.split_tracks`: the PREDICT time-out and the
exit from the detection range, as the online tracker ends a track); every segment is classified
on its own, and a track's verdict is its first segment that says Pedestrian, else its first
classified segment, else its first (matching goes on until Pedestrian, Sec. 4.2).
"""

from __future__ import annotations

import sys

import jax.numpy as jnp
import numpy as np

from .params import Config
from .rhythm import classify_batch
from .segments import split_tracks
from .status import REASON_LABELS, VERDICT_LABELS, Verdict


VERDICT_COLUMNS = ["track_id", "verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps",
                   "n_samples"]


def _chunk_size(n_tracks: int, chunk: int) -> int:
    """Chunk rows: `chunk`, or the next power of two >= n_tracks when that is smaller."""
    return min(chunk, max(8, 1 << max(0, int(n_tracks - 1).bit_length())))


def padded_chunks(cfg: Config, batch, chunk: int):
    """Yield (start, end, (z, width, intensity, dt, present)) over the tracks of a `TrackBatch`
    in chunks of one fixed row count (`_chunk_size`); the last chunk is padded with empty tracks
    (no measurement, NaN intensity, dt = 1 / fps), so one compilation serves every chunk."""
    B = len(batch.ids)
    rows = _chunk_size(B, chunk)
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
                    split: bool = True) -> dict:
    """Classify every track of a `TrackBatch`; returns NumPy columns of the verdicts table
    (`VERDICT_COLUMNS`, verdict and reason as labels) plus `peak_*` arrays for plots and
    `n_segments` (Fig. 3 segments per track; `split` False: every track whole, one segment,
    the behaviour before the time-out and the range exit were applied). `n_samples` counts
    the frames tracked over all of a track's segments."""
    B = len(batch.ids)
    if split:
        segs, owner = split_tracks(cfg, batch, _chunk_size(B, chunk))
    else:
        segs, owner = batch, np.arange(B)
    res = classify_each(cfg, segs, chunk, progress)
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
