"""Tracks files read by record batches, cells converted and checked as `read_table` does.

A file is read `batch_rows` rows at a time: CSV through pyarrow's streaming CSV reader (every
column as text, bad rows recorded, blank lines dropped, as `io.tables` reads a whole file),
Parquet by record batches of the row groups that hold the rows asked for. Each batch is a `Table`
whose `lines` are the file's own line (CSV, header = 1) or row (Parquet, 1-based) numbers, so the
messages of `io.files.validated_tracks` name the same places as for the whole file.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from .errors import BadInput, PathLike
from .files import OPTIONAL_TRACK_COLUMNS, TRACK_COLUMNS, TRACK_NOT_EMPTY, TRACK_TYPES
from .tables import (
    Table,
    bad_rows_error,
    blank_rows,
    check_table_path,
    convert_csv,
    convert_parquet,
    csv_options,
    csv_parse_error,
    csv_setup,
    select_columns,
)


BATCH_ROWS = 1 << 16  # rows per record batch read


def source_files(source: PathLike | Sequence[PathLike]) -> list[str]:
    """The tracks files of `source`: a file, a list of files, or a folder (its .parquet files,
    else its .csv files, in sorted path order, at any depth as in a Hive-partitioned dataset;
    names starting with '.' or '_' left out, as pyarrow.dataset does). `BadInput` for none."""
    if isinstance(source, (list, tuple)):
        files = [os.fspath(s) for s in source]
    else:
        p = os.fspath(source)
        files = _folder_files(p) if os.path.isdir(p) else [p]
    for f in files:
        check_table_path(f)
    return files


def _folder_files(p: str) -> list[str]:
    found: dict[str, list[str]] = {".parquet": [], ".csv": []}
    for d, dirs, names in os.walk(p):
        dirs[:] = sorted(x for x in dirs if not x.startswith((".", "_")))
        for n in names:
            ext = os.path.splitext(n)[1].lower()
            if ext in found and not n.startswith((".", "_")):
                found[ext].append(os.path.join(d, n))
    files = sorted(found[".parquet"]) or sorted(found[".csv"])
    if not files:
        raise BadInput(p, "the folder holds no .parquet or .csv tracks file")
    return files


def fingerprint(files: Sequence[str]) -> list[dict]:
    """Each file's absolute path, size and modification time (ns): what a resumed run checks."""
    out = []
    for f in files:
        st = os.stat(f)
        out.append({"path": os.path.abspath(f), "size": st.st_size, "mtime_ns": st.st_mtime_ns})
    return out


# ----------------------------------------------------------------------------------------------
def read_batches(path: PathLike, *, batch_rows: int = BATCH_ROWS, row_start: int = 0,
                 row_stop: int | None = None, columns: Sequence[str] | None = None
                 ) -> Iterator[Table]:
    """The rows [row_start, row_stop) of a tracks file, `batch_rows` at a time (CSV: about that
    many), as converted `Table`s whose `lines` are the file's lines (CSV) or rows (Parquet);
    `columns` (default: the tracks columns) must be present. Raises `BadInput` as `read_table`."""
    p = os.fspath(path)
    suffix = check_table_path(p)
    if columns is None:
        # the tracker's `state` is for selfcal and people, not the classifier: not streamed
        required = TRACK_COLUMNS
        optional = tuple(c for c in OPTIONAL_TRACK_COLUMNS if c != "state")
    else:
        required, optional = tuple(columns), ()
    types = {k: v for k, v in TRACK_TYPES.items() if k in (*required, *optional)}
    not_empty = set(TRACK_NOT_EMPTY) & set(required)
    read = _csv_batches if suffix == ".csv" else _parquet_batches
    try:
        yield from read(p, required, optional, types, not_empty, batch_rows, row_start,
                        row_stop)
    except PermissionError as e:
        raise BadInput(p, f"cannot read: {e.strerror}") from None


def _parquet_batches(p, required, optional, types, not_empty, batch_rows, start, stop):
    import pyarrow.parquet as pq

    def broken():
        return BadInput(p, "not a valid Parquet file (truncated?)")

    try:
        pf = pq.ParquetFile(p, pre_buffer=False)  # pre-buffered row groups stay in memory
        keep = select_columns(p, list(pf.schema_arrow.names), required, optional)
        # text columns as their dictionary's indices (each distinct value converted once)
        text = [n for n in keep if pa.types.is_string(pf.schema_arrow.field(n).type)]
        if text:
            pf = pq.ParquetFile(p, pre_buffer=False, read_dictionary=text)
        md = pf.metadata
        bounds = np.r_[0, np.cumsum([md.row_group(i).num_rows
                                     for i in range(md.num_row_groups)])].astype(np.int64)
    except (pa.ArrowException, OSError) as e:
        if isinstance(e, PermissionError):
            raise
        raise broken() from None
    stop = int(bounds[-1]) if stop is None else min(int(stop), int(bounds[-1]))
    groups = [i for i in range(len(bounds) - 1) if bounds[i + 1] > start and bounds[i] < stop]
    if not groups:
        return
    row = int(bounds[groups[0]])
    batches = (rb for g in groups for rb in pf.iter_batches(
        batch_size=batch_rows, row_groups=[g], columns=keep, use_threads=False))
    while row < stop:
        try:
            rb = next(batches)
        except StopIteration:
            break
        except (pa.ArrowException, OSError) as e:
            if isinstance(e, PermissionError):
                raise
            raise broken() from None
        n = rb.num_rows
        lo, hi = max(start - row, 0), min(stop - row, n)
        if hi > lo:
            yield convert_parquet(p, rb.slice(lo, hi - lo),
                                  np.arange(row + lo + 1, row + hi + 1, dtype=np.int64), keep,
                                  types, not_empty, keys=("track_id", "label"))
        row += n


def _csv_block_size(p: str, batch_rows: int) -> int:
    """Bytes per CSV block for about `batch_rows` rows (from the first 64 KiB); at least 1 MiB
    (a block must hold the longest row) unless `batch_rows` is small (tests)."""
    with open(p, "rb") as f:
        head = f.read(1 << 16)
    lines = head.split(b"\n")
    per_row = max(8.0, len(head) / max(1, len(lines) - 1))
    floor = (1 << 20) if batch_rows >= 4096 else 16 * max(len(x) for x in lines) + 1024
    return int(min(1 << 28, max(floor, batch_rows * per_row)))


def _csv_batches(p, required, optional, types, not_empty, batch_rows, start, stop):
    raw, names, keep, bad, on_bad_row = csv_setup(p, required, optional)

    opts = pacsv.ReadOptions(use_threads=False, block_size=_csv_block_size(p, batch_rows))
    try:
        reader = pacsv.open_csv(p, read_options=opts, **csv_options(raw, on_bad_row))
    except pa.ArrowInvalid as e:
        err = csv_parse_error(p, e)
        if err is None:
            return
        raise err from None
    row, last = 0, -1  # data rows read; index of the last row holding values
    while stop is None or row < stop:
        try:
            rb = reader.read_next_batch()
        except StopIteration:
            break
        except pa.ArrowInvalid as e:
            err = csv_parse_error(p, e)
            if err is None:
                break
            raise err from None
        n = rb.num_rows
        cols = {nm: rb.column(r) for nm, r in zip(names, raw, strict=True)}
        blank = blank_rows(cols, n)
        if (~blank).any():
            last = row + int(np.flatnonzero(~blank)[-1])
        if bad:
            raise _bad_rows(p, reader, bad, names, raw, row + n, last)
        lo, hi = max(start - row, 0), n if stop is None else min(stop - row, n)
        if hi > lo:
            keep_rows = ~blank[lo:hi]
            sub = {nm: cols[nm].slice(lo, hi - lo) for nm in keep}
            if not keep_rows.all():
                mask = pa.array(keep_rows)
                sub = {nm: c.filter(mask) for nm, c in sub.items()}
            lines = np.arange(row + lo + 2, row + hi + 2, dtype=np.int64)[keep_rows]
            yield convert_csv(p, sub, lines, keep, types, not_empty)
        row += n


def _bad_rows(p, reader, bad, names, raw, row, last) -> BadInput:
    """The error for rows with the wrong number of fields, worded as `read_table` words it: the
    rest of the file is read (parsed only) for the count and the last line holding values."""
    while True:
        try:
            rb = reader.read_next_batch()
        except (StopIteration, pa.ArrowInvalid):
            break
        blank = blank_rows({nm: rb.column(r) for nm, r in zip(names, raw, strict=True)},
                           rb.num_rows)
        if (~blank).any():
            last = row + int(np.flatnonzero(~blank)[-1])
        row += rb.num_rows
    line = 1 if last < 0 else last + 2  # the last data row's line, skipped bad rows counted
    for b in sorted(x[0] for x in bad):
        if b <= line:
            line += 1
    return bad_rows_error(p, bad, line)
