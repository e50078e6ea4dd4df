"""The speed of each half of the deciding rhythm window, for tracks judged Pedestrian on the own
scenes, by the object the window followed (issue 16; a study: nothing is chosen here).

A track that followed a walker and then a bicycle passing it can be judged Pedestrian by a window
that holds both: the Theil-Sen speed (12) over the whole window is the walker's (the median
slope), while the bicycle's rows move at 3 m/s. This prints, per Pedestrian track, the speed (12)
(`track.toolkit.half_speeds`, rule 42's: the measured foot points taken to the ground, else the
filter's ground positions) of the window's first and last N/2 rows against the fastest walk
(14) accepts (`model.params.walking_top_speed`, 2.57 m/s with Table 1), with the object the
window followed (`sim.evaluate.window_objects`) and the object each row's foot point lies
nearest (`study_tracks.nearest_per_row`). Tracked as `eval_synthetic.py` tracks (cached under -d).

    python benchmarks/study_half_speed.py SEED[,SEED...] [--scenes 10] [--set KEY=JSON] -d DIR
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).parent))

from eval_synthetic import RECOMMENDED, scene_specs  # noqa: E402
from study_tracks import nearest_per_row, track_scene  # noqa: E402


def main(argv=None) -> int:
    from rhythmjax.model.params import config_from_dict, walking_top_speed
    from rhythmjax.model.status import Verdict
    from rhythmjax.sim.evaluate import deciding_windows, match_tracks, window_objects
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.track.options import with_changes
    from rhythmjax.track.toolkit import half_speeds

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("seeds")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--set", action="append", default=[], metavar="KEY=JSON")
    p.add_argument("-d", "--cache", type=Path, required=True)
    a = p.parse_args(argv)
    changes = {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)}
    opt = with_changes(synthetic_options(), changes)
    cfg = config_from_dict(RECOMMENDED)
    top = walking_top_speed(cfg)
    tag = "-".join(f"{k}={v}" for k, v in sorted(changes.items())) or "defaults"
    print(f"fastest walk (14): {top:.2f} m/s")
    for seed in (int(s) for s in a.seeds.split(",")):
        for i, (s, spec) in enumerate(scene_specs(seed, a.scenes, camera=cfg.camera)):
            tracks, verdicts, objs, truth = track_scene(cfg, s, spec,
                                                        a.cache / tag / str(seed), options=opt)
            owner = match_tracks(tracks, truth)
            followed = window_objects(tracks, truth, deciding_windows(objs))
            for o in objs:
                if (o.result is None or "window" not in o.result
                        or int(o.result["verdict"]) != Verdict.PEDESTRIAN):
                    continue
                k0, k1 = (int(k) for k in o.result["window"])
                first, last = half_speeds(cfg, o.rows[k0:k1])
                kind = getattr(followed.get(o.track_id), "kind", "none")
                track_kind = getattr(owner.get(o.track_id), "kind", "none")
                flag = " FAST" if max(first, last) > top else ""
                print(f"{seed}:{i} track {o.track_id} window {kind} (track {track_kind}) "
                      f"speed {float(o.result['speed_mps']):.2f} halves {first:.2f} "
                      f"{last:.2f}{flag}  {nearest_per_row(o, k0, k1, truth)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
