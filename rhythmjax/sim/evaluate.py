"""Scoring tracks and verdicts against synthetic ground truth (demo, evaluation, regression test).

A track is assigned to the true object whose foot point is nearest over the frames they share
(median distance, px, below max(`max_px`, `width_frac` x the object's median image width over
those frames): a 10 px foot-point offset is a miss at 20 m but not at 4 m, where a walker is
~100 px wide), one object per track, greedily by distance. Per object: whether it was
tracked, the verdict of its longest classified track (or, given the deciding windows, of the
windows that looked at it: `score`), and pace and stride errors.
"""

from __future__ import annotations

import math

import numpy as np


def _followed(frames, u, v, truth, *, max_px: float, width_frac: float, min_frames: int):
    """(median foot-point distance px, object, its limit px) for every true object visible in
    at least `min_frames` of the frames where the track was measured."""
    out = []
    for obj in truth:
        ok = (frames < len(obj.u)) & np.isfinite(u)
        ok[ok] &= obj.visible[frames[ok]]
        if ok.sum() < min_frames:
            continue
        d = np.hypot(u[ok] - obj.u[frames[ok]], v[ok] - obj.v[frames[ok]])
        w = np.nanmedian(obj.width_px[frames[ok]]) if np.any(
            np.isfinite(obj.width_px[frames[ok]])) else 0.0
        out.append((float(np.median(d)), obj, max(max_px, width_frac * w)))
    return out


def _rows_of(tracks: dict, t: int):
    rows = np.asarray(tracks["track_id"]) == t
    return (np.asarray(tracks["frame"])[rows], np.asarray(tracks["u"])[rows],
            np.asarray(tracks["v"])[rows])


def match_tracks(tracks: dict, truth, *, max_px: float = 15.0,
                 width_frac: float = 0.35) -> dict[int, object]:
    """{track_id: ObjectTruth} from the tracks columns (frame, u, v; NaN where unmeasured)."""
    pairs = []
    for t in np.unique(np.asarray(tracks["track_id"])):
        frames, u, v = _rows_of(tracks, int(t))
        pairs += [(d, int(t), obj, lim) for d, obj, lim in _followed(
            frames, u, v, truth, max_px=max_px, width_frac=width_frac, min_frames=5)]
    out: dict[int, object] = {}
    for d, t, obj, lim in sorted(pairs, key=lambda p: p[0]):
        if d <= lim and t not in out:
            out[t] = obj
    return out


def deciding_windows(objs) -> dict[int, tuple[int, int]]:
    """{track_id: (first frame, last frame)} of the rhythm window behind each judged track's
    verdict (the online tracker's objects, `result["window"]`: row indices)."""
    out = {}
    for o in objs:
        if o.result is not None and "window" in o.result:
            k0, k1 = o.result["window"]
            out[o.track_id] = (int(o.rows[k0][0]), int(o.rows[k1 - 1][0]))
    return out


def window_objects(tracks: dict, truth, windows: dict, *, max_px: float = 15.0,
                   width_frac: float = 0.35) -> dict[int, object]:
    """{track_id: the object the track followed during its deciding window}: the nearest (median
    foot-point distance within the same limit as `match_tracks`) over the window's frames, the
    object visible in at least half of its measured frames; tracks that followed none left
    out. A track that changed objects after its verdict (an identity switch) is judged here by
    what it looked at when it decided."""
    out = {}
    for t, (f0, f1) in windows.items():
        frames, u, v = _rows_of(tracks, t)
        inside = (frames >= f0) & (frames <= f1)
        n = int(np.sum(inside & np.isfinite(u)))
        cand = [(d, obj) for d, obj, lim in _followed(
            frames[inside], u[inside], v[inside], truth, max_px=max_px, width_frac=width_frac,
            min_frames=max(5, (n + 1) // 2)) if d <= lim]
        if cand:
            out[t] = min(cand, key=lambda c: c[0])[1]
    return out


def score(tracks: dict, verdicts: dict, truth, *, max_px: float = 15.0,
          windows: dict | None = None, classifiable: dict | None = None) -> dict:
    """Per-object outcome rows and summary figures (pace MAE, stride median error, rates).

    Each track is assigned to one object (`match_tracks`); an object's verdict is that of its
    longest classified track. With `windows` (`deciding_windows`), each judged track's verdict
    goes instead to the object it followed during its deciding window (`window_objects`):
    Pedestrian when any such window said so, else Non-pedestrian when any judged it; an object
    no window judged is unclassified when a track followed it, else missed. With
    `classifiable` ({object track_id: (longest clean run, whether classifiable)}, as
    `sim.clean.classifiable` gives), each row carries `clean_frames` and `classifiable`, and the
    figures count the classifiable walkers apart."""
    assigned = match_tracks(tracks, truth, max_px=max_px)
    judged = None if windows is None else window_objects(tracks, truth, windows, max_px=max_px)
    vid = [int(t) for t in verdicts["track_id"]]
    rows = []
    for obj in truth:
        mine = [t for t, o in assigned.items() if o is obj]
        if judged is None:
            best = None
            for t in sorted(mine, key=lambda t: -int(verdicts["n_samples"][vid.index(t)])):
                i = vid.index(t)
                if verdicts["verdict"][i] != "unclassified":
                    best = i
                    break
            if best is None and mine:
                best = vid.index(mine[0])
        else:
            looked = sorted((vid.index(t) for t, o in judged.items() if o is obj),
                            key=lambda i: (verdicts["verdict"][i] != "pedestrian",
                                           -int(verdicts["n_samples"][i])))
            best = looked[0] if looked else (-1 if mine else None)  # -1: followed, not judged
        row = {"object": obj.track_id, "kind": obj.kind, "pace_true": obj.pace_hz,
               "stride_true": obj.step_length_m, "tracks": len(mine), "verdict": "missed",
               "pace": math.nan, "stride": math.nan}
        if best == -1:
            row["verdict"] = "unclassified"
        elif best is not None:
            row.update(verdict=str(verdicts["verdict"][best]),
                       pace=float(verdicts["pace_hz"][best]),
                       stride=float(verdicts["stride_m"][best]))
        if classifiable is not None:
            row["clean_frames"], row["classifiable"] = classifiable[obj.track_id]
        rows.append(row)
    return {"objects": rows, **summarise(rows)}


def summarise(rows: list[dict]) -> dict:
    """Figures from per-object rows: walkers judged Pedestrian of all, of those judged (Table 3)
    and of the classifiable ones (rows without `classifiable` count as classifiable), non-walkers
    judged Non-pedestrian, pace MAE and maximum error (Hz) and the step-length median error (m)
    over the walkers judged Pedestrian."""
    walkers = [r for r in rows if r["kind"] == "pedestrian"]
    others = [r for r in rows if r["kind"] != "pedestrian"]
    judged_w = [r for r in walkers if r["verdict"] in ("pedestrian", "non-pedestrian")]
    judged_o = [r for r in others if r["verdict"] in ("pedestrian", "non-pedestrian")]
    ped = [r for r in judged_w if r["verdict"] == "pedestrian"]
    # classifiable (`sim.clean`, where the rows carry it; else every walker counts)
    cl = [r for r in walkers if r.get("classifiable", True)]
    cl_ped = sum(r["verdict"] == "pedestrian" for r in cl)
    pace_err = [abs(r["pace"] - r["pace_true"]) for r in ped if math.isfinite(r["pace"])]
    stride_err = [abs(r["stride"] - r["stride_true"]) for r in ped if math.isfinite(r["stride"])]
    return {
        "walkers": len(walkers),
        "walkers_judged": len(judged_w),
        "walkers_pedestrian": len(ped),
        "walker_pedestrian_rate": len(ped) / len(walkers) if walkers else math.nan,
        # the paper's Table 3 counts only objects tracked for N frames or more (judged):
        "walker_pedestrian_rate_judged": len(ped) / len(judged_w) if judged_w else math.nan,
        "walkers_classifiable": len(cl),
        "classifiable_pedestrian": cl_ped,
        "walker_pedestrian_rate_classifiable": cl_ped / len(cl) if cl else math.nan,
        "others": len(others),
        "others_judged": len(judged_o),
        "others_non_pedestrian": sum(r["verdict"] == "non-pedestrian" for r in judged_o),
        "pace_mae_hz": float(np.mean(pace_err)) if pace_err else math.nan,
        "pace_max_err_hz": float(np.max(pace_err)) if pace_err else math.nan,
        "stride_median_err_m": float(np.median(stride_err)) if stride_err else math.nan,
    }
