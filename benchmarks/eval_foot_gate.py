"""The foot-point gates of `count.foot_gate` (options a and b) on and off, through eval_all's
count sources: own counting scenes of `--seeds` (eval_count's scene specs), `dev_count` (report
only) and `pets_count`. One `--variant NAME` at a time (2 shared cores):

    off    the defaults
    a      placement.in_range
    a2     placement.in_range, placement.gate_heights = 1
    g1/g2  placement.gate_heights = 1 / 2
    r, g1r stitch.reid alone / with placement.gate_heights = 1
    b      placement.lift_heights = 0.15
    b25    placement.lift_heights = 0.25
    bu     placement.lift_heights = 0.15, placement.lift_keep_u
    ab     in_range and lift_heights = 0.15

    python benchmarks/eval_foot_gate.py --variant a --sources count:42024,count:31337,dev_count
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import time


VARIANTS = {
    "off": {},
    "a": {"placement.in_range": True},
    "a2": {"placement.in_range": True, "placement.gate_heights": 1.0},
    "g1": {"placement.gate_heights": 1.0},
    "g2": {"placement.gate_heights": 2.0},
    "r": {"stitch.reid": True},
    "g1r": {"placement.gate_heights": 1.0, "stitch.reid": True},
    "b": {"placement.lift_heights": 0.15},
    "b25": {"placement.lift_heights": 0.25},
    "bu": {"placement.lift_heights": 0.15, "placement.lift_keep_u": True},
    "ab": {"placement.in_range": True, "placement.lift_heights": 0.15},
}


def count_seed(seed: int, log) -> dict:
    """eval_all.run_count on one seed's 10 counting scenes."""
    import eval_all as ea
    import eval_count as ec
    from eval_all_score import count_row

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import render_scene

    cfg = config_from_dict(SYNTHETIC_CONFIG)
    clips = []
    for scene_seed, spec in ec.scene_specs(10, seed=seed, camera=cfg.camera):
        scene = render_scene(scene_seed, spec)
        truth, kinds = ec.truth_boxes(scene)
        frames = [(k, k / scene.fps, f) for k, f in enumerate(scene.frames)]
        clips.append(ea.count_clip(cfg, frames, truth, kinds, -1))
        log(f"count {seed}/{scene_seed}: {clips[-1]}")
    return {"count": count_row(clips), "clips": clips}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--variant", default="off", choices=sorted(VARIANTS))
    p.add_argument("--sources", default="count:42024")
    p.add_argument("-o", "--output")
    a = p.parse_args(argv)

    import eval_all as ea

    import rhythmjax.count as rc
    from rhythmjax.count.options import CountOptions, with_changes

    opt = with_changes(CountOptions(), VARIANTS[a.variant])
    rc.count_frames = functools.partial(rc.count_frames, options=opt)
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    out = {"variant": a.variant, "options": VARIANTS[a.variant]}
    for src in a.sources.split(","):
        t0 = time.perf_counter()
        if src.startswith("count:"):
            seed = int(src.split(":")[1])
            r = count_seed(seed, log)
        elif src == "dev_count":
            r = ea.run_dev_count([], False, log)
        elif src == "pets_count":
            r = ea.run_pets_count([], False, log)
        else:
            raise SystemExit(f"unknown source {src}")
        out[src] = r
        c = r["count"]
        print(f"{a.variant:4s} {src:12s} counted {c['counted']}/{c['true']} err "
              f"{100 * c['count_err_sum']:.1f} % others {c['others_counted']} "
              f"mota {c['mota']:.3f} idf1 {c['idf1']:.3f} ({time.perf_counter() - t0:.0f} s)",
              flush=True)
    if a.output:
        with open(a.output, "w") as f:
            json.dump(out, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
