"""Streaming classification of stored tracks: the driver behind `rhythmjax classify`.

A reader thread reads the source by record batches (`io.stream`), hands out blocks of whole
tracks (`BLOCK_TRACKS` tracks or `BLOCK_ROWS` rows), validates each as `io.files.read_tracks`
does and prepares it (`stream.blocks.prepare`): the tracks in groups by padded length class
(`io.stream.by_length`: a short track is not padded to a long one; a track longer than
`segment_rows` alone, through `classify_tracks`' long-track path), each padded
(`io.files.to_batch`). Kernel threads classify the prepared blocks (`model.batch.
classify_tracks`, one call per group), `kernel_threads` blocks at once, so that one block's host
work between its programs overlaps another's programs; the main thread writes each block's
verdicts as a part (`io.parts`), in order; at the end the parts become the output, in the
input's track order. All overlap: while blocks k and k+1 are in the kernels, block k+2 is read
and prepared.

Memory bound: the blocks alive (prepared, queued, in the kernels or being written) are at most
`prefetch + 1 + kernel_threads` (one in the reader's hands, `prefetch` in the queue,
`kernel_threads` in the kernels), each of at most `block_tracks` tracks and, unless one track is
longer, `block_rows` rows: at most (prefetch + 1 + kernel_threads) x block_tracks tracks, as
many times block_rows rows (defaults 4 x 4096 tracks, 4 x 2^19 rows). The reader also holds
less than one block plus one record batch (`batch_rows` rows) of rows not yet handed out.
Nothing grows with the file but the ids' hashes (8 bytes a track) and, with no output file, the
verdicts. The driver counts the tracks alive and reports the peak (`peak_tracks_in_memory`,
against `memory_bound_tracks`).

The verdicts are those of the whole-file path (`classify_whole`, kept for files whose tracks'
rows are not contiguous, which the stream cannot group: a note says so).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import queue
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from .. import __version__
from ..io.errors import BadInput
from ..io.files import validated_tracks
from ..io.parts import VerdictParts
from ..io.stream import (
    BATCH_ROWS,
    BLOCK_ROWS,
    BLOCK_TRACKS,
    NotGrouped,
    fingerprint,
    iter_blocks,
    source_files,
)
from ..model.batch import summarise
from ..model.long_tracks import SEGMENT_ROWS
from ..model.params import config_to_dict
from ..track.looks import reads_heights
from ..track.options import SizeOptions
from .blocks import (
    Notes,
    blind_note,
    camera_counts as camera_counts,
    classify_partition as classify_partition,
    classify_prepared,
    classify_whole,
    concat_columns,
    prepare,
    verdict_order,
)


PREFETCH = 1  # prepared blocks waiting in the queue
# blocks in the kernels at once, each on its own thread: one block's host work (NumPy between
# the programs, under the GIL) overlaps the other's compiled programs (which release it)
KERNEL_THREADS = 2


def _log_stderr(msg: str) -> None:
    print(msg, file=sys.stderr)


def _add_counts(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        if isinstance(v, dict):
            out[k] = _add_counts(out.get(k, {}), v)
        elif isinstance(v, (int, float)):
            out[k] = out.get(k, 0) + v
    return out


def run_key(cfg, files: list[str], *, chunk: int, segment_rows: int, block_tracks: int,
            block_rows: int, size: SizeOptions | None = None) -> dict:
    """What a resumed run must share with the interrupted one: the inputs' fingerprint, the
    config's hash, the settings that fix the blocks, the height rules (`size`: rules 37 and
    26, None off) and the package version."""
    text = json.dumps(config_to_dict(cfg), sort_keys=True, default=str)
    heights = None if not reads_heights(size) else dataclasses.asdict(size)
    return {"input": fingerprint(files), "config": hashlib.sha256(text.encode()).hexdigest(),
            "chunk": chunk, "segment_rows": segment_rows, "block_tracks": block_tracks,
            "block_rows": block_rows, "heights": heights, "version": __version__}


# ----------------------------------------------------------------------------------------------
@dataclass
class _Stats:
    read_s: float = 0.0
    prepare_s: float = 0.0
    kernel_s: float = 0.0
    write_s: float = 0.0
    wait_s: float = 0.0
    alive: int = 0
    peak: int = 0
    lock: threading.Lock = field(default_factory=threading.Lock)

    def hold(self, n: int) -> None:
        with self.lock:
            self.alive += n
            self.peak = max(self.peak, self.alive)


def _reader(q: queue.Queue, stop: threading.Event, cfg, files, skip: int, st: _Stats, *,
            chunk, segment_rows, block_tracks, block_rows, batch_rows, size) -> None:
    """The reader thread: ("block", Prepared) for each block after the first `skip` (done by
    an earlier run: read, not validated or prepared), then ("end", blocks read); ("error",
    exception) on any failure. Stops when `stop` is set."""
    def put(item) -> bool:
        while not stop.is_set():
            try:
                q.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    try:
        blocks = iter_blocks(files, block_tracks=block_tracks, block_rows=block_rows,
                             batch_rows=batch_rows)
        i = 0
        while not stop.is_set():
            t0 = time.perf_counter()
            try:
                p, block = next(blocks)
            except StopIteration:
                break
            if i < skip:
                st.read_s += time.perf_counter() - t0
                i += 1
                continue
            tracks = validated_tracks(p, block, fps=cfg.camera.fps, grouped=True)
            del block
            st.hold(len(tracks.ids))
            t1 = time.perf_counter()
            st.read_s += t1 - t0
            prep = prepare(cfg, tracks, chunk=chunk, segment_rows=segment_rows, size=size)
            del tracks
            st.prepare_s += time.perf_counter() - t1
            i += 1
            if not put(("block", prep)):
                return
        put(("end", i))
    except BaseException as e:  # noqa: BLE001 - handed to the main thread
        put(("error", e))


def classify_source(cfg, source, output, *, chunk: int = 256, segment_rows: int = SEGMENT_ROWS,
                    progress: bool = False, resume: bool = True, devices=None,
                    log: Callable[[str], None] | None = _log_stderr,
                    block_tracks: int = BLOCK_TRACKS, block_rows: int = BLOCK_ROWS,
                    batch_rows: int = BATCH_ROWS, prefetch: int = PREFETCH,
                    kernel_threads: int = KERNEL_THREADS,
                    on_part: Callable[[dict], None] | None = None,
                    size: SizeOptions | None = None) -> dict:
    """Classify every track of `source` (a tracks file, a list of files or a folder of them)
    streaming: read by record batches, classify block by block while the next is prepared,
    write each block's verdicts as a part beside `output`, then assemble `output` (CSV or
    Parquet, the input's track order) atomically. `output` a folder (a path ending in a
    separator): the parts stay there as a Parquet dataset. `output` None: nothing
    written, the verdict columns returned in the summary's "verdicts_table" (memory then grows
    with the file's tracks).

    A rerun after an interruption (Ctrl-C, SIGTERM, kill -9) with the same inputs and settings
    resumes after the parts done (`resume`; `log` says so); a changed input or config starts
    over (`log` says so). A file whose tracks' rows are not contiguous is classified whole
    (`classify_whole`, a note says so); for a list or folder of files that is a `BadInput`.
    `size`: rules 37 and 26 from the tracks' top rows (`track.looks.height_looks`; None: neither).
    `devices` is passed on to `classify_tracks` when not None; `on_part(entry)` is called after
    each part is written (tests). Up to `kernel_threads` blocks are classified at once, each
    on its own thread (the first block alone: it compiles the programs); the parts are
    written in order by this thread.

    Returns a summary: n_tracks, verdicts, reasons, labels (when labelled), notes, streamed,
    parts, resumed_parts, peak_tracks_in_memory, memory_bound_tracks and timing (read_s,
    prepare_s: in the reader thread; kernel_s: in the kernel threads, summed over them;
    write_s, wait_s: in the main thread; total_s)."""
    t_start = time.perf_counter()
    log = log or (lambda msg: None)
    files = source_files(source)
    out = None if output is None else os.fspath(output)
    dataset = out is not None and out.endswith(("/", os.sep))
    parts = None
    if out is not None:
        key = run_key(cfg, files, chunk=chunk, segment_rows=segment_rows,
                      block_tracks=block_tracks, block_rows=block_rows, size=size)
        parts = VerdictParts(out, key, dataset=dataset)
        msg = parts.open(resume=resume)
        if msg:
            log(msg)
    st = _Stats()
    skip = len(parts.done) if parts else 0
    q: queue.Queue = queue.Queue(maxsize=max(1, prefetch))
    stop = threading.Event()
    thread = threading.Thread(
        target=_reader, args=(q, stop, cfg, files, skip, st), daemon=True,
        name="rhythmjax-reader", kwargs=dict(chunk=chunk, segment_rows=segment_rows,
                                             block_tracks=block_tracks, block_rows=block_rows,
                                             batch_rows=batch_rows, size=size))
    notes, counts, camera = Notes(), {}, [0, 0, 0]
    kept: list[dict] = []
    labelled: bool | None = None
    for e in parts.done if parts else []:
        notes.add(e.get("notes", []))
        counts = _add_counts(counts, e.get("summary", {}))
        camera = [a + b for a, b in zip(camera, e.get("camera", [0, 0, 0]), strict=True)]
        labelled = "label" in e.get("columns", [])
    bar = _bar(progress, counts.get("n_tracks", 0))
    pool = ThreadPoolExecutor(max(1, kernel_threads), thread_name_prefix="rhythmjax-kernels")
    inflight: deque = deque()  # (prepared block, future of its verdict columns), in order

    def kernels(prep):
        t1 = time.perf_counter()
        cols = classify_prepared(cfg, prep, chunk=chunk, segment_rows=segment_rows,
                                 devices=devices, size=size)
        return cols, time.perf_counter() - t1

    def finish() -> None:
        nonlocal counts, camera
        prep, fut = inflight.popleft()
        cols, dt = fut.result()
        st.kernel_s += dt
        t2 = time.perf_counter()
        summ = summarise(cols, cols.get("label"))
        counts = _add_counts(counts, summ)
        notes.add(prep.notes)
        camera = [a + b for a, b in zip(camera, prep.camera, strict=True)]
        if parts is not None:
            entry = parts.write(cols, verdict_order(labelled), {
                "tracks": prep.n_tracks, "notes": prep.notes, "camera": prep.camera,
                "summary": summ})
            if on_part:
                on_part(entry)
        else:
            kept.append(cols)
        st.write_s += time.perf_counter() - t2
        st.hold(-prep.n_tracks)
        if bar is not None:
            bar.update(prep.n_tracks)

    thread.start()
    done_blocks = 0
    try:
        while True:
            t0 = time.perf_counter()
            item = q.get()
            st.wait_s += time.perf_counter() - t0
            if item[0] == "error":
                raise item[1]
            if item[0] == "end":
                n_blocks = item[1]
                break
            prep = item[1]
            if labelled is not None and labelled != (prep.labels is not None):
                raise BadInput(files[0], "some of the files have a 'label' column and some "
                                         "not; give all or none")
            labelled = prep.labels is not None
            inflight.append((prep, pool.submit(kernels, prep)))
            del prep
            while inflight and len(inflight) >= (max(1, kernel_threads) if done_blocks else 1):
                finish()
                done_blocks += 1
        while inflight:
            finish()
    except NotGrouped as e:
        _stop(stop, q, thread)
        if parts is not None:
            parts.discard()
        if len(files) > 1:
            raise
        if dataset:
            raise BadInput(files[0], f"{e.message}; a dataset output needs a file whose tracks' "
                                     "rows are contiguous (sort it by track_id)",
                           track_id=e.track_id) from None
        summary = classify_whole(cfg, files[0], out, chunk=chunk, segment_rows=segment_rows,
                                 progress=progress, devices=devices, size=size)
        summary["notes"].insert(0, f"{e}: read the whole file into memory instead of "
                                   "streaming it (sort the file by track_id to stream it)")
        summary["timing"]["total_s"] = round(time.perf_counter() - t_start, 3)
        return summary
    except BadInput:
        _stop(stop, q, thread)
        if parts is not None:
            parts.discard()
        raise
    except BaseException:
        _stop(stop, q, thread)
        if parts is not None:
            parts.discard_if_empty()
            if parts.done:
                log(f"{len(parts.done)} part(s) done kept in {parts.folder}: the same command "
                    "resumes from them")
        raise
    finally:
        for _, fut in inflight:
            fut.cancel()
        pool.shutdown(wait=True)
        if bar is not None:
            bar.close()
    thread.join()
    if n_blocks == 0 and not (parts and parts.done):  # no track: as the whole-file path
        if parts is not None:
            parts.discard()
        return classify_whole(cfg, files[0], out if not dataset else None, chunk=chunk,
                              segment_rows=segment_rows, progress=False, devices=devices,
                              size=size)
    t3 = time.perf_counter()
    verdicts = None
    if parts is not None:
        if dataset:
            parts.finish()
        else:
            parts.assemble()
    else:
        verdicts = concat_columns(kept)
    st.write_s += time.perf_counter() - t3
    blind = blind_note(cfg, camera)
    summary = {**counts, "notes": notes.list + ([blind] if blind else []), "streamed": True,
               "parts": len(parts.done) if parts else n_blocks,
               "resumed_parts": parts.resumed if parts else 0,
               "peak_tracks_in_memory": st.peak,
               "memory_bound_tracks": (max(1, prefetch) + 1 + max(1, kernel_threads))
               * block_tracks,
               "timing": {k: round(getattr(st, k), 3) for k in
                          ("read_s", "prepare_s", "kernel_s", "write_s", "wait_s")}}
    summary["timing"]["total_s"] = round(time.perf_counter() - t_start, 3)
    if verdicts is not None:
        summary["verdicts_table"] = verdicts
    return summary


def _bar(progress: bool, done: int):
    if progress and sys.stderr.isatty():
        from tqdm import tqdm

        return tqdm(initial=done, unit="track", desc="classify", file=sys.stderr)
    return None


def _stop(stop: threading.Event, q: queue.Queue, thread: threading.Thread) -> None:
    """Stop the reader thread (it checks `stop` between blocks and while the queue is full)."""
    stop.set()
    with contextlib.suppress(queue.Empty):
        while True:
            q.get_nowait()
    thread.join(timeout=10)
