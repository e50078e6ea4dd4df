"""Scoring and table of benchmarks/eval_all.py (issue 16, item 5): config overrides, the table's
columns from per-object verdict rows and per-clip counts, and the dev clips' truth files
(../shared/data/dev, README there). Pure functions; tests/test_eval_all.py."""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass

import numpy as np


KINDS = {1: "pedestrian", 2: "bicycle", 3: "dog", 4: "car"}  # MOT gt class of the dev clips


# ----------------------------------------------------------------------------------------------
# config overrides


def parse_set(items) -> list[tuple[str, str, object]]:
    """`SECTION.KEY=VALUE` strings -> (section, key, value); VALUE as JSON (numbers, lists,
    true/false), else the string. Raises ValueError naming the item."""
    out = []
    for s in items or ():
        name, eq, raw = s.partition("=")
        sec, dot, key = name.strip().partition(".")
        if not eq or not dot or not sec or not key:
            raise ValueError(f"--set {s!r}: expected SECTION.KEY=VALUE")
        try:
            val = json.loads(raw)
        except json.JSONDecodeError:
            val = raw
        out.append((sec, key, val))
    return out


def apply_set(d: dict, sets) -> dict:
    """A deep copy of the config dict `d` with every (section, key, value) of `sets` written in."""
    out = copy.deepcopy(d)
    for sec, key, val in sets:
        out.setdefault(sec, {})[key] = val
    return out


# ----------------------------------------------------------------------------------------------
# scoring (pure functions; tests/test_eval_all.py)


def _div(a, b):
    return a / b if b else math.nan


def verdict_row(rows: list[dict]) -> dict:
    """Table columns from per-object rows (kind, verdict in pedestrian | non-pedestrian |
    unclassified | missed, pace / pace_true Hz, stride / stride_true m, optional classifiable,
    default True)."""
    walk = [r for r in rows if r["kind"] == "pedestrian"]
    other = [r for r in rows if r["kind"] != "pedestrian"]
    judged = ("pedestrian", "non-pedestrian")
    wj = [r for r in walk if r["verdict"] in judged]
    wc = [r for r in walk if r.get("classifiable", True)]
    oj = [r for r in other if r["verdict"] in judged]
    ped = [r for r in wj if r["verdict"] == "pedestrian"]
    pace = [abs(r["pace"] - r["pace_true"]) for r in ped
            if math.isfinite(r.get("pace", math.nan))
            and math.isfinite(r.get("pace_true", math.nan))]
    step = [abs(r["stride"] - r["stride_true"]) for r in ped
            if math.isfinite(r.get("stride", math.nan))
            and math.isfinite(r.get("stride_true", math.nan))]
    n_ped_cl = sum(r["verdict"] == "pedestrian" for r in wc)
    n_oped = sum(r["verdict"] == "pedestrian" for r in other)
    return {"walkers": len(walk), "walkers_judged": len(wj), "walkers_pedestrian": len(ped),
            "walkers_classifiable": len(wc), "classifiable_pedestrian": n_ped_cl,
            "rate_judged": _div(len(ped), len(wj)), "rate_classifiable": _div(n_ped_cl, len(wc)),
            "others": len(other), "others_judged": len(oj), "others_pedestrian": n_oped,
            "pace_mae_hz": float(np.mean(pace)) if pace else math.nan,
            "step_median_err_cm": 100 * float(np.median(step)) if step else math.nan}


def count_row(clips: list[dict]) -> dict:
    """Count columns from per-clip dicts (counted, true, optional others_counted, mota, idf1,
    distinct): the per-clip errors summed, sum |counted - true| / sum true; MOTA / IDF1 as the
    mean over clips (each clip weighted equally); when every clip has `distinct` (the most
    tracks standing for distinct walkers, `count_bounds`), its sum and its per-clip errors
    summed, the floor a counting rule that counts no walker twice could reach on these tracks;
    when every clip has `counts` (counts.json's), how often its stated range walkers_low ..
    walkers_high holds the true count: `range_holds`, and the clips whose truth lies below
    (`true_below_range`) or above it (`true_above_range`: walkers no track stood for)."""
    true = sum(c["true"] for c in clips)
    out = {"counted": sum(c["counted"] for c in clips), "true": true,
           "count_err_sum": _div(sum(abs(c["counted"] - c["true"]) for c in clips), true),
           "others_counted": sum(c.get("others_counted", 0) for c in clips)}
    if clips and all("distinct" in c for c in clips):
        out["distinct"] = sum(c["distinct"] for c in clips)
        out["distinct_err_sum"] = _div(sum(abs(c["distinct"] - c["true"]) for c in clips), true)
    if clips and all("counts" in c for c in clips):
        lo = [c["true"] < c["counts"]["walkers_low"] for c in clips]
        hi = [c["true"] > c["counts"]["walkers_high"] for c in clips]
        out.update(range_holds=len(clips) - sum(lo) - sum(hi), true_below_range=sum(lo),
                   true_above_range=sum(hi), clips=len(clips))
    for k in ("mota", "idf1"):
        v = [c[k] for c in clips if math.isfinite(c.get(k, math.nan))]
        out[k] = float(np.mean(v)) if v else math.nan
    return out


def ucsd_row(total: dict) -> dict:
    """UCSD's columns from the tracks' verdict counts {"anomaly": {verdict: n}, "other": ...}
    (benchmarks/eval_real_video.py's score_ucsd): tracks on the cyclists' and the cart's boxes
    are the non-walkers; the other tracks (no truth: mostly walkers) fill the walker columns."""
    a, o = total.get("anomaly", {}), total.get("other", {})
    return {"others": sum(a.values()), "others_pedestrian": a.get("pedestrian", 0),
            "others_judged": a.get("pedestrian", 0) + a.get("non-pedestrian", 0),
            "walkers_pedestrian": o.get("pedestrian", 0),
            "walkers_judged": o.get("pedestrian", 0) + o.get("non-pedestrian", 0)}


def casia_row(clips: dict) -> dict:
    """CASIA-B's columns from {clip: verdict of its longest track}: every clip but the
    background clip (`*bkgrd*`, nobody in it) holds one walker."""
    return verdict_row([{"kind": "pedestrian", "verdict": v} for c, v in clips.items()
                        if "bkgrd" not in c])


def _frac(a, b) -> str:
    return "-" if not b else f"{a}/{b} ({100 * a / b:.0f} %)"


def _num(x, fmt) -> str:
    return "-" if x is None or not math.isfinite(x) else format(x, fmt)


HEADER = ("| source | walkers Ped. / judged (>= N) | walkers Ped. / all classifiable | non-walkers "
          "Ped. / all (/ judged) | pace MAE (Hz) | step err. median (cm) | walkers counted / true"
          " (per-clip errors summed) | non-walkers counted | MOTA | IDF1 |\n|" + "---|" * 10)


def table_line(name: str, v: dict | None, c: dict | None) -> str:
    """One markdown row from `verdict_row` (or None) and `count_row` (or None)."""
    v, c = v or {}, c or {}
    cells = [name,
             _frac(v.get("walkers_pedestrian", 0), v.get("walkers_judged", 0)),
             _frac(v.get("classifiable_pedestrian", 0), v.get("walkers_classifiable", 0)),
             "-" if not v.get("others") else
             f"{v['others_pedestrian']}/{v['others']} (/{v['others_judged']})",
             _num(v.get("pace_mae_hz"), ".3f"), _num(v.get("step_median_err_cm"), ".1f"),
             "-" if not c else f"{c['counted']}/{c['true']} ({100 * c['count_err_sum']:.1f} %)",
             "-" if not c else str(c.get("others_counted", "-")),
             _num(c.get("mota"), ".3f"), _num(c.get("idf1"), ".3f")]
    return "| " + " | ".join(cells) + " |"


# ----------------------------------------------------------------------------------------------
# dev clips: truth


@dataclass
class DevObject:
    """One truth object of a dev clip in the shape `sim.evaluate` reads: per-frame arrays of
    length n_frames (NaN / False where the object has no row or its foot point is off-image)."""

    track_id: int
    kind: str
    pace_hz: float
    step_length_m: float
    classifiable: bool
    u: np.ndarray
    v: np.ndarray
    width_px: np.ndarray
    visible: np.ndarray


def dev_truth(truth: dict) -> list[DevObject]:
    """The truth JSON of a dev clip -> DevObjects (walkers: pace = steps/s, stride = m/step)."""
    T = int(truth["n_frames"])
    out = []
    for o in truth["objects"]:
        tr = o["track"]
        f = np.asarray(tr["frame"], np.int64)
        u, v, w = (np.full(T, np.nan) for _ in range(3))
        vis = np.zeros(T, bool)
        u[f], v[f] = tr["u"], tr["v"]
        w[f] = tr["width_px"]
        vis[f] = np.asarray(tr["in_image"], bool) & (np.asarray(tr["visible_frac"]) > 0)
        out.append(DevObject(int(o["id"]), o["kind"], float(o["pace_hz"]),
                             float(o["stride_m"]) if o["stride_m"] is not None else math.nan,
                             bool(o["classifiable"]), u, v, w, vis))
    return out


def dev_camera(truth: dict) -> dict:
    """The config of a dev clip: its camera section only (the folder's README)."""
    c = truth["camera"]
    return {"camera": {k: c[k] for k in ("f_m", "h_m", "theta_deg", "a_px_per_m", "b_px_per_m",
                                         "uc_px", "vc_px")}
            | {"fps": truth["fps"], "image_width_px": c["width_px"],
               "image_height_px": c["height_px"]}}


def read_gt(path) -> tuple[dict, dict[int, str]]:
    """A dev crowd clip's MOT gt (frame 1-based, id, box, 1, class, visibility) -> the box
    columns and each id's kind."""
    a = np.loadtxt(path, delimiter=",", ndmin=2)
    cols = {"frame": a[:, 0].astype(np.int64), "id": a[:, 1].astype(np.int64),
            "bb_left": a[:, 2], "bb_top": a[:, 3], "bb_width": a[:, 4], "bb_height": a[:, 5]}
    return cols, {int(i): KINDS[int(k)] for i, k in zip(a[:, 1], a[:, 7])}


def objects_rows(res_objects, truth_objs) -> list[dict]:
    """`sim.evaluate.score` rows with each object's `classifiable` flag."""
    cl = {o.track_id: o.classifiable for o in truth_objs}
    return [dict(r, classifiable=cl.get(r["object"], True)) for r in res_objects]
