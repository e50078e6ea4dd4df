"""Tracks, footprints, verdicts and config files (ARCHITECTURE.md, "File formats").

Validation lives here, at the edge; the jitted kernels trust what `to_batch` gives them. Every
problem is a `BadInput` whose one-line message names the file and the line, column, track or key.
Tables: `io_tables` (strict CSV/Parquet reading, atomic writes), re-exported here.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .atomic import (
    atomic_path as atomic_path,
    atomic_write as atomic_write,
    check_writable as check_writable,
    make_output_dir as make_output_dir,
)
from .configs import (
    config_or_bad_input as config_or_bad_input,
    dumps_json as dumps_json,
    read_config as read_config,
    read_config_dict as read_config_dict,
    write_config as write_config,
)
from .footprints import Footprints as Footprints, read_footprints as read_footprints
from .table_write import write_table as write_table
from .tables import (
    KEY_SUFFIX,
    BadInput as BadInput,
    PathLike,
    Table as Table,
    map_text,
    read_table as read_table,
)
from .track_checks import (
    check_track_rows,
    check_track_units,
    first_true,
    time_steps,
    track_order,
    track_starts,
)


TRACK_COLUMNS = ("track_id", "frame", "t", "u", "v", "width_px", "intensity")
# Candidate windows B (issue 16): I(k) summed again with window B moved by this many walker
# widths W (negative: up), one optional column each; a file has all of them or none. Every
# classifier takes, per rhythm window, the candidate (`intensity` included) whose strongest
# spectral peak is highest (`model.candidates`).
WINDOW_CANDIDATES = (("intensity_up20", -0.2), ("intensity_up10", -0.1),
                     ("intensity_down10", 0.1))
CANDIDATE_COLUMNS = tuple(name for name, _ in WINDOW_CANDIDATES)
# Rule 50b (issue 16, off): window B moved this many W left (negative) and right on its row, two
# optional columns after the candidates'; they decide a window only by (13)-(15) at their own peak.
ACROSS_CANDIDATES = (("intensity_left10", -0.1), ("intensity_right10", 0.1))
ACROSS_COLUMNS = tuple(name for name, _ in ACROSS_CANDIDATES)
# The pace window (rule 34, issue 16): I(k) summed in a window at window B's foot point as wide
# as a walker's step, one optional column after the candidates'. It never decides a verdict:
# where a rhythm window says Pedestrian and the pace window over the same rows does too, that
# window's pace and stride are the pace window's (`model.candidates.strongest`).
PACE_COLUMN = "intensity_wide"
OPTIONAL_TRACK_COLUMNS = ("label", "x", "y", "v_top", "u_top", "top_at_edge", "state",
                          *CANDIDATE_COLUMNS, *ACROSS_COLUMNS, PACE_COLUMN)
LABELS = ("pedestrian", "bicycle", "dog", "car", "other")
TRACK_STATES = ("none", "detect", "observe", "predict")  # `state` (`status.TrackState` names)
MEASUREMENTS = ("u", "v", "width_px", "intensity", "x", "y", "v_top", "u_top", "top_at_edge",
                *CANDIDATE_COLUMNS, *ACROSS_COLUMNS, PACE_COLUMN)
MAX_ABS = 1e12
TRACK_TYPES = {"track_id": "id", "frame": "int", "t": "float", "u": "float", "v": "float",
               "width_px": "float", "intensity": "float", "label": "str", "x": "float",
               "y": "float", "v_top": "float", "u_top": "float", "top_at_edge": "float",
               "state": "str",
               **{name: "float" for name in (*CANDIDATE_COLUMNS, *ACROSS_COLUMNS, PACE_COLUMN)}}
TRACK_NOT_EMPTY = ("track_id", "frame", "t")
TRACK_KEY = "track_id" + KEY_SUFFIX  # a Table's codes of its track ids (`tables.convert_parquet`)


@dataclass
class Tracks:
    """Validated rows of a tracks file, sorted by (track, frame); tracks keep the order in which
    they first appear. `line` is each row's source line (CSV, header = 1) or row (Parquet), named
    by `unit`. `notes` records what was repaired (e.g. re-sorted rows) for the run summary."""

    path: str
    track_id: np.ndarray  # object array of str, as written in the file
    frame: np.ndarray  # int64
    t: np.ndarray  # float64, seconds
    u: np.ndarray  # float64 px; NaN = no measurement
    v: np.ndarray
    width_px: np.ndarray
    intensity: np.ndarray
    line: np.ndarray  # int64
    unit: str = "line"
    label: np.ndarray | None = None  # object array of normalised labels ("" = unlabelled)
    x: np.ndarray | None = None
    y: np.ndarray | None = None
    fps: float | int | None = None
    v_top: np.ndarray | None = None  # top row px of the moving region (the head); NaN missing
    u_top: np.ndarray | None = None  # the head's column px at v_top; NaN missing
    top_at_edge: np.ndarray | None = None  # 1: the moving region reached the image's first
    # row (v_top NaN: the object goes on above it); 0 or NaN: not
    notes: list[str] = field(default_factory=list)
    track_key: np.ndarray | None = None  # int64 codes equal where track_id is (`run_key`)
    state: np.ndarray | None = None  # object array of `TRACK_STATES` ("" = not given)
    candidates: np.ndarray | None = None  # (rows, K) float64: `CANDIDATE_COLUMNS`' I(k)
    # (where given), then `ACROSS_COLUMNS`' (where given: `across`), then `PACE_COLUMN`'s
    # (where given: `pace_window`)
    pace_window: bool = False  # the last candidates column is the pace window (rule 34)
    across: int = 0  # rule 50b: the candidates columns before the pace window's that are
    # `ACROSS_COLUMNS` (0 or their count)

    def __len__(self) -> int:
        return int(self.frame.shape[0])

    @property
    def ids(self) -> list[str]:
        """Track ids in file order."""
        return [str(i) for i in self.track_id[track_starts(run_key(self))]]

    def by_span(self, rows: int) -> list[Tracks]:
        """The tracks in groups to pad and classify apart: first those spanning at most `rows`
        frames (first to last; their padded length is at most that), then each longer track on
        its own, so that one long track does not pad every other to its length. Each group
        keeps the file order; a group is all the tracks when none is longer."""
        key = run_key(self)
        starts = track_starts(key)
        if not len(starts):
            return [self]
        ends = np.r_[starts[1:], len(self.frame)] - 1
        long = np.flatnonzero(self.frame[ends] - self.frame[starts] + 1 > rows)
        if not long.size:
            return [self]
        track = np.cumsum(np.r_[False, key[1:] != key[:-1]])
        short = np.setdiff1d(np.arange(len(starts)), long)
        groups = ([np.isin(track, short)] if short.size else []) + [track == i for i in long]
        return [self.take(m) for m in groups]

    def take(self, rows: np.ndarray) -> Tracks:
        """These tracks' rows `rows` (a mask or indices; whole tracks), notes left out."""
        take = lambda a: None if a is None else a[rows]  # noqa: E731
        return dataclasses.replace(
            self, track_id=take(self.track_id), frame=take(self.frame), t=take(self.t),
            u=take(self.u), v=take(self.v), width_px=take(self.width_px),
            intensity=take(self.intensity), line=take(self.line), label=take(self.label),
            x=take(self.x), y=take(self.y), v_top=take(self.v_top), u_top=take(self.u_top),
            top_at_edge=take(self.top_at_edge), notes=[],
            track_key=take(self.track_key), state=take(self.state),
            candidates=take(self.candidates))

    def to_batch(self, *, max_gap_frames: int, min_len: int, bucket: bool = True,
                 fps: float | int | None = None) -> TrackBatch:
        return to_batch(self, max_gap_frames=max_gap_frames, min_len=min_len, bucket=bucket,
                        fps=fps)


@dataclass
class TrackBatch:
    """Tracks padded to a common length T on their frame grid (float32, NaN = no measurement).

    dt[:, 0] is the nominal step and dt[:, k] = t[:, k] - t[:, k-1]; `present` is False on the
    padding, where t continues by the nominal step and dt equals it."""

    ids: list[str]
    z: np.ndarray  # (B, T, 2) u, v px
    width: np.ndarray  # (B, T) px
    intensity: np.ndarray  # (B, T)
    t: np.ndarray  # (B, T) s
    dt: np.ndarray  # (B, T) s
    present: np.ndarray  # (B, T) bool
    length: np.ndarray  # (B,) int32
    labels: list[str] | None = None
    xy: np.ndarray | None = None  # (B, T, 2) m
    v_top: np.ndarray | None = None  # (B, T) px, the top row (head) where the file has it
    u_top: np.ndarray | None = None  # (B, T) px, the head's column at v_top, likewise
    top_at_edge: np.ndarray | None = None  # (B, T): 1 where the region reached the image's top
    candidates: np.ndarray | None = None  # (B, T, K): the candidate windows' I(k), if any
    pace_window: bool = False  # the last candidates column is the pace window's (rule 34)
    across: int = 0  # rule 50b: that many columns before it are `ACROSS_COLUMNS`' (`Tracks`)


# ----------------------------------------------------------------------------------------------
def read_tracks(path: PathLike, *, fps: float | int | None = None) -> Tracks:
    """Read and validate a tracks file (RELIABILITY.md section 3, items 17-30).

    `fps` (the camera's) sharpens the milliseconds check. Raises `BadInput`."""
    p = os.fspath(path)
    tab = read_table(p, TRACK_COLUMNS, OPTIONAL_TRACK_COLUMNS, types=TRACK_TYPES,
                     not_empty=TRACK_NOT_EMPTY)
    return validated_tracks(p, tab, fps=fps)


def validated_tracks(p: str, tab: Table, *, fps: float | int | None = None,
                     grouped: bool = False) -> Tracks:
    """The checks of `read_tracks` on the table `tab` read from `p` (converted cells; `tab.lines`
    the rows' lines or rows in the file, so messages name them): values, labels, rows sorted by
    (track, frame), frames and times per track, units. `grouped`: the caller knows each track's
    rows are contiguous (`io.stream` reads whole tracks), so only the frames within a track are
    sorted. Raises `BadInput`."""
    bad_t = first_true(~np.isfinite(tab["t"]))
    if bad_t is not None:
        raise tab.where(p, bad_t, "t", f"{float(tab['t'][bad_t])!r} is not a finite time (s)")
    for c in MEASUREMENTS:
        if c not in tab:
            continue
        a = tab[c]
        i = first_true(np.abs(a) > MAX_ABS)  # inf too; NaN (a missing value) never
        if i is not None:
            raise tab.where(p, i, c, f"{float(a[i])!r} is not a usable value (inf or |value| > "
                            "1e12); leave the cell empty for a missing measurement")
        if c in ("width_px", "intensity", *CANDIDATE_COLUMNS, *ACROSS_COLUMNS, PACE_COLUMN):
            i = first_true(a < 0)
            if i is not None:
                raise tab.where(p, i, c, f"{float(a[i])!r} is negative")
    have = [c for c in CANDIDATE_COLUMNS if c in tab]
    if have and len(have) < len(CANDIDATE_COLUMNS):
        missing = [c for c in CANDIDATE_COLUMNS if c not in tab]
        raise BadInput(p, f"candidate window columns come together: {', '.join(have)} given, "
                       f"{', '.join(missing)} missing", column=missing[0])
    across = [c for c in ACROSS_COLUMNS if c in tab]
    if across and len(across) < len(ACROSS_COLUMNS):
        missing = [c for c in ACROSS_COLUMNS if c not in tab]
        raise BadInput(p, f"the columns of the windows moved across come together: "
                       f"{', '.join(across)} given, {', '.join(missing)} missing",
                       column=missing[0])
    if "state" in tab:
        state = np.asarray(tab["state"], dtype=object)
        known = np.isin(state, TRACK_STATES + ("",))
        i = first_true(~known)
        if i is not None:
            raise tab.where(p, i, "state", f"unknown state {state[i]!r} (expected one of "
                            f"{', '.join(TRACK_STATES)}, or empty)")
    labels = label_key = None
    if "label" in tab:
        labels, label_key, known = _labels(tab)
        i = first_true(~known)
        if i is not None:
            raise tab.where(p, i, "label", f"unknown label {tab['label'][i]!r} (expected one of "
                            f"{', '.join(LABELS)}, or empty)")
    tid = np.asarray(tab["track_id"], dtype=object)
    key = run_key(tab)
    notes: list[str] = []
    if grouped:
        run = np.cumsum(np.r_[False, key[1:] != key[:-1]]) if len(tid) else np.zeros(0, int)
        order = np.lexsort((tab["frame"], run))
    else:
        order = track_order(tid, tab["frame"])
    if np.any(order != np.arange(len(order))):
        moved = int(np.flatnonzero(order != np.arange(len(order)))[0])
        notes.append(f"{p}: rows were not grouped by track and ordered by frame (first at "
                     f"{tab.unit} {int(tab.lines[order[moved]])}); sorted by (track_id, frame)")
    else:  # the rows are in order: taken as they are
        order = None
    col = {k: tab[k] if order is None else tab[k][order] for k in tab if k != "label"}
    pace_window = PACE_COLUMN in tab
    extra = [*(CANDIDATE_COLUMNS if have else ()), *across,
             *((PACE_COLUMN,) if pace_window else ())]
    candidates = (np.stack([col[c] for c in extra], axis=1).astype(np.float64)
                  if extra else None)
    lines = tab.lines if order is None else tab.lines[order]
    if order is not None:
        tid = tid[order]
        labels, label_key = (None, None) if labels is None else (labels[order], label_key[order])
    key = col.get(TRACK_KEY, tid)
    check_track_rows(p, tab.unit, tid, key, col["frame"], col["t"], lines, labels, label_key)
    check_track_units(p, tab.unit, tid, key, col, lines, fps, notes)
    return Tracks(path=p, track_id=tid, frame=col["frame"].astype(np.int64), t=col["t"],
                  u=col["u"], v=col["v"], width_px=col["width_px"], intensity=col["intensity"],
                  line=lines, unit=tab.unit, label=labels, x=col.get("x"), y=col.get("y"),
                  fps=None if fps is None else float(fps), v_top=col.get("v_top"),
                  u_top=col.get("u_top"), top_at_edge=col.get("top_at_edge"), notes=notes,
                  track_key=col.get(TRACK_KEY), state=col.get("state"), candidates=candidates,
                  pace_window=pace_window, across=len(across))


def run_key(rows) -> np.ndarray:
    """Per row of a `Table` or `Tracks`, what is equal where the track id is: the ids' int64
    codes when the reader kept them (`TRACK_KEY`, `Tracks.track_key`), else the ids."""
    if isinstance(rows, Tracks):
        return rows.track_id if rows.track_key is None else rows.track_key
    return rows.get(TRACK_KEY, rows["track_id"])


def _labels(tab: Table) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row of `tab`, its label normalised (stripped, lower case; an object array), int64
    codes equal where those are, and whether it is known (`LABELS` or ""). Normalised once per
    run of equal cells (found on the reader's codes of the column when it kept them)."""
    raw = np.asarray(tab["label"], dtype=object)
    key = tab.get("label" + KEY_SUFFIX, raw)
    first = track_starts(key)
    norm, code = map_text(raw[first], lambda s: s.strip().lower(), codes=True)
    size = np.diff(np.r_[first, len(raw)]).astype(np.int64)
    known = np.isin(norm, LABELS + ("",))
    return np.repeat(norm, size), np.repeat(code, size), np.repeat(known, size)


# ----------------------------------------------------------------------------------------------
def _bucket(n: int) -> int:
    return 1 << max(0, int(n - 1).bit_length())


def to_batch(tracks: Tracks, *, max_gap_frames: int, min_len: int, bucket: bool = True,
             fps: float | int | None = None) -> TrackBatch:
    """Pad tracks onto their frame grid in one (B, T) batch.

    A gap of up to `max_gap_frames` frames is filled with missing rows (NaN measurement,
    present=True, t interpolated linearly); a longer gap stays one step of the real duration.
    Neither splits a track: `model.batch.classify_tracks` cuts it where Fig. 3 ends it (a
    prediction, over missing rows or one long step, longer than predict_timeout; the estimate
    leaving the range), `model.segments`.
    T = max(min_len, longest track), rounded up to a power of two when `bucket`, so that batches
    of similar length share one compiled shape. The nominal step is 1/fps (`fps` or the
    tracks'), else the median time per frame, else 1 s."""
    if max_gap_frames < 1 or min_len < 1:
        raise ValueError("max_gap_frames and min_len must be >= 1")
    tid, key, frame, t = tracks.track_id, run_key(tracks), tracks.frame, tracks.t
    n = len(frame)
    starts = track_starts(key)
    B = len(starts)
    seg = np.cumsum(np.r_[False, key[1:] != key[:-1]]) if n else np.zeros(0, np.int64)
    df = np.diff(frame)
    same = seg[1:] == seg[:-1]
    fps = fps or tracks.fps
    if fps:
        dt0 = 1.0 / fps
    else:
        steps = time_steps(key, frame, t)
        dt0 = float(np.median(steps)) if steps.size else 1.0
    ins = np.zeros(n, np.int64)
    if n > 1:
        ins[1:] = np.where(same & (df > 1) & (df <= max_gap_frames), df - 1, 0)
    g = np.cumsum(ins + 1) - 1  # expanded index of each row over the whole file
    pos = g - g[starts][seg] if n else np.zeros(0, np.int64)
    ends = np.r_[starts[1:], n] - 1 if B else np.zeros(0, np.int64)
    length = (pos[ends] + 1).astype(np.int32)
    T = max(int(min_len), int(length.max()) if B else 1)
    T = _bucket(T) if bucket else T

    def grid(*cols: np.ndarray | None, dtype=np.float32) -> np.ndarray | None:
        """The columns on the (B, T) grid (stacked on a last axis when more than one), NaN
        elsewhere, cast to `dtype` as they are put (as `astype` casts)."""
        if any(a is None for a in cols):
            return None
        out = np.full((B, T, len(cols)), np.nan, dtype)
        for i, a in enumerate(cols):
            out[seg, pos, i] = a
        return out if len(cols) > 1 else out[..., 0]

    tg = grid(t, dtype=np.float64)
    # inserted rows: j = 1..m between row k-1 and row k, at pos[k] - m - 1 + j
    kk = np.repeat(np.arange(n), ins)
    if kk.size:
        m = ins[kk]
        j = np.arange(kk.size) - np.repeat(np.cumsum(ins) - ins, ins) + 1
        tg[seg[kk], pos[kk] - m - 1 + j] = t[kk - 1] + (t[kk] - t[kk - 1]) * j / (m + 1)
    idx = np.arange(T)
    present = idx[None, :] < length[:, None]
    if B:
        t_last = tg[np.arange(B), length - 1]
        tg = np.where(present, tg, t_last[:, None] + dt0 * (idx[None, :] - length[:, None] + 1))
    dt = np.concatenate([np.full((B, 1), dt0), np.diff(tg, axis=1)], axis=1)
    labels = None if tracks.label is None else [str(s) for s in tracks.label[starts]]
    candidate_grid = None
    if tracks.candidates is not None:
        candidate_grid = grid(*tracks.candidates.T)
        candidate_grid = candidate_grid.reshape(B, T, tracks.candidates.shape[1])
    return TrackBatch(ids=[str(s) for s in tid[starts]], z=grid(tracks.u, tracks.v),
                      width=grid(tracks.width_px), intensity=grid(tracks.intensity),
                      t=tg.astype(np.float32), dt=dt.astype(np.float32), present=present,
                      length=length, labels=labels, xy=grid(tracks.x, tracks.y),
                      v_top=grid(tracks.v_top), u_top=grid(tracks.u_top),
                      top_at_edge=grid(tracks.top_at_edge),
                      candidates=candidate_grid, pace_window=tracks.pace_window,
                      across=tracks.across)


__all__: Sequence[str] = (
    "BadInput", "Footprints", "Table", "Tracks", "TrackBatch", "atomic_path", "atomic_write",
    "check_writable", "config_or_bad_input", "dumps_json", "make_output_dir", "read_config",
    "read_config_dict", "read_footprints", "read_table", "read_tracks", "to_batch",
    "validated_tracks", "write_config", "write_table",
)
