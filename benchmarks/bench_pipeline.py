"""Frames per second of detect + track + rhythm (the online tracker) at 512x512 with 1 and 5
objects, against the plain OpenCV floor (absdiff + Sobel + threshold + projections) on the same
frames, in one process. Prints a markdown table.

    python benchmarks/bench_pipeline.py [--frames 150] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import time

import cv2
import numpy as np


def scenes(n_frames: int):
    from rhythmjax.synth import SceneSpec, dog, render_scene, walker

    one = (walker(-3.4, 12.0, 0.0, pace_hz=1.9, step_length_m=0.62),)
    five = one + (walker(3.0, 7.0, 3.1, pace_hz=2.1, step_length_m=0.75),
                  walker(-1.0, 17.0, 0.3, pace_hz=2.0, step_length_m=0.7),
                  walker(1.5, 5.0, 1.9, pace_hz=1.8, step_length_m=0.65),
                  dog(-2.0, 9.5, 0.0, pace_hz=4.0, step_length_m=0.25))
    return {n: render_scene(7, SceneSpec(n_frames=n_frames, actors=acts))
            for n, acts in ((1, one), (5, five))}


def floor(frames: np.ndarray, thr: float = 15.0) -> None:
    """The plain OpenCV floor: absdiff + Sobel + threshold (both maps) + the two projections."""
    prev = frames[0]
    for cur in frames[1:]:
        d = cv2.absdiff(prev, cur)
        _, t = cv2.threshold(d, thr, 1, cv2.THRESH_BINARY)
        e = cv2.convertScaleAbs(cv2.Sobel(d, cv2.CV_16S, 1, 0, ksize=3))
        _, e = cv2.threshold(e, 4 * thr, 1, cv2.THRESH_BINARY)
        m = cv2.add(t, e)
        cv2.reduce(m, 0, cv2.REDUCE_SUM, dtype=cv2.CV_32S)
        cv2.reduce(m, 1, cv2.REDUCE_SUM, dtype=cv2.CV_32S)
        prev = cur


def pipeline(cfg, frames: np.ndarray, fps: float) -> int:
    from rhythmjax.tracker import OnlineTracker

    tr = OnlineTracker(cfg)
    for i, f in enumerate(frames):
        tr.update(i, i / fps, f)
    _, verdicts, _ = tr.finish()
    return len(verdicts["track_id"])


def best_fps(fn, n: int, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return n / min(times)


def main(argv=None) -> int:
    from rhythmjax.params import Config

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=150)
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args(argv)
    cfg = Config()
    rows = []
    for n_obj, scene in scenes(a.frames).items():
        frames = scene.frames
        pipeline(cfg, frames, scene.fps)  # compile (and warm the classify window)
        f_fps = best_fps(lambda fr=frames: floor(fr), len(frames) - 1, a.repeat)
        p_fps = best_fps(lambda fr=frames, sc=scene: pipeline(cfg, fr, sc.fps), len(frames),
                         a.repeat)
        rows.append((n_obj, p_fps, f_fps))
    import jax

    print(f"512x512, {a.frames} frames, best of {a.repeat}; {os.cpu_count()} CPUs, "
          f"jax {jax.__version__} on {jax.default_backend()}, OpenCV {cv2.__version__} "
          f"({cv2.getNumThreads()} threads)\n")
    print("| objects | detect + track + rhythm (fps) | OpenCV floor (fps) | ratio floor/pipeline |")
    print("|---|---|---|---|")
    for n_obj, p_fps, f_fps in rows:
        print(f"| {n_obj} | {p_fps:.0f} | {f_fps:.0f} | {f_fps / p_fps:.1f}x |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
