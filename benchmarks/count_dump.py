"""Run `count.count_frames` on one counting source and save, per clip, what a counting rule
needs to be re-applied offline: the CountResult's mot, tracks and verdicts tables, the counts,
and the MOT truth with each truth id's kind (a pickle). A diagnostic for
`benchmarks/diag_count_unjudged.py`; the sources and configs are `eval_all.py`'s.

    python benchmarks/count_dump.py SOURCE OUT.pkl [--seed S] [--scenes 10] [--set KEY=JSON ...]

SOURCE: pets | count (own counting scenes of `eval_count.scene_specs`, seed --seed) |
dev_count (report only). --set overrides a `count.CountOptions` field (dotted).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def clips_of(source: str, seed: int, scenes: int):
    """(name, cfg, frames, truth, kinds, offset, true walkers) per clip of `source`."""
    import eval_all as ea
    import eval_count as ec
    import eval_real_video as ev

    from rhythmjax.evaluation import datasets
    from rhythmjax.vision.video import VideoSource

    if source == "pets":
        cfg = ev.video_config(ev.pets_config_dict(), datasets.pets_video(), datasets.PETS_FPS)
        frames = list(VideoSource(str(datasets.pets_video()), fps=datasets.PETS_FPS))
        truth = datasets.pets_boxes()
        kinds = {int(i): "pedestrian" for i in np.unique(truth["id"])}
        yield "pets", cfg, frames, truth, kinds, -1, len(kinds)
    elif source == "count":
        from rhythmjax.model.params import config_from_dict
        from rhythmjax.sim.presets import SYNTHETIC_CONFIG
        from rhythmjax.sim.scene import render_scene

        cfg = config_from_dict(SYNTHETIC_CONFIG)
        for s, spec in ec.scene_specs(scenes, seed=seed, camera=cfg.camera):
            scene = render_scene(s, spec)
            truth, kinds = ec.truth_boxes(scene)
            seen = set(truth["id"].tolist())
            frames = [(k, k / scene.fps, f) for k, f in enumerate(scene.frames)]
            yield (f"{seed}/{s}", cfg, frames, truth, kinds, -1,
                   sum(1 for t in seen if kinds[t] == "pedestrian"))
    elif source == "dev_count":
        for c in ea._dev_index():
            if not c.get("count"):
                continue
            truth_js = json.loads((ea.DEV_ROOT / c["truth"]).read_text())
            path = ea.DEV_ROOT / c["video"]
            cfg = ev.video_config(ea.dev_camera(truth_js), path, truth_js["fps"])
            gt, kinds = ea.read_gt(ea.DEV_ROOT / c["mot_gt"])
            frames = list(VideoSource(str(path), fps=truth_js["fps"]))
            yield c["clip"], cfg, frames, gt, kinds, 0, int(c["count"]["n_walkers"])
    else:
        raise SystemExit(f"unknown source {source!r}")


def main(argv=None) -> int:
    from rhythmjax.count import CountOptions, count_frames
    from rhythmjax.track.options import with_changes

    p = argparse.ArgumentParser()
    p.add_argument("source")
    p.add_argument("out")
    p.add_argument("--seed", type=int, default=42024)
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--set", action="append", default=[])
    a = p.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    rows = []
    for name, cfg, frames, truth, kinds, off, true in clips_of(a.source, a.seed, a.scenes):
        res = count_frames(cfg, iter(frames), n_frames=len(frames), options=opt)
        rows.append({"clip": name, "mot": res.mot, "tracks": res.tracks,
                     "verdicts": res.verdicts, "counts": res.counts, "truth": truth,
                     "kinds": kinds, "offset": off, "true": true, "fps": cfg.camera.fps,
                     "summary": res.summary})
        print(name, res.counts["walkers"], "of", true, flush=True)
    with open(a.out, "wb") as f:
        pickle.dump(rows, f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
