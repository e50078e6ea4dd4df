"""Where window B sits against the true foot point, and what it costs the rhythm (issue 16, 2).

Per tracked object (a track assigned to a true object by `sim.evaluate.match_tracks`; the
object's longest track), over the rows where the object's true foot point is in the image:
- `dist_med`, `dist_p90`: the pixel distance between the foot point window B was placed at
  (the tracker's: the filtered estimate, `BodyOptions.sample_estimate`) and the true foot point;
  `dv_med`: the median |row error| (window B is only W/5 rows high);
- `P_trk`, `P_true`: the best-window P, the strongest MEM peak's power relative to the white
  level (what (13) compares with P_thr), the maximum over the track's rhythm windows (N rows,
  one every `hop_samples`), with I(k) summed in window B at the tracker's foot point and at the
  true foot point; the same D images, the same W (the tracker's, at its filtered ground point)
  and the same missing samples (the tracker's NaN rows), so only the placement differs;
- `ped_trk`, `ped_true`: whether any of those windows says Pedestrian.

Sources: own scenes (`sim.random_spec` as benchmarks/eval_synthetic.py, seeds OWN_SEEDS, camera
shake `jitter_px` px standard deviation per frame, the truth moved with it), and the dev clips
(../shared/data/dev, report only: nothing may be chosen on them). Each source is run with
`MotionOptions.stabilise` off and on (`--stabilise off,on`); D is computed as the tracker
computes it under that setting.

    python benchmarks/eval_window_b.py [--source own,dev] [--jitter 0,1] [--scenes 4]
                                       [--stabilise off,on] [--option GROUP.KEY=JSON]
                                       [-o eval_window_b.json]
    python benchmarks/eval_window_b.py --verdicts --scenes 6 --jitter 0,0.5,1,2
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

from rhythmjax.model.camera import image_width, measure  # noqa: E402
from rhythmjax.model.rhythm import classify_window_jit  # noqa: E402
from rhythmjax.model.status import Verdict  # noqa: E402
from rhythmjax.sim.evaluate import match_tracks  # noqa: E402
from rhythmjax.track import track_frames  # noqa: E402
from rhythmjax.track.options import TrackerOptions, with_changes  # noqa: E402
from rhythmjax.vision import detect, stabilise  # noqa: E402


OWN_SEEDS = (4100, 5100, 6100, 7100, 8100, 9100)  # not eval_synthetic's 20240603, not 777001
DEV_ROOT = Path("/work/shared/data/dev")


def differences(frames, options: TrackerOptions) -> list:
    """D per frame index (None for frame 0), computed as `OnlineTracker.update` does."""
    m = options.motion
    out = [None]
    for k in range(1, len(frames)):
        prev = frames[k - 1]
        if m.stabilise:
            prev = stabilise.align_previous(prev, frames[k],
                                            min_shift_px=m.stabilise_min_shift_px)[0]
        out.append(detect.frame_difference(prev, frames[k]))
    return out


def judged_windows(cfg, t, signal, xy):
    """`classify_window`'s result for each rhythm window of `signal` (N rows, one every hop,
    at most N/4 missing), in order; `t` s and `xy` m (ground points) per row."""
    n, hop = int(cfg.thresholds.n), int(cfg.thresholds.hop_samples)
    for k in range(0, len(signal) - n + 1, hop):
        x = signal[k:k + n]
        if np.sum(~np.isfinite(x)) > 0.25 * n:
            continue
        yield classify_window_jit(cfg, jnp.asarray(x, jnp.float32),
                                  jnp.asarray(t[k:k + n] - t[k], jnp.float32),
                                  jnp.asarray(xy[k:k + n], jnp.float32), jnp.asarray(True))


def _best_p(cfg, t, signal, xy):
    """(best-window P, any window Pedestrian) over the windows of N rows, one every hop."""
    best, ped = math.nan, False
    for r in judged_windows(cfg, t, signal, xy):
        p = np.asarray(r.peak_power)[np.asarray(r.peak_mask)]
        if p.size:
            best = float(np.nanmax([best, p.max()])) if math.isfinite(best) else float(p.max())
        ped |= int(r.verdict) == Verdict.PEDESTRIAN
    return best, ped


def measure_clip(cfg, frames, truth, options: TrackerOptions) -> list[dict]:
    """One row per true object with a track (its longest assigned track)."""
    fps = float(cfg.camera.fps)
    items = ((i, i / fps, f) for i, f in enumerate(frames))
    tracks, _, _, _ = track_frames(cfg, items, progress=False, options=options)
    D = differences(frames, options)
    assigned = match_tracks(tracks, truth)
    tid = np.asarray(tracks["track_id"])
    best: dict = {}
    for t, obj in assigned.items():
        n = int(np.sum(tid == t))
        if obj.track_id not in best or n > best[obj.track_id][0]:
            best[obj.track_id] = (n, t, obj)
    proj = jax.jit(jax.vmap(lambda x, y: measure(cfg.camera, jnp.stack([x, 0.0 * x, y, 0.0 * x]))))
    rows = []
    for n, t, obj in best.values():
        sel = tid == t
        f = np.asarray(tracks["frame"])[sel]
        x, y = np.asarray(tracks["x_est"])[sel], np.asarray(tracks["y_est"])[sel]
        uv = np.asarray(proj(jnp.asarray(x, jnp.float32), jnp.asarray(y, jnp.float32)), float)
        W = np.asarray(image_width(cfg.camera, cfg.width.mean, jnp.asarray(y, jnp.float32)), float)
        if not options.body.sample_estimate:  # B at the measured foot point where there is one
            z = np.stack([np.asarray(tracks["u"])[sel], np.asarray(tracks["v"])[sel]], 1)
            uv = np.where(np.isfinite(z).all(1)[:, None], z, uv)
        I_trk = np.asarray(tracks["intensity"])[sel]
        ut, vt = obj.u[f], obj.v[f]
        vis = obj.visible[f] & np.isfinite(ut) & np.isfinite(vt)
        I_true = np.array([detect.window_b_intensity(D[k], ut[i], vt[i], W[i])
                           if vis[i] and math.isfinite(I_trk[i]) and D[k] is not None
                           else math.nan for i, k in enumerate(f)])
        check = [abs(detect.window_b_intensity(D[k], uv[i, 0], uv[i, 1], W[i]) - I_trk[i])
                 / max(I_trk[i], 1.0) for i, k in enumerate(f) if math.isfinite(I_trk[i])]
        I_trk = np.where(vis, I_trk, math.nan)
        d = np.hypot(uv[:, 0] - ut, uv[:, 1] - vt)[vis]
        tt = np.asarray(tracks["t"])[sel]
        xy = np.stack([x, y], 1)
        p_trk, ped_trk = _best_p(cfg, tt, I_trk, xy)
        p_true, ped_true = _best_p(cfg, tt, I_true, xy)
        rows.append({"object": str(obj.track_id), "kind": obj.kind, "rows": int(n),
                     "rows_visible": int(vis.sum()),
                     "dist_med": float(np.median(d)) if d.size else math.nan,
                     "dist_p90": float(np.percentile(d, 90)) if d.size else math.nan,
                     "dv_med": float(np.median(np.abs(uv[:, 1] - vt)[vis])) if d.size
                     else math.nan,
                     "P_trk": p_trk, "P_true": p_true, "ped_trk": bool(ped_trk),
                     "ped_true": bool(ped_true),
                     # self-check: I(k) recomputed here at the window's foot point against the
                     # tracker's, the median relative difference (float32 rounding of est_uv)
                     "I_check": float(np.median(check)) if check else math.nan})
    return rows


def own_clips(n_scenes: int, jitter_px: float):
    """(name, cfg, frames, truth) of the own scenes with camera shake `jitter_px` (px, std)."""
    import dataclasses

    import eval_synthetic as es

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.scene import render_scene

    cfg = config_from_dict(es.RECOMMENDED)
    for seed in OWN_SEEDS[:n_scenes]:
        spec = es.scene_specs(seed, 1, camera=cfg.camera)[0][1]
        spec = dataclasses.replace(spec, jitter_px=jitter_px)
        scene = render_scene(seed, spec)
        yield f"own_{seed}_j{jitter_px:g}", cfg, list(scene.frames), scene.truth


def dev_clips():
    """(name, cfg, frames, truth) of the dev clips with single objects (report only)."""
    import eval_real_video as ev
    from eval_all_score import dev_camera, dev_truth

    from rhythmjax.vision.video import VideoSource

    index = json.loads((DEV_ROOT / "index.json").read_text())["clips"]
    for c in index:
        if c.get("count"):
            continue
        truth = json.loads((DEV_ROOT / c["truth"]).read_text())
        path = DEV_ROOT / c["video"]
        cfg = ev.video_config(dev_camera(truth), path, truth["fps"])
        frames = [f for _, _, f in VideoSource(str(path), fps=truth["fps"])]
        yield c["clip"], cfg, frames, dev_truth(truth)


def own_verdicts(n_scenes: int, jitters, modes) -> None:
    """Walkers (and others) judged Pedestrian on the own scenes with each shake and stabilise
    setting, scored as benchmarks/eval_synthetic.py scores (each object's verdict from the
    windows that looked at it)."""
    import dataclasses

    import eval_synthetic as es

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import synthetic_options

    cfg = config_from_dict(es.RECOMMENDED)
    for j in jitters:
        for mode in modes:
            opt = with_changes(synthetic_options(), {"motion.stabilise": mode == "on"})
            walk = ped = other = 0
            for seed in OWN_SEEDS[:n_scenes]:
                spec = dataclasses.replace(es.scene_specs(seed, 1, camera=cfg.camera)[0][1],
                                           jitter_px=j)
                for r in es.run_scene(cfg, seed, spec, opt)[0]["objects"]:
                    if r["kind"] == "pedestrian":
                        walk, ped = walk + 1, ped + (r["verdict"] == "pedestrian")
                    else:
                        other += r["verdict"] == "pedestrian"
            print(f"verdicts shake {j:g} px stabilise {mode}: walkers Pedestrian {ped}/{walk}, "
                  f"others Pedestrian {other}", flush=True)


def summary(rows: list[dict]) -> dict:
    """Medians over the walkers and the count judged Pedestrian with each placement."""
    w = [r for r in rows if r["kind"] == "pedestrian"]
    med = lambda k: float(np.nanmedian([r[k] for r in w])) if w else math.nan  # noqa: E731
    return {"walkers": len(w), "dist_med": med("dist_med"), "dist_p90": med("dist_p90"),
            "dv_med": med("dv_med"), "P_trk": med("P_trk"), "P_true": med("P_true"),
            "ped_trk": sum(r["ped_trk"] for r in w), "ped_true": sum(r["ped_true"] for r in w)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", default="own,dev")
    ap.add_argument("--jitter", default="0,1", help="own scenes: shake std px, comma-separated")
    ap.add_argument("--scenes", type=int, default=4)
    ap.add_argument("--stabilise", default="off,on")
    ap.add_argument("--min-shift", type=float, default=None,
                    help="MotionOptions.stabilise_min_shift_px (default: the option's)")
    ap.add_argument("--option", action="append", default=[], metavar="GROUP.KEY=JSON",
                    help="a tracker option for every run, e.g. body.sample_estimate=false")
    ap.add_argument("-o", "--output", default=None)
    ap.add_argument("--verdicts", action="store_true",
                    help="own scenes only: walkers judged Pedestrian per shake and setting")
    a = ap.parse_args(argv)
    if a.verdicts:
        own_verdicts(a.scenes, [float(j) for j in a.jitter.split(",")], a.stabilise.split(","))
        return 0
    extra = {k: json.loads(v) for k, _, v in (o.partition("=") for o in a.option)}
    from rhythmjax.sim.presets import synthetic_options

    out: dict = {}
    for src in a.source.split(","):
        clips = (dev_clips() if src == "dev" else
                 (c for j in a.jitter.split(",") for c in own_clips(a.scenes, float(j))))
        base = TrackerOptions() if src == "dev" else synthetic_options()
        for name, cfg, frames, truth in clips:
            for mode in a.stabilise.split(","):
                ch = {**extra, "motion.stabilise": mode == "on"}
                if a.min_shift is not None:
                    ch["motion.stabilise_min_shift_px"] = a.min_shift
                rows = measure_clip(cfg, frames, truth, with_changes(base, ch))
                out.setdefault(mode, {})[name] = rows
                for r in rows:
                    print(f"{mode:3s} {name:16s} {r['object']:>7s} {r['kind'][:5]:5s} "
                          f"rows {r['rows']:3d} d_med {r['dist_med']:5.1f} p90 "
                          f"{r['dist_p90']:5.1f} dv {r['dv_med']:4.1f}  P trk {r['P_trk']:6.1f}"
                          f" true {r['P_true']:6.1f}  ped {int(r['ped_trk'])}/"
                          f"{int(r['ped_true'])}", flush=True)
    groups: dict = {}
    for mode, clips in out.items():
        for name, rows in clips.items():
            key = "dev" if name.startswith("dev") else name.rsplit("_", 1)[1]
            groups.setdefault(f"{mode}/{key}", []).extend(rows)
    summ = {k: summary(v) for k, v in groups.items()}
    for k, s in summ.items():
        print(k, json.dumps({q: round(x, 2) if isinstance(x, float) else x
                             for q, x in s.items()}))
    if a.output:
        Path(a.output).write_text(json.dumps({"rows": out, "summary": summ}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
