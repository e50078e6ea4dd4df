"""One block of whole tracks through the classifier: grouped by length, padded, classified, in
the block's track order (`stream.classify` drives the blocks; `classify_partition` is the unit of
work of the Dask path). Also the whole-file path (`classify_whole`, the behaviour before
streaming) and the camera check summed over blocks (`camera_counts`, `blind_note`)."""

from __future__ import annotations

import dataclasses
import re
import time
from dataclasses import dataclass

import numpy as np

from ..io.files import Tracks, read_tracks, to_batch, validated_tracks, write_table
from ..io.stream import BATCH_ROWS, BLOCK_ROWS, BLOCK_TRACKS, Partition, by_length, iter_blocks
from ..model.batch import VERDICT_COLUMNS, classify_tracks, merge_verdicts, summarise
from ..model.long_tracks import SEGMENT_ROWS
from ..track.looks import height_looks, reads_heights
from ..track.options import SizeOptions


# ----------------------------------------------------------------------------------------------
@dataclass
class Prepared:
    """A block of whole tracks ready for the kernels: `batches` (one `TrackBatch` per group of
    `io.stream.by_length`), `order` (the block's track index of each row the groups give)."""

    ids: np.ndarray
    labels: np.ndarray | None
    batches: list
    order: np.ndarray
    notes: list[str]
    camera: list[int]  # foot points measured, on the ground, inside the detection range

    @property
    def n_tracks(self) -> int:
        return len(self.ids)


def camera_counts(cfg, u: np.ndarray, v: np.ndarray) -> list[int]:
    """[foot points measured, of them on the ground, of them inside the detection range]."""
    from ..model.camera_np import ground_of_pixels

    have = np.isfinite(u) & np.isfinite(v)
    if not have.any():
        return [0, 0, 0]
    _, y, ok = ground_of_pixels(cfg.camera, u[have], v[have])
    thr = cfg.thresholds
    inside = ok & (y >= float(thr.range_min)) & (y <= float(thr.range_max))
    return [int(have.sum()), int(np.sum(ok)), int(np.sum(inside))]


def blind_note(cfg, counts: list[int]) -> str | None:
    """A warning when the config's camera sees none of the foot points (`camera_counts`, summed
    over the file) on the ground inside the detection range: every track would be cut by the
    gates and left unclassified."""
    have, ok, inside = counts
    if not have or inside:
        return None
    thr = cfg.thresholds
    lo, hi = float(thr.range_min), float(thr.range_max)
    return (f"warning: the config's camera sees none of the {have} foot points on "
            f"the ground within the detection range {lo:g}-{hi:g} m ({ok} below "
            "the horizon at all): every track will be unclassified; check camera.h_m, "
            "theta_deg, vc_px (`rhythmjax camera`)")


def _gap(cfg) -> int:
    return max(1, round(float(cfg.thresholds.predict_timeout) * cfg.camera.fps))


def prepare(cfg, tracks: Tracks, *, chunk: int, segment_rows: int,
            size: SizeOptions | None = None) -> Prepared:
    """Group a block's tracks by length and pad each group (`to_batch`). The ground positions
    and the heads' columns (x, y, u_top) are left out of the batches: the kernels do not read
    them; so are the top rows (v_top, top_at_edge) unless rules 37 or 26 read them (`size`)."""
    keep = reads_heights(size)
    slim = dataclasses.replace(tracks, x=None, y=None, u_top=None, state=None,
                               v_top=tracks.v_top if keep else None,
                               top_at_edge=tracks.top_at_edge if keep else None)
    groups, order = by_length(slim, chunk, segment_rows, cfg.thresholds.n)
    batches = [to_batch(g, max_gap_frames=_gap(cfg), min_len=cfg.thresholds.n) for g in groups]
    ids = np.asarray(tracks.ids, dtype=object)
    labels = None
    if tracks.label is not None:
        labels = np.concatenate([np.asarray(b.labels, dtype=object) for b in batches])
    return Prepared(ids=ids, labels=labels, batches=batches, order=order,
                    notes=list(tracks.notes), camera=camera_counts(cfg, tracks.u, tracks.v))


def classify_prepared(cfg, prep: Prepared, *, chunk: int, segment_rows: int,
                      devices=None, size: SizeOptions | None = None) -> dict:
    """The verdict columns (`classify_tracks`' plus "label" when labelled) of a prepared block,
    in the block's track order; rules 37 and 26 where `size` has them (`height_looks`)."""
    kw = {} if devices is None else {"devices": devices}
    parts = [classify_tracks(cfg, b, chunk=chunk, segment_rows=segment_rows, progress=False,
                             second_look=height_looks(cfg, b, size), **kw)
             for b in prep.batches]
    back = np.empty(len(prep.order), np.int64)
    back[prep.order] = np.arange(len(prep.order))
    cols = {k: np.concatenate([np.asarray(p[k]) for p in parts])[back] for k in parts[0]}
    if prep.labels is not None:
        cols["label"] = prep.labels[back]
    return cols


def concat_columns(parts: list[dict]) -> dict:
    if len(parts) == 1:
        return parts[0]
    return {k: np.concatenate([np.asarray(p[k]) for p in parts]) for k in parts[0]}


def verdict_order(labelled: bool) -> list[str]:
    return list(VERDICT_COLUMNS) + (["label"] if labelled else [])


# ----------------------------------------------------------------------------------------------
def classify_partition(cfg, partition: Partition, *, chunk: int = 256,
                       segment_rows: int = SEGMENT_ROWS, devices=None,
                       return_notes: bool = False, block_tracks: int = BLOCK_TRACKS,
                       block_rows: int = BLOCK_ROWS, batch_rows: int = BATCH_ROWS,
                       size: SizeOptions | None = None):
    """Classify the whole tracks in `partition` (rows [row_start, row_stop) of one file, cut at
    track boundaries by `io.stream.plan_partitions`). Returns the verdict columns as
    `model.batch.classify_tracks` returns them (NumPy arrays, `VERDICT_COLUMNS` plus peak_* and
    n_segments) plus "label" when the file has labels, one row per track in the partition's
    track order; with `return_notes`, (columns, notes). Validation as `io.files.read_tracks`
    (`BadInput` with the file's own line or row numbers), block by block, so memory is bounded
    by the block size, not the partition's. `devices` is passed on to `classify_tracks` when
    not None; `size`: rules 37 and 26 (`height_looks`; None: neither)."""
    out, notes = [], Notes()
    for p, block in iter_blocks(partition, block_tracks=block_tracks, block_rows=block_rows,
                                batch_rows=batch_rows):
        tracks = validated_tracks(p, block, fps=cfg.camera.fps, grouped=True)
        prep = prepare(cfg, tracks, chunk=chunk, segment_rows=segment_rows, size=size)
        notes.add(prep.notes)
        out.append(classify_prepared(cfg, prep, chunk=chunk, segment_rows=segment_rows,
                                     devices=devices, size=size))
    if not out:  # no rows: the columns of an empty batch
        empty = np.zeros(0)
        tracks = Tracks(path=partition.path, track_id=np.zeros(0, object),
                        frame=np.zeros(0, np.int64), t=empty, u=empty, v=empty, width_px=empty,
                        intensity=empty, line=np.zeros(0, np.int64), fps=cfg.camera.fps)
        out = [classify_tracks(cfg, to_batch(tracks, max_gap_frames=_gap(cfg),
                                             min_len=cfg.thresholds.n), progress=False)]
    cols = concat_columns(out)
    return (cols, notes.list) if return_notes else cols


class Notes:
    """Notes from the blocks, each kind once (the first block's wording)."""

    def __init__(self) -> None:
        self.list: list[str] = []
        self._keys: set[str] = set()

    def add(self, notes) -> None:
        for n in notes:
            k = re.sub(r"[-+.\deE]+", "#", n)
            if k not in self._keys:
                self._keys.add(k)
                self.list.append(n)


# ----------------------------------------------------------------------------------------------
def classify_whole(cfg, path, output, *, chunk: int = 256, segment_rows: int = SEGMENT_ROWS,
                   progress: bool = False, devices=None, size: SizeOptions | None = None
                   ) -> dict:
    """The whole-file path (before streaming; for files whose tracks' rows are not contiguous):
    read and validate the whole file (`read_tracks`), pad it (`to_batch`, a track longer than
    `segment_rows` apart), classify (rules 37 and 26 where `size` has them), write `output`
    (None: return the verdicts in the summary's "verdicts_table"). Memory grows with the
    file."""
    t0 = time.perf_counter()
    tracks = read_tracks(path, fps=cfg.camera.fps)
    blind = blind_note(cfg, camera_counts(cfg, tracks.u, tracks.v))
    if blind:
        tracks.notes.append(blind)
    t1 = time.perf_counter()
    kw = {} if devices is None else {"devices": devices}
    parts = []
    for group in tracks.by_span(segment_rows):  # a long track pads no other
        batch = to_batch(group, max_gap_frames=_gap(cfg), min_len=cfg.thresholds.n)
        part = classify_tracks(cfg, batch, chunk=chunk, segment_rows=segment_rows,
                               progress=progress, second_look=height_looks(cfg, batch, size),
                               **kw)
        if batch.labels is not None:
            part["label"] = np.asarray(batch.labels, dtype=object)
        parts.append(part)
    verdicts = merge_verdicts(parts, tracks.ids)
    t2 = time.perf_counter()
    labels = verdicts.get("label")
    if output is not None:
        write_table(output, verdicts, verdict_order(labels is not None))
    t3 = time.perf_counter()
    n = len(tracks.ids)
    summary = {**summarise(verdicts, labels), "notes": list(tracks.notes), "streamed": False,
               "parts": 0, "resumed_parts": 0, "peak_tracks_in_memory": n,
               "timing": {"read_s": round(t1 - t0, 3), "prepare_s": 0.0,
                          "kernel_s": round(t2 - t1, 3), "write_s": round(t3 - t2, 3),
                          "wait_s": 0.0, "total_s": round(t3 - t0, 3)}}
    if output is None:
        summary["verdicts_table"] = verdicts
    return summary
