"""Tracks files read by record batches, as blocks of whole tracks (streaming classification).

A file, a list of files or a folder of them is read `batch_rows` rows at a time (`io.batches`:
CSV through pyarrow's streaming CSV reader, Parquet a row group at a time), each record batch
converted and checked cell by cell as `io.files.read_tracks` does, with the file's own line
(CSV) or row (Parquet) numbers, and cut at track boundaries with NumPy: the tracks it
completes go on, the last one (which may go on in the next batch) is carried over. Whole tracks
are handed out in blocks of `block_tracks` tracks or `block_rows` rows, whichever comes first
(the same blocks whatever the record batch size, so a resumed run cuts the same parts), and a
block is validated with `io.files.validated_tracks` (the same `BadInput`s; the median-based unit
checks and notes see one block, not the whole file).

A track's rows must be contiguous (rows within a track may be in any frame order: sorted per
block). A track id that comes back after other tracks raises `NotGrouped` (a `BadInput`); the
driver then reads that file whole (`stream.classify`). Ids met are kept as 64-bit hashes (8 bytes
a track); a hash collision would only send a file to the whole-file path.

Memory: the carried track, the pending tracks (< one block + one record batch) and the block
being cut; nothing grows with the file but the hashes.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from .batches import (
    BATCH_ROWS,
    fingerprint as fingerprint,
    read_batches,
    source_files as source_files,
)
from .errors import BadInput, PathLike
from .files import TRACK_KEY, Tracks, run_key, validated_tracks
from .tables import KEY_SUFFIX, Table


BLOCK_TRACKS = 4096  # whole tracks per block, at most
BLOCK_ROWS = 1 << 19  # rows per block, at most (unless one track is longer)


@dataclass(frozen=True)
class Partition:
    """Rows [row_start, row_stop) (0-based data rows; for CSV the rows pyarrow reads, blank lines
    included) of the tracks file `path`, holding whole tracks. Picklable: the unit of work a
    scheduler hands out (`plan_partitions`)."""

    path: str
    row_start: int
    row_stop: int


class NotGrouped(BadInput):
    """A track's rows are not contiguous: its id comes back after other tracks."""


# ----------------------------------------------------------------------------------------------
class _Seen:
    """64-bit hashes of the track ids met so far, as sorted runs whose lengths at least double
    from the newest to the oldest (a run is merged into the one before it once it is as long),
    so a lookup costs a binary search per run (about log2 of the ids met) and each hash is
    sorted again about log2 times in all: the work per id does not grow with the file."""

    def __init__(self) -> None:
        self.runs: list[np.ndarray] = []

    def add(self, ids: np.ndarray) -> int | None:
        """Add the ids of tracks that just began; the index of the first one met before (or twice
        among them), else None."""
        h = np.fromiter(map(hash, ids), np.int64, len(ids))
        if not len(h):
            return None
        _, first = np.unique(h, return_index=True)
        hit = np.ones(len(h), bool)
        hit[first] = False
        for run in self.runs:
            pos = np.minimum(np.searchsorted(run, h), len(run) - 1)
            hit |= run[pos] == h
        if hit.any():
            return int(np.flatnonzero(hit)[0])
        self.runs.append(np.sort(h))
        while len(self.runs) > 1 and 2 * len(self.runs[-1]) > len(self.runs[-2]):
            last = self.runs.pop()
            self.runs[-1] = np.sort(np.concatenate([self.runs[-1], last]))
        return None


def _refuse_repeats(p: str, tab: Table, seen: _Seen, new: np.ndarray) -> None:
    """Record the ids of the tracks beginning at rows `new` of `tab`; `NotGrouped` naming the
    row and the track when one was met before (its rows are not contiguous)."""
    if not new.size:
        return
    i = seen.add(tab["track_id"][new])
    if i is not None:
        k = int(new[i])
        raise NotGrouped(p, f"rows are not contiguous: the id comes back at {tab.unit} "
                         f"{int(tab.lines[k])} after other tracks' rows",
                         track_id=str(tab["track_id"][k]), **_where(p, tab, k))


def _slice(tab: Table, a: int, b: int | None = None) -> Table:
    return Table({k: v[a:b] for k, v in tab.items()}, tab.lines[a:b], tab.unit)


def _concat(tabs: list[Table]) -> Table:
    if len(tabs) == 1:
        return tabs[0]
    return Table({k: np.concatenate([t[k] for t in tabs]) for k in tabs[0]},
                 np.concatenate([t.lines for t in tabs]), tabs[0].unit)


def _runs(tid: np.ndarray) -> np.ndarray:
    """The first row of each run of equal ids (or of their codes, `run_key`)."""
    return np.flatnonzero(np.r_[True, tid[1:] != tid[:-1]]) if len(tid) else np.zeros(0, int)


def _where(p: str, tab: Table, i: int) -> dict:
    return {"line": int(tab.lines[i])} if tab.unit == "line" else {"row": int(tab.lines[i])}


class _Pending:
    """Whole tracks read but not yet handed out: pieces (joined only when a block is cut) and
    how many tracks and rows they hold."""

    def __init__(self) -> None:
        self.pieces: list[Table] = []
        self.tracks = 0
        self.rows = 0

    def add(self, pieces: list[Table], tracks: int) -> None:
        self.pieces += pieces
        self.tracks += tracks
        self.rows += sum(len(t.lines) for t in pieces)

    def cut(self, block_tracks: int, block_rows: int, *, final: bool) -> Iterator[Table]:
        """Hand out the blocks the pending tracks complete: each the fewest leading tracks
        that reach `block_tracks` tracks or `block_rows` rows; with `final` the rest too."""
        if not self.pieces or not final and self.tracks < block_tracks and \
                self.rows < block_rows:
            return
        rest = _concat(self.pieces)
        self.pieces, self.tracks, self.rows = [], 0, 0
        while len(rest.lines):
            ends = np.r_[_runs(run_key(rest))[1:], len(rest.lines)]
            k = min(block_tracks, int(np.searchsorted(ends, block_rows)) + 1)
            if k > len(ends):
                if not final:
                    self.add([rest], len(ends))
                    return
                k = len(ends)
            e = int(ends[k - 1])
            yield _slice(rest, 0, e)
            rest = _slice(rest, e)


def _file_blocks(p: str, tables: Iterator[Table], seen: _Seen, block_tracks: int,
                 block_rows: int) -> Iterator[Table]:
    """Blocks of whole tracks (rows in file order) of one file's record batches."""
    carry: list[Table] = []  # rows of the last track, which may go on in the next batch
    pending = _Pending()
    base = 0  # the ids' codes (`TRACK_KEY`) of each batch moved past the earlier batches'
    for tab in tables:
        n = len(tab.lines)
        if not n:
            continue
        tid = tab["track_id"]
        cont = bool(carry) and tid[0] == carry[0]["track_id"][0]
        for k in [k for k in tab if k.endswith(KEY_SUFFIX)]:  # codes unique to this batch
            tab[k] = tab[k] + base
        base += n
        if cont and TRACK_KEY in tab:  # the carried track's code goes on
            key = tab[TRACK_KEY]
            key[key == key[0]] = carry[0][TRACK_KEY][0]
        starts = _runs(run_key(tab))
        new = starts[1:] if cont else starts
        _refuse_repeats(p, tab, seen, new)
        if cont and len(starts) == 1:
            carry.append(tab)
            continue
        last = int(starts[-1])
        # the carried track (ended here, or going on in this batch's first run) and the
        # tracks this batch ends
        tracks = bool(carry) + len(starts) - 1 - cont
        pending.add(carry + ([_slice(tab, 0, last)] if last else []), tracks)
        carry = [_slice(tab, last)]
        yield from pending.cut(block_tracks, block_rows, final=False)
    pending.add(carry, bool(carry))
    yield from pending.cut(block_tracks, block_rows, final=True)


def iter_blocks(source: PathLike | Sequence[PathLike] | Partition, *,
                block_tracks: int = BLOCK_TRACKS, block_rows: int = BLOCK_ROWS,
                batch_rows: int = BATCH_ROWS) -> Iterator[tuple[str, Table]]:
    """(file, block) for the blocks of whole tracks of `source` (files, or one `Partition`),
    in file order, cells converted and checked, not yet validated as tracks (see
    `validated_tracks`). A track id met twice raises `NotGrouped`; a track does not go on from
    one file into the next."""
    if isinstance(source, Partition):
        parts = [(source.path, source.row_start, source.row_stop)]
    else:
        parts = [(f, 0, None) for f in source_files(source)]
    seen = _Seen()
    for p, a, b in parts:
        tables = read_batches(p, batch_rows=batch_rows, row_start=a, row_stop=b)
        for block in _file_blocks(p, tables, seen, block_tracks, block_rows):
            yield p, block


def read_blocks(source, *, fps: float | int | None = None, **kw) -> Iterator[Tracks]:
    """`iter_blocks` validated: each block a `Tracks` (rows sorted by frame within a track)."""
    for p, block in iter_blocks(source, **kw):
        yield validated_tracks(p, block, fps=fps, grouped=True)


# ----------------------------------------------------------------------------------------------
def by_length(tracks: Tracks, chunk: int, segment_rows: int, min_len: int = 1
              ) -> tuple[list[Tracks], np.ndarray]:
    """The tracks in groups to pad and classify apart, so that a short track is not padded far
    beyond its length: those spanning at most `segment_rows` frames by padded length class (the
    power of two >= max(span, min_len), as `to_batch` pads), classes taken shortest first and
    joined while the group's padded cells stay within twice its rows, or it holds fewer than
    `chunk` tracks (few, large calls: the kernel orders a call's tracks by length itself); then
    each longer track on its own (as `Tracks.by_span`). Returns the groups and `order`: the
    tracks' indices (file order) in the order the groups hold them."""
    frame = tracks.frame
    starts = _runs(run_key(tracks))
    if not len(starts):
        return [], np.zeros(0, np.int64)
    ends = np.r_[starts[1:], len(frame)]
    rows = ends - starts
    span = frame[ends - 1] - frame[starts] + 1
    short = np.flatnonzero(span <= segment_rows)
    cls = np.ceil(np.log2(np.maximum(np.maximum(span[short], min_len), 1))).astype(np.int64)
    short = short[np.argsort(cls, kind="stable")]  # by class, file order within a class
    cls = np.sort(cls, kind="stable")
    groups: list[np.ndarray] = []
    a = n = r = 0  # the open group: first index, tracks, rows
    for c in np.unique(cls):
        lo, hi = int(np.searchsorted(cls, c)), int(np.searchsorted(cls, c, side="right"))
        rc = int(rows[short[lo:hi]].sum())
        if n >= chunk and (n + hi - lo) << int(c) > 2 * (r + rc):
            groups.append(short[a:lo])
            a, n, r = lo, 0, 0
        n, r = n + hi - lo, r + rc
    if a < len(short):
        groups.append(short[a:])
    groups += [np.asarray([i]) for i in np.flatnonzero(span > segment_rows)]
    out = []
    for g in groups:
        k = rows[g]
        idx = np.repeat(starts[g] - np.r_[0, np.cumsum(k)[:-1]], k) + np.arange(int(k.sum()))
        out.append(tracks.take(idx))
    return out, np.concatenate(groups)


# ----------------------------------------------------------------------------------------------
def plan_partitions(source: PathLike | Sequence[PathLike], rows_per_partition: int,
                    *, batch_rows: int = BATCH_ROWS) -> list[Partition]:
    """Cut `source` (a tracks file, a list of files or a folder) into partitions of about
    `rows_per_partition` rows, each ending at a track boundary (a partition holds whole tracks;
    a longer track makes a longer partition; a partition never spans two files). Reads only the
    track_id column. A track whose rows are not contiguous (its id comes back) is a `BadInput`
    (`NotGrouped`)."""
    if rows_per_partition < 1:
        raise ValueError("rows_per_partition must be >= 1")
    out: list[Partition] = []
    seen = _Seen()
    for p in source_files(source):
        first = 2 if p.lower().endswith(".csv") else 1  # line/row of data row 0
        begin, end, prev = 0, None, None
        for tab in read_batches(p, batch_rows=batch_rows, columns=("track_id",)):
            if not len(tab.lines):
                continue
            tid = tab["track_id"]
            starts = _runs(run_key(tab))
            if prev is not None and tid[0] == prev:
                starts = starts[1:]
            _refuse_repeats(p, tab, seen, starts)
            bounds = tab.lines[starts] - first  # data row of each track's first row
            while True:
                j = np.searchsorted(bounds, begin + rows_per_partition)
                if j >= len(bounds):
                    break
                cut = int(bounds[j])
                out.append(Partition(p, begin, cut))
                begin = cut
            prev, end = tid[-1], int(tab.lines[-1]) - first + 1
        if end is not None and end > begin:
            out.append(Partition(p, begin, end))
    return out
