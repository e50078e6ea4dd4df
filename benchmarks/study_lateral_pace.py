"""Why walkers crossing the view have their pace read worse (issue 16; a study, nothing chosen).

Own evaluation scenes (`eval_synthetic.scene_specs`) with the default paths (radial: towards or
away from the camera) and with every path within 30 degrees of crossing the view
(`random_spec`'s lateral_deg), tracked with the own preset. Per walker, on its longest assigned
track (`sim.evaluate.match_tracks`), the rhythm windows (N rows, one every hop, at most N/4
missing) are judged with I(k) summed five ways over the same difference images D and the same
missing rows: window B where the tracker put it (`trk`: its recorded intensity), the same foot
points with B two walker widths wide (`trk2W`), and B at the true foot point, W and 2W wide
(`truthW`, `truth2W`). Each reports the walkers with a window judged Pedestrian and the pace error
of the first such window (`trk_first`, the tracker's rule, Sec. 4.2) or of the one with the
strongest peak (the others).

    python benchmarks/study_lateral_pace.py SEED [SEED ...] [-o ROWS.json] [--rods]

`-o` writes every walker's row (true pace and each way's, by path kind) for paired reading. The
walkers bend their knees and roll their feet heel to toe (`sim.legs`, the own scenes' default
since issue 16's thirty-eighth round); `--rods` draws the straight legs of the scenes before it
(`--articulated`, the flag of the thirty-seventh round, is accepted and changes nothing).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import jax.numpy as jnp
import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402
import eval_window_b as ewb  # noqa: E402

from rhythmjax.model.camera import image_width  # noqa: E402
from rhythmjax.model.params import config_from_dict  # noqa: E402
from rhythmjax.model.status import Verdict  # noqa: E402
from rhythmjax.sim.evaluate import match_tracks  # noqa: E402
from rhythmjax.sim.presets import synthetic_options  # noqa: E402
from rhythmjax.sim.scene import render_scene  # noqa: E402
from rhythmjax.track import track_frames  # noqa: E402
from rhythmjax.vision import detect  # noqa: E402


WAYS = ("trk_first", "trk", "trk_median", "trk2W", "trk2W_median", "truthW", "truth2W")


def window_paces(cfg, t, signal, xy) -> tuple[float, float, float]:
    """(pace Hz of the first window judged Pedestrian, of the Pedestrian window with the
    strongest peak, the median over the Pedestrian windows); NaN each when none is."""
    first, best, paces = math.nan, (-1.0, math.nan), []
    for r in ewb.judged_windows(cfg, t, signal, xy):
        if int(r.verdict) != Verdict.PEDESTRIAN:
            continue
        p = float(np.asarray(r.peak_power)[np.asarray(r.peak_mask)].max())
        first = float(r.pace_hz) if math.isnan(first) else first
        best = max(best, (p, float(r.pace_hz)))
        paces.append(float(r.pace_hz))
    return first, best[1], float(np.median(paces)) if paces else math.nan


def window_b_signal(D, frames, I_trk, u, v, widths) -> np.ndarray:
    """I(k) in window B at (u, v) px, `widths` px wide, on the rows where the tracker had a
    sample (`I_trk` finite); NaN elsewhere."""
    return np.array([detect.window_b_intensity(D[k], u[i], v[i], widths[i])
                     if math.isfinite(I_trk[i]) and D[k] is not None else math.nan
                     for i, k in enumerate(frames)])


def walker_rows(cfg, options, seed: int, lateral_deg: float | None,
                articulated: bool = True) -> list[dict]:
    """One row per walker of the seed's ten scenes with a track: its true pace and the pace
    each way of `WAYS` reads (NaN where no window is judged Pedestrian); `articulated`:
    walkers with knees and heel-to-toe feet (`sim.legs`)."""
    out = []
    for s, spec in es.scene_specs(seed, 10, camera=cfg.camera, lateral_deg=lateral_deg,
                                  articulated=articulated):
        scene = render_scene(s, spec)
        frames = list(scene.frames)
        tracks, _, _, _ = track_frames(cfg, ((i, i / scene.fps, f) for i, f in enumerate(frames)),
                                       progress=False, options=options)
        D = ewb.differences(frames, options)
        tid = np.asarray(tracks["track_id"])
        longest: dict = {}
        for t, obj in match_tracks(tracks, scene.truth).items():
            c = int(np.sum(tid == t))
            if obj.kind == "pedestrian" and c > longest.get(obj.track_id, (0, None, None))[0]:
                longest[obj.track_id] = (c, t, obj)
        for _, t, obj in longest.values():
            sel = tid == t
            f = np.asarray(tracks["frame"])[sel]
            y = np.asarray(tracks["y_est"])[sel]
            xy = np.stack([np.asarray(tracks["x_est"])[sel], y], 1)
            W = np.asarray(image_width(cfg.camera, cfg.width.mean, jnp.asarray(y, jnp.float32)))
            I_trk = np.asarray(tracks["intensity"])[sel]
            tt = np.asarray(tracks["t"])[sel]

            def signal(u, v, widths, D=D, f=f, I_trk=I_trk, W=W):
                return window_b_signal(D, f, I_trk, u, v, widths * W)

            u, v = np.asarray(tracks["u"])[sel], np.asarray(tracks["v"])[sel]
            first, best, median = window_paces(cfg, tt, I_trk, xy)
            _, best2, median2 = window_paces(cfg, tt, signal(u, v, 2.0), xy)
            out.append({"true": float(spec.actors[int(obj.track_id[3:])].pace_hz),
                        "trk_first": first, "trk": best, "trk_median": median,
                        "trk2W": best2, "trk2W_median": median2,
                        "truthW": window_paces(cfg, tt, signal(obj.u[f], obj.v[f], 1.0), xy)[1],
                        "truth2W": window_paces(cfg, tt, signal(obj.u[f], obj.v[f], 2.0),
                                                xy)[1]})
    return out


def main(argv: list[str]) -> int:
    out = argv[argv.index("-o") + 1] if "-o" in argv else None
    seeds = [int(s) for s in argv if s.isdigit()] or [1470001]
    articulated = "--rods" not in argv
    cfg = config_from_dict(es.RECOMMENDED)
    every = {}
    for name, lateral in (("radial (default paths)", None), ("crossing (lateral_deg 30)", 30.0)):
        rows = [r for s in seeds
                for r in walker_rows(cfg, synthetic_options(), s, lateral, articulated)]
        every[name] = rows
        print(f"{name}: {len(rows)} walkers with a track")
        for way in WAYS:
            e = np.array([abs(r[way] - r["true"]) for r in rows if math.isfinite(r[way])])
            print(f"  {way:9s} Pedestrian {e.size:3d}  pace MAE {e.mean():.3f} Hz  median "
                  f"{np.median(e):.3f}  > 0.1 Hz: {int(np.sum(e > 0.1))}", flush=True)
    if out:
        Path(out).write_text(json.dumps(every, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
