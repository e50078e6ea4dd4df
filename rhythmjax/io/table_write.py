"""Tables (CSV, Parquet) written atomically: `write_table` (the extension picks the format) and
`arrow_table` (the Arrow table it writes, for writers of Parquet parts). NaN is written as null
(an empty CSV cell), so `io.tables.read_table` reads it back as NaN."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from .atomic import atomic_write
from .errors import PathLike
from .tables import table_suffix


def _arrow_column(name: str, a: Any) -> pa.Array:
    a = np.asarray(a)
    if a.ndim != 1:
        raise ValueError(f"column {name!r} must be one-dimensional, got shape {a.shape}")
    if a.dtype.kind in "US":
        return pa.array(a.astype(str).tolist(), pa.string())
    return pa.array(a, from_pandas=True)  # NaN (float or object) -> null


def arrow_table(columns: Mapping[str, Any], order: Sequence[str]) -> pa.Table:
    """`columns` in `order` as the Arrow table `write_table` writes (NaN as null)."""
    arrays = [_arrow_column(n, columns[n]) for n in order]
    if len({len(a) for a in arrays}) > 1:
        raise ValueError(f"write_table: columns differ in length: "
                         f"{ {n: len(a) for n, a in zip(order, arrays, strict=True)} }")
    return pa.Table.from_arrays(arrays, names=list(order))


def write_table(path: PathLike, columns: Mapping[str, Any], order: Sequence[str]) -> None:
    """Write `columns` in `order` as CSV (UTF-8, header, NaN as an empty cell) or Parquet (NaN as
    null), chosen by the extension, atomically."""
    p = os.fspath(path)
    suffix = table_suffix(p)
    missing = [n for n in order if n not in columns]
    if missing:
        raise ValueError(f"write_table: no column {missing[0]!r} to write")
    table = arrow_table(columns, order)
    with atomic_write(p, "wb") as f:
        if suffix == ".csv":
            pacsv.write_csv(table, f, pacsv.WriteOptions(quoting_style="needed"))
        else:
            import pyarrow.parquet as pq

            pq.write_table(table, f)
