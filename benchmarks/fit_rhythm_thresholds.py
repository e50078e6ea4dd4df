"""Fit the rhythm classifier's thresholds from labelled tracks of the project's own scenes, then
say what the fitted values do on every other source (issue 16 item 3: a rule beyond the paper is a
parameter fitted from labelled data, with a held-out split, or it is not kept).

Training data: the own renderer's scenes with TRAINING seeds only (never the evaluation seed
20240603 nor eval_all's fresh seed 777001), through the online tracker exactly as
`eval_synthetic.py` runs them; each track is labelled with the kind of the true object it follows
(`sim.evaluate.match_tracks`; unmatched tracks unlabelled). `fit.walking.fit_walking` then fits
P_thr (13), R_thr (15) and k_sigma3 (14) for the balanced accuracy on a stratified training split
(the walking model is fitted too; the own renderer draws walkers from Table 1's Gaussians, so only
the thresholds are reported as new) and reports the balanced accuracy on the held-out split.

    python benchmarks/fit_rhythm_thresholds.py [--seeds 5555,6666] [--scenes 10] [-o DIR]

Writes DIR/tracks.parquet (labelled), DIR/fit.json (thresholds, balanced accuracies) and prints
the `--set` arguments of eval_all.py that apply the fitted thresholds.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def labelled_tracks(cfg, seeds, n_scenes) -> dict[str, np.ndarray]:
    import eval_synthetic as es

    from rhythmjax.sim.evaluate import match_tracks

    parts = []
    for seed in seeds:
        for i, (s, spec) in enumerate(es.scene_specs(seed, n_scenes, camera=cfg.camera)):
            _, tracks, _, scene, _ = es.run_scene(cfg, s, spec)
            owner = match_tracks(tracks, scene.truth)
            tid = np.asarray(tracks["track_id"])
            cols = {k: np.asarray(v) for k, v in tracks.items()}
            cols["label"] = np.array([owner[int(t)].kind if int(t) in owner else ""
                                      for t in tid], dtype=object)
            cols["track_id"] = np.array([f"{seed}-{i}-{int(t)}" for t in tid], dtype=object)
            parts.append(cols)
            print(f"seed {seed} scene {i}: {len(np.unique(tid))} tracks, "
                  f"{len(owner)} labelled", file=sys.stderr)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def main(argv=None) -> int:
    import eval_synthetic as es

    from fit.walking import fit_walking
    from rhythmjax.io import read_tracks, to_batch, write_table
    from rhythmjax.model.params import config_from_dict

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", default="5555,6666")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--test-fraction", type=float, default=0.3)
    p.add_argument("-o", "--out", default="fit_thresholds")
    a = p.parse_args(argv)
    seeds = [int(s) for s in a.seeds.split(",")]
    if {20240603, 777001} & set(seeds):
        p.error("20240603 and 777001 are evaluation seeds: fit on others")
    d = json.loads(json.dumps(es.RECOMMENDED))
    d.setdefault("thresholds", {})["harmonic_max_ratio"] = 0.0  # the paper's (13)-(15)
    cfg = config_from_dict(d)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    cols = labelled_tracks(cfg, seeds, a.scenes)
    write_table(out / "tracks.parquet", cols, list(cols))
    tr = read_tracks(out / "tracks.parquet", fps=cfg.camera.fps)
    batch = to_batch(tr, max_gap_frames=5, min_len=cfg.thresholds.n, fps=cfg.camera.fps)
    r = fit_walking(cfg, batch, test_fraction=a.test_fraction, seed=0)
    res = {"seeds": seeds, "scenes": a.scenes, "thresholds": r.thresholds,
           "start_thresholds": r.start_thresholds, "ba": r.ba, "counts": r.counts,
           "estimates": r.estimates, "success": r.success, "reasons": r.reasons}
    (out / "fit.json").write_text(json.dumps(res, indent=2, default=float))
    print(json.dumps(res, indent=2, default=float))
    keys = {"p_thr": "p_thr", "r_thr": "r_thr", "k_sigma3": "k_sigma3"}
    print(" ".join(f"--set thresholds.{keys[k]}={v:g}" for k, v in r.thresholds.items()
                   if k in keys))
    return 0


if __name__ == "__main__":
    sys.exit(main())
