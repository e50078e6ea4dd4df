"""Fit the height thresholds of rule 26 (`size.min_height_heights`, a priori 0.5 walker heights)
and rule 37 (`size.twice_pace_heights`, a priori 0.75) from labelled tracker tracks of the own
scenes (`fit.heights`; issue 16 item 3), on training seeds, and report them on held-out seeds.

Each scene (`eval_synthetic.scene_specs`, walkers with knees) goes through the online tracker
exactly as `eval_synthetic.py` runs it; each track is labelled with the kind of the object it
follows (`sim.evaluate.match_tracks`) and its median height read as rule 26 reads it and as
rule 37 reads it (with the rows at the image's edge; `fit.heights.track_heights`). Each
threshold is fitted on the `--train` seeds' tracks and reported on the `--test` seeds' (choose
on one source, report on another).

    python benchmarks/fit_height_threshold.py [--train 5555] [--test 6666] [--scenes 10] [-o F]
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(__file__))

import eval_synthetic as es  # noqa: E402

from fit.heights import fit_height_threshold, track_heights  # noqa: E402
from rhythmjax.model.camera_np import camera_tuple  # noqa: E402
from rhythmjax.model.params import config_from_dict, host_float  # noqa: E402
from rhythmjax.sim.evaluate import match_tracks  # noqa: E402
from rhythmjax.sim.presets import synthetic_options  # noqa: E402


def labelled_heights(cfg, seeds, n_scenes) -> tuple[dict, np.ndarray, np.ndarray]:
    """({"rule26", "rule37"}: heights in walker heights, labels, seed) of every tracker track of
    the seeds' scenes."""
    opt = synthetic_options()
    camera, walker_m = camera_tuple(cfg.camera), host_float(cfg.width.height)
    H: dict = {"rule26": [], "rule37": []}
    L, S = [], []
    for seed in seeds:
        for i, (s, spec) in enumerate(es.scene_specs(seed, n_scenes, camera=cfg.camera)):
            _, tracks, _, scene, _ = es.run_scene(cfg, s, spec, opt)
            owner = match_tracks(tracks, scene.truth)
            for rule, edge in (("rule26", False), ("rule37", True)):
                ids, h = track_heights(camera, tracks, walker_m, opt.size.top_inside_heights,
                                       opt.size.min_height_rows, edge=edge)
                H[rule] += list(h)
            L += [owner[int(t)].kind if int(t) in owner else "" for t in ids]
            S += [seed] * len(ids)
            print(f"seed {seed} scene {i}: {len(ids)} tracks", file=sys.stderr)
    return ({k: np.asarray(v) for k, v in H.items()}, np.asarray(L, dtype=object),
            np.asarray(S))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--train", default="5555")
    p.add_argument("--test", default="6666")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("-o", "--out", default="fit_height_threshold.json")
    a = p.parse_args(argv)
    train = [int(s) for s in a.train.split(",")]
    test = [int(s) for s in a.test.split(",")]
    if {20240603, 777001} & set(train):
        p.error("20240603 and 777001 are evaluation seeds: fit on others")
    cfg = config_from_dict(es.RECOMMENDED)
    heights, labels, seed = labelled_heights(cfg, train + test, a.scenes)
    size = synthetic_options().size
    res = {"train": train, "test": test, "scenes": a.scenes}
    for rule, start in (("rule26", size.min_height_heights), ("rule37", size.twice_pace_heights)):
        h = heights[rule]
        r = fit_height_threshold(h, labels, np.isin(seed, test), start=start)
        res[rule] = {"threshold": r.threshold, "start": r.start, "plateau": r.plateau,
                     "ba": r.ba, "auc": r.auc, "counts": r.counts,
                     "heights": {k: sorted(round(float(x), 3)
                                           for x in h[(labels == k) & np.isfinite(h)])
                                 for k in ("pedestrian", "dog", "bicycle")}}
    with open(a.out, "w") as f:
        json.dump(res, f, indent=1)
    print(json.dumps({k: ({kk: vv for kk, vv in v.items() if kk != "heights"}
                          if isinstance(v, dict) else v) for k, v in res.items()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
