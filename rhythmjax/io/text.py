"""Text columns read through a dictionary: each distinct value converted once (`map_text`)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa


def map_text(col: Any, f, codes: bool = False):
    """`f` (a str -> str function) of each cell of the text column `col` (an Arrow array,
    dictionary-encoded or not, or a sequence of str; no nulls) as an object array, `f` called
    once per distinct value; with `codes`, also int64 codes equal where the results are."""
    enc = pa.array(col, pa.string()).dictionary_encode() if not isinstance(col, pa.Array) \
        else col if pa.types.is_dictionary(col.type) else col.dictionary_encode()
    idx = np.asarray(enc.indices.to_numpy(zero_copy_only=False), np.int64)
    used = np.flatnonzero(np.bincount(idx, minlength=len(enc.dictionary)))
    done = np.empty(len(enc.dictionary) + 1, dtype=object)
    done[used] = [f(s) for s in enc.dictionary.take(pa.array(used)).to_pylist()]
    done[-1] = ""
    if not codes:
        return done[idx]
    key = np.zeros(len(done), np.int64)
    key[used] = np.unique(done[used], return_inverse=True)[1].reshape(-1)
    return done[idx], key[idx]


def is_text(t) -> bool:
    """Whether the Arrow type `t` holds text (string, large_string, string_view)."""
    return pa.types.is_string(t) or pa.types.is_large_string(t) or str(t) == "string_view"
