"""Peak memory of `rhythmjax classify` on one long track (issue 17: long tracks in segments).

    python benchmarks/bench_long_track.py [--rows 100000 1000000] [--keep DIR]

Writes one synthetic walker track of ROWS rows (a Parquet file: a walker going round an ellipse
inside the detection range, 15 fps, the foot point by (3) of the default camera, I(k) a 2.05 Hz
gait swing plus noise, 2 % of rows without a measurement), then runs `rhythmjax classify` on it in
a child process and reports the child's peak resident set size (`resource.getrusage`,
RUSAGE_CHILDREN ru_maxrss, one wrapper process per run), its wall time and the verdict. The
compilation cache is off (RHYTHMJAX_CACHE_DIR=0) so every run pays the same compilation.
`--segment-rows 1000000000` sends every track through the batch path (the behaviour before
`model.long_tracks`): 1e5 rows then peak at about 3.2 GB.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np


def write_track(path: str, rows: int, seed: int = 0, short: int = 0) -> None:
    """One walker going round an ellipse (x +-3 m, y 7-13 m ahead) at about 1.5 m/s; then
    `short` more such walkers of 200 rows each (ids s0, s1, ...)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from rhythmjax.model.camera_np import image_width_of, project_3d
    from rhythmjax.model.params import Camera

    cam = Camera()
    fps = float(cam.fps)
    rng = np.random.default_rng(seed)
    frame = np.arange(rows, dtype=np.int64)
    t = frame / fps
    w = 2 * np.pi / 12.5  # one lap in 12.5 s
    x, y = 3.0 * np.sin(w * t), 10.0 + 3.0 * np.cos(w * t)
    u, v = project_3d(cam, x, y, 0.0)
    u = u + rng.normal(0, 1.0, rows)
    v = v + rng.normal(0, 1.0, rows)
    width = image_width_of(cam, 0.5, y) * (1 + rng.normal(0, 0.05, rows))
    inten = 1000.0 * (1.0 + 0.5 * np.sin(2 * np.pi * 2.05 * t) + 0.1 * rng.normal(size=rows))
    gone = rng.random(rows) < 0.02
    u[gone] = np.nan
    v[gone] = np.nan
    ids = np.full(rows, "walker", dtype=object)
    if short:
        k = np.arange(rows) - (rows - 200 * short)
        ids = np.where(k >= 0, np.char.add("s", (np.maximum(k, 0) // 200).astype(str)), ids)
        frame = np.where(k >= 0, k % 200, frame)
        t = frame / fps
    cols = {"track_id": ids.astype(str), "frame": frame, "t": t, "u": u, "v": v,
            "width_px": width, "intensity": np.abs(inten)}
    pq.write_table(pa.table(cols), path)


# A wrapper process per measurement: RUSAGE_CHILDREN's ru_maxrss is the largest child so far,
# so each classify runs as the only child of its own wrapper, which prints that child's peak.
_WRAP = ("import resource, subprocess, sys, time; t0 = time.perf_counter(); "
         "p = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
         "print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, "
         "time.perf_counter() - t0); sys.stderr.write(p.stderr)")


def run_classify(tracks: str, out: str, segment_rows: int | None = None) -> dict:
    env = dict(os.environ, RHYTHMJAX_CACHE_DIR="0")
    extra = [] if segment_rows is None else ["--segment-rows", str(segment_rows)]
    p = subprocess.run([sys.executable, "-c", _WRAP, sys.executable, "-m", "rhythmjax.cli.main",
                        "classify", tracks, "-o", out, "--quiet"] + extra, capture_output=True,
                       text=True, env=env)
    rc, peak_kib, wall = p.stdout.split()
    verdict = open(out).read().splitlines()[1] if rc == "0" else p.stderr.strip()
    return {"rc": int(rc), "peak_mib": int(peak_kib) / 1024, "wall_s": float(wall),
            "verdict": verdict}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--keep", help="keep the tracks files in this folder")
    ap.add_argument("--short", type=int, default=0, help="also this many tracks of 200 rows in "
                    "the same file (a long track among short ones)")
    ap.add_argument("--segment-rows", type=int, help="classify --segment-rows (a huge value: "
                    "every track through the batch path, the behaviour before)")
    a = ap.parse_args()
    d = a.keep or tempfile.mkdtemp(prefix="bench_long_")
    os.makedirs(d, exist_ok=True)
    for rows in sorted(a.rows):
        path = os.path.join(d, f"long_{rows}_{a.short}.parquet")
        if not os.path.exists(path):
            write_track(path, rows + 200 * a.short, short=a.short)
        r = run_classify(path, os.path.join(d, f"verdicts_{rows}.csv"), a.segment_rows)
        print(f"rows {rows:>9} (+{a.short} x 200): rc {r['rc']}, peak RSS "
              f"{r['peak_mib']:.0f} MiB, wall {r['wall_s']:.1f} s; {r['verdict']}", flush=True)


if __name__ == "__main__":
    main()
