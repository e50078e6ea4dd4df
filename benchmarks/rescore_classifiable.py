"""Saved own-scene runs re-scored with the classifiable walkers apart (issue 16's targets).

`sim.clean.classifiable` depends on the scene only (the renderer's silhouettes, not the tracker),
so a run saved before the evaluations carried it can be re-scored without tracking again: each
scene is re-rendered from its seed and every object row gets `clean_frames` and `classifiable`.
Reads `eval_all.py` / `eval_rules.py` JSON (sources -> seed -> objects; the own synthetic
sources) and `eval_synthetic.py` JSON (by window and by track), writes the file with the flags
(`-o DIR`: the same names in another folder) and prints, per source and seed, walkers judged
Pedestrian of those judged, of all and of the classifiable ones, and non-walkers judged
Pedestrian. Nothing is chosen here; it only measures.

    python benchmarks/rescore_classifiable.py RUN.json [RUN2.json ...] [-o OUT_DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import sys


# scene options of each own synthetic source (eval_all.py's runners)
SOURCE_SCENES = {
    "synthetic": {}, "synthetic_knees": {},
    "synthetic_any": {"clothing": "any"},
    "synthetic_suitcase": {"suitcase_fraction": 0.5},
    "synthetic_lateral": {"lateral_deg": 30.0}, "synthetic_lateral_knees": {"lateral_deg": 30.0},
    "synthetic_lateral_suitcase": {"lateral_deg": 30.0, "suitcase_fraction": 0.5},
    "synthetic_rods": {"articulated": False},
    "synthetic_lateral_rods": {"lateral_deg": 30.0, "articulated": False},
}


def flags_for(seed: int, n_scenes: int, scene_kw: dict) -> list[dict]:
    """Per scene index: {object: (longest clean run, classifiable)} of eval_synthetic's scenes."""
    import eval_synthetic as es

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.clean import classifiable
    from rhythmjax.sim.scene import render_scene

    cfg = config_from_dict(es.RECOMMENDED)
    return [classifiable(render_scene(s, spec), n=int(cfg.thresholds.n))
            for s, spec in es.scene_specs(seed, n_scenes, camera=cfg.camera, **scene_kw)]


def mark(rows: list[dict], flags: list[dict]) -> None:
    for r in rows:
        r["clean_frames"], r["classifiable"] = flags[int(r["scene"])][r["object"]]


def line(name: str, rows: list[dict]) -> str:
    from eval_all_score import verdict_row

    v = verdict_row(rows)
    return (f"| {name} | {v['walkers_pedestrian']}/{v['walkers_judged']} | "
            f"{v['walkers_pedestrian']}/{v['walkers']} | "
            f"{v['classifiable_pedestrian']}/{v['walkers_classifiable']} | "
            f"{v['others_pedestrian']}/{v['others']} |")


def rescore(path: str) -> tuple[dict, list[str]]:
    with open(path) as fh:
        run = json.load(fh)
    lines = []
    if "sources" in run:
        for name, by_seed in run["sources"].items():
            if name not in SOURCE_SCENES:
                continue
            for seed, s in by_seed.items():
                rows = s["objects"]
                n = 1 + max(int(r["scene"]) for r in rows)
                mark(rows, flags_for(int(seed), n, SOURCE_SCENES[name]))
                lines.append(line(f"{name} {seed}", rows))
    else:
        seed = int(run["seed"])
        scene_kw = {"articulated": run.get("legs", "knees") == "knees"}
        rows = run["objects"]
        flags = flags_for(seed, 1 + max(int(r["scene"]) for r in rows), scene_kw)
        mark(rows, flags)
        mark(run["by_track"]["objects"], flags)
        lines.append(line(f"eval_synthetic {seed} by window", rows))
        lines.append(line(f"eval_synthetic {seed} by track", run["by_track"]["objects"]))
    return run, lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+")
    p.add_argument("-o", "--output-dir", required=True, help="folder for the re-scored files")
    a = p.parse_args(argv)
    os.makedirs(a.output_dir, exist_ok=True)
    print("| run | walkers Ped. / judged | / all | / classifiable | non-walkers Ped. |\n"
          "|---|---|---|---|---|")
    for path in a.runs:
        run, lines = rescore(path)
        print("\n".join(lines))
        sys.stdout.flush()
        out = os.path.join(a.output_dir, os.path.basename(path))
        tmp = out + ".tmp"
        with open(tmp, "w") as fh:
            json.dump(run, fh, default=float)
        os.replace(tmp, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
