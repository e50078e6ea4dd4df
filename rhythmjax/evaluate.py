"""Scoring tracks and verdicts against synthetic ground truth (demo, evaluation, regression test).

A track is assigned to the true object whose foot point is nearest over the frames they share
(median distance, px, below max(`max_px`, `width_frac` x the object's median image width over
those frames): a 10 px foot-point offset is a miss at 20 m but not at 4 m, where a walker is
~100 px wide), one object per track, greedily by distance. Per object:
whether it was tracked, the verdict of its longest classified track, and pace and stride errors.
"""

from __future__ import annotations

import math

import numpy as np


def match_tracks(tracks: dict, truth, *, max_px: float = 15.0,
                 width_frac: float = 0.35) -> dict[int, object]:
    """{track_id: ObjectTruth} from the tracks columns (frame, u, v; NaN where unmeasured)."""
    pairs = []
    tid = np.asarray(tracks["track_id"])
    for t in np.unique(tid):
        rows = tid == t
        frames = np.asarray(tracks["frame"])[rows]
        u, v = np.asarray(tracks["u"])[rows], np.asarray(tracks["v"])[rows]
        for obj in truth:
            ok = (frames < len(obj.u)) & np.isfinite(u)
            ok[ok] &= obj.visible[frames[ok]]
            if ok.sum() < 5:
                continue
            d = np.hypot(u[ok] - obj.u[frames[ok]], v[ok] - obj.v[frames[ok]])
            w = np.nanmedian(obj.width_px[frames[ok]]) if np.any(
                np.isfinite(obj.width_px[frames[ok]])) else 0.0
            pairs.append((float(np.median(d)), int(t), obj, max(max_px, width_frac * w)))
    out: dict[int, object] = {}
    for d, t, obj, lim in sorted(pairs, key=lambda p: p[0]):
        if d <= lim and t not in out:
            out[t] = obj
    return out


def score(tracks: dict, verdicts: dict, truth, *, max_px: float = 15.0) -> dict:
    """Per-object outcome rows and summary figures (pace MAE, stride median error, rates)."""
    assigned = match_tracks(tracks, truth, max_px=max_px)
    vid = [int(t) for t in verdicts["track_id"]]
    rows = []
    for obj in truth:
        mine = [t for t, o in assigned.items() if o is obj]
        best = None
        for t in sorted(mine, key=lambda t: -int(verdicts["n_samples"][vid.index(t)])):
            i = vid.index(t)
            if verdicts["verdict"][i] != "unclassified":
                best = i
                break
        if best is None and mine:
            best = vid.index(mine[0])
        row = {"object": obj.track_id, "kind": obj.kind, "pace_true": obj.pace_hz,
               "stride_true": obj.step_length_m, "tracks": len(mine), "verdict": "missed",
               "pace": math.nan, "stride": math.nan}
        if best is not None:
            row.update(verdict=str(verdicts["verdict"][best]),
                       pace=float(verdicts["pace_hz"][best]),
                       stride=float(verdicts["stride_m"][best]))
        rows.append(row)
    return {"objects": rows, **summarise(rows)}


def summarise(rows: list[dict]) -> dict:
    walkers = [r for r in rows if r["kind"] == "pedestrian"]
    others = [r for r in rows if r["kind"] != "pedestrian"]
    judged_w = [r for r in walkers if r["verdict"] in ("pedestrian", "non-pedestrian")]
    judged_o = [r for r in others if r["verdict"] in ("pedestrian", "non-pedestrian")]
    ped = [r for r in judged_w if r["verdict"] == "pedestrian"]
    pace_err = [abs(r["pace"] - r["pace_true"]) for r in ped if math.isfinite(r["pace"])]
    stride_err = [abs(r["stride"] - r["stride_true"]) for r in ped if math.isfinite(r["stride"])]
    return {
        "walkers": len(walkers),
        "walkers_judged": len(judged_w),
        "walkers_pedestrian": len(ped),
        "walker_pedestrian_rate": len(ped) / len(walkers) if walkers else math.nan,
        "others": len(others),
        "others_judged": len(judged_o),
        "others_non_pedestrian": sum(r["verdict"] == "non-pedestrian" for r in judged_o),
        "pace_mae_hz": float(np.mean(pace_err)) if pace_err else math.nan,
        "pace_max_err_hz": float(np.max(pace_err)) if pace_err else math.nan,
        "stride_median_err_m": float(np.median(stride_err)) if stride_err else math.nan,
    }
