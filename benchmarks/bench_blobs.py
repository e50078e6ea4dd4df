"""Time per frame of the images + blobs levels at 768x576 with 6 walkers, against the plain
OpenCV floor, side by side in one process (interleaved blocks, median of the blocks).

floor:     cv2.absdiff(frame, background) + cv2.threshold + cv2.connectedComponentsWithStats
           (OpenCV's default int32 labels), against a fixed background image.
floor16:   the same with 16-bit labels (what find_blobs uses first).
blobs:     BackgroundModel.apply (selective running average, open 3x3, close 5x5) + find_blobs
           (stats, perimeters from box crops).
graph:     blob_graph between successive frames' blobs (on the blobs found above).
Frames: a textured background with sensor noise and 6 dark walkers (body + swinging legs) that
cross one another (merges and splits), pre-rendered. Run: python benchmarks/bench_blobs.py
[--frames N] [--blocks B] [--threads T]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import cv2
import numpy as np

from rhythmjax.vision.blobgraph import blob_graph
from rhythmjax.vision.blobs import BackgroundModel, find_blobs


W, H = 768, 576


def scene(n: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    tex = cv2.resize(rng.normal(0, 1, (H // 8, W // 8)), (W, H), interpolation=cv2.INTER_CUBIC)
    bg = np.clip(150 + 25 * tex, 0, 255).astype(np.uint8)
    # 6 walkers: x0, foot row, px per frame (opposite directions, so they cross)
    walkers = [(40, 300, 3), (700, 320, -3), (100, 420, 2), (650, 440, -2), (300, 520, 4),
               (500, 250, -4)]
    frames = []
    for k in range(n):
        f = bg.copy()
        for x0, bottom, vx in walkers:
            x = int((x0 + vx * k) % (W - 40))
            hgt = bottom // 3
            cv2.rectangle(f, (x, bottom - hgt), (x + hgt // 4, bottom - hgt // 2), 40, -1)
            s = int(0.1 * hgt * np.sin(0.9 * k))
            for hx, sw in ((x + 2, s), (x + hgt // 4 - 8, -s)):
                leg = np.array([[hx, bottom - hgt // 2], [hx + 6, bottom - hgt // 2],
                                [hx + sw + 6, bottom], [hx + sw, bottom]], np.int32)
                cv2.fillConvexPoly(f, leg, 40)
        noise = rng.integers(-4, 5, (H, W), dtype=np.int16)
        frames.append(np.clip(f.astype(np.int16) + noise, 0, 255).astype(np.uint8))
    return frames


def timed(fn: Callable[[], object], n: int) -> tuple[tuple[float, float], object]:
    """((wall s, CPU s of this process) per item, fn's result) for n items."""
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return ((time.perf_counter() - t) / n, (time.process_time() - c) / n), out


def run_floor(frames: list[np.ndarray], ltype: int) -> tuple[float, float]:
    def go() -> None:
        bg = frames[0]
        for f in frames[1:]:
            d = cv2.absdiff(f, bg)
            _, m = cv2.threshold(d, 20, 1, cv2.THRESH_BINARY)
            cv2.connectedComponentsWithStats(m, connectivity=8, ltype=ltype)
    return timed(go, len(frames) - 1)[0]


def run_blobs(frames: list[np.ndarray]) -> tuple[tuple[float, float], list[list]]:
    def go() -> list[list]:
        model = BackgroundModel(frames[0])
        return [find_blobs(model.apply(f))[0] for f in frames[1:]]
    return timed(go, len(frames) - 1)  # type: ignore[return-value]


def run_graph(blobs: list[list]) -> tuple[tuple[float, float], dict[str, int]]:
    stats = {"merges": 0, "splits": 0, "appeared": 0, "vanished": 0, "greedy": 0, "blobs": 0}
    dt, graphs = timed(lambda: [blob_graph(a, b) for a, b in zip(blobs[:-1], blobs[1:])],
                       max(len(blobs) - 1, 1))
    for g in graphs:  # type: ignore[attr-defined]
        stats["merges"] += len(g.merges)
        stats["splits"] += len(g.splits)
        stats["appeared"] += len(g.appeared)
        stats["vanished"] += len(g.vanished)
        stats["greedy"] += g.n_greedy
        stats["blobs"] += g.n_cur
    return dt, stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--blocks", type=int, default=5)
    ap.add_argument("--threads", type=int, default=None, help="cv2.setNumThreads")
    args = ap.parse_args()
    if args.threads is not None:
        cv2.setNumThreads(args.threads)
    frames = scene(args.frames)
    res: dict[str, list[tuple[float, float]]] = {"floor": [], "floor16": [], "blobs": [],
                                                 "graph": []}
    stats: dict[str, int] = {}
    for _ in range(args.blocks):
        res["floor"].append(run_floor(frames, cv2.CV_32S))
        res["floor16"].append(run_floor(frames, cv2.CV_16U))
        dt, blobs = run_blobs(frames)
        res["blobs"].append(dt)
        dt, stats = run_graph(blobs)
        res["graph"].append(dt)
    print(f"768x576, {args.frames} frames, {args.blocks} interleaved blocks, "
          f"cv2 threads {cv2.getNumThreads()}, medians (wall; CPU of the process):")
    for which, name in ((0, "wall"), (1, "cpu")):
        med = {k: statistics.median(v[which] for v in vs) for k, vs in res.items()}
        for k, v in med.items():
            print(f"  {name} {k:8s} {1e3 * v:7.3f} ms/frame  {1 / v:8.1f} fps")
        both = med["blobs"] + med["graph"]
        print(f"  {name} blobs+graph {1e3 * both:.3f} ms/frame ({1 / both:.1f} fps); "
              f"blobs / floor = {med['blobs'] / med['floor']:.2f}, blobs / floor16 = "
              f"{med['blobs'] / med['floor16']:.2f}, (blobs + graph) / floor = "
              f"{both / med['floor']:.2f}")
    print(f"  per frame: {stats['blobs'] / (args.frames - 2):.1f} blobs; over the run: "
          + ", ".join(f"{k} {v}" for k, v in stats.items() if k != "blobs"))


if __name__ == "__main__":
    main()
