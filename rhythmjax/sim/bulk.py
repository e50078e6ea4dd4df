"""Large synthetic tracks files (1e4 to 1e6+ tracks) for scale tests and benchmarks.

The physics of `sim.tracks.make_tracks` (its helpers: Table 1's pace and stride, the rhythm
signal model, the widths, bicycles, dogs, cars, short tracks, missing measurements, the default
camera of (3)), drawn for a block of tracks at once in NumPy (float64), not one object at a time.
Blocks of `block` tracks are generated and appended to the file as they go (Parquet row groups or
CSV lines), so memory is bounded by the block (peak RSS 1.35 GB at 50 000 tracks, 4.2 M rows,
the process included), whatever the size: 1e5 tracks in 9 s on 2 shared cores.
The file is written to a temp file and renamed over `path` at the end. Deterministic for a seed
and block size (block b draws from `default_rng([seed, b])`); not the same draws as
`make_tracks`, whose per-object order the tests depend on.

Columns: track_id, frame, t (s), u, v (px; empty where missing), width_px, intensity, label,
x, y (true ground position, m) -- the tracks format of `io.files`. About 84 rows a track with
the default mix (that of `rhythmjax simulate`'s defaults: 20 walkers, 5 bicycles, 5 dogs, 3
cars, 2 short walkers).
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Mapping

import numpy as np
import pyarrow as pa

from ..io import atomic_path, table_suffix
from ..model.camera_np import image_width_of, project_3d
from ..model.params import Camera, ConfigError
from .tracks import (
    PLACE_TRIES,
    START_Y_M,
    WIDTH_M,
    in_view,
    kind_params,
    rhythm_per_px,
    start_half_width,
    track_frames,
)


# the kinds of a mix: "short" is a walker tracked for 20-55 frames (fewer than N = 64)
MIX_KINDS = ("pedestrian", "bicycle", "dog", "car", "short")
DEFAULT_MIX = {"pedestrian": 20, "bicycle": 5, "dog": 5, "car": 3, "short": 2}
COLUMNS = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y")
_PREFIX = np.array(["ped", "bic", "dog", "car", "sho"])
_LABEL = ("pedestrian", "bicycle", "dog", "car", "pedestrian")  # of each kind code
_SCHEMA = pa.schema([("track_id", pa.string()), ("frame", pa.int64())]
                    + [(c, pa.float64()) for c in COLUMNS[2:7]] + [("label", pa.string())]
                    + [(c, pa.float64()) for c in COLUMNS[8:]])


def mix_counts(n: int, mix: Mapping[str, float | int]) -> np.ndarray:
    """Tracks of each kind of `MIX_KINDS` among n, in the proportions of `mix` (largest
    remainders, so they add up to n). Unknown kinds, negative weights or all weights 0 are a
    `ConfigError` (a ValueError) keyed "mix"."""
    bad = set(mix) - set(MIX_KINDS)
    if bad or any(float(w) < 0 for w in mix.values()) or not sum(mix.values()) > 0:
        raise ConfigError("mix", f"weights >= 0 of {MIX_KINDS}, not all 0; got {dict(mix)}")
    w = np.array([float(mix.get(k, 0.0)) for k in MIX_KINDS])
    share = n * w / w.sum()
    counts = np.floor(share).astype(np.int64)
    rest = np.argsort(-(share - counts), kind="stable")[: n - counts.sum()]
    counts[rest] += 1
    return counts


def _paths(camera: Camera, rng, speed, n, radial):
    """Vectorised `tracks._path`: (x0, y0, heading, n) per track; tracks that no try keeps in
    view for n frames (up to `PLACE_TRIES` rounds of redraws for those that failed) are cut at
    the frames their best try stays in view."""
    B = len(speed)
    x0, y0, head = np.zeros(B), np.zeros(B), np.zeros(B)
    best = np.full(B, -1, np.int64)
    todo = np.arange(B)
    for _ in range(PLACE_TRIES):
        k = len(todo)
        rad = radial[todo]
        h = np.where(rad, rng.uniform(-0.35, 0.35, k) + rng.choice([0.5, -0.5], k) * math.pi,
                     rng.uniform(-math.pi, math.pi, k))
        yy = np.where(rad, np.where(np.sin(h) < 0, rng.uniform(15.0, 19.0, k),
                                    rng.uniform(4.0, 6.0, k)), rng.uniform(*START_Y_M, k))
        half = start_half_width(camera, yy)
        xx = rng.uniform(-half, half)
        nt = n[todo]
        t = np.arange(int(nt.max())) / camera.fps
        sp = speed[todo][:, None]
        x = xx[:, None] + sp * np.cos(h)[:, None] * t
        y = yy[:, None] + sp * np.sin(h)[:, None] * t
        u, v = project_3d(camera, x, y, 0.0)
        inside = in_view(camera, u, v, y) | (t[None, :] * camera.fps >= nt[:, None] - 0.5)
        stay = np.where(inside.all(1), nt, np.argmin(inside, axis=1))
        better = stay > best[todo]
        sel = todo[better]
        x0[sel], y0[sel], head[sel], best[sel] = xx[better], yy[better], h[better], stay[better]
        todo = todo[best[todo] < n[todo]]
        if not len(todo):
            break
    if len(todo) and np.any(2 * best[todo] < n[todo]):
        raise ConfigError("camera", f"no straight path of {int(n[todo].max())} frames stays "
                          "half its length in view and in 3.3-19.7 m ahead; is the camera "
                          "sensible (`rhythmjax camera`)?")
    return x0, y0, head, np.minimum(n, best)


def make_block(camera: Camera, rng: np.random.Generator, counts: np.ndarray, first: int,
               frame0: int, *, id_digits: int = 7, r_std_px: float = 1.5,
               gap_rate: float = 0.03, intensity_noise: float = 0.15, min_frames: int = 72,
               max_frames: int = 110) -> tuple[pa.Table, int, dict]:
    """One block of tracks, `counts` of each kind of `MIX_KINDS` in random order, numbered from
    `first` and starting at frame `frame0`: (the rows as an Arrow table with `COLUMNS`, the
    next block's first frame, {"cut": tracks cut where they leave the view}). The noise
    parameters are `make_tracks`'s (px, fraction of frames, relative)."""
    code = rng.permutation(np.repeat(np.arange(len(MIX_KINDS)), counts))
    B = len(code)
    pace, stride, speed, depth = (np.zeros(B) for _ in range(4))
    n = np.zeros(B, np.int64)
    for c, kind in enumerate(MIX_KINDS):
        i = np.flatnonzero(code == c)
        if len(i):
            pace[i], stride[i], speed[i], depth[i] = kind_params(_LABEL[c], rng, len(i))
            n[i] = track_frames(kind, rng, speed[i], camera.fps, min_frames, max_frames,
                                len(i))
    radial = (code == 1) | (code == 3)
    x0, y0, head, n_kept = _paths(camera, rng, speed, n, radial)
    # one row per track and frame
    r = np.repeat(np.arange(B), n_kept)
    k = np.arange(len(r)) - np.repeat(np.cumsum(n_kept) - n_kept, n_kept)
    t_in = k / camera.fps
    x = x0[r] + (speed * np.cos(head))[r] * t_in
    y = y0[r] + (speed * np.sin(head))[r] * t_in
    u, v = project_3d(camera, x, y, 0.0)
    u = u + rng.normal(0, r_std_px, len(r))
    v = v + rng.normal(0, r_std_px, len(r))
    front = np.array([WIDTH_M[lab][0] for lab in _LABEL])[code]
    side = np.array([WIDTH_M[lab][1] for lab in _LABEL])[code]
    walker = (code == 0) | (code == 4)
    w_m = np.abs(np.sin(head)) * front + np.abs(np.cos(head)) * side
    w_m = np.where(walker, w_m + rng.normal(0, 0.04, B), w_m)
    w_px = image_width_of(camera, w_m[r], y) * (1 + rng.normal(0, 0.05, len(r)))
    area = image_width_of(camera, 0.5, y) ** 2 / 5.0
    phase = rng.uniform(0, 1, B)
    asym = np.where(walker, rng.uniform(0.8, 0.95, B), 1.0)
    per_px = rhythm_per_px(t_in, pace[r], phase[r], asym[r], depth[r],
                           rng.standard_normal(len(r)), intensity_noise, (code == 3)[r])
    intensity = np.maximum(per_px, 0.0) * area
    gaps = rng.random(len(r)) < gap_rate
    u[gaps], v[gaps], w_px[gaps] = np.nan, np.nan, np.nan
    starts = frame0 + np.r_[0, np.cumsum(rng.integers(0, 5, B))]
    frame = starts[:-1][r] + k
    ids = np.char.add(_PREFIX[code], np.char.zfill((first + np.arange(B)).astype(str),
                                                   id_digits))
    ri = pa.array(r.astype(np.int32))
    tid = pa.DictionaryArray.from_arrays(ri, pa.array(ids.tolist())).dictionary_decode()
    lab_code = np.array([0, 1, 2, 3, 0], np.int32)[code][r]
    lab = pa.DictionaryArray.from_arrays(pa.array(lab_code),
                                         pa.array(list(_LABEL[:4]))).dictionary_decode()
    f64 = lambda a: pa.array(a, pa.float64(), from_pandas=True)  # NaN -> null
    table = pa.Table.from_arrays(
        [tid, pa.array(frame, pa.int64()), f64(frame / camera.fps), f64(u), f64(v), f64(w_px),
         f64(intensity), lab, f64(x), f64(y)], schema=_SCHEMA)
    return table, int(starts[-1]), {"cut": int(np.sum(n_kept < n))}


def write_bulk_tracks(path, n_tracks: int, *, seed: int = 0,
                      mix: Mapping[str, float | int] = DEFAULT_MIX, block: int = 50_000,
                      progress: bool = False, camera: Camera | None = None) -> dict:
    """Write a synthetic tracks file of `n_tracks` tracks (.parquet or .csv, by the suffix),
    `block` tracks at a time (Parquet row groups of at most 2^20 rows, or CSV lines, appended
    per block), atomically (a temp file beside `path`, renamed over it at the end).

    `mix`: relative weights of `MIX_KINDS` (default `DEFAULT_MIX`, `rhythmjax simulate`'s
    defaults). `camera`: default `Camera()` (the paper's, 15 fps, 512 x 512). `progress`:
    one line per block on stderr. Returns a summary: output, n_tracks, n_rows, labels (tracks
    per label), kinds (tracks per kind), cut (tracks cut short where they left the view),
    seed, block, seconds (wall time), bytes (file size)."""
    p = os.fspath(path)
    suffix = table_suffix(p)
    if n_tracks < 0 or block < 1:
        raise ValueError("n_tracks must be >= 0 and block >= 1")
    camera = camera or Camera()
    counts_all = mix_counts(n_tracks, mix)
    digits = max(3, len(str(max(n_tracks - 1, 0))))
    t0 = time.perf_counter()
    n_rows, cut, frame0 = 0, 0, 0
    kinds = np.zeros(len(MIX_KINDS), np.int64)
    with atomic_path(p) as tmp:
        if suffix == ".csv":
            import pyarrow.csv as pacsv

            writer = pacsv.CSVWriter(tmp, _SCHEMA, write_options=pacsv.WriteOptions(
                quoting_style="needed"))
        else:
            import pyarrow.parquet as pq

            writer = pq.ParquetWriter(tmp, _SCHEMA)
        with writer:
            if not n_tracks:
                writer.write_table(_SCHEMA.empty_table())
            for b, s in enumerate(range(0, n_tracks, block)):
                size = min(block, n_tracks - s)
                # this block's share of the kinds left (the last block takes the rest exactly)
                left = dict(zip(MIX_KINDS, (counts_all - kinds).tolist(), strict=True))
                counts = mix_counts(size, left)
                rng = np.random.default_rng([seed, b])
                table, frame0, info = make_block(camera, rng, counts, s, frame0,
                                                 id_digits=digits)
                writer.write_table(table)
                kinds += counts
                n_rows += table.num_rows
                cut += info["cut"]
                if progress:
                    print(f"bulk: {s + size}/{n_tracks} tracks, {n_rows} rows, "
                          f"{time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    labels: dict[str, int] = {}
    for label, count in zip(_LABEL, kinds.tolist(), strict=True):
        labels[label] = labels.get(label, 0) + count
    return {"output": p, "n_tracks": int(n_tracks), "n_rows": int(n_rows),
            "labels": {k: v for k, v in sorted(labels.items()) if v},
            "kinds": {k: int(v) for k, v in zip(MIX_KINDS, kinds, strict=True) if v},
            "cut": cut, "seed": seed, "block": block,
            "seconds": round(time.perf_counter() - t0, 3), "bytes": os.path.getsize(p)}
