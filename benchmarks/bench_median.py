"""The exact median of the Theil-Sen speed (12) per rhythm window: `windows.nanmedian_exact`
(32-level bisection on int32 keys), `windows.nanmedian_select` (a sorted sample's bracket,
interpolation passes with data values as trial keys, min / max resolution; the medians it
leaves unresolved taken again by `nanmedian_exact`) and `jnp.nanmedian` (float sort), side by
side in one process.

    python benchmarks/bench_median.py [--blocks 8] [--repeat 5] [--seed 0] [--sweep]
        [--tracks 200]

Data: the slopes (`windows.window_slopes`, 2 x 2016 per window at N = 64) of synthetic walkers
(ground position linear in t, projected to the image with pixel noise of 0.5-3 px, a share of
0-80 % of the foot points missing, so that both position sets occur; the filtered positions
lag) in blocks of `windows.WINDOW_BLOCK` windows, vmapped + jitted as in
`classify_window_block`. Prints us per window (best of --repeat warm calls per block, summed
over blocks), the fallback rate and a bit-for-bit check against `nanmedian_exact` (and a value
check against `jnp.nanmedian`); then the whole window: the exact `classify_window_block` (one
program per block), the old `classify_window_rows` (that program per block + host work,
`rows_exact`) and the new one (select speeds, fallback medians from the slopes, classification
with the given speeds); --tracks W: the fallback rate over every complete window of the Fig. 3
segments of `make_tracks` tracks with W walkers (a tenth bicycles, a tenth dogs).
Single-threaded XLA CPU unless XLA_FLAGS says otherwise. --sweep also times other (stride,
spread, steps).

Measured (2-core machine shared with other jobs, load 1-3.6, 1024 windows, best of 5):
nanmedian_exact 23.1-24.3 us/window, nanmedian_select (64, 3, 8) 11.2-11.8 us/window with
3.4 % of the windows falling back (4.3 % of the 353 windows of make_tracks with 200 walkers);
jnp.nanmedian ~385. The whole window through classify_window_rows: 56.8-60.5 us/window old,
50.0-51.6 new. A bracket + compact + sort variant (top_k of the entries inside a sample's
bracket) was slower than the bisection: XLA CPU's TopK with k = 256 costs ~40 us/window,
cumsum + scatter compaction ~30.
"""

from __future__ import annotations

import argparse
import os
import time


os.environ.setdefault("JAX_PLATFORMS", "cpu")
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false "
                      "intra_op_parallelism_threads=1")

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from rhythmjax.model.camera_np import project_3d  # noqa: E402
from rhythmjax.model.params import Config  # noqa: E402
from rhythmjax.model.rhythm import window_times  # noqa: E402
from rhythmjax.model.windows import (  # noqa: E402
    WINDOW_BLOCK,
    classify_window_block,
    classify_window_rows,
    nanmedian_exact,
    nanmedian_select,
    window_slopes,
)


def walkers(cfg: Config, W: int, seed: int):
    """dt (W, N), xy (W, N, 2) m, observed (W, N, 2) px of W synthetic walkers' windows."""
    rng = np.random.default_rng(seed)
    cam, N = cfg.camera, cfg.thresholds.n
    t = np.cumsum(np.full((W, N), 1.0 / float(cam.fps)) * (1 + 0.02 * rng.random((W, N))), 1)
    x0, y0 = rng.uniform(-3, 3, (W, 1)), rng.uniform(5, 15, (W, 1))
    vx, vy = rng.normal(0, 1.2, (W, 1)), rng.normal(0, 1.2, (W, 1))
    x, y = x0 + vx * t, y0 + vy * t
    u, v = project_3d(cam, x, y, 0.0)
    px = rng.uniform(0.5, 3.0, (W, 1))
    uv = np.stack([u + px * rng.normal(size=u.shape), v + px * rng.normal(size=v.shape)], -1)
    uv[rng.random((W, N)) < rng.uniform(0, 0.8, (W, 1))] = np.nan
    xy = np.stack([x0 + 0.7 * vx * t, y0 + 0.7 * vy * t], -1)
    xy = xy + 0.01 * rng.normal(size=xy.shape)
    dt = np.diff(t, axis=1, prepend=t[:, :1] - 1.0 / float(cam.fps))
    return [np.asarray(a, np.float32) for a in (dt, xy, uv)]


def track_windows(cfg: Config, walkers: int, seed: int):
    """Every complete window of the Fig. 3 segments of `sim.tracks.make_tracks` tracks
    (walkers, a tenth bicycles and dogs), as `fast_batch` gathers them: dt, xy, observed."""
    import tempfile

    from rhythmjax.io import read_tracks, to_batch, write_table
    from rhythmjax.model.fast_batch import Segments
    from rhythmjax.model.segments import filter_rounds
    from rhythmjax.sim.tracks import make_tracks

    cols, _ = make_tracks(n_walkers=walkers, n_bicycles=walkers // 10, n_dogs=walkers // 10,
                          n_cars=1, seed=seed, max_frames=120)
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "t.csv")
        write_table(path, cols, list(cols))
        tracks = read_tracks(path, fps=cfg.camera.fps)
    gap = max(1, round(float(cfg.thresholds.predict_timeout) * cfg.camera.fps))
    batch = to_batch(tracks, max_gap_frames=gap, min_len=cfg.thresholds.n)
    segs = Segments(cfg, list(filter_rounds(cfg, batch)))
    seg = np.repeat(np.arange(len(segs)), segs.windows)
    j = np.arange(len(seg)) - np.repeat(np.cumsum(segs.windows) - segs.windows, segs.windows)
    _, dt, xy, obs = segs.gather(seg, j)
    return dt, xy, obs


def rows_exact(cfg: Config, *arrays: np.ndarray) -> dict[str, np.ndarray]:
    """The old `classify_window_rows`: `classify_window_block` (bisection median) over every
    block, the results as NumPy (the same host work as the new one, without its fallback)."""
    W, parts = len(arrays[0]), []
    for s in range(0, W, WINDOW_BLOCK):
        rows = np.r_[np.arange(s, min(s + WINDOW_BLOCK, W)),
                     np.zeros(max(0, s + WINDOW_BLOCK - W), np.int64)]
        parts.append(classify_window_block(cfg, *(jnp.asarray(a[rows]) for a in arrays)))
    return {f: np.concatenate([np.asarray(getattr(r, f)) for r in parts])[:W]
            for f in ("verdict", "speed_mps")}


def best(f, x, repeat: int) -> float:
    jax.block_until_ready(f(x))
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        jax.block_until_ready(f(x))
        out.append(time.perf_counter() - t)
    return min(out)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--blocks", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sweep", action="store_true")
    ap.add_argument("--tracks", type=int, default=0,
                    help="also the fallback rate over every window of make_tracks tracks "
                         "with this many walkers")
    args = ap.parse_args()
    cfg = Config()
    W = WINDOW_BLOCK * args.blocks
    dt, xy, uv = walkers(cfg, W, args.seed)
    slopes_of = jax.jit(jax.vmap(lambda d, p, o: window_slopes(cfg, window_times(d), p, o)[0]))
    blocks = [slopes_of(dt[s:s + WINDOW_BLOCK], xy[s:s + WINDOW_BLOCK], uv[s:s + WINDOW_BLOCK])
              for s in range(0, W, WINDOW_BLOCK)]  # (128, 2, 2016) each
    nan_share = float(np.mean([np.isnan(np.asarray(b)).mean() for b in blocks]))
    old = jax.jit(jax.vmap(nanmedian_exact))
    ref = jax.jit(jax.vmap(lambda s: jnp.nanmedian(s, axis=-1)))
    variants = {"select (64, 3, 8)": (64, 3, 8)}
    if args.sweep:
        variants.update({f"select ({s}, {d}, {i})": (s, d, i) for s, d, i in
                         ((64, 3, 9), (64, 2, 8), (128, 2, 8), (32, 3, 8))})
    fns = {name: jax.jit(jax.vmap(lambda s, v=v: nanmedian_select(s, *v)))
           for name, v in variants.items()}
    print(f"{W} windows in blocks of {WINDOW_BLOCK}, NaN share of the slopes {nan_share:.2f}, "
          f"load {os.getloadavg()[0]:.2f}")
    t_old = sum(best(old, b, args.repeat) for b in blocks) / W * 1e6
    t_ref = sum(best(ref, b, args.repeat) for b in blocks[:1]) / WINDOW_BLOCK * 1e6
    exact = [np.asarray(old(b)) for b in blocks]
    for b, e in zip(blocks[:1], exact):
        np.testing.assert_array_equal(np.asarray(ref(b)), e)  # value equality (== for +-0)
    print(f"| nanmedian_exact (old) | {t_old:.2f} us/window |")
    print(f"| jnp.nanmedian (1 block) | {t_ref:.2f} us/window |")
    for name, f in fns.items():
        t_new = sum(best(f, b, args.repeat) for b in blocks) / W * 1e6
        fails, windows_failed = 0, 0
        for b, e in zip(blocks, exact):
            med, ok = (np.asarray(a) for a in f(b))
            assert np.array_equal(med[ok].view(np.int32), e[ok].view(np.int32)), name
            fails += int((~ok).sum())
            windows_failed += int((~ok.all(-1)).sum())
        # the fallback: the failed windows' medians again by nanmedian_exact (a 16-window call)
        t_fb = best(jax.jit(jax.vmap(nanmedian_exact)), blocks[0][:16], args.repeat) / 16 * 1e6
        rate = windows_failed / W
        print(f"| {name} | {t_new:.2f} us/window | fallback {rate:.2%} of windows "
              f"({fails} of {2 * W} medians) | with fallback ~{t_new + rate * t_fb:.2f} |")
    # the whole window: the exact block (old path) vs classify_window_rows (select + fallback)
    rng = np.random.default_rng(args.seed)
    t = np.cumsum(dt, axis=1)
    inten = (1.0 + 0.3 * np.sin(2 * np.pi * rng.uniform(1.5, 2.5, (W, 1)) * t)
             + 0.05 * rng.normal(size=t.shape)).astype(np.float32)
    rows = [tuple(jnp.asarray(a[s:s + WINDOW_BLOCK]) for a in (inten, dt, xy, uv))
            for s in range(0, W, WINDOW_BLOCK)]
    t_blk = sum(best(lambda r: classify_window_block(cfg, *r), r, args.repeat)
                for r in rows) / W * 1e6
    t_rows = best(lambda _: classify_window_rows(cfg, inten, dt, xy, uv), None,
                  args.repeat) / W * 1e6
    t_old_rows = best(lambda _: rows_exact(cfg, inten, dt, xy, uv), None, args.repeat) / W * 1e6
    print(f"| whole window, exact block (old) | {t_blk:.2f} us/window |")
    print(f"| whole window, old classify_window_rows (exact block, host) | {t_old_rows:.2f} "
          f"us/window |")
    print(f"| whole window, classify_window_rows (select + fallback, host) | {t_rows:.2f} "
          f"us/window |")
    if args.tracks:
        dt, xy, obs = track_windows(cfg, args.tracks, args.seed)
        sel = jax.jit(jax.vmap(lambda d, p, o: nanmedian_select(
            window_slopes(cfg, window_times(d), p, o)[0])[1]))
        ok = np.concatenate([np.asarray(sel(dt[s:s + WINDOW_BLOCK], xy[s:s + WINDOW_BLOCK],
                                            obs[s:s + WINDOW_BLOCK]))
                             for s in range(0, len(dt), WINDOW_BLOCK)])
        print(f"make_tracks ({args.tracks} walkers): {len(dt)} windows, fallback "
              f"{(~ok.all(-1)).mean():.2%} of windows ({(~ok).sum()} of {ok.size} medians)")


if __name__ == "__main__":
    main()
