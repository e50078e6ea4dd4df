"""Batch classification of stored tracks in fixed-shape jitted chunks (no recompilation per track).

Tracks are padded to a bucketed length T (by `io.to_batch`) and cut into chunks of a fixed number
of tracks; the last chunk is padded with empty tracks. One compilation serves every chunk of a
bucket. A progress bar is shown on a terminal.
"""

from __future__ import annotations

import sys

import jax.numpy as jnp
import numpy as np

from .params import Config
from .rhythm import classify_batch
from .status import REASON_LABELS, VERDICT_LABELS


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


def classify_tracks(cfg: Config, batch, *, chunk: int = 256, progress: bool = True) -> dict:
    """Classify every track of a `TrackBatch`; returns NumPy columns of the verdicts table
    (`VERDICT_COLUMNS`, verdict and reason as labels) plus `peak_*` arrays for plots."""
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
    out = {k: (np.concatenate(v) if v else np.zeros((0,))) for k, v in parts.items()}
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
