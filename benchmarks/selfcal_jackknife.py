"""Self-calibration's sensitivity to single walkers (issue 19): leave each walker out in turn.

    python benchmarks/selfcal_jackknife.py TRACKS.parquet --image-size WxH --fps F
        [--truth H_M,TILT_DEG,AF_PX]

Fits the camera (`fit.selfcal.fit_selfcal`, the command's defaults) from every track of a
tracks file, then once more without each walker the first fit used. Prints each refit, the
range of h, tilt and a f over the refits and their jackknife standard errors,
sqrt((n - 1) / n sum (x_i - mean)^2), beside the fit's own Gauss-Newton SEs: whether one walker
holds an estimate (a non-walker that slipped through, a wrong pace) and whether the reported SEs
are honest. Tracks files are read where they lie (for PETS09: the tracks `selfcal_real.py`
made under its --work folder); nothing is written.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
from selfcal_real import pooled_batch


NAMES = ("h", "theta", "af")


def fit_without(path: Path, size, fps: float, track_id: str | None):
    """`fit_selfcal` on the tracks file without one track (None: every track)."""
    from fit.selfcal import fit_selfcal

    tab = pq.read_table(path)
    if track_id is not None:
        tab = tab.filter(pc.invert(pc.equal(pc.cast(tab["track_id"], pa.string()), track_id)))
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / path.parent.name
        p.mkdir()
        pq.write_table(tab, p / "tracks.parquet")
        cfg, batch = pooled_batch([p / "tracks.parquet"], size, fps)
    return fit_selfcal(cfg, batch)


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    a.add_argument("tracks", type=Path)
    a.add_argument("--image-size", required=True)
    a.add_argument("--fps", type=float, required=True)
    a.add_argument("--truth", help="H_M,TILT_DEG,AF_PX to print beside")
    args = a.parse_args(argv)
    size = tuple(int(q) for q in args.image_size.split("x"))
    fmt = lambda v: "  ".join(f"{k} {v[k]:.2f}" for k in NAMES)
    full = fit_without(args.tracks, size, args.fps, None)
    if full.camera is None:
        print(f"refused: {'; '.join(full.reasons)}")
        return 1
    print(f"all {full.n_walkers} walkers: {fmt(full.values)}  (Gauss-Newton SE "
          f"{fmt(full.se)})", flush=True)
    rows = []
    for wid in full.walker_ids:
        tid = wid.split(":", 1)[1]
        r = fit_without(args.tracks, size, args.fps, tid)
        if r.camera is None:
            print(f"without {tid}: refused ({'; '.join(r.reasons)})", flush=True)
            continue
        rows.append([r.values[k] for k in NAMES])
        print(f"without {tid}: {fmt(r.values)}", flush=True)
    x = np.asarray(rows)
    n = len(x)
    jack = np.sqrt((n - 1) / n * np.sum((x - x.mean(0)) ** 2, 0))
    print(f"\n{n} refits: " + "; ".join(f"{k} {lo:.2f}..{hi:.2f}, jackknife SE {s:.3g} "
                                         f"(Gauss-Newton {full.se[k]:.3g})"
                                         for k, lo, hi, s in zip(NAMES, x.min(0), x.max(0), jack,
                                                                 strict=True)))
    if args.truth:
        print("truth: " + "  ".join(f"{k} {t}" for k, t in zip(NAMES, args.truth.split(","),
                                                               strict=False)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
