"""Where the time of batch classification goes, per track, for the fast kernel
(`model.fast_batch`, behind `batch.classify_tracks`) beside the reference path
(`batch.classify_tracks_reference`: `segments.split_tracks`, then `rhythm.classify_batch` on
every window slot with float-sort medians), in one process on the same data.

    python benchmarks/bench_classify_kernel.py [--tracks FILE] [--walkers 400] [--seed 1]
        [--ref-tracks 512] [--repeat 3]

Data: a tracks file (`rhythmjax simulate -o x.parquet --seed 1 --walkers 2000 --bicycles 200
--dogs 100` is docs/benchmarks.md's set), or `sim.tracks.make_tracks` with --walkers walkers,
a tenth as many bicycles and a twentieth dogs. Warm timings (every program compiled first),
best of --repeat, float32, `jax.block_until_ready`; the load average is printed (on a shared
machine the figures move with it).

Rows (us per track unless said): the whole kernel; its steps: the filter rounds (EKF + Fig. 3
ends + the rows of the next round), the EKF alone (`segments.filter_chunks` once over all
tracks), the segment table and window gathering (host), the window classification; per window
(us per window, blocks of `windows.WINDOW_BLOCK` first windows): the kernel's one program a block
(`window_block.classify_block`) and its speeds (`window_block.block_speeds`), the whole block
with the bisection median (`windows.classify_window_block`), the speed of (12)
(`windows.theil_sen_speed`) and the reference's `rhythm.window_speed`, the rest of the window
(spectrum, peaks, matching: `rhythm.classify_window` with a given speed), Burg alone (`mem.burg`,
M = 15); and the floor (operation counts in the printout).
"""

from __future__ import annotations

import argparse
import os
import time


os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from rhythmjax.io import read_tracks, to_batch  # noqa: E402
from rhythmjax.model import mem  # noqa: E402
from rhythmjax.model.batch import classify_tracks, classify_tracks_reference  # noqa: E402
from rhythmjax.model.fast_batch import Segments, classify_segments  # noqa: E402
from rhythmjax.model.params import Config  # noqa: E402
from rhythmjax.model.rhythm import classify_window, window_speed, window_times  # noqa: E402
from rhythmjax.model.segments import filter_chunks, filter_rounds  # noqa: E402
from rhythmjax.model.window_block import block_speeds, classify_block  # noqa: E402
from rhythmjax.model.windows import WINDOW_BLOCK, classify_window_block, theil_sen_speed  # noqa
from rhythmjax.sim.tracks import make_tracks  # noqa: E402


def best(f, repeat: int) -> float:
    """Best wall time (s) of `repeat` warm calls (one call first to compile)."""
    jax.block_until_ready(f())
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        jax.block_until_ready(f())
        out.append(time.perf_counter() - t)
    return min(out)


def load(args, cfg):
    if args.tracks:
        tr = read_tracks(args.tracks, fps=cfg.camera.fps)
    else:
        cols, _ = make_tracks(n_walkers=args.walkers, n_bicycles=args.walkers // 10,
                              n_dogs=args.walkers // 20, n_cars=0, seed=args.seed)
        cols = {k: np.asarray(v) for k, v in cols.items()}
        path = "/tmp/bench_classify_kernel.parquet"
        from rhythmjax.io import write_table

        write_table(path, cols, list(cols))
        tr = read_tracks(path, fps=cfg.camera.fps)
    gap = max(1, round(float(cfg.thresholds.predict_timeout) * cfg.camera.fps))
    return to_batch(tr, max_gap_frames=gap, min_len=cfg.thresholds.n)


def subset(batch, n):
    import dataclasses

    take = lambda a: None if a is None else a[:n]  # noqa: E731
    return dataclasses.replace(batch, ids=batch.ids[:n], z=take(batch.z),
                               width=take(batch.width), intensity=take(batch.intensity),
                               t=take(batch.t), dt=take(batch.dt), present=take(batch.present),
                               length=take(batch.length),
                               labels=None if batch.labels is None else batch.labels[:n],
                               xy=take(batch.xy))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tracks")
    ap.add_argument("--walkers", type=int, default=400)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--ref-tracks", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--chunk", type=int, default=256)
    args = ap.parse_args()
    cfg = Config()
    batch = load(args, cfg)
    B = len(batch.ids)
    rows = int(np.sum(batch.length))
    print(f"{B} tracks, {rows} rows ({rows / B:.1f} a track), T = {batch.z.shape[1]}, "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs, "
          f"jax {jax.__version__}")
    us = lambda s, n: f"{s / n * 1e6:9.1f}"  # noqa: E731

    # whole paths
    fast = best(lambda: classify_tracks(cfg, batch, chunk=args.chunk, progress=False),
                args.repeat)
    nref = min(B, args.ref_tracks)
    sub = subset(batch, nref)
    ref = best(lambda: classify_tracks_reference(cfg, sub, chunk=args.chunk), 1)
    fast_sub = best(lambda: classify_tracks(cfg, sub, chunk=args.chunk, progress=False),
                    args.repeat)
    a = classify_tracks(cfg, sub, chunk=args.chunk, progress=False)
    b = classify_tracks_reference(cfg, sub, chunk=args.chunk)
    same = all(list(a[k]) == list(b[k]) for k in ("verdict", "reason", "n_samples"))

    # the kernel's steps
    rounds = list(filter_rounds(cfg, batch, args.chunk))
    t_rounds = best(lambda: list(filter_rounds(cfg, batch, args.chunk)), args.repeat)
    t_ekf = best(lambda: filter_chunks(cfg, batch, args.chunk), args.repeat)
    t_segs = best(lambda: Segments(cfg, rounds), args.repeat)
    segs = Segments(cfg, rounds)
    t_windows = best(lambda: classify_segments(cfg, segs), args.repeat)
    n_seg, n_win = len(segs), int(segs.windows.sum())
    first = np.flatnonzero(segs.windows > 0)
    seg = np.resize(first, WINDOW_BLOCK)
    t_gather = best(lambda: segs.gather(seg, np.zeros(len(seg), np.int64)), args.repeat)
    inten, dt, xy, obs = (jnp.asarray(x) for x in segs.gather(seg, np.zeros(len(seg), int)))

    blk = best(lambda: classify_window_block(cfg, inten, dt, xy, obs), args.repeat)
    kernel_blk = best(lambda: classify_block(cfg, inten, dt, xy, obs), args.repeat)
    speeds = jax.jit(lambda d, p, o: block_speeds(cfg, d, p, o))
    t_speeds = best(lambda: speeds(dt, xy, obs), args.repeat)
    sp = jax.jit(jax.vmap(lambda d, p, o: theil_sen_speed(cfg, window_times(d), p, o)))
    t_speed = best(lambda: sp(dt, xy, obs), args.repeat)
    sp_ref = jax.jit(jax.vmap(lambda d, p, o: window_speed(cfg, window_times(d), p, o)))
    t_speed_ref = best(lambda: sp_ref(dt, xy, obs), args.repeat)
    rest = jax.jit(jax.vmap(lambda i, d, p, o: classify_window(
        cfg, i, window_times(d), p, jnp.asarray(True), o, speed=jnp.float32(1.0))))
    t_rest = best(lambda: rest(inten, dt, xy, obs), args.repeat)
    x = jnp.nan_to_num(inten)
    burg = jax.jit(jax.vmap(lambda v: mem.burg(v, int(cfg.thresholds.m))))
    t_burg = best(lambda: burg(x), args.repeat)

    W = WINDOW_BLOCK
    print(f"\n{n_seg} segments, {n_win} complete windows ({n_win / n_seg:.2f} a segment); "
          f"reference on the first {nref} tracks: verdicts, reasons, n_samples "
          f"{'identical' if same else 'DIFFER'}\n")
    print("| step | us per track |\n|---|---:|")
    print(f"| reference path (split_tracks + classify_batch), {nref} tracks | {us(ref, nref)} |")
    print(f"| fast kernel, the same {nref} tracks | {us(fast_sub, nref)} |")
    print(f"| fast kernel, all {B} tracks | {us(fast, B)} |")
    print(f"| - filter rounds (EKF, Fig. 3 ends, next rounds' rows) | {us(t_rounds, B)} |")
    print(f"| - of which the EKF once over every track | {us(t_ekf, B)} |")
    print(f"| - segment table | {us(t_segs, B)} |")
    print(f"| - windows: gather + classify, all phases | {us(t_windows, B)} |")
    print(f"\n| per window (blocks of {W} first windows) | us per window |\n|---|---:|")
    print(f"| gather (host) | {us(t_gather, W)} |")
    print(f"| whole window, the kernel's program (`window_block.classify_block`) | "
          f"{us(kernel_blk, W)} |")
    print(f"| - its speeds of (12) (`window_block.block_speeds`: windows on the minor axis, "
          f"select median + in-program fallback) | {us(t_speeds, W)} |")
    print(f"| whole window, bisection median (`classify_window_block`) | {us(blk, W)} |")
    print(f"| speed of (12), bisection median, one window at a time (`theil_sen_speed`) | "
          f"{us(t_speed, W)} |")
    print(f"| speed of (12), reference (`window_speed`, two float sorts) | "
          f"{us(t_speed_ref, W)} |")
    print(f"| the rest: Burg, PSD, peaks, (13)-(15) | {us(t_rest, W)} |")
    print(f"| Burg alone (M = {int(cfg.thresholds.m)}) | {us(t_burg, W)} |")
    n, m, nf = int(cfg.thresholds.n), int(cfg.thresholds.m), 512
    P = n * (n - 1) // 2
    ekf_ops = 400 * rows / B
    win_ops = 6 * n * m + 10 * nf * m + 30 * nf + 6 * P + 2 * 34 * P
    print(f"\nFloor by operation count: EKF ~400 flops a step x {rows / B:.0f} rows = "
          f"{ekf_ops / 1e3:.0f} k; a window: Burg ~{6 * n * m / 1e3:.0f} k, lattice PSD "
          f"~{10 * nf * m / 1e3:.0f} k, peaks ~{30 * nf / 1e3:.0f} k, slopes {6 * P / 1e3:.0f} "
          f"k, selection median 2 x 34 passes x {P} = {2 * 34 * P / 1e3:.0f} k compares; "
          f"at {n_win / B:.2f} windows a track: "
          f"{(ekf_ops + win_ops * n_win / B) / 1e3:.0f} k operations a track.")


if __name__ == "__main__":
    main()
