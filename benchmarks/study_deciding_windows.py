"""What the half-pace rule and a height test could tell apart in the windows that decide a
Pedestrian verdict today (issue 16 item 3, forty-second round; a study, nothing chosen).

Item 3 asks for the half-pace rule's threshold to be fitted from labelled tracks. A fit needs
the feature to separate the two kinds where the rule acts: the windows that judge a track
Pedestrian. Per own scene of `eval_synthetic.scene_specs` (radial, or `--lateral` 30 deg),
tracked with the demo's config and `sim.presets.synthetic_options()` (cached under ``-d DIR``
as `study_rescue_windows.py` caches them), every track judged Pedestrian is labelled with the
kind of the object it is assigned to (`sim.evaluate.match_tracks`; "none": no object), and its
deciding window gives:
- the half-pace ratio (`fp_replay.half_ratio`: the power within 0.2 F of 2F over the matched
  peak's; what `thresholds.harmonic_max_ratio` compares), for windows judged "matched" (a
  window judged at half its strongest peak by rule 37, "matched-twice", has it >= 1 by
  construction);
- whether the paper's window B (candidate 0, `fp_replay.judge`) or the deciding candidate has
  its strongest peak within 0.2 F of 2F (the object's rhythm there is twice the pace judged),
  and the window's height as rule 37 reads it (`track.twice.twice_height`, walker heights;
  NaN under `size.min_height_rows` rows): a rule asking such a window for rule 37's height
  (`size.twice_pace_heights`) would refuse those below it.

    python benchmarks/study_deciding_windows.py 3380001,3390001 [--lateral] [-d /tmp/rescue]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections import Counter
from pathlib import Path

import numpy as np


sys.path.insert(0, os.path.dirname(__file__))


def strongest_hz(out: dict) -> float:
    """The frequency (Hz) of an outcome's strongest peak (NaN: no peak)."""
    f, p, m = (np.asarray(out[k]) for k in ("peak_freq", "peak_power", "peak_mask"))
    return float(f[np.argmax(np.where(m, p, -1.0))]) if m.any() else math.nan


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("seeds")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--lateral", action="store_true")
    p.add_argument("-d", "--cache", default="/tmp/study_rescue")
    a = p.parse_args(argv)

    import eval_synthetic as es
    from fp_replay import half_ratio, judge
    from study_false_positives import track_scene

    from rhythmjax.model.camera_np import camera_tuple
    from rhythmjax.model.params import config_from_dict, host_float
    from rhythmjax.model.status import Reason, Verdict
    from rhythmjax.sim.evaluate import match_tracks
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.track.twice import twice_height

    cfg, opt = config_from_dict(es.RECOMMENDED), synthetic_options()
    camera, walker_m = camera_tuple(cfg.camera), host_float(cfg.width.height)
    kw = {"lateral_deg": 30.0} if a.lateral else {}
    ratios: dict[str, list] = {}
    at_double = Counter()
    for seed in (int(s) for s in a.seeds.split(",") if s):
        for idx, (s, spec) in enumerate(es.scene_specs(seed, a.scenes, camera=cfg.camera, **kw)):
            tracks, _, objs, truth = track_scene(cfg, s, spec, Path(a.cache) / str(seed), opt)
            owner = match_tracks(tracks, truth)
            for obj in objs:
                res = obj.result
                if res is None or int(res["verdict"]) != Verdict.PEDESTRIAN:
                    continue
                kind = owner[obj.track_id].kind if obj.track_id in owner else "none"
                if Reason(int(res["reason"])).label != "matched":
                    continue
                ratios.setdefault(kind, []).append(half_ratio(res))
                first, end = res["window"]
                chosen, _, every = judge(cfg, obj, first)
                F = float(res["pace_hz"])
                double = [abs(strongest_hz(o) - 2 * F) <= 0.2 * F for o in (every[0], chosen)]
                if not any(double):
                    continue
                cols = np.asarray([(r.u, r.v, r.v_top, r.top_at_edge)
                                   for r in obj.rows[first:end]], np.float64)
                h, n = twice_height(camera, cols[:, 0], cols[:, 1], cols[:, 2], cols[:, 3],
                                    walker_m, opt.size.top_inside_heights)
                h = h / walker_m if n >= opt.size.min_height_rows else math.nan
                low = not h >= opt.size.twice_pace_heights
                at_double[(kind, "below rule 37's height" if low else "tall")] += 1
                if low or kind != "pedestrian":
                    print(f"{seed}:{idx} track {obj.track_id} ({kind}): F {F:.2f} Hz, strongest "
                          f"peak at 2F in window B {double[0]}, in the deciding candidate "
                          f"{double[1]}; height {h:.2f} walker heights over {n} rows")
    print("\nhalf-pace ratio of the deciding 'matched' windows, per kind (quantiles 0, 50, 90, "
          "100 %; how many reach 0.25, 0.6):")
    for kind, v in sorted(ratios.items()):
        v = np.asarray(v, np.float64)
        q = np.round(np.nanquantile(v, [0, 0.5, 0.9, 1.0]), 2)
        print(f"  {kind}: {len(v)} windows, {q.tolist()}, >= 0.25: {int(np.sum(v >= 0.25))}, "
              f">= 0.6: {int(np.sum(v >= 0.6))}")
    print("windows whose window B or deciding candidate peaks at 2F, by kind and rule 37's "
          "height:", dict(sorted(at_double.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
