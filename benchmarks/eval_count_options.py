"""`count.count_frames` with any `count.options.CountOptions` changes, on eval_all's counting
sources: own counting scenes of a seed (`count:SEED`, eval_count's scene specs, `--scenes` of
them, clothing as `--clothing`), `dev_count` (the dev crowd clips; report only) and
`pets_count`. Prints one line per source: walkers counted / true, per-clip errors summed,
non-walkers counted, MOTA, IDF1 (eval_all's columns) and the distinct bound (the most tracks
standing for distinct walkers and its per-clip errors summed, `count_bounds`) and how often
counts.json's range walkers_low .. walkers_high holds the true count; `-o` keeps every clip.

    python benchmarks/eval_count_options.py --sources count:42024,count:31337 \\
        [--scenes 10] [--clothing any] [--focal-px 500] [--set new.head_feet=1.25 ...] \\
        [--name NAME] [-o OUT.json]

`--set GROUP.FIELD=JSON` (repeatable) changes a CountOptions field (`track.options.
with_changes`); nothing here chooses anything: it measures.
"""

from __future__ import annotations

import argparse
import copy
import functools
import json
import math
import os
import sys
import time


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def count_seed(seed: int, clothing: str, log, scenes: int = 10, focal_px: float = 0.0) -> dict:
    """eval_all.run_count on one seed's counting scenes (`clothing`: `random_spec`'s;
    `focal_px` > 0: the camera's a f = b f in px instead of the paper's 800)."""
    import eval_all as ea
    import eval_count as ec
    from eval_all_score import count_row

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import render_scene

    d = copy.deepcopy(SYNTHETIC_CONFIG)
    if focal_px > 0:
        d["camera"] = {"a_px_per_m": focal_px / 0.008, "b_px_per_m": focal_px / 0.008}
    cfg = config_from_dict(d)
    clips = []
    for scene_seed, spec in ec.scene_specs(scenes, seed=seed, camera=cfg.camera, clothing=clothing):
        scene = render_scene(scene_seed, spec)
        truth, kinds = ec.truth_boxes(scene)
        frames = [(k, k / scene.fps, f) for k, f in enumerate(scene.frames)]
        clips.append(ea.count_clip(cfg, frames, truth, kinds, -1))
        log(f"count {seed}/{scene_seed}: {clips[-1]}")
    return {"count": count_row(clips), "clips": clips}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sources", default="count:42024")
    p.add_argument("--set", action="append", default=[], metavar="GROUP.FIELD=JSON")
    p.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    p.add_argument("--scenes", type=int, default=10, help="own scenes per seed")
    p.add_argument("--focal-px", type=float, default=0.0, help="own scenes' camera a f = b f "
                   "(px; default the paper's 800: heads cut nearer than 15 m; 500: from 3.3 m)")
    p.add_argument("--name", default="", help="a label for the printed lines")
    p.add_argument("--gaps", choices=("interpolate", "segments"),
                   help="a rhythm window's missing samples (`rhythm.GAPS`; default the library's)")
    p.add_argument("-o", "--output")
    a = p.parse_args(argv)

    import eval_all as ea

    import rhythmjax.count as rc
    import rhythmjax.model.rhythm as rh

    rh.GAPS = a.gaps or rh.GAPS  # before the first window is traced
    from rhythmjax.count.options import CountOptions, with_changes

    changes = {k: json.loads(v) for k, v in (s.split("=", 1) for s in a.set)}
    rc.count_frames = functools.partial(rc.count_frames,
                                        options=with_changes(CountOptions(), changes))
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    out = {"changes": changes, "clothing": a.clothing, "focal_px": a.focal_px}
    name = a.name or (",".join(a.set) or "defaults")
    for src in a.sources.split(","):
        t0 = time.perf_counter()
        if src.startswith("count:"):
            r = count_seed(int(src.split(":")[1]), a.clothing, log, a.scenes, a.focal_px)
        elif src == "dev_count":
            r = ea.run_dev_count([], False, log)
        elif src == "pets_count":
            r = ea.run_pets_count([], False, log)
        else:
            raise SystemExit(f"unknown source {src}")
        out[src] = r
        c = r["count"]
        print(f"{name} {src} ({a.clothing if src.startswith('count:') else '-'}): counted "
              f"{c['counted']}/{c['true']} err {100 * c['count_err_sum']:.1f} % others "
              f"{c['others_counted']} mota {c['mota']:.3f} idf1 {c['idf1']:.3f} distinct "
              f"{c.get('distinct', '-')} err {100 * c.get('distinct_err_sum', math.nan):.1f} % "
              f"range holds the truth {c.get('range_holds', '-')}/{c.get('clips', '-')} "
              f"(below {c.get('true_below_range', '-')}, above {c.get('true_above_range', '-')}) "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
    if a.output:
        with open(a.output, "w") as f:
            json.dump(out, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
