"""Which of window B's coordinates spoils a walker's pace, and whether a column estimate mends it
(issue 16, forty-eighth round; a study: nothing is chosen here).

Per walker (its longest assigned track, `sim.evaluate.match_tracks`) the tracker's rhythm
windows (N rows, one every hop, at most N/4 missing: `eval_window_b.judged_windows`, without the
tracker's rules 35c and 37) are judged on I(k) summed over the same difference images D, the
same missing rows and the same W, with window B's foot point taken each way of `WAYS`:
- `tracker`: the recorded I(k); `measured`: B at the tracker's foot point (u_p, v_p), summed
  again;
- `true_u`, `true_v`, `true_uv`: the true column, row or both, the other the tracker's;
- `filter_u`: the column of the EKF's ground estimate projected by (3), the tracker's row;
- `mass_u`, `trunk_u`: the mean column of the motion (D > 15) in a box 2 W wide around u_p,
  over the body's rows (one walker height above v_p) or the trunk's (0.45-0.75 of it);
- `centred_u`, `causal_u`: a least-squares line through the measured columns of the 15 frames
  centred on the row, or ending at it, read at the row (`line_column`);
- `candidates_u`: B at u_p and at u_p +- 0.1 W, the window with the highest strongest peak
  deciding each rhythm window (as `model.candidates.strongest` chooses among the vertical ones).
Each way reports the pace error of the first window judged Pedestrian. Per walker also the
tracker's column against the truth in W: ahead along its motion, outwards from the image's
centre column, and the spread (`column_offsets`).

    python benchmarks/study_window_column.py radial|lateral SEED [SEED ...] [--scenes 10] [-o J]
    python benchmarks/study_window_column.py dev [-o J]

Own scenes as `eval_synthetic` renders them (own preset; `lateral`: every path within 30
degrees of crossing the view); the dev clips with single objects as `eval_window_b` reads them
(report only). Figures: docs/window_b.md, "Window B's column and the pace".
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import jax.numpy as jnp
import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402
import eval_window_b as ewb  # noqa: E402
from study_lateral_pace import window_b_signal  # noqa: E402

from rhythmjax.model.camera import image_width  # noqa: E402
from rhythmjax.model.camera_np import project_3d  # noqa: E402
from rhythmjax.model.params import config_from_dict  # noqa: E402
from rhythmjax.model.status import Verdict  # noqa: E402
from rhythmjax.sim.evaluate import match_tracks  # noqa: E402
from rhythmjax.sim.presets import synthetic_options  # noqa: E402
from rhythmjax.sim.scene import render_scene  # noqa: E402
from rhythmjax.track import track_frames  # noqa: E402
from rhythmjax.track.lean import motion_column  # noqa: E402
from rhythmjax.track.options import TrackerOptions  # noqa: E402


WAYS = ("tracker", "measured", "true_u", "true_v", "true_uv", "filter_u", "mass_u", "trunk_u",
        "centred_u", "causal_u", "candidates_u")
HEIGHT_PER_W = 3.4  # a walker's height in walker widths (1.7 m / 0.5 m)
MOTION_GREY = 15.0  # D above this is motion (`MotionOptions.diff_threshold`)


def mass_column(D, u: float, v: float, W: float, rows: tuple[float, float]) -> float:
    """The mean column (px) of the motion pixels (D > 15) in the box u +- W px across and from
    rows[0] to rows[1] walker heights (3.4 W) above the foot row v (`track.lean.motion_column`,
    rule 48's, over that band); NaN where it holds none."""
    H = HEIGHT_PER_W * W
    return motion_column(D, u, v - rows[0] * H, W, (rows[1] - rows[0]) * H, MOTION_GREY)


def line_column(frames: np.ndarray, u: np.ndarray, back: int, ahead: int) -> np.ndarray:
    """Per row i, the least-squares line through the finite columns u of rows i-back..i+ahead
    (by frame), read at row i's frame; u[i] itself where fewer than 3 are finite, NaN where
    u[i] is."""
    out = np.full(len(u), np.nan)
    for i in range(len(u)):
        if not math.isfinite(u[i]):
            continue
        j = np.arange(max(0, i - back), min(len(u), i + ahead + 1))
        j = j[np.isfinite(u[j])]
        out[i] = np.polyval(np.polyfit(frames[j], u[j], 1), frames[i]) if j.size >= 3 else u[i]
    return out


def column_offsets(t, u, u_true, uc: float, W: float) -> tuple[float, float, float]:
    """(ahead, outwards, spread) of the columns u against u_true, in W: the mean of u - u_true
    signed by the true motion's direction across (a least-squares slope over t) and by the
    side of the image's centre column uc the walker is on, and its standard deviation. NaN
    each where fewer than 6 rows have both."""
    ok = np.isfinite(u) & np.isfinite(u_true)
    if ok.sum() < 6:
        return math.nan, math.nan, math.nan
    d = (u - u_true)[ok]
    ahead = float(np.mean(d) * np.sign(np.polyfit(t[ok], u_true[ok], 1)[0]))
    outwards = float(np.mean(d * np.sign(u_true[ok] - uc)))
    return ahead / W, outwards / W, float(np.std(d)) / W


def strongest_peak(result) -> float:
    p = np.asarray(result.peak_power)[np.asarray(result.peak_mask)]
    return float(p.max()) if p.size else -1.0


def first_pedestrian_pace(cfg, t, signals: list, xy) -> float:
    """The pace (Hz) of the first rhythm window judged Pedestrian where each window is judged
    on the signal (of `signals`, the first on ties) whose strongest peak is highest; NaN where
    none is."""
    judged = [list(ewb.judged_windows(cfg, t, s, xy)) for s in signals]
    for k in range(min(len(j) for j in judged)):
        best = max(range(len(judged)), key=lambda c: (strongest_peak(judged[c][k]), -c))
        if int(judged[best][k].verdict) == Verdict.PEDESTRIAN:
            return float(judged[best][k].pace_hz)
    return math.nan


def walker_rows(cfg, frames, truth, options, pace_of) -> list[dict]:
    """One row per walker with a track: its true pace, each way's and its column offsets."""
    fps = float(cfg.camera.fps)
    tracks, _, _, _ = track_frames(cfg, ((i, i / fps, f) for i, f in enumerate(frames)),
                                   progress=False, options=options)
    D = ewb.differences(frames, options)
    tid, longest = np.asarray(tracks["track_id"]), {}
    for t, obj in match_tracks(tracks, truth).items():
        n = int(np.sum(tid == t))
        if obj.kind == "pedestrian" and n > longest.get(obj.track_id, (0, None, None))[0]:
            longest[obj.track_id] = (n, t, obj)
    rows = []
    for _, t, obj in longest.values():
        sel = tid == t
        f, tt = np.asarray(tracks["frame"])[sel], np.asarray(tracks["t"])[sel]
        xy = np.stack([np.asarray(tracks["x_est"])[sel], np.asarray(tracks["y_est"])[sel]], 1)
        W = np.asarray(image_width(cfg.camera, cfg.width.mean, jnp.asarray(xy[:, 1], jnp.float32)),
                       np.float64)
        I_trk = np.asarray(tracks["intensity"])[sel]
        u, v = np.asarray(tracks["u"])[sel], np.asarray(tracks["v"])[sel]
        ut, vt = obj.u[f], obj.v[f]
        boxes = {"mass_u": (0.0, 1.0), "trunk_u": (0.45, 0.75)}
        cols = {"measured": (u, v), "true_u": (ut, v), "true_v": (u, vt), "true_uv": (ut, vt),
                "filter_u": (np.asarray(project_3d(cfg.camera, xy[:, 0], xy[:, 1],
                                                   0 * xy[:, 0])[0], np.float64), v),
                "centred_u": (line_column(f, u, 7, 7), v),
                "causal_u": (line_column(f, u, 14, 0), v)}
        for key, band in boxes.items():
            c = np.array([mass_column(D[k], u[i], v[i], W[i], band) for i, k in enumerate(f)])
            cols[key] = (np.where(np.isfinite(c), c, u), v)

        def signal(cu, cv, f=f, I_trk=I_trk, W=W):
            return window_b_signal(D, f, I_trk, cu, cv, W)

        row = {"true": pace_of(obj),
               "tracker": first_pedestrian_pace(cfg, tt, [I_trk], xy),
               "candidates_u": first_pedestrian_pace(
                   cfg, tt, [signal(u + o * W, v) for o in (0.0, -0.1, 0.1)], xy)}
        row.update({k: first_pedestrian_pace(cfg, tt, [signal(*c)], xy) for k, c in cols.items()})
        row["ahead_W"], row["outwards_W"], row["spread_W"] = column_offsets(
            tt, u, ut, float(cfg.camera.uc), float(np.nanmedian(W)))
        rows.append(row)
    return rows


def sources(a):
    """(cfg, frames, truth, options, pace of a true object) per scene or clip."""
    if a.source == "dev":
        for _, cfg, frames, truth in ewb.dev_clips():
            yield cfg, frames, truth, TrackerOptions(), lambda o: float(o.pace_hz)
        return
    cfg = config_from_dict(es.RECOMMENDED)
    lateral = 30.0 if a.source == "lateral" else None
    for seed in a.seeds:
        for s, spec in es.scene_specs(seed, a.scenes, camera=cfg.camera, lateral_deg=lateral):
            scene = render_scene(s, spec)
            yield (cfg, list(scene.frames), scene.truth, synthetic_options(),
                   lambda o, spec=spec: float(spec.actors[int(o.track_id[3:])].pace_hz))


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("source", choices=("radial", "lateral", "dev"))
    p.add_argument("seeds", type=int, nargs="*")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("-o", "--out", type=Path)
    a = p.parse_args(argv)
    rows = [r for cfg, frames, truth, options, pace_of in sources(a)
            for r in walker_rows(cfg, frames, truth, options, pace_of)]
    print(f"{a.source}: {len(rows)} walkers with a track")
    for key in ("ahead_W", "outwards_W", "spread_W"):
        x = [r[key] for r in rows if math.isfinite(r[key])]
        print(f"  tracker's column {key[:-2]}: median {np.median(x):+.3f} W (n {len(x)})")
    for way in WAYS:
        e = np.array([r[way] - r["true"] for r in rows if math.isfinite(r[way])])
        print(f"  {way:12s} Pedestrian {e.size:3d}  pace MAE {np.abs(e).mean():.4f} Hz  "
              f"mean signed {e.mean():+.4f}", flush=True)
    if a.out:
        a.out.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
