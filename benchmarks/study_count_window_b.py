"""The counting tracker's window B against the truth foot point: for the tracks on a walker that
were judged for one reason (default "no-peak"), the best spectral peak P of their rhythm windows
with I(k) as the track sampled it and with I(k) sampled in window B at the walker's truth foot
point (its box's bottom centre, W the camera's patch width there) in the same frames, and how far
the track's foot point lay from the truth (row, column px; medians). Windows: N rows from the
track's first, every N/2, only those without a stitching gap and with at most N/4 missing.
Issue 16, twenty-third round (docs/rules.md): is a walker's missing peak the window or the signal?
Since the twenty-fourth round also with window B at the other `PLACES` (`places`): the truth
column at the track's row, the track's column at the truth row, the legs' centroid
(`leg_column`) and the filter's column at the track's row.

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
    mid, mfr = np.asarray(res.mot["id"]), np.asarray(res.mot["frame"])
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
        at = {name: np.full(len(k), np.nan) for name in PLACES}
        off = []
        for j, f in enumerate(fr):
            m = np.flatnonzero((truth["id"] == o) & (truth["frame"] == truth_frame(int(f), offset)))
            if f < 1 or not m.size:
                continue
            u = truth["bb_left"][m[0]] + 0.5 * truth["bb_width"][m[0]]
            vv = truth["bb_top"][m[0]] + truth["bb_height"][m[0]] - 1.0  # box bottom: v + 1
            b = np.flatnonzero((mid == tid) & (mfr == f))
            ue = res.mot["bb_left"][b[0]] + 0.5 * res.mot["bb_width"][b[0]] if b.size else np.nan
            ve = res.mot["bb_top"][b[0]] + res.mot["bb_height"][b[0]] if b.size else np.nan
            us, vs = (u_tr[j], v_tr[j]) if np.isfinite(u_tr[j]) else (ue, ve)  # as sampled
            D = frame_difference(grays[f - 1], grays[f])
            for name, (pu, pv) in places(u, vv, us, vs, ue).items():
                if np.isfinite(pu) and np.isfinite(pv):
                    W = float(shape.size(pu, pv)[0])
                    if name.startswith("legs"):
                        pu = leg_column(D, pu, pv, W, 1.0 if name == "legs" else 0.5)
                    at[name][j] = window_b_intensity(D, pu, pv, W)
            if np.isfinite(v_tr[j]):
                off.append((abs(v_tr[j] - vv), abs(u_tr[j] - u)))
        starts = window_starts(fr, n)
        sampled = np.asarray(tr["intensity"], np.float64)[k]
        row, col = np.median(np.asarray(off), axis=0) if off else (np.nan, np.nan)
        out.append((len(k), best_power(cfg, sampled, t, xy, starts),
                    *(best_power(cfg, at[name], t, xy, starts) for name in PLACES),
                    float(row), float(col)))
    return out


PLACES = ("truth", "truth-column", "truth-row", "legs", "legs-half", "estimate-column")


def places(u, v, us, vs, ue) -> dict[str, tuple[float, float]]:
    """Window B's foot points compared: the truth (u, v); the truth column at the track's row
    (us, vs: where the track sampled); the track's column at the truth row; the track's point
    with its column moved to the legs (`leg_column`, reach W and W/2); the filter's column ue
    (its box centre) at the track's row."""
    return {"truth": (u, v), "truth-column": (u, vs), "truth-row": (us, v), "legs": (us, vs),
            "legs-half": (us, vs), "estimate-column": (ue, vs)}


def leg_column(D: np.ndarray, u: float, v: float, W: float, reach: float = 1.0) -> float:
    """The column px of the difference D's centroid over window B's rows (W/5 rows ending at v)
    and the columns u +- reach W (clipped to the image); u where D is all zero there."""
    from rhythmjax.vision.window_b import window_b_rect

    x0, y0, x1, y1 = window_b_rect(D.shape, u, v, 2.0 * reach * W)
    y0 = max(y1 - max(1, int(np.floor(W / 5 + 0.5))), 0)
    col = np.asarray(D[y0:y1, x0:x1], np.float64).sum(axis=0)
    if x1 <= x0 or col.sum() <= 0:
        return float(u)
    return float(x0 + np.sum(np.arange(x1 - x0) * col) / col.sum())


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
    print(f"{len(r)} walker tracks judged {a.reason!r}: medians {np.median(r[:, 0]):.0f} rows; "
          f"best P {np.nanmedian(r[:, 1]):.1f} on the track's window B, " + ", ".join(
              f"{np.nanmedian(r[:, 2 + c]):.1f} at {name} "
              f"({int(np.sum(r[judged, 2 + c] >= 10))} >= 10)" for c, name in enumerate(PLACES))
          + f" of {int(judged.sum())} judged; foot point off the truth "
          f"{np.nanmedian(r[:, -2]):.1f} px in row, {np.nanmedian(r[:, -1]):.1f} px in column")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
