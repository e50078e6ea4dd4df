"""Run `count.count_frames` on one counting source and save, per clip, what a counting rule
needs to be re-applied offline: the CountResult's mot, tracks and verdicts tables, the counts,
and the MOT truth with each truth id's kind (a pickle). A diagnostic for
`benchmarks/diag_count_unjudged.py`; the sources and configs are `eval_all.py`'s.

    python benchmarks/count_dump.py SOURCE OUT.pkl [--seed S[,S...]] [--scenes 10] \\
        [--clothing any] [--focal-px 500] [--pairs 0.5] [--set KEY=JSON ...]

SOURCE: pets | count (own counting scenes of `eval_count.scene_specs`, seed --seed) |
dev_count (report only). --clothing and --focal-px change the own scenes as in
`eval_count_options.py` (clothing of any grey; the camera's a f = b f in px); --pairs joins
that fraction of their walkers with a partner at their shoulder, or in file with
`--pair-layout file` (`late`: the second appearing 1-2 s after the first; `sim.groups.with_pairs`).
--set overrides a `count.CountOptions` field (dotted).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def own_config(focal_px: float = 0.0):
    """The own counting scenes' Config: the synthetic preset, with a f = b f = `focal_px` px
    (f 8 mm) where > 0."""
    import copy

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG

    d = copy.deepcopy(SYNTHETIC_CONFIG)
    if focal_px > 0:
        d["camera"] = {"a_px_per_m": focal_px / 0.008, "b_px_per_m": focal_px / 0.008}
    return config_from_dict(d)


def clips_of(source: str, seed: int, scenes: int, clothing: str = "contrasted",
             focal_px: float = 0.0, pairs: float = 0.0, pair_layout: str = "side"):
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
        from rhythmjax.sim.scene import render_scene

        cfg = own_config(focal_px)
        for s, spec in ec.scene_specs(scenes, seed=seed, camera=cfg.camera, clothing=clothing,
                                      pairs=pairs, pair_layout=pair_layout):
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
    p.add_argument("--seed", default="42024", help="one seed or a comma list")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    p.add_argument("--focal-px", type=float, default=0.0)
    p.add_argument("--pairs", type=float, default=0.0,
                   help="own scenes: fraction of walkers joined by a partner side by side")
    p.add_argument("--pair-layout", default="side", choices=("side", "file", "late"),
                   help="own scenes: pairs side by side, in file, or in file with the second "
                   "appearing later (`sim.groups.LAYOUTS`)")
    p.add_argument("--set", action="append", default=[])
    a = p.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    rows = []
    clips = (c for seed in a.seed.split(",")
             for c in clips_of(a.source, int(seed), a.scenes, a.clothing, a.focal_px,
                                 a.pairs, a.pair_layout))
    for name, cfg, frames, truth, kinds, off, true in clips:
        res = count_frames(cfg, iter(frames), n_frames=len(frames), options=opt)
        rows.append({"clip": name, "mot": res.mot, "tracks": res.tracks,
                     "verdicts": res.verdicts, "counts": res.counts, "truth": truth,
                     "kinds": kinds, "offset": off, "true": true, "fps": cfg.camera.fps,
                     "image_size": (int(cfg.camera.image_width), int(cfg.camera.image_height)),
                     "summary": res.summary})
        print(name, res.counts["walkers"], "of", true, flush=True)
    with open(a.out, "wb") as f:
        pickle.dump(rows, f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
