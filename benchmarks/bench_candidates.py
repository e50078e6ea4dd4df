"""Candidate windows B in the batch classifier: each window's speed once for every signal.

    python benchmarks/bench_candidates.py [--windows 4096] [--candidates 3] [--repeat 5]

W complete rhythm windows of N = 64 samples (a walker's ground track at 1.4 m/s with 5 cm of
noise, its foot points measured, random rhythm signals) packed as the batch classifier packs
them, with C - 1 candidate signals. Three ways, side by side in this process, each compiled
first, best of `--repeat`:

- shared: `windows.classify_windows_packed_candidates`, the speeds (steps 1-2 of
  `model.window_block`) once a block, step 3 once per signal (what `classify` runs);
- per signal: `windows.classify_windows_packed` once per signal (speeds and step 3 every
  time: what `classify` ran before);
- floor: `windows.classify_windows_packed` of window B alone (no candidates).

Prints ms per call, the speed-up of shared against per signal, and shared against the floor
(the ideal, with step 3 ~20 % of a block: 1 + 0.2 (C - 1)). Results are checked equal between
the first two ways.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rhythmjax.model.params import Config
from rhythmjax.model.windows import (
    classify_windows_packed,
    classify_windows_packed_candidates,
)


def packed_windows(W: int, n: int, extra: int, seed: int = 0) -> np.ndarray:
    """(6 + extra, W, n) float32: intensity, dt, x, y, observed u, v, then `extra` signals."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 15.0
    out = np.empty((6 + extra, W, n), np.float32)
    out[0] = 100 + 30 * np.sin(2 * np.pi * 2.0 * t) + rng.normal(0, 10, (W, n))
    out[1] = 1 / 15.0
    out[2] = 1.4 * t + rng.normal(0, 0.05, (W, n))
    out[3] = 10.0 + rng.normal(0, 0.05, (W, n))
    out[4] = 200 + 10 * t
    out[5] = 300.0
    for c in range(extra):
        out[6 + c] = out[0] + rng.normal(0, 20, (W, n))
    return out


def best(f, repeat: int) -> float:
    f()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--windows", type=int, default=4096)
    p.add_argument("--candidates", type=int, default=3, help="candidate signals besides window B")
    p.add_argument("--repeat", type=int, default=5)
    a = p.parse_args(argv)
    cfg = Config()
    packed = packed_windows(a.windows, cfg.thresholds.n, a.candidates)
    rows = [0] + list(range(6, 6 + a.candidates))

    def per_signal():
        out = []
        for r in rows:
            one = packed[:6].copy()
            one[0] = packed[r]
            out.append(classify_windows_packed(cfg, one))
        return out

    shared = classify_windows_packed_candidates(cfg, packed)
    for x, y in zip(shared, per_signal(), strict=True):
        for k in x:
            np.testing.assert_array_equal(x[k], y[k], err_msg=k)
    t_shared = best(lambda: classify_windows_packed_candidates(cfg, packed), a.repeat)
    t_per = best(per_signal, a.repeat)
    t_floor = best(lambda: classify_windows_packed(cfg, packed[:6]), a.repeat)
    C = 1 + a.candidates
    print(f"{a.windows} windows, {C} signals each (window B + {a.candidates} candidates)")
    print("| way | ms | x floor |\n|---|---|---|")
    for name, t in (("shared speeds", t_shared), ("per signal", t_per),
                    ("floor: window B alone", t_floor)):
        print(f"| {name} | {1e3 * t:.0f} | {t / t_floor:.2f} |")
    print(f"\nshared against per signal: {t_per / t_shared:.2f}x faster; ideal against the floor "
          f"(step 3 ~20 % of a block): {1 + 0.2 * (C - 1):.1f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
