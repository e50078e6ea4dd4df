"""Frames per second of detect + track + rhythm (the online tracker) at 512x512 with 1 and 5
objects, against the plain OpenCV floor (absdiff + Sobel + threshold + projections) on the same
frames, in one process, with and without the candidate windows B (`body.window_candidates`).
Prints a markdown table.

    python benchmarks/bench_pipeline.py [--frames 150] [--repeat 5] [--xla-inline]
    python benchmarks/bench_pipeline.py --toggle body.window_mean_refused --toggle size.every_window

The floor and the pipeline are timed alternately (best of `repeat` each), so a load change on
shared cores hits both. `--xla-inline` runs XLA's per-frame step on the calling thread
(XLA_FLAGS `--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1`, set before jax
is imported); on 2 shared cores it made no consistent difference (README, Benchmarks).
"""

from __future__ import annotations

import argparse
import os
import time

import cv2
import numpy as np


def scenes(n_frames: int):
    from rhythmjax.sim.scene import SceneSpec, dog, render_scene, walker

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


def pipeline(cfg, frames: np.ndarray, fps: float, candidates: bool = False,
             changes: dict | None = None) -> int:
    """The online tracker over `frames`; `candidates`: with the candidate windows B
    (`body.window_candidates`: three more window B sums a row, four spectra a rhythm window);
    `changes`: further option changes (`--toggle`)."""
    from rhythmjax.track.options import TrackerOptions, with_changes
    from rhythmjax.track.tracker import OnlineTracker

    tr = OnlineTracker(cfg, with_changes(TrackerOptions(),
                                         {"body.window_candidates": candidates,
                                          **(changes or {})}))
    for i, f in enumerate(frames):
        tr.update(i, i / fps, f)
    _, verdicts, _ = tr.finish()
    return len(verdicts["track_id"])


def best_seconds(fns, repeat: int) -> list[float]:
    """Best wall time of each function, the functions timed in turn `repeat` times."""
    best = [float("inf")] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            best[i] = min(best[i], time.perf_counter() - t0)
    return best


SINGLE_THREAD_XLA = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=150)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--xla-inline", action="store_true", help="no XLA CPU thread pool")
    p.add_argument("--toggle", metavar="GROUP.FIELD", action="append", default=[],
                   help="time the tracker (defaults, candidates on) with these boolean options "
                        "all false against all true, interleaved (e.g. body.window_mean_refused)")
    a = p.parse_args(argv)
    if a.xla_inline:
        os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + " " + SINGLE_THREAD_XLA)
    from rhythmjax.model.params import Config

    cfg = Config()
    if a.toggle:
        return toggle(cfg, a)
    rows = []
    for n_obj, scene in scenes(a.frames).items():
        frames = scene.frames
        pipeline(cfg, frames, scene.fps)  # compile (and warm the classify window)
        pipeline(cfg, frames, scene.fps, True)
        f_s, p_s, c_s = best_seconds([
            lambda fr=frames: floor(fr),
            lambda fr=frames, sc=scene: pipeline(cfg, fr, sc.fps),
            lambda fr=frames, sc=scene: pipeline(cfg, fr, sc.fps, True)], a.repeat)
        rows.append((n_obj, len(frames) / p_s, (len(frames) - 1) / f_s, len(frames) / c_s))
    import jax

    print(f"512x512, {a.frames} frames, best of {a.repeat}; {os.cpu_count()} CPUs, "
          f"jax {jax.__version__} on {jax.default_backend()}, OpenCV {cv2.__version__} "
          f"({cv2.getNumThreads()} threads), XLA thread pool {'off' if a.xla_inline else 'on'}"
          "\n")
    print("| objects | detect + track + rhythm (fps) | OpenCV floor (fps) | ratio floor/pipeline "
          "| with candidate windows B (fps) | ratio floor/that |")
    print("|---|---|---|---|---|---|")
    for n_obj, p_fps, f_fps, c_fps in rows:
        print(f"| {n_obj} | {p_fps:.0f} | {f_fps:.0f} | {f_fps / p_fps:.1f}x | {c_fps:.0f} "
              f"| {f_fps / c_fps:.1f}x |")
    return 0


def toggle(cfg, a) -> int:
    """`--toggle`: frames per second of the tracker with the named options false and true."""
    off, on = ({k: v for k in a.toggle} for v in (False, True))
    print(f"512x512, {a.frames} frames, best of {a.repeat}, interleaved; options "
          f"{', '.join(a.toggle)}\n")
    print("| objects | false (fps) | true (fps) | time true / false |\n|---|---|---|---|")
    for n_obj, scene in scenes(a.frames).items():
        runs = [lambda c=c, sc=scene: pipeline(cfg, sc.frames, sc.fps, True, c) for c in (off, on)]
        for run in runs:
            run()  # compile
        t_off, t_on = best_seconds(runs, a.repeat)
        n = len(scene.frames)
        print(f"| {n_obj} | {n / t_off:.0f} | {n / t_on:.0f} | {t_on / t_off:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
