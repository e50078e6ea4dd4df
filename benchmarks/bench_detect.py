"""Frames/s of detection at 512x512: the plain OpenCV floor against rhythmjax.vision.detect.

floor: absdiff + Sobel d/dx + two thresholds + add + full-frame projections (cv2.reduce).
detect: motion_image + per object detect_in_window (120 x 160 px window) + window_b_intensity;
"+ W" adds walker_width_px (one batched jitted JAX call per frame). Frames: a textured background
with 5 dark walkers moving 2 px/frame, pre-rendered.
Run: python benchmarks/bench_detect.py [--frames N]
"""

from __future__ import annotations

import argparse
import time

import cv2
import numpy as np

from rhythmjax.model.params import Camera, WidthModel
from rhythmjax.vision.detect import (
    detect_in_window,
    motion_image,
    walker_width_px,
    window_b_intensity,
)


S = 512
T = 20.0


def scene(n: int, seed: int = 0) -> tuple[list[np.ndarray], list[list[tuple[float, float]]]]:
    rng = np.random.default_rng(seed)
    tex = cv2.resize(rng.normal(0, 1, (S // 8, S // 8)), (S, S), interpolation=cv2.INTER_CUBIC)
    bg = np.clip(150 + 25 * tex, 0, 255).astype(np.uint8)
    starts = [(40 + 90 * j, 300 + 40 * (j % 3)) for j in range(5)]
    frames, feet = [], []
    for k in range(n):
        f = bg.copy()
        fk = []
        for x0, bottom in starts:
            x = x0 + 2 * (k % 40)
            cv2.rectangle(f, (x, bottom - 90), (x + 29, bottom - 35), 40, -1)
            s = int(6 * np.sin(0.9 * k))
            for hx, sw in ((x + 4, s), (x + 18, -s)):
                leg = np.array([[hx, bottom - 35], [hx + 7, bottom - 35], [hx + sw + 7, bottom],
                                [hx + sw, bottom]], np.int32)
                cv2.fillPoly(f, [leg], 55)
            fk.append((x + 14.5, float(bottom)))
        frames.append(np.clip(f + rng.normal(0, 2, f.shape), 0, 255).astype(np.uint8))
        feet.append(fk)
    return frames, feet


def floor(prev: np.ndarray, cur: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = cv2.absdiff(prev, cur)
    _, t = cv2.threshold(d, T, 1, cv2.THRESH_BINARY)
    _, e = cv2.threshold(cv2.convertScaleAbs(cv2.Sobel(d, cv2.CV_16S, 1, 0, ksize=3)), 4 * T, 1,
                         cv2.THRESH_BINARY)
    m = cv2.add(t, e)
    return cv2.reduce(m, 0, cv2.REDUCE_SUM, dtype=cv2.CV_32S), cv2.reduce(m, 1, cv2.REDUCE_SUM,
                                                                          dtype=cv2.CV_32S)


def rate(step, frames, feet, n_obj: int, reps: int) -> float:
    n = len(frames)
    for k in range(1, min(n, 5)):  # warm-up (JIT compilation included)
        step(frames[k - 1], frames[k], feet[k][:n_obj])
    t0 = time.perf_counter()
    for _ in range(reps):
        for k in range(1, n):
            step(frames[k - 1], frames[k], feet[k][:n_obj])
    return reps * (n - 1) / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=80)
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args()
    frames, feet = scene(a.frames)
    cam, wm = Camera(), WidthModel()

    def detect(prev, cur, pts, with_w=False):
        m, d = motion_image(prev, cur, diff_threshold=T)
        dets = [det for u, v in pts if (det := detect_in_window(m, (u, v), (120, 160)))]
        if with_w:  # one batched JAX call for all objects of the frame
            ws = walker_width_px(cam, wm, np.array([x.u for x in dets]),
                                 np.array([x.v for x in dets]))
        else:
            ws = [30.0] * len(dets)
        for det, w in zip(dets, ws):
            window_b_intensity(d, det.u, det.v, w)

    fl = rate(lambda p, c, _: floor(p, c), frames, feet, 0, a.reps)
    rows = [("OpenCV floor", "-", fl)]
    for n_obj in (1, 5):
        rows.append(("detect", str(n_obj), rate(detect, frames, feet, n_obj, a.reps)))
        rows.append(("detect + W", str(n_obj),
                     rate(lambda p, c, q: detect(p, c, q, True), frames, feet, n_obj, a.reps)))
    print(f"512x512, {a.frames - 1} frame pairs x {a.reps}, cv2 threads {cv2.getNumThreads()}\n")
    print("| pipeline | objects | frames/s | floor / this |")
    print("| --- | --- | ---: | ---: |")
    for name, n_obj, r in rows:
        print(f"| {name} | {n_obj} | {r:,.0f} | {fl / r:.2f} |")


if __name__ == "__main__":
    main()
