"""Batch classification beyond one machine: `io.stream.Partition`s mapped over a Dask cluster.

`classify_dask` plans partitions of whole tracks on the client (`io.stream.plan_partitions`,
the track_id column only) and submits one task per partition not done yet. A worker runs
`run_partition`, i.e. `stream.classify.classify_partition`: the same jitted chunks as the single
process (`classify_source`), so the verdicts are identical. The client writes each partition's
verdicts as the next part (`io.parts.VerdictParts`, as the single process: atomic parts, a
manifest, resume) once every partition before it is in, then assembles the output.

What travels: to a worker, the partition (a path, two row numbers) and the config as JSON text
(`config_wire`: the `config_to_dict` dict plus the exact float32 leaves; the dict alone gives
some leaves one bit off); back, the verdict columns (~100 bytes a track, against ~5 KB of input
rows a track the worker read itself). So the client is the one writer of the parts and the
manifest, and only the input, not the output folder, must be visible to the workers.

Per worker, once: the persistent XLA compilation cache is pointed at the client's folder
(`worker_setup`), the config is rebuilt once (`config_from_wire`), and the jitted functions are
module-level, so a worker compiles each shape at most once and loads what another stored.

A worker's `BadInput` cannot cross the wire as itself (pickle does not replay its keywords): it
comes back as its fields and the client raises the same `BadInput` (same message, exit 2).
Dask is imported lazily: `pip install "rhythmjax[dask]"`.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import sys
import time
import uuid
from collections.abc import Iterator

import jax
import jax.numpy as jnp
import numpy as np

from ..io import BadInput
from ..io.parts import VerdictParts
from ..io.stream import (
    BLOCK_ROWS,
    BLOCK_TRACKS,
    NotGrouped,
    Partition,
    plan_partitions,
    source_files,
)
from ..model.batch import VERDICT_COLUMNS, summarise
from ..model.long_tracks import SEGMENT_ROWS
from ..model.params import Config, config_from_dict, config_to_dict
from ..track.options import SizeOptions
from .classify import classify_partition, classify_source, run_key
from .cluster import local_cluster


ROWS_PER_PARTITION = 1 << 20  # rows per task: ~11 600 tracks of 90 rows (docs/distributed.md)
CONNECT_TIMEOUT_S = 30  # seconds to reach a scheduler given by address
_BAD_INPUT_FIELDS = ("path", "message", "line", "row", "column", "track_id", "key")


# ----------------------------------------------------------------------------------------------
# what runs on a worker
def config_wire(cfg: Config) -> str:
    """`cfg` as JSON text for the workers: its `config_to_dict` dict and every leaf's exact
    value (float32 values are exact in JSON's float64), so `config_from_wire` gives a config
    with the same bits as `cfg`; no pickled JAX arrays."""
    leaves = [np.asarray(x).tolist() for x in jax.tree_util.tree_leaves(cfg)]
    return json.dumps({"config": config_to_dict(cfg), "leaves": leaves})


_CONFIGS: dict[str, Config] = {}  # per process: the JSON text -> the config built from it
_SETUP: dict[str, str | None] = {}  # per process: the compilation cache folder set, once


def config_from_wire(text: str) -> Config:
    """The config of `config_wire`'s text, built once per process: `config_from_dict` gives the
    structure and the static fields, the leaves are restored bit for bit."""
    cfg = _CONFIGS.get(text)
    if cfg is None:
        d = json.loads(text)
        leaves, treedef = jax.tree_util.tree_flatten(config_from_dict(d["config"]))
        if len(leaves) != len(d["leaves"]):
            raise ValueError("the config's leaves do not match its dict (another rhythmjax "
                             "version on the worker?)")
        exact = [jnp.asarray(np.asarray(v, dtype=np.asarray(x).dtype).reshape(np.shape(x)))
                 for x, v in zip(leaves, d["leaves"], strict=True)]
        cfg = _CONFIGS.setdefault(text, jax.tree_util.tree_unflatten(treedef, exact))
    return cfg


def worker_setup(cache_dir: str | None) -> str | None:
    """Point this process's persistent XLA compilation cache at `cache_dir` (once, before its
    first compilation); a folder that cannot be made or written leaves the cache off (the worker
    then compiles each shape once in memory). Returns the folder in use, or None."""
    if "cache_dir" in _SETUP:
        return _SETUP["cache_dir"]
    used = None
    if cache_dir:
        try:
            os.makedirs(cache_dir, exist_ok=True)
            if os.access(cache_dir, os.W_OK):
                jax.config.update("jax_compilation_cache_dir", cache_dir)
                jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
                used = cache_dir
        except OSError:
            used = None
    _SETUP["cache_dir"] = used
    return used


def run_partition(wire: str, partition: Partition, *, chunk: int, segment_rows: int,
                  cache_dir: str | None, devices: int | str | None = None,
                  size: SizeOptions | None = None) -> dict:
    """One task, on a worker: classify `partition` with the config of `wire` (`devices`: a
    count or "all" of the worker's own devices, as `classify_tracks` takes it; `size`: rules
    37 and 26, `track.looks.height_looks`).

    Returns {"columns": the verdict columns (`VERDICT_COLUMNS`, "label" when the file has
    labels), "notes", "seconds", "worker"}, or {"bad_input": fields} for a `BadInput`
    (re-raised by the client, `bad_input_from`)."""
    t0 = time.perf_counter()
    worker_setup(cache_dir)
    cfg = config_from_wire(wire)
    try:
        res, notes = classify_partition(cfg, partition, chunk=chunk, segment_rows=segment_rows,
                                        devices=devices, return_notes=True, size=size)
    except BadInput as e:
        return {"bad_input": {k: getattr(e, k) for k in _BAD_INPUT_FIELDS}}
    return {"columns": {k: res[k] for k in (*VERDICT_COLUMNS, "label") if k in res},
            "notes": list(notes),
            "seconds": time.perf_counter() - t0,
            "worker": f"{socket.gethostname()}:{os.getpid()}"}


# ----------------------------------------------------------------------------------------------
# the client
def print_stderr(msg: str) -> None:
    """The default `log`: one line on stderr."""
    print(msg, file=sys.stderr)


@contextlib.contextmanager
def connect(scheduler=None, n_workers: int = 2) -> Iterator:
    """A `dask.distributed.Client`: a LocalCluster of `n_workers` processes with one thread each
    for None or "local" (`cluster.local_cluster`), the scheduler at an address
    ("tcp://host:8786"), or a Client given (used as it is, not closed). An unreachable address,
    or Dask not installed, is a `BadInput`."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise BadInput("--dask", "needs dask.distributed, which is not installed: pip install "
                                 "'rhythmjax[dask]'") from None

    if isinstance(scheduler, Client):
        yield scheduler
        return
    if scheduler is None or scheduler == "local":
        with local_cluster(n_workers) as cluster, Client(cluster) as client:
            yield client
        return
    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as e:
        raise BadInput(str(scheduler), f"cannot reach a Dask scheduler there ({e})") from None
    with client:
        yield client


def bad_input_from(fields: dict) -> BadInput:
    """The worker's `BadInput` again, from its fields: the same message."""
    kw = {k: fields[k] for k in _BAD_INPUT_FIELDS[2:]}
    return BadInput(fields["path"], fields["message"], **kw)


def default_cache_dir() -> str | None:
    """The client's persistent compilation cache folder (the CLI sets it; RHYTHMJAX_CACHE_DIR),
    shared with the workers where the filesystem is."""
    return jax.config.jax_compilation_cache_dir or None


def dask_key(cfg: Config, files: list[str], *, chunk: int, segment_rows: int,
             rows_per_partition: int, size: SizeOptions | None = None) -> dict:
    """The manifest's key of a Dask run: `stream.classify.run_key` (the inputs' fingerprint,
    the config's hash, the settings, the version) plus the partitions' size. A rerun with the
    same key resumes after the parts listed; the single-process path cuts other blocks, so its
    parts are not taken up (and the reverse): the run starts over, and says so."""
    return {**run_key(cfg, files, chunk=chunk, segment_rows=segment_rows,
                      block_tracks=BLOCK_TRACKS, block_rows=BLOCK_ROWS, size=size),
            "engine": "dask", "rows_per_partition": int(rows_per_partition)}


def classify_dask(cfg: Config, source, output, *, scheduler=None, n_workers: int = 2,
                  rows_per_partition: int = ROWS_PER_PARTITION, chunk: int = 256,
                  segment_rows: int = SEGMENT_ROWS, progress: bool = True, resume: bool = True,
                  cache_dir: str | None = None, devices: int | str | None = None,
                  log=print_stderr, size: SizeOptions | None = None) -> dict:
    """Classify every track of `source` (a tracks file, a list or a folder of them) on a Dask
    cluster, as `stream.classify.classify_source` does on one process, with the same verdicts:
    `output` a verdicts file (CSV or Parquet, the input's track order), a folder (the parts stay
    there as a Parquet dataset) or None (the verdicts in the summary's "verdicts_table").

    `scheduler`: None or "local" (a LocalCluster of `n_workers` processes, one thread each), an
    address ("tcp://host:8786") or a `dask.distributed.Client`. A partition holds whole tracks,
    about `rows_per_partition` rows. A rerun after an interruption resumes from the parts done
    (`resume`; `log` says so). `cache_dir`: the workers' compilation cache (None: the client's,
    "": none). `devices`: a count or "all" of each worker's devices (`classify_tracks`).
    `size`: rules 37 and 26 from the tracks' top rows (`track.looks.height_looks`; None:
    neither), on every worker and in the resume key. A single file whose tracks' rows are not
    contiguous cannot be partitioned: it is classified whole here, by `classify_source` (a note
    says so).

    Returns a summary: n_tracks, verdicts, reasons, labels (when labelled), notes, engine,
    partitions, parts, resumed_parts, workers (in the cluster), workers_used (that ran a task),
    timing (plan_s, cluster_s, classify_s: the wait for the partitions in order, write_s,
    assemble_s, worker_s: the tasks' own time summed, total_s). Raises the `BadInput` a worker
    met (the first in file order), as the single process does."""
    t0 = time.perf_counter()
    timing = dict.fromkeys(("plan_s", "cluster_s", "classify_s", "write_s", "assemble_s",
                            "worker_s"), 0.0)
    files = source_files(source)
    out = None if output is None else os.fspath(output)
    try:
        partitions = plan_partitions(files, rows_per_partition)
    except NotGrouped as e:
        if len(files) > 1:
            raise
        summary = classify_source(cfg, files[0], output, chunk=chunk,
                                  segment_rows=segment_rows, progress=progress, resume=resume,
                                  devices=devices, log=log, size=size)
        summary["notes"].insert(0, f"{e}: classified on this process, not the cluster")
        return summary
    if not partitions:  # no track: the single process writes the empty table
        return classify_source(cfg, files, output, chunk=chunk, segment_rows=segment_rows,
                               progress=False, resume=resume, devices=devices, log=log,
                               size=size)
    timing["plan_s"] = time.perf_counter() - t0
    dataset = out is not None and (out.endswith(("/", os.sep)) or os.path.isdir(out))
    parts = None
    if out is not None:
        parts = VerdictParts(out, dask_key(cfg, files, chunk=chunk, segment_rows=segment_rows,
                                           rows_per_partition=rows_per_partition, size=size),
                             dataset=dataset)
        msg = parts.open(resume=resume)
        if msg and log:
            log(msg)
    start = parts.resumed if parts is not None else 0
    done = Done(parts)
    cache = default_cache_dir() if cache_dir is None else (cache_dir or None)
    workers = 0
    try:
        t1 = time.perf_counter()
        todo = start < len(partitions)  # else every part was done before: no cluster needed
        with connect(scheduler, n_workers) if todo else contextlib.nullcontext() as client:
            workers = len(client.nthreads()) if todo else 0
            timing["cluster_s"] = time.perf_counter() - t1
            t2 = time.perf_counter()
            bar = progress_bar(len(partitions), start, progress)
            ordered = in_order(client, config_wire(cfg), partitions, start, chunk=chunk,
                               segment_rows=segment_rows, cache_dir=cache, devices=devices,
                               size=size)
            with contextlib.closing(ordered):
                for k, res in ordered:
                    t3 = time.perf_counter()
                    done.add(files[0], partitions[k], res)
                    timing["write_s"] += time.perf_counter() - t3
                    timing["worker_s"] += res["seconds"]
                    if bar is not None:
                        bar.update(1)
            if bar is not None:
                bar.close()
            timing["classify_s"] = time.perf_counter() - t2 - timing["write_s"]
    except BadInput:
        if parts is not None:
            parts.discard()
        raise
    except BaseException:
        if parts is not None:
            parts.discard_if_empty()
            if parts.done and log:
                log(f"{len(parts.done)} part(s) done kept in {parts.folder}: the same command "
                    "resumes from them")
        raise
    t4 = time.perf_counter()
    if parts is not None:
        if dataset:
            parts.finish()
        else:
            parts.assemble()
    timing["assemble_s"] = time.perf_counter() - t4
    timing["total_s"] = time.perf_counter() - t0
    summary = {**done.counts, "notes": done.notes, "engine": "dask",
               "partitions": len(partitions), "parts": len(partitions),
               "resumed_parts": start, "workers": workers, "workers_used": len(done.workers),
               "timing": {k: round(v, 3) for k, v in timing.items()}}
    if parts is None:
        summary["verdicts_table"] = concat_columns(done.kept)
    return summary


class Done:
    """The partitions done, in order: each written as the next part (or kept, with no output),
    its counts and notes added; the counts and notes of the parts an earlier run left, too."""

    def __init__(self, parts: VerdictParts | None) -> None:
        self.parts, self.kept, self.workers = parts, [], set()
        self.counts: dict = {}
        self.notes: list[str] = []
        self.labelled: bool | None = None
        for e in parts.done if parts is not None else []:
            self.counts = added(self.counts, e.get("summary", {}))
            self.note(e.get("notes", []))
            self.labelled = "label" in e.get("columns", [])

    def note(self, notes: list[str]) -> None:
        """Keep each note once."""
        self.notes += [n for n in notes if n not in self.notes]

    def add(self, first_file: str, partition: Partition, res: dict) -> None:
        """One partition's result (`run_partition`'s), in its turn."""
        cols = res["columns"]
        labelled = "label" in cols
        if self.labelled is not None and labelled != self.labelled:
            raise BadInput(first_file, "some of the files have a 'label' column and some not; "
                                       "give all or none")
        self.labelled = labelled
        summ = summarise(cols, cols.get("label"))
        self.counts = added(self.counts, summ)
        self.note(res["notes"])
        self.workers.add(res["worker"])
        if self.parts is None:
            self.kept.append(cols)
            return
        order = list(VERDICT_COLUMNS) + (["label"] if labelled else [])
        self.parts.write(cols, order, {
            "tracks": int(len(cols["track_id"])), "notes": res["notes"], "summary": summ,
            "partition": [partition.path, partition.row_start, partition.row_stop]})


def added(a: dict, b: dict) -> dict:
    """Counts `a` + `b`, nested dicts added key by key."""
    out = dict(a)
    for k, v in b.items():
        out[k] = added(out.get(k, {}), v) if isinstance(v, dict) else out.get(k, 0) + v
    return out


def in_order(client, wire: str, partitions: list[Partition], start: int, *, chunk: int,
             segment_rows: int, cache_dir: str | None,
             devices: int | str | None = None,
             size: SizeOptions | None = None) -> Iterator[tuple[int, dict]]:
    """Submit `run_partition` for partitions[start:] (earlier ones first) and yield (index,
    result) in partition order as they come in. A partition's `BadInput` is raised in its
    turn, after the partitions before it (so the error is the first in file order, as on one
    process); the partitions after it are cancelled at once. Closing the generator cancels
    what is still running."""
    if start >= len(partitions):
        return
    from dask.distributed import as_completed

    n, token = len(partitions), uuid.uuid4().hex[:8]
    futures = [client.submit(run_partition, wire, partitions[k], chunk=chunk,
                             segment_rows=segment_rows, cache_dir=cache_dir, devices=devices,
                             size=size, key=f"rhythmjax-partition-{k:06d}-{token}", priority=n - k)
               for k in range(start, n)]
    index = {f.key: start + i for i, f in enumerate(futures)}
    waiting: dict[int, dict] = {}
    nxt, stop = start, n
    try:
        for f in as_completed(futures):
            k = index[f.key]
            if k >= stop or f.cancelled():
                continue
            res = f.result()  # a task's other exception is raised here
            f.release()
            if "bad_input" in res:
                stop = k + 1
                client.cancel(futures[stop - start:])
            waiting[k] = res
            while nxt in waiting:
                res = waiting.pop(nxt)
                if "bad_input" in res:
                    raise bad_input_from(res["bad_input"])
                yield nxt, res
                nxt += 1
            if nxt >= stop:
                break
    finally:
        client.cancel(futures)


def concat_columns(parts: list[dict]) -> dict:
    """The parts' verdict columns (at least one part) as one table, in order."""
    return {k: np.concatenate([np.asarray(p[k]) for p in parts]) for k in parts[0]}


def progress_bar(total: int, done: int, enabled: bool):
    """A tqdm bar over the partitions on a terminal's stderr, else None."""
    if enabled and sys.stderr.isatty():
        from tqdm import tqdm

        return tqdm(total=total, initial=done, unit="part", desc="classify (dask)",
                    file=sys.stderr)
    return None

