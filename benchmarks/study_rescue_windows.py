"""How many rhythm windows a walker's track gives, and what a rule that asks two of them could
rescue (issue 16, forty-second round; a study, nothing chosen).

Rules 38 and 38b (`thresholds.trend_max_cycles`) rescued walkers whose window a trend refused
and also let a dog and UCSD anomaly tracks through (docs/rules.md). A rescue asked to be
corroborated by a second Pedestrian window of the same track would refuse a non-walker's single
weak match; this measures whether walkers would keep their rescues. Per own scene of
`eval_synthetic.scene_specs` (radial, or `--lateral` 30 deg), tracked with the demo's config
and `sim.presets.synthetic_options()` (cached under ``-d DIR``, `study_false_positives.
track_scene`), every walker's longest assigned track of N rows or more is replayed
(`fp_replay.replay`, every window, no stop) with the rule off and on (`--cycles`), and counted:
- judged by the replay with the rule off / on (any window Pedestrian);
- on with corroboration: off's verdict, or at least two windows Pedestrian with the rule on;
- how many windows each walker's track gives (every walker; those missed with the rule off;
  the rescued ones).
The replay applies (13)-(15), the candidates and rules 38/38b, not the tracker's later rules
(size, twice the pace, the recheck), so only walkers are counted: a non-walker's figure here is
not the pipeline's.

    python benchmarks/study_rescue_windows.py 3300001,3310001,3320001,3330001 [--lateral]
        [--cycles 2] [-d /tmp/rescue]
"""

from __future__ import annotations

import argparse
import os
import sys
from collections import Counter
from pathlib import Path


sys.path.insert(0, os.path.dirname(__file__))


def walker_tracks(cfg, seed: int, n_scenes: int, lateral: bool, cache: Path):
    """(scene index, walker truth, its longest assigned track's slim object) per walker of
    `seed`'s scenes with a track of N rows or more."""
    import eval_synthetic as es
    from study_false_positives import track_scene

    from rhythmjax.sim.evaluate import match_tracks
    from rhythmjax.sim.presets import synthetic_options

    kw = {"lateral_deg": 30.0} if lateral else {}
    for idx, (s, spec) in enumerate(es.scene_specs(seed, n_scenes, camera=cfg.camera, **kw)):
        tracks, _, objs, truth = track_scene(cfg, s, spec, cache / str(seed),
                                             synthetic_options())
        by_id = {o.track_id: o for o in objs}
        per: dict[str, list] = {}
        for tid, obj in match_tracks(tracks, truth).items():
            if obj.kind == "pedestrian" and tid in by_id:
                per.setdefault(obj.track_id, [obj]).append(by_id[tid])
        for truth_obj, *cands in per.values():
            long = [o for o in cands if len(o.rows) >= cfg.thresholds.n]
            if long:
                yield idx, truth_obj, max(long, key=lambda o: len(o.rows))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("seeds")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--lateral", action="store_true")
    p.add_argument("--cycles", type=float, default=2.0, help="trend_max_cycles when on")
    p.add_argument("-d", "--cache", default="/tmp/study_rescue")
    a = p.parse_args(argv)

    import eval_synthetic as es
    from fp_replay import replay

    from rhythmjax.model.params import config_from_dict, config_to_dict
    from rhythmjax.model.status import Reason

    d = config_to_dict(config_from_dict(es.RECOMMENDED))
    off = config_from_dict(d)
    d["thresholds"]["trend_max_cycles"] = a.cycles
    on = config_from_dict(d)
    tally, windows, rescued_windows, missed_windows = Counter(), Counter(), Counter(), Counter()
    for seed in (int(s) for s in a.seeds.split(",") if s):
        for idx, truth, obj in walker_tracks(off, seed, a.scenes, a.lateral, Path(a.cache)):
            ped_off = [w["ped"] for w in replay(off, obj, stop=False)]
            res_on = replay(on, obj, stop=False)
            ped_on = [w["ped"] for w in res_on]
            v_off, v_on = any(ped_off), any(ped_on)
            v_two = v_off or sum(ped_on) >= 2
            tally.update({"walkers": 1, "off": v_off, "on": v_on, "on, two windows": v_two})
            windows[len(ped_on)] += 1
            if not v_off:
                missed_windows[len(ped_on)] += 1
            if v_on and not v_off:
                rescued_windows[len(ped_on)] += 1
                labels = [Reason(int(w["out"]["reason"])).label + ("*" if w["ped"] else "")
                          for w in res_on]
                print(f"{seed}:{idx} {truth.track_id}: rescued, {len(res_on)} window(s) {labels}")
    print(f"\nwalkers with a track of N rows or more: {tally['walkers']}; judged Pedestrian "
          f"by the replay: off {tally['off']}, on {tally['on']}, on with two windows "
          f"{tally['on, two windows']}")
    print("windows judged per walker's track (all):", dict(sorted(windows.items())))
    print("windows judged per walker's track the replay misses with the rule off:",
          dict(sorted(missed_windows.items())))
    print("windows judged per rescued walker's track:", dict(sorted(rescued_windows.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
