"""A tracker rule ON against OFF on a pool of own scenes, paired by scene, with a bootstrap CI.

`eval_rules.py` decides a tracker rule on two training seeds and reports it on single seeds of
10 scenes, where a change to a track's first frames moves which track claims a shared detection
later and so moves a seed by two or three walkers either way (docs/rules.md, rule 16). Here the
same scenes (`eval_synthetic.py`'s, with its preset config and tracker options) run with the
defaults (OFF) and with the changes (ON) over a pool of seeds; per scene the walkers judged
Pedestrian (each object's longest judged track, `sim.evaluate.score`) and the non-walkers judged
Pedestrian; the pooled difference ON - OFF with a 95 % bootstrap interval over scenes (2 000
resamples, fixed generator). Nothing is chosen here.

    python benchmarks/paired_tracker.py --seeds 11,12,13,14 [--scenes 10] \\
        [--option body.side_anchor=true] [--set noise.r_std_px=[3,5]] [-o paired.json]

`--option GROUP.KEY=JSON` changes the tracker options (`track.options.with_changes`), `--set
SECTION.KEY=JSON` the config (`eval_all.apply_set`); both repeatable.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

BOOTSTRAP = 2000


def scene_counts(by_track: dict) -> tuple[int, int, int]:
    """(walkers, walkers judged Pedestrian, non-walkers judged Pedestrian) of one scene's
    by-track score (`sim.evaluate.score`: one row per object with kind and verdict)."""
    objs = by_track["objects"]
    walkers = [o for o in objs if o["kind"] == "pedestrian"]
    ped = sum(o["verdict"] == "pedestrian" for o in walkers)
    others = sum(o["verdict"] == "pedestrian" for o in objs if o["kind"] != "pedestrian")
    return len(walkers), int(ped), int(others)


def paired_interval(diff: np.ndarray, n_boot: int = BOOTSTRAP, seed: int = 0):
    """(sum, low, high): the summed per-scene differences and its 95 % bootstrap interval
    (scenes resampled with replacement)."""
    diff = np.asarray(diff, np.float64)
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, len(diff), size=(n_boot, len(diff)))
    sums = diff[idx].sum(axis=1)
    return float(diff.sum()), float(np.percentile(sums, 2.5)), float(np.percentile(sums, 97.5))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", required=True, help="comma-separated own-scene seeds")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--option", action="append", default=[], help="GROUP.KEY=JSON (tracker)")
    p.add_argument("--set", action="append", default=[], help="SECTION.KEY=JSON (config)")
    p.add_argument("-o", "--out")
    a = p.parse_args(argv)

    import eval_synthetic as es
    from eval_all_score import apply_set, parse_set

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.track.options import with_changes

    sets = parse_set(a.set)
    cfg_off = config_from_dict(es.RECOMMENDED)
    cfg_on = config_from_dict(apply_set(es.RECOMMENDED, sets))
    opt_off = es.synthetic_options()
    opt_on = with_changes(opt_off, {f"{g}.{k}": v for g, k, v in parse_set(a.option)})
    rows = []
    for seed in (int(s) for s in a.seeds.split(",")):
        for i, (s, spec) in enumerate(es.scene_specs(seed, a.scenes, camera=cfg_off.camera)):
            off = scene_counts(es.run_scene(cfg_off, s, spec, opt_off)[4])
            on = scene_counts(es.run_scene(cfg_on, s, spec, opt_on)[4])
            rows.append({"seed": seed, "scene": i, "walkers": off[0], "ped_off": off[1],
                         "ped_on": on[1], "others_off": off[2], "others_on": on[2]})
        print(f"seed {seed}: walkers Pedestrian OFF {sum(r['ped_off'] for r in rows)} ON "
              f"{sum(r['ped_on'] for r in rows)} (pooled so far)", flush=True)
    d_ped = np.array([r["ped_on"] - r["ped_off"] for r in rows])
    d_oth = np.array([r["others_on"] - r["others_off"] for r in rows])
    res = {"seeds": a.seeds, "scenes": len(rows), "walkers": sum(r["walkers"] for r in rows),
           "walkers_pedestrian": [int(sum(r["ped_off"] for r in rows)),
                                  int(sum(r["ped_on"] for r in rows))],
           "non_walkers_pedestrian": [int(sum(r["others_off"] for r in rows)),
                                      int(sum(r["others_on"] for r in rows))],
           "walkers_diff": paired_interval(d_ped), "non_walkers_diff": paired_interval(d_oth),
           "scenes_better": int(np.sum(d_ped > 0)), "scenes_worse": int(np.sum(d_ped < 0)),
           "option": a.option, "set": a.set, "rows": rows}
    w, o = res["walkers_diff"], res["non_walkers_diff"]
    print(f"{res['scenes']} scenes, {res['walkers']} walkers: judged Pedestrian "
          f"{res['walkers_pedestrian'][0]} -> {res['walkers_pedestrian'][1]} "
          f"({w[0]:+.0f} [{w[1]:+.0f}, {w[2]:+.0f}]; scenes better {res['scenes_better']}, "
          f"worse {res['scenes_worse']}); non-walkers {res['non_walkers_pedestrian'][0]} -> "
          f"{res['non_walkers_pedestrian'][1]} ({o[0]:+.0f} [{o[1]:+.0f}, {o[2]:+.0f}])")
    if a.out:
        tmp = a.out + ".tmp"
        with open(tmp, "w") as f:
            json.dump(res, f, indent=1)
        os.replace(tmp, a.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
