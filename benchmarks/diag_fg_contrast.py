"""Per walker: its contrast against the background and how much of it the foreground mask keeps,
beside the noise of D = I - B on empty pixels (a diagnostic for the noise-adaptive threshold,
docs/rules.md "Noise-adaptive foreground threshold").

The counting front end's `vision.blobs.BackgroundModel` (the `count.CountOptions` blobs settings,
--set to change them) runs over each clip of a counting source (`count_dump.clips_of`); in each
frame, before the update:
- noise: sigma_empty = 1.4826 x median |D - median D| over the pixels outside every truth box
  (grown by 4 px), sigma_frame = the same over the whole frame, and sigma_est = what the
  noise-adaptive threshold estimates (`fg_threshold.noise_sigma`: every 4th row and column,
  the pixels the previous mask called background), grey levels; p9999 = the 99.99th percentile
  of |D| on empty pixels; zero = the fraction of the sampled |D| below 0.5 grey level;
- per walker box (truth, clipped): `c75` the 75th percentile of |D| in the box (grey levels: the
  walker covers about half its box), `raw` the fraction of box pixels with |D| > threshold and
  `fg` the fraction in the returned mask M, `lo` the fraction with |D| > 4 sigma_empty (what a
  threshold at 4 sigma would keep).
Per walker the medians over its frames; with --dump PKL (`count_dump.py` of the same source and
seed) each walker is marked by whether any track owns it (`eval_count.owner_of_tracks`).

    python benchmarks/diag_fg_contrast.py SOURCE [--seed S] [--scenes 10] [--dump PKL]
                                          [--set KEY=JSON ...]
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

MAD_SIGMA = 1.4826  # sigma of a Gaussian per median absolute deviation


def mad_sigma(x: np.ndarray) -> float:
    """1.4826 x the median absolute deviation from the median (grey levels)."""
    return float(MAD_SIGMA * np.median(np.abs(x - np.median(x)))) if x.size else float("nan")


def clip_stats(frames, truth, kinds, off: int, opt) -> tuple[dict, dict]:
    """(noise medians over the frames, per walker id the medians of c75, raw, fg, n frames)."""
    import cv2

    from rhythmjax.vision.blobs import BackgroundModel

    b = opt.blobs
    model = None
    from rhythmjax.vision.fg_threshold import NOISE_STEP, noise_sigma

    noise = {"sigma_empty": [], "sigma_frame": [], "sigma_est": [], "p9999": [], "zero": []}
    prev = None
    per: dict[int, list] = {}
    tf, tid = truth["frame"], truth["id"]
    for k, (_, _, gray) in enumerate(frames):
        if gray.ndim == 3:
            gray = cv2.cvtColor(gray, cv2.COLOR_BGR2GRAY)
        if model is None:
            model = BackgroundModel(gray, **b.model_kwargs())
            continue
        D = gray.astype(np.float32) - model.background
        raw = np.abs(D) > model.threshold
        est = noise_sigma(D, None if prev is None else (prev == 0).view(np.uint8))
        M = prev = model.apply(gray)
        rows = np.flatnonzero(tf == k + 1 + off)
        empty = np.ones(gray.shape, bool)
        H, W = gray.shape
        boxes = []
        for r in rows:
            x0, y0 = int(truth["bb_left"][r]), int(truth["bb_top"][r])
            x1 = int(np.ceil(truth["bb_left"][r] + truth["bb_width"][r]))
            y1 = int(np.ceil(truth["bb_top"][r] + truth["bb_height"][r]))
            x0, y0, x1, y1 = max(0, x0), max(0, y0), min(W, x1), min(H, y1)
            if x1 <= x0 or y1 <= y0:
                continue
            empty[max(0, y0 - 4):y1 + 4, max(0, x0 - 4):x1 + 4] = False
            boxes.append((int(tid[r]), x0, y0, x1, y1))
        if k < 15:  # the first second: B is still learning (ghosts)
            continue
        e = D[empty]
        sig = mad_sigma(e)
        noise["sigma_empty"].append(sig)
        noise["sigma_frame"].append(mad_sigma(D[::2, ::2]))
        noise["sigma_est"].append(est)
        noise["zero"].append(float(np.mean(np.abs(D[::NOISE_STEP, ::NOISE_STEP]) < 0.5)))
        noise["p9999"].append(float(np.percentile(np.abs(e), 99.99)))
        for t, x0, y0, x1, y1 in boxes:
            if kinds.get(t) != "pedestrian":
                continue
            a = np.abs(D[y0:y1, x0:x1])
            per.setdefault(t, []).append((float(np.percentile(a, 75)),
                                          float(raw[y0:y1, x0:x1].mean()),
                                          float(M[y0:y1, x0:x1].mean()),
                                          float((a > 4.0 * sig).mean())))
    med = {n: float(np.median(v)) for n, v in noise.items()}
    med["est_p10"], med["est_p90"] = np.percentile(noise["sigma_est"], [10, 90]).tolist()
    walkers = {t: (*np.median(np.asarray(v), 0).tolist(), len(v)) for t, v in per.items()}
    return med, walkers


def main(argv=None) -> int:
    import count_dump as cd
    from eval_count import owner_of_tracks

    from rhythmjax.count import CountOptions
    from rhythmjax.track.options import with_changes

    p = argparse.ArgumentParser()
    p.add_argument("source")
    p.add_argument("--seed", type=int, default=42024)
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--dump", default=None)
    p.add_argument("--set", action="append", default=[])
    a = p.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    dump = {}
    if a.dump:
        with open(a.dump, "rb") as f:
            dump = {r["clip"]: r for r in pickle.load(f)}
    print("clip  sigma_empty sigma_frame sigma_est (p10-p90) p9999 zero | walker c75 raw fg lo "
          "frames tracked")
    for name, _cfg, frames, truth, kinds, off, _ in cd.clips_of(a.source, a.seed, a.scenes):
        noise, walkers = clip_stats(frames, truth, kinds, off, opt)
        owned = None
        if name in dump:
            r = dump[name]
            owned = set(v for v in owner_of_tracks(r["truth"], r["mot"], r["offset"]).values()
                        if v is not None)
        print(f"{name}  {noise['sigma_empty']:.2f} {noise['sigma_frame']:.2f} "
              f"{noise['sigma_est']:.2f} ({noise['est_p10']:.2f}-{noise['est_p90']:.2f}) "
              f"{noise['p9999']:.1f} {noise['zero']:.2f}", flush=True)
        for t, (c75, raw, fg, lo, n) in sorted(walkers.items()):
            mark = "" if owned is None else (" yes" if t in owned else " NO TRACK")
            print(f"    {t:3d} {c75:6.1f} {raw:5.2f} {fg:5.2f} {lo:5.2f} {n:4d}{mark}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
