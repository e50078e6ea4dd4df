"""The counting tracker's window B against the truth foot point: for the tracks on a walker that
were judged for one reason (default "no-peak"), the best spectral peak P of their rhythm windows
with I(k) as the track sampled it and with I(k) sampled in window B at the walker's truth foot
point (its box's bottom centre, W the camera's patch width there) in the same frames, and how far
the track's foot point lay from the truth (row, column px; medians). Windows: N rows from the
track's first, every N/2, only those without a stitching gap and with at most N/4 missing.
Issue 16, twenty-third round (docs/rules.md): is a walker's missing peak the window or the signal?

    python benchmarks/study_count_window_b.py --seed 160001,160002,160003 --scenes 10 \\
        [--reason no-peak] [--set placement.shared_row_gate=true]

Own counting scenes only (the truth boxes of `count_dump.py count`). Nothing is chosen here.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def window_starts(frames: np.ndarray, n: int) -> list[int]:
    """First rows of the rhythm windows of a track whose rows hold frame indices `frames`: every
    n // 2 rows from 0 while n rows remain, skipping a window whose frames are not consecutive
    (a stitching gap inside it)."""
    return [s for s in range(0, len(frames) - n + 1, n // 2)
            if frames[s + n - 1] - frames[s] == n - 1]


def best_power(cfg, intensity: np.ndarray, t: np.ndarray, xy: np.ndarray,
               starts: list[int]) -> float:
    """The strongest spectral peak P (`rhythm.classify_window`'s peak power) over the windows
    starting at `starts`, NaN where none has at most N/4 missing samples."""
    import jax.numpy as jnp

    from rhythmjax.model.rhythm import classify_window_jit

    n, best = int(cfg.thresholds.n), np.nan
    for s in starts:
        x = intensity[s:s + n]
        if np.mean(np.isnan(x)) > 0.25:
            continue
        r = classify_window_jit(cfg, jnp.asarray(x), jnp.asarray(t[s:s + n]),
                                jnp.asarray(xy[s:s + n]), jnp.asarray(True))
        p = float(np.max(np.where(np.asarray(r.peak_mask), np.asarray(r.peak_power), 0.0)))
        best = p if not p <= best else best
    return best


def track_against_truth(cfg, shape, res, grays: dict, truth, kinds, offset: int, reason: str):
    """Per track judged for `reason` on a walker: (clip rows, best P on the track's I(k), best P
    at the truth foot point, median |row| and |column| px off the truth)."""
    import eval_count as ec
    from study_track_ends import truth_frame

    from rhythmjax.vision.detect import frame_difference
    from rhythmjax.vision.window_b import window_b_intensity

    own = ec.owner_of_tracks(truth, res.mot, offset)
    v, tr, n = res.verdicts, res.tracks, int(cfg.thresholds.n)
    ids = np.asarray(tr["track_id"])
    out = []
    for i, tid in enumerate(v["track_id"]):
        o = own.get(int(tid))
        if v["reason"][i] != reason or o is None or kinds[o] != "pedestrian":
            continue
        k = np.flatnonzero(ids == tid)
        fr = np.asarray(tr["frame"])[k]
        t = np.asarray(tr["t"], np.float64)[k]
        xy = np.stack([np.asarray(tr[c], np.float64)[k] for c in ("x_est", "y_est")], 1)
        u_tr, v_tr = (np.asarray(tr[c], np.float64)[k] for c in ("u", "v"))
        at_truth, off = np.full(len(k), np.nan), []
        for j, f in enumerate(fr):
            m = np.flatnonzero((truth["id"] == o) & (truth["frame"] == truth_frame(int(f), offset)))
            if f < 1 or not m.size:
                continue
            u = truth["bb_left"][m[0]] + 0.5 * truth["bb_width"][m[0]]
            vv = truth["bb_top"][m[0]] + truth["bb_height"][m[0]] - 1.0  # box bottom: v + 1
            at_truth[j] = window_b_intensity(frame_difference(grays[f - 1], grays[f]), u, vv,
                                             float(shape.size(u, vv)[0]))
            if np.isfinite(v_tr[j]):
                off.append((abs(v_tr[j] - vv), abs(u_tr[j] - u)))
        starts = window_starts(fr, n)
        sampled = np.asarray(tr["intensity"], np.float64)[k]
        row, col = np.median(np.asarray(off), axis=0) if off else (np.nan, np.nan)
        out.append((len(k), best_power(cfg, sampled, t, xy, starts),
                    best_power(cfg, at_truth, t, xy, starts), float(row), float(col)))
    return out


def main(argv=None) -> int:
    from count_dump import clips_of

    from rhythmjax.count import CountOptions, count_frames
    from rhythmjax.count.patches import ShapeModel
    from rhythmjax.track.options import with_changes

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", default="160001")
    ap.add_argument("--scenes", type=int, default=10)
    ap.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    ap.add_argument("--focal-px", type=float, default=0.0)
    ap.add_argument("--reason", default="no-peak")
    ap.add_argument("--set", action="append", default=[])
    a = ap.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    rows = []
    for seed in a.seed.split(","):
        for _name, cfg, frames, truth, kinds, off, _ in clips_of("count", int(seed), a.scenes,
                                                                a.clothing, a.focal_px):
            res = count_frames(cfg, iter(frames), options=opt)
            shape = ShapeModel.from_config(cfg, opt.dynamics)
            rows += track_against_truth(cfg, shape, res, {k: g for k, _, g in frames}, truth,
                                        kinds, off, a.reason)
    if not rows:
        print(f"no walker track judged {a.reason!r}")
        return 0
    r = np.asarray(rows, np.float64)
    judged = np.isfinite(r[:, 2])
    print(f"{len(r)} walker tracks judged {a.reason!r}: medians {np.median(r[:, 0]):.0f} rows, "
          f"best P {np.nanmedian(r[:, 1]):.1f} on the track's window B, "
          f"{np.nanmedian(r[:, 2]):.1f} at the truth foot point "
          f"({int(np.sum(r[judged, 2] >= 10))} of {int(judged.sum())} with a judged window "
          f">= 10 there); foot point off the truth {np.nanmedian(r[:, 3]):.1f} px in row, "
          f"{np.nanmedian(r[:, 4]):.1f} px in column")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
