"""A counted track's blob width against how many walkers it lies on (issue 16, counting; a
study: nothing is chosen here).

Walkers the count misses walk beside another walker, inside one blob. Could the counted track on
such a pair be told by its blob's width? Per counted track of the own counting scenes
(`eval_count.scene_specs`, `count.COUNT_RULE`): its median measured blob width in metres
(`verdicts["width_m"]`, `count.counting.track_width`) and the fraction of its frames in which its
box meets two or more walkers' truth boxes with IoU >= 0.3. Prints the widths' 10th, 50th and
90th percentiles for tracks on two walkers in at least half their frames against the others, and
how many of each reach a few widths.

    python benchmarks/study_pair_width.py SEED[,SEED...] [--scenes 10]
"""

from __future__ import annotations

import argparse
import copy
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from eval_count import scene_specs, truth_boxes  # noqa: E402


BOX = ("bb_left", "bb_top", "bb_width", "bb_height")


def pair_fraction(mot, truth, walkers, track_id: int) -> float:
    """Fraction of `track_id`'s rows in `mot` (frames 1-based) whose box meets two or more of
    the `walkers`' truth boxes (frames 0-based) with IoU >= 0.3."""
    from rhythmjax.evaluation.motscore import iou_matrix

    tb = np.stack([truth[c] for c in BOX], 1)
    rows = np.flatnonzero(np.asarray(mot["id"]) == track_id)
    hb = np.stack([np.asarray(mot[c])[rows] for c in BOX], 1)
    pairs = 0
    for r, f in enumerate(np.asarray(mot["frame"])[rows] - 1):
        kt = np.flatnonzero((truth["frame"] == f) & np.isin(truth["id"], walkers))
        if kt.size and int((iou_matrix(hb[r:r + 1], tb[kt])[0] >= 0.3).sum()) >= 2:
            pairs += 1
    return pairs / rows.size if rows.size else 0.0


def main(argv=None) -> int:
    from rhythmjax.count import CountOptions, count_frames
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import render_scene

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("seeds")
    p.add_argument("--scenes", type=int, default=10)
    a = p.parse_args(argv)
    cfg = config_from_dict(copy.deepcopy(SYNTHETIC_CONFIG))
    width, pair = [], []
    for seed in (int(s) for s in a.seeds.split(",")):
        for s, spec in scene_specs(a.scenes, seed=seed, camera=cfg.camera):
            scene = render_scene(s, spec)
            res = count_frames(cfg, iter([(k, k / scene.fps, f)
                                          for k, f in enumerate(scene.frames)]),
                               n_frames=len(scene.frames), options=CountOptions())
            truth, kinds = truth_boxes(scene)
            walkers = [t for t, k in kinds.items() if k == "pedestrian"]
            v = res.verdicts
            for j in np.flatnonzero(np.asarray(v["counted"], bool)):
                width.append(float(v["width_m"][j]))
                pair.append(pair_fraction(res.mot, truth, walkers, int(v["track_id"][j])))
    width, pair = np.asarray(width), np.asarray(pair)
    ok = np.isfinite(width)
    groups = (("on one walker", ok & (pair < 0.5)), ("on two or more walkers", ok & (pair >= 0.5)))
    for name, m in groups:
        q = np.round(np.quantile(width[m], [0.1, 0.5, 0.9]), 2) if m.any() else "-"
        print(f"counted tracks {name}: {int(m.sum())}, width m 10/50/90 %: {q}")
    for thr in (0.7, 0.8, 0.9, 1.0):
        print(f"width >= {thr} m: " + ", ".join(f"{int(np.sum(width[m] >= thr))}/{int(m.sum())} "
                                               f"{name}" for name, m in groups))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
