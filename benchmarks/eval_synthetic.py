"""Synthetic evaluation set of issue 3 (Measured acceptance): fixed seed, the paper's camera.

10 scenes of 180 frames at 15 Hz, 512x512, each with 3-4 walkers (pace N(2.05, 0.183) Hz, step
N(0.72, 0.09) m, 3-20 m), one bicycle (3.0-3.2 m/s on a mostly radial path: fast enough to be a
bicycle, slow enough to stay ~70 frames (>= 64 = N) in the range and the image) and, in half
of them, a dog: 35 walkers, 10 bicycles, 5 dogs. The walkers bend their knees and roll their
feet heel to toe (`random_spec`'s articulated, `sim.legs`; since issue 16's thirty-eighth round:
before it they had straight legs, `--legs rods`).
Every scene goes through the online tracker (detect + Fig. 3 state machine + rhythm windows) and
`evaluate.score`; prints pace MAE, step-length median error, walkers judged Pedestrian (of all
and of the classifiable ones: `sim.clean`, the dev renderer's convention, a run of N frames
with the feet in the image, 3-20 m away and not hidden), bicycles and dogs judged
Non-pedestrian, and missed / unclassified counts; writes the figures as JSON.

    python benchmarks/eval_synthetic.py [-o eval_synthetic.json] [--config C.json] [--scenes 10]
                                        [--seed S] [--legs knees|rods]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from rhythmjax.model.params import Config, config_from_dict, config_to_dict
from rhythmjax.sim.evaluate import summarise
from rhythmjax.sim.presets import SCENE_OPTIONS, SYNTHETIC_CONFIG, synthetic_options


SEED = 20240603
N_FRAMES = 180
RECOMMENDED = SYNTHETIC_CONFIG  # the demo's config (and its tracker options, SYNTHETIC_OPTIONS)


def scene_specs(seed: int = SEED, n_scenes: int = 10, n_frames: int = N_FRAMES, camera=None,
                clothing: str = "contrasted", suitcase_fraction: float = 0.0,
                lateral_deg: float | None = None, articulated: bool = True):
    """The fixed evaluation scenes: (scene_seed, SceneSpec) pairs (`clothing`: `random_spec`'s,
    "any" for clothing grey levels that may match the ground's; `suitcase_fraction`: of the
    walkers pulling a suitcase, `lateral_deg`, paths crossing the view, and `articulated`,
    walkers with knees and heel-to-toe feet: `random_spec`'s; False, straight legs, the scenes
    before issue 16's thirty-eighth round)."""
    from rhythmjax.sim.scene import random_spec

    out = []
    for i in range(n_scenes):
        s = seed + 1000 * i
        out.append((s, random_spec(s, n_walkers=4 if i < 5 else 3, n_bicycles=1,
                                   n_dogs=1 if i % 2 == 0 else 0, n_frames=n_frames,
                                   camera=camera, clothing=clothing,
                                   suitcase_fraction=suitcase_fraction,
                                   lateral_deg=lateral_deg, articulated=articulated,
                                   **SCENE_OPTIONS)))
    return out


def run_scene(cfg, seed, spec, options=None):
    """Render, track and score one scene; returns (score dict with each object's verdict from
    the windows that looked at it, tracks, verdicts, scene, score dict with each object's
    verdict from the track assigned to it); see `evaluate.score`."""
    from rhythmjax.sim.clean import classifiable
    from rhythmjax.sim.evaluate import deciding_windows, score
    from rhythmjax.sim.scene import render_scene
    from rhythmjax.track import track_frames

    scene = render_scene(seed, spec)
    frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
    tracks, verdicts, objs, _ = track_frames(cfg, frames, progress=False,
                                             options=options or synthetic_options())
    clean = classifiable(scene, n=int(cfg.thresholds.n))
    by_window = score(tracks, verdicts, scene.truth, windows=deciding_windows(objs),
                      classifiable=clean)
    return (by_window, tracks, verdicts, scene,
            score(tracks, verdicts, scene.truth, classifiable=clean))


def evaluate(cfg, specs, options=None, verbose=True) -> dict:
    """Figures with each object's verdict from the windows that looked at it (the main ones)
    and, under "by_track", from the track assigned to it."""
    rows, rows_track, n_tracks = [], [], 0
    for i, (seed, spec) in enumerate(specs):
        res, _, verdicts, scene, res_track = run_scene(cfg, seed, spec, options)
        n_tracks += len(verdicts["track_id"])
        for r in res["objects"] + res_track["objects"]:
            r["scene"] = i
            r["visible_frames"] = int(next(o for o in scene.truth
                                           if o.track_id == r["object"]).visible.sum())
        rows += res["objects"]
        rows_track += res_track["objects"]
        if verbose:
            print(f"scene {i}: " + ", ".join(f"{r['object']}:{r['verdict'][:5]}/{r['tracks']}"
                                            for r in res["objects"]), file=sys.stderr)
    out = figures(rows, n_tracks)
    out["by_track"] = figures(rows_track, n_tracks)
    return out


def figures(rows, n_tracks) -> dict:
    out = summarise(rows)
    for kind in ("pedestrian", "bicycle", "dog"):
        mine = [r for r in rows if r["kind"] == kind]
        out[f"{kind}_n"] = len(mine)
        for v in ("pedestrian", "non-pedestrian", "unclassified", "missed"):
            out[f"{kind}_{v}"] = sum(r["verdict"] == v for r in mine)
    others = out["bicycle_n"] + out["dog_n"]
    non = out["bicycle_non-pedestrian"] + out["dog_non-pedestrian"]
    out["others_non_pedestrian_rate"] = non / others if others else math.nan
    out["others_pedestrian"] = out["bicycle_pedestrian"] + out["dog_pedestrian"]
    walkers = [r for r in rows if r["kind"] == "pedestrian"]
    out["walker_tracks_per_object"] = (float(np.mean([r["tracks"] for r in walkers]))
                                       if walkers else math.nan)
    out["n_tracks"] = n_tracks
    out["objects"] = rows
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default="eval_synthetic.json")
    p.add_argument("--config", help="config JSON (default: the recommended one, RECOMMENDED)")
    p.add_argument("--defaults", action="store_true", help="use params.py's defaults")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--seed", type=int, default=SEED)
    p.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"),
                   help="clothing grey levels of the scenes' objects (random_spec)")
    p.add_argument("--legs", default="knees", choices=("knees", "rods"),
                   help="walkers' legs: knees and heel-to-toe feet (default) or straight rods")
    a = p.parse_args(argv)
    if a.config:
        with open(a.config) as fh:
            cfg = config_from_dict(json.load(fh))
    else:
        cfg = Config() if a.defaults else config_from_dict(RECOMMENDED)
    t0 = time.perf_counter()
    out = evaluate(cfg, scene_specs(a.seed, a.scenes, camera=cfg.camera, clothing=a.clothing,
                                    articulated=a.legs == "knees"))
    out["seconds"] = time.perf_counter() - t0
    out["config"] = config_to_dict(cfg)
    out["seed"] = a.seed
    out["legs"] = a.legs
    with open(a.output, "w") as fh:
        json.dump(out, fh, indent=1, default=float)
    f = lambda x: f"{x:.3f}"  # noqa: E731
    print("verdicts from the windows that looked at each object (by track: from the track "
          "assigned to it)\n")
    print("| figure | by window | by track | target |\n|---|---|---|---|")
    b = out["by_track"]
    print(f"| pace MAE (Hz) | {f(out['pace_mae_hz'])} | {f(b['pace_mae_hz'])} | <= 0.03 |")
    print(f"| step-length median error (m) | {f(out['stride_median_err_m'])} | "
          f"{f(b['stride_median_err_m'])} | <= 0.03 |")
    for name, ped, key, judged, target in (
            ("walkers judged Pedestrian, of all", "walkers_pedestrian",
             "walker_pedestrian_rate", "walkers", ""),
            ("... of the classifiable ones (sim.clean)", "classifiable_pedestrian",
             "walker_pedestrian_rate_classifiable", "walkers_classifiable", ">= 90 %"),
            ("... of those tracked >= N frames (Table 3)", "walkers_pedestrian",
             "walker_pedestrian_rate_judged", "walkers_judged", ">= 95 %")):
        print(f"| {name} | " + " | ".join(
            f"{o[ped]}/{o[judged]} ({100 * o[key]:.1f} %)" for o in (out, b))
            + f" | {target} |")
    for kind in ("bicycle", "dog"):
        print(f"| {kind}s judged Non-pedestrian | " + " | ".join(
            f"{o[kind + '_non-pedestrian']}/{o[kind + '_n']} (pedestrian "
            f"{o[kind + '_pedestrian']}, unclassified {o[kind + '_unclassified']}, missed "
            f"{o[kind + '_missed']})" for o in (out, b)) + " | 100 % |")
    print("| walkers unclassified / missed / non-pedestrian | " + " | ".join(
        f"{o['pedestrian_unclassified']} / {o['pedestrian_missed']} / "
        f"{o['pedestrian_non-pedestrian']}" for o in (out, b)) + " | |")
    print(f"| tracks per walker | {out['walker_tracks_per_object']:.2f} | | 1 |")
    print(f"\n{out['n_tracks']} tracks, {out['seconds']:.0f} s; wrote {a.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
