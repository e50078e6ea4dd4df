"""Cost of the noise-adaptive foreground threshold (`vision.fg_threshold`): time per frame of
`BackgroundModel.apply` + `find_blobs` on `bench_blobs.py`'s 768x576 scene (6 walkers, sensor
noise), fixed threshold (OFF) against noise_k 3.89 (ON) and ON with hysteresis 0.5 (2 px),
interleaved blocks, medians of the blocks (wall and process CPU, ms/frame).

    python benchmarks/bench_fg_threshold.py [--frames 200] [--blocks 5]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_blobs import scene, timed  # noqa: E402

from rhythmjax.vision.blobs import BackgroundModel, find_blobs  # noqa: E402


VARIANTS = {"off": {}, "noise": {"noise_k": 3.89},
            "noise+hyst": {"noise_k": 3.89, "hysteresis": 0.5, "hysteresis_px": 2}}


def run(frames, kw: dict):
    def go():
        model = BackgroundModel(frames[0], **kw)
        return [find_blobs(model.apply(f))[0] for f in frames[1:]]
    return timed(go, len(frames) - 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--blocks", type=int, default=5)
    a = ap.parse_args()
    frames = scene(a.frames)
    res: dict[str, list] = {k: [] for k in VARIANTS}
    nblobs: dict[str, float] = {}
    for _ in range(a.blocks):
        for k, kw in VARIANTS.items():
            dt, blobs = run(frames, kw)
            res[k].append(dt)
            nblobs[k] = sum(len(b) for b in blobs) / len(blobs)
    print(f"768x576, {a.frames} frames, {a.blocks} interleaved blocks, medians:")
    for k, v in res.items():
        wall = statistics.median(x[0] for x in v)
        cpu = statistics.median(x[1] for x in v)
        print(f"  {k:11s} wall {1e3 * wall:6.3f} ms/frame, cpu {1e3 * cpu:6.3f} ms/frame, "
              f"{nblobs[k]:.1f} blobs/frame")


if __name__ == "__main__":
    main()
