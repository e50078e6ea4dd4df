"""Tables (CSV, Parquet) read strictly; the `BadInput` error.

Reading is validation at the edge (RELIABILITY.md sections 3 and 6): CSV is parsed by pyarrow with
every column as text and an `invalid_row_handler` that records the line of each row with the wrong
number of fields (the first data row and a truncated last row included); numbers are converted
here so that the first bad cell is reported with its line and column. Writing is
`io.table_write` (through `atomic_write`: a temp file beside the target that keeps the suffix,
fsync, then `os.replace`).
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from .atomic import (
    atomic_path as atomic_path,
    check_writable as check_writable,
    make_output_dir as make_output_dir,
)
from .errors import BadInput as BadInput, PathLike
from .text import is_text, map_text as map_text


TABLE_SUFFIXES = (".csv", ".parquet")
NULL_TOKENS = ("", "nan", "NaN", "NAN", "NA", "N/A", "null", "NULL", "None")
KINDS = ("float", "int", "id", "str")
KEY_SUFFIX = "#key"  # `convert_parquet`'s code columns: name + KEY_SUFFIX


# ----------------------------------------------------------------------------------------------
# Reading

class Table(dict):
    """Columns (name -> NumPy array) plus `lines`: the source line (CSV, header = 1) or row
    (Parquet, 1-based) of each row, and `unit` ("line" or "row")."""

    def __init__(self, cols: Mapping[str, np.ndarray], lines: np.ndarray, unit: str):
        super().__init__(cols)
        self.lines, self.unit = lines, unit

    def where(self, path: PathLike, i: int, column: str | None, message: str) -> BadInput:
        """A BadInput for row index `i` of this table."""
        n = int(self.lines[i])
        return BadInput(path, message, column=column,
                        **({"line": n} if self.unit == "line" else {"row": n}))


def table_suffix(path: PathLike) -> str:
    """The table format of `path` by its extension (".csv" or ".parquet"); any other is a
    `BadInput` naming it (checked before any work)."""
    return _table_suffix(os.fspath(path))


def _table_suffix(p: str) -> str:
    suffix = os.path.splitext(p)[1].lower()
    if suffix not in TABLE_SUFFIXES:
        raise BadInput(p, f"unsupported table format '{suffix or '(no extension)'}' "
                       "(use .csv or .parquet)")
    return suffix


def check_table_path(path: PathLike) -> str:
    """The suffix of the table file `path`; a `BadInput` for another suffix, a folder or no file."""
    p = os.fspath(path)
    suffix = _table_suffix(p)
    if os.path.isdir(p):
        raise BadInput(p, "is a directory, not a table file")
    if not os.path.exists(p):
        raise BadInput(p, "no such file")
    return suffix


def read_table(path: PathLike, required: Sequence[str] = (), optional: Sequence[str] = (), *,
               types: Mapping[str, str] | None = None, not_empty: Sequence[str] = ()) -> Table:
    """Read a `.csv` or `.parquet` table strictly; raise `BadInput` naming the file and location.

    `types` maps a column to "float" (empty cell / null -> NaN), "int", "id" (integer or text,
    returned as text) or "str"; columns without a type are inferred (CSV: int, then float, else
    text). Columns in `not_empty` must have a value in every row. With `required` or `optional`
    given, only those columns are returned (unknown extra columns are ignored)."""
    p, suffix = os.fspath(path), check_table_path(path)
    types = dict(types or {})
    if not set(types.values()) <= set(KINDS):
        raise ValueError(f"unknown column type in {types} (use {KINDS})")
    try:
        if suffix == ".csv":
            return _read_csv(p, tuple(required), tuple(optional), types, set(not_empty))
        return _read_parquet(p, tuple(required), tuple(optional), types, set(not_empty))
    except PermissionError as e:
        raise BadInput(p, f"cannot read: {e.strerror}") from None


def select_columns(p: str, names: list[str], required, optional) -> list[str]:
    missing = [c for c in required if c not in names]
    if missing:
        found = ", ".join(names) if names else "no columns"
        hint = ""
        lower = {n.lower(): n for n in names}
        if missing[0].lower() in lower:
            hint = f"; '{lower[missing[0].lower()]}' differs only in case"
        raise BadInput(p, f"missing column '{missing[0]}' (found: {found}){hint}")
    if not required and not optional:
        return list(names)
    return [c for c in (*required, *optional) if c in names]


def csv_header(p: str) -> list[str]:
    with open(p, "rb") as f:
        head = f.read(1 << 16)
    text = head.decode("utf-8-sig", errors="replace")
    if not text.strip():
        raise BadInput(p, "empty file (no header)")
    first = text.splitlines()[0]
    if not first.strip():
        raise BadInput(p, "the header line is empty (the column names must be on line 1)",
                       line=1)
    raw = next(csv.reader([first]))
    if len(raw) == 1:
        for sep, word in ((";", "';'"), ("\t", "tab"), ("|", "'|'")):
            if sep in raw[0]:
                raise BadInput(p, f"1 column named {raw[0][:60]!r}; the file looks "
                               f"{word}-separated (use ',')", line=1)
    seen: set[str] = set()
    for name in raw:
        if name.strip() in seen:
            raise BadInput(p, f"column '{name.strip()}' appears twice in the header", line=1)
        seen.add(name.strip())
    return raw


def csv_options(raw: list[str], on_bad_row) -> dict:
    """The pyarrow CSV options of a strict read: every column as text, `on_bad_row` recording
    each row with the wrong number of fields, empty lines kept (their line numbers count)."""
    return dict(parse_options=pacsv.ParseOptions(invalid_row_handler=on_bad_row,
                                                 ignore_empty_lines=False),
                convert_options=pacsv.ConvertOptions(
                    column_types={n: pa.string() for n in raw}, strings_can_be_null=False,
                    quoted_strings_can_be_null=False))


def blank_rows(cols: Mapping[str, Any], n: int) -> np.ndarray:
    """Rows whose every cell is empty (blank lines), dropped by the readers."""
    blank = np.ones(n, bool)
    for c in cols.values():
        blank &= np.asarray(pc.equal(c, "").to_numpy(zero_copy_only=False), bool)
    return blank


def bad_rows_error(p: str, bad: list[tuple[int, int, int]], last: int) -> BadInput:
    """The error for rows with the wrong number of fields: `bad` (line, expected, actual) as
    the invalid-row handler saw them; `last` the last line holding values (for the hint)."""
    number, expected, actual = bad[0]
    hint = " (file truncated?)" if actual < expected and number > last else ""
    more = ""
    if len(bad) > 1:
        shown = ", ".join(str(b[0]) for b in bad[1:4]) + (", ..." if len(bad) > 4 else "")
        more = f"; {len(bad)} such rows, also line(s) {shown}"
    return BadInput(p, f"expected {expected} fields, saw {actual}{hint}{more}", line=number)


def convert_csv(p: str, cols: Mapping[str, Any], lines: np.ndarray, keep, types,
                not_empty) -> Table:
    """The `keep` columns of text `cols` (blank rows already dropped) converted by `types`;
    `lines` each row's line. Raises `BadInput` for the earliest bad cell."""
    table = Table({}, lines, "line")
    results = {n: _csv_column(cols[n], n, types.get(n), n in not_empty) for n in keep}
    _raise_first(p, table, results)
    table.update(results)
    return table


def csv_parse_error(p: str, e: pa.ArrowInvalid) -> BadInput | None:
    """The `BadInput` for pyarrow's CSV parse error `e` on file `p` (text that is not UTF-8, a
    malformed row); None for a file with a header and no data rows (pyarrow's "cannot infer the
    number of columns" or "Empty CSV"), which the caller reads as empty."""
    msg = str(e)
    if "cannot infer number of columns" in msg or "Empty CSV" in msg:  # header, no newline
        return None
    if "UTF8" in msg:
        return BadInput(p, f"not UTF-8 text ({msg.splitlines()[0]})")
    return BadInput(p, f"cannot parse as CSV: {msg.splitlines()[0]}")


class CsvSetup(NamedTuple):
    """What a CSV reader needs before its first row: the header as written (`raw`) and
    stripped (`names`), the columns kept, the list the bad rows go to and pyarrow's
    `invalid_row_handler` that fills it (row number, columns expected, columns found)."""
    raw: list[str]
    names: list[str]
    keep: list[str]
    bad: list[tuple[int, int, int]]
    on_bad_row: Any


def csv_setup(p: str, required, optional) -> CsvSetup:
    """The header of CSV file `p` read and checked (`select_columns`), and a bad-row recorder:
    shared by the whole-file and the streaming readers."""
    raw = csv_header(p)
    names = [n.strip() for n in raw]
    bad: list[tuple[int, int, int]] = []

    def on_bad_row(row) -> str:
        bad.append((row.number, row.expected_columns, row.actual_columns))
        return "skip"

    return CsvSetup(raw, names, select_columns(p, names, required, optional), bad, on_bad_row)


def _read_csv(p: str, required, optional, types, not_empty) -> Table:
    raw, names, keep, bad, on_bad_row = csv_setup(p, required, optional)

    try:
        tbl = pacsv.read_csv(p, read_options=pacsv.ReadOptions(use_threads=False),
                             **csv_options(raw, on_bad_row))
    except pa.ArrowInvalid as e:
        err = csv_parse_error(p, e)
        if err is not None:
            raise err from None
        tbl = pa.table({n: pa.array([], pa.string()) for n in raw})
    total = tbl.num_rows + len(bad)
    good = np.ones(total, bool)
    good[[b[0] - 2 for b in bad]] = False
    lines = np.arange(2, 2 + total, dtype=np.int64)[good]
    cols = {n: tbl.column(r) for n, r in zip(names, raw, strict=True)}
    blank = blank_rows(cols, tbl.num_rows)  # blank lines read as rows of empty cells: drop them
    if bad:
        raise bad_rows_error(p, bad, int(lines[~blank].max()) if (~blank).any() else 1)
    if blank.any():
        cols = {n: c.filter(pa.array(~blank)) for n, c in cols.items()}
        lines = lines[~blank]
    return convert_csv(p, cols, lines, keep, types, not_empty)


def _raise_first(p: str, table: Table, results: dict) -> None:
    """Raise for the earliest bad cell (by row, then column order) among the converted columns."""
    errors = [(v[0], i, n, v[1]) for i, (n, v) in enumerate(results.items())
              if isinstance(v, tuple)]
    if errors:
        r, _, n, msg = min(errors)
        raise table.where(p, r, n, msg)


def _first(mask: np.ndarray) -> int | None:
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def _csv_column(col: pa.Array | pa.ChunkedArray, name: str, kind: str | None, required: bool):
    """Convert one text column. Returns an array, or (row index, message) for the first bad cell."""
    if isinstance(col, pa.ChunkedArray):
        col = col.combine_chunks()
    text = pc.utf8_trim_whitespace(col)
    null_mask = pc.is_in(text, value_set=pa.array(NULL_TOKENS))
    null = np.asarray(null_mask.to_numpy(zero_copy_only=False), bool)
    clean = pc.if_else(null_mask, pa.scalar(None, pa.string()), text)  # null tokens -> null
    if kind is None:
        kind = _infer(clean, null)
    if required or kind == "int":
        i = _first(null)
        if i is not None:
            s = text[i].as_py()
            return i, f"{'empty cell' if s == '' else repr(s)}: a value is required in every row"
    if kind in ("id", "str"):
        return np.asarray(text.to_numpy(zero_copy_only=False), dtype=object)
    target = pa.int64() if kind == "int" else pa.float64()
    try:
        out = pc.cast(clean, target).to_numpy(zero_copy_only=False)
        return out.astype(np.int64 if kind == "int" else np.float64)
    except pa.ArrowInvalid:
        return _slow_numbers(np.asarray(text.to_numpy(zero_copy_only=False), dtype=object),
                             null, kind)


def _infer(clean: pa.Array, null: np.ndarray) -> str:
    for kind, target in (("int", pa.int64()), ("float", pa.float64())):
        try:
            if not (kind == "int" and null.any()):
                pc.cast(clean, target)
                return kind
        except pa.ArrowInvalid:
            pass
    return "str"


def _slow_numbers(values: np.ndarray, null: np.ndarray, kind: str):
    out = np.empty(len(values), np.int64 if kind == "int" else np.float64)
    for i, (s, isnull) in enumerate(zip(values, null, strict=True)):
        if isnull:
            out[i] = np.nan
            continue
        try:
            if "_" in s:
                raise ValueError
            x = float(s)
        except ValueError:
            return i, f"{s!r} is not a number"
        if kind == "int":
            if not (math.isfinite(x) and x == int(x)):
                return i, f"{s!r} is not an integer"
            if abs(x) >= 2.0 ** 63:
                return i, f"{s!r} is out of range (at most 2^63 in size)"
            x = int(x)
        out[i] = x
    return out


def _read_parquet(p: str, required, optional, types, not_empty) -> Table:
    import pyarrow.parquet as pq

    try:
        pf = pq.ParquetFile(p)
        names = list(pf.schema_arrow.names)
        keep = select_columns(p, names, required, optional)
        tbl = pf.read(columns=keep)
    except (pa.ArrowException, OSError) as e:
        if isinstance(e, PermissionError):
            raise
        raise BadInput(p, "not a valid Parquet file (truncated?)") from None
    return convert_parquet(p, tbl, np.arange(1, tbl.num_rows + 1, dtype=np.int64), keep,
                           types, not_empty)


def convert_parquet(p: str, tbl, rows: np.ndarray, keep, types, not_empty,
                    keys: Sequence[str] = ()) -> Table:
    """The `keep` columns of the Arrow table or record batch `tbl` converted by `types`; `rows`
    each row's 1-based row in the file. Raises `BadInput` for the earliest bad cell. For each
    text column named in `keys`, also a column `name + KEY_SUFFIX`: int64 codes equal where the
    converted values are (within this table), so runs of equal values are found without
    comparing strings. A text column stored dictionary-encoded is read through its dictionary
    (each distinct value converted once)."""
    table = Table({}, rows, "row")
    results, codes = {}, {}
    for n in keep:
        col = tbl.column(n)
        col = col.combine_chunks() if isinstance(col, pa.ChunkedArray) else col
        if pa.types.is_dictionary(col.type) and not is_text(col.type.value_type):
            col = col.dictionary_decode()
        results[n] = _parquet_column(p, col, n, types.get(n), n in not_empty, codes)
    _raise_first(p, table, results)
    table.update(results)
    table.update({n + KEY_SUFFIX: codes[n] for n in keys if n in codes})
    return table


def _parquet_column(p: str, col: pa.Array, name: str, kind: str | None, required: bool,
                    codes: dict):
    t = col.type.value_type if pa.types.is_dictionary(col.type) else col.type
    text = is_text(t)
    is_int = pa.types.is_integer(t)
    is_num = is_int or pa.types.is_floating(t) or pa.types.is_decimal(t)
    if kind is None:
        if not (is_num or text):  # e.g. bool or timestamp: no conversion asked for
            return col.to_numpy(zero_copy_only=False)
        kind = "int" if is_int and not col.null_count else "float" if is_num else "str"
    ok = {"float": is_num, "int": is_num, "id": is_num or text, "str": text}[kind]
    if not ok:
        expected = {"float": "float", "int": "integer", "id": "integer or string",
                    "str": "string"}[kind]
        raise BadInput(p, f"column '{name}' has type {t}, expected {expected}")
    null = np.asarray(col.is_null().to_numpy(zero_copy_only=False), bool)
    if text:
        values, key = map_text(col.fill_null(""), str.strip, codes=True)
        # the codes follow the sorted distinct values: "" (an empty cell) is code 0 if present
        zero = np.flatnonzero(key == 0)
        if zero.size and values[zero[0]] == "":
            null |= key == 0
        codes[name] = key
    else:
        values = col.cast(pa.float64()).to_numpy(zero_copy_only=False)
        null |= np.isnan(values)
    if (required or kind in ("int", "id")) and null.any():
        return _first(null), "empty cell: a value is required in every row"
    if kind == "str":
        return values
    if kind == "float":
        return np.asarray(values, np.float64)
    if text:  # id given as text
        return values
    if is_int:
        ints = col.cast(pa.int64()).to_numpy(zero_copy_only=False)
    else:
        frac = ~np.isfinite(values) | (values != np.round(values))
        if frac.any():
            i = _first(frac)
            return i, f"{float(values[i])!r} is not an integer"
        big = np.abs(values) >= 2.0 ** 63
        if big.any():
            i = _first(big)
            return i, f"{float(values[i])!r} is out of range (at most 2^63 in size)"
        ints = values.astype(np.int64)
    return ints if kind == "int" else np.asarray([str(v) for v in ints.tolist()], dtype=object)
