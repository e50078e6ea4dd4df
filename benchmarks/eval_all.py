"""One evaluation table over every source (issue 16, item 5): one row per source, the same columns.

Columns (each names its own denominator; "-" where the source has no truth for it):
- walkers judged Pedestrian of those judged (tracked >= N frames: the paper's Table 3 convention)
  and of all classifiable walkers (own scenes: `sim.clean.classifiable`, the dev renderer's
  convention computed from the own renderer's silhouettes, every walker in runs stored before
  issue 16's forty-first round; dev clips: `classifiable` of the truth JSON, >= 64 clean
  frames; PETS: the 19 annotated people);
- non-walkers judged Pedestrian, of all non-walkers and of those judged;
- pace MAE (Hz) and step-length median error (cm) over the walkers judged Pedestrian;
- count: walkers counted / true, and the per-clip errors summed, sum_c |counted_c - true_c| /
  sum_c true_c (%); non-walkers counted (tracks counted as walkers that follow a non-walker);
- MOTA / IDF1 (py-motmetrics, IoU >= 0.5) where truth boxes exist, against every truth box
  (non-walkers too, as benchmarks/eval_count.py scores), the mean over clips.

Sources (`--only`): `synthetic` (benchmarks/eval_synthetic.py's scenes: evaluation seed 20240603
and a fresh seed, FRESH_SEED), `count` (benchmarks/eval_count.py's counting scenes, its seed and
FRESH_SEED), `synthetic_any` and `count_any` (the same scenes with clothing of any grey, some
close to the ground's: `sim.scene.random_spec`'s clothing "any"), `synthetic_suitcase` (the
scenes with half the walkers pulling a wheeled suitcase: `random_spec`'s suitcase_fraction 0.5),
`synthetic_lateral` (the scenes with every path within 30 degrees of crossing the view),
`synthetic_lateral_suitcase` (crossing paths and half the walkers pulling a suitcase, which then
trails beside them in the image, as `dev_walk_05`'s does; since issue 16's fifty-third round).
The own scenes' walkers bend their knees and roll their feet heel to toe (`random_spec`'s
articulated, `sim.legs`; since issue 16's thirty-eighth round); `synthetic_rods`,
`synthetic_lateral_rods` and `count_rods` are the same scenes with the straight legs drawn
before it (`synthetic_knees` and `synthetic_lateral_knees`, the names of the thirty-seventh
round, stay as aliases), `dev` (the 15 single/multi clips of ../shared/data/dev through the
tracker, as `rhythmjax run -c CAMERA.json`), `dev_count` (the 3 crowd clips through
`count_frames`, as `rhythmjax count -c CAMERA.json`), `pets` (the tracker, eval_real_video's
scoring), `pets_count`, `pets_boxes` (`rhythmjax rhythm --boxes` on the annotated boxes, when
that verb exists), `ucsd`, `casia`. Dev clips: the config is the camera section of the truth
JSON only (README of the folder; principal point 255.5), everything else the defaults; a track
belongs to the object whose truth foot point it follows (`sim.evaluate.match_tracks`), an
object's verdict is its longest judged track's. Own scenes: eval_synthetic's verdicts by track
(the same rule).

`--set SECTION.KEY=VALUE` (repeatable) overrides a config key for every source, e.g.
`--set thresholds.harmonic_max_ratio=0` (the paper's rule; the default 0.25 is the half-pace
rule). Nothing here was chosen on any source: it only measures.

    python benchmarks/eval_all.py [--only SOURCE[,SOURCE]] [-o eval_all.json] [--quick]
                                  [--set thresholds.harmonic_max_ratio=0]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from eval_all_score import (
    HEADER,
    apply_set,
    casia_row,
    count_row,
    dev_camera,
    dev_truth,
    objects_rows,
    parse_set,
    read_gt,
    table_line,
    ucsd_row,
    verdict_row,
)


FRESH_SEED = 777_001  # a seed no rule was chosen on (eval_synthetic's is 20240603)
DEV_ROOT = Path(os.environ.get("RHYTHMJAX_DEV", "/work/shared/data/dev"))
SOURCES = ("synthetic", "count", "synthetic_any", "count_any", "synthetic_suitcase",
           "synthetic_lateral", "synthetic_lateral_suitcase", "synthetic_rods",
           "synthetic_lateral_rods", "count_rods", "dev", "dev_count", "pets", "pets_count",
           "pets_boxes", "ucsd", "casia")
OWN_SOURCES = ("synthetic", "count", "synthetic_any", "count_any", "synthetic_suitcase",
               "synthetic_lateral", "synthetic_lateral_suitcase", "synthetic_rods",
               "synthetic_lateral_rods", "count_rods", "synthetic_knees",
               "synthetic_lateral_knees")  # one row per seed


# ----------------------------------------------------------------------------------------------
# sources


def run_synthetic(sets, quick, log, clothing: str = "contrasted",
                  suitcase_fraction: float = 0.0, lateral_deg: float | None = None,
                  articulated: bool = True) -> dict:
    import eval_synthetic as es

    from rhythmjax.model.params import config_from_dict

    cfg = config_from_dict(apply_set(es.RECOMMENDED, sets))
    out = {}
    for seed in (es.SEED, FRESH_SEED):
        t0 = time.perf_counter()
        r = es.evaluate(cfg, es.scene_specs(seed, 3 if quick else 10, camera=cfg.camera,
                                            clothing=clothing,
                                            suitcase_fraction=suitcase_fraction,
                                            lateral_deg=lateral_deg,
                                            articulated=articulated),
                        verbose=False)["by_track"]
        out[str(seed)] = {"verdicts": verdict_row(r["objects"]), "objects": r["objects"],
                          "seconds": time.perf_counter() - t0}
        log(f"synthetic {seed}: {out[str(seed)]['verdicts']}")
    return out


def count_clip(cfg, frames, truth, kinds, offset) -> dict:
    """`count_frames` on one clip scored against MOT truth (`kinds`: truth id -> kind), with
    `distinct`: the most of its tracks that stand for distinct true walkers
    (`count_bounds.distinct_walkers`: the floor of a keep/drop counting rule that counts no
    walker twice)."""
    import count_bounds as cb
    import eval_count as ec

    from rhythmjax.count import count_frames
    from rhythmjax.evaluation.motscore import score_mot

    res = count_frames(cfg, iter(frames), n_frames=len(frames))
    walk = ec.walking_ids(res)
    seen = set(np.asarray(truth["id"]).tolist())
    twalk = [t for t in seen if kinds.get(t) == "pedestrian"]
    s = score_mot(truth, res.mot, frame_offset=offset, walking_ids=walk, truth_walking_ids=twalk)
    own = ec.owner_of_tracks(truth, res.mot, offset)
    return {"counted": len(walk), "true": len(twalk), "mota": s.mota, "idf1": s.idf1,
            "id_switches": s.id_switches, "counts": res.counts,
            "others_counted": sum(1 for h in walk if own.get(h) and kinds[own[h]] != "pedestrian"),
            "distinct": cb.distinct_walkers(
                {"truth": truth, "mot": res.mot, "offset": offset, "kinds": kinds},
                [int(i) for i in res.verdicts["track_id"]])}


def run_count(sets, quick, log, clothing: str = "contrasted", articulated: bool = True) -> dict:
    import eval_count as ec

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import render_scene

    cfg = config_from_dict(apply_set(SYNTHETIC_CONFIG, sets))
    out = {}
    for seed in (ec.SEED, FRESH_SEED):
        clips = []
        for scene_seed, spec in ec.scene_specs(3 if quick else 10, seed=seed, camera=cfg.camera,
                                               clothing=clothing, articulated=articulated):
            scene = render_scene(scene_seed, spec)
            truth, kinds = ec.truth_boxes(scene)
            frames = [(k, k / scene.fps, f) for k, f in enumerate(scene.frames)]
            clips.append(count_clip(cfg, frames, truth, kinds, -1))
            log(f"count {seed}/{scene_seed}: {clips[-1]}")
        out[str(seed)] = {"count": count_row(clips), "clips": clips}
    return out


def _dev_index():
    return json.loads((DEV_ROOT / "index.json").read_text())["clips"]


def run_dev(sets, quick, log) -> dict:
    import eval_real_video as ev

    from rhythmjax.sim.evaluate import score
    from rhythmjax.track import track_frames
    from rhythmjax.track.options import TrackerOptions
    from rhythmjax.vision.video import open_video

    rows, clips = [], {}
    for c in _dev_index():
        if c.get("count"):
            continue
        truth = json.loads((DEV_ROOT / c["truth"]).read_text())
        path = DEV_ROOT / c["video"]
        cfg = ev.video_config(apply_set(dev_camera(truth), sets), path, truth["fps"])
        with open_video(str(path), fps=truth["fps"]) as src:
            tracks, verdicts, _, _ = track_frames(cfg, src, progress=False,
                                                  options=TrackerOptions())
        objs = dev_truth(truth)
        r = objects_rows(score(tracks, verdicts, objs)["objects"], objs)
        clips[c["clip"]] = r
        rows += r
        log(f"dev {c['clip']}: " + ", ".join(f"{x['kind']}:{x['verdict']}" for x in r))
    return {"verdicts": verdict_row(rows), "clips": clips}


def run_dev_count(sets, quick, log) -> dict:
    import eval_real_video as ev

    from rhythmjax.vision.video import VideoSource

    clips = []
    for c in _dev_index():
        if not c.get("count"):
            continue
        truth = json.loads((DEV_ROOT / c["truth"]).read_text())
        path = DEV_ROOT / c["video"]
        cfg = ev.video_config(apply_set(dev_camera(truth), sets), path, truth["fps"])
        gt, kinds = read_gt(DEV_ROOT / c["mot_gt"])
        frames = list(VideoSource(str(path), fps=truth["fps"]))
        r = count_clip(cfg, frames, gt, kinds, 0)
        r["true"] = int(c["count"]["n_walkers"])  # the README's count rule
        r["clip"] = c["clip"]
        clips.append(r)
        log(f"dev_count {c['clip']}: {r}")
    return {"count": count_row(clips), "clips": clips}


def run_pets(sets, quick, log) -> dict:
    import eval_real_video as ev

    from rhythmjax.evaluation import datasets

    cfg = ev.video_config(apply_set(ev.pets_config_dict(), sets), datasets.pets_video(),
                          datasets.PETS_FPS)
    tracks, verdicts = ev.track(cfg, datasets.pets_video(), datasets.PETS_FPS)
    res = ev.score_pets(tracks, verdicts, datasets.pets_boxes())
    rows = [{"kind": "pedestrian", "verdict": p["verdict"]} for p in res["people"].values()]
    return {"verdicts": verdict_row(rows), "score": res}


def run_pets_count(sets, quick, log) -> dict:
    import eval_real_video as ev

    from rhythmjax.evaluation import datasets
    from rhythmjax.vision.video import VideoSource

    cfg = ev.video_config(apply_set(ev.pets_config_dict(), sets), datasets.pets_video(),
                          datasets.PETS_FPS)
    frames = list(VideoSource(str(datasets.pets_video()), fps=datasets.PETS_FPS))
    truth = datasets.pets_boxes()
    kinds = {int(i): "pedestrian" for i in np.unique(truth["id"])}
    r = count_clip(cfg, frames, truth, kinds, -1)
    return {"count": count_row([r]), "clip": r}


def has_rhythm_verb() -> bool:
    """Whether `rhythmjax rhythm` (issue 16 item 1) is installed."""
    import importlib.util

    return importlib.util.find_spec("rhythmjax.cli.rhythm") is not None


RHYTHM_FLAGS: list[str] = []  # extra `rhythmjax rhythm` flags (eval_rules' tracker rules)


def run_pets_boxes(sets, quick, log) -> dict:
    """`rhythmjax rhythm VIDEO --boxes GT.txt -c pets.json --fps 7` on PETS's annotated boxes
    (all 19 people; occluded boxes included), each person's verdict its box track's."""
    import subprocess
    import tempfile

    import eval_real_video as ev
    import pandas as pd

    from rhythmjax.evaluation import datasets

    if not has_rhythm_verb():
        return {"skipped": "not yet (rhythmjax rhythm --boxes absent)"}
    b = datasets.pets_boxes()  # 0-based frames, 480 x 360 px
    with tempfile.TemporaryDirectory() as tmp:
        gt, cfg, out = (os.path.join(tmp, n) for n in ("gt.txt", "pets.json", "out"))
        with open(gt, "w") as fh:
            for r in range(len(b["frame"])):
                fh.write(f"{int(b['frame'][r]) + 1},{int(b['id'][r])},{b['bb_left'][r]:.3f},"
                         f"{b['bb_top'][r]:.3f},{b['bb_width'][r]:.3f},{b['bb_height'][r]:.3f},"
                         "1,-1,-1,-1\n")
        with open(cfg, "w") as fh:
            json.dump(apply_set(ev.pets_config_dict(), sets), fh)
        cmd = [sys.executable, "-m", "rhythmjax.cli.main", "rhythm", str(datasets.pets_video()),
               "--boxes", gt, "--frame-base", "1", "-c", cfg, "--fps", str(datasets.PETS_FPS),
               "-o", out, "-q", *RHYTHM_FLAGS]
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode:
            return {"skipped": f"failed: rhythmjax rhythm exit {p.returncode}: "
                               f"{p.stderr.strip()[-300:]}"}
        v = pd.read_csv(os.path.join(out, "verdicts.csv"))
    got = {int(t): str(w) for t, w in zip(v["track_id"], v["verdict"])}
    people = sorted(set(int(i) for i in b["id"]))
    rows = [{"kind": "pedestrian", "verdict": got.get(i, "missed")} for i in people]
    return {"verdicts": verdict_row(rows), "people": {i: got.get(i, "missed") for i in people}}


def run_ucsd(sets, quick, log) -> dict:
    import eval_real_video as ev

    from rhythmjax.evaluation import datasets

    d = apply_set({"camera": ev.UCSD_CAMERA, "thresholds": {"window_s": 32 / 30}}, sets)
    total = {"anomaly": {}, "other": {}}
    for clip in datasets.UCSD_CLIPS[:1] if quick else datasets.UCSD_CLIPS:
        folder, boxes = datasets.ucsd_clip(clip)
        cfg = ev.video_config(d, folder, 30.0)
        r = ev.score_ucsd(*ev.track(cfg, folder, 30.0), boxes)
        for g in total:
            for k, n in r[g].items():
                total[g][k] = total[g].get(k, 0) + n
    return {"total": total, "verdicts": ucsd_row(total)}


def run_casia(sets, quick, log) -> dict:
    import eval_real_video as ev

    from rhythmjax.evaluation import datasets

    rows = {}
    for path in sorted((datasets.DATA_ROOT / "casia_b_090").glob("*.avi")):
        cfg = ev.video_config(apply_set(ev.CASIA_CONFIG, sets), path, 25.0)
        tracks, verdicts = ev.track(cfg, path, 25.0, max_objects=8)
        tid = np.asarray(tracks["track_id"])
        v = "missed"
        if tid.size:
            ids, n = np.unique(tid, return_counts=True)
            v = str(verdicts["verdict"][[int(t) for t in verdicts["track_id"]].index(
                int(ids[int(np.argmax(n))]))])
        rows[path.stem] = v
    return {"verdicts": casia_row(rows), "clips": rows}


def run_synthetic_any(sets, quick, log) -> dict:
    """`synthetic` with clothing of any grey (`sim.scene.random_spec`'s clothing "any")."""
    return run_synthetic(sets, quick, log, clothing="any")


def run_synthetic_suitcase(sets, quick, log) -> dict:
    """`synthetic` with half the walkers pulling a suitcase (`random_spec`'s suitcase_fraction
    0.5; the dev renderer's trailing baggage)."""
    return run_synthetic(sets, quick, log, suitcase_fraction=0.5)


def run_synthetic_lateral(sets, quick, log) -> dict:
    """`synthetic` with every path within 30 degrees of crossing the view (`random_spec`'s
    lateral_deg; the default scenes' walkers walk mostly towards or away from the camera)."""
    return run_synthetic(sets, quick, log, lateral_deg=30.0)


def run_synthetic_lateral_suitcase(sets, quick, log) -> dict:
    """`synthetic_lateral` with half the walkers pulling a suitcase (beside them in the image)."""
    return run_synthetic(sets, quick, log, lateral_deg=30.0, suitcase_fraction=0.5)


def run_synthetic_rods(sets, quick, log) -> dict:
    """`synthetic` with the straight-legged walkers drawn before the thirty-eighth round."""
    return run_synthetic(sets, quick, log, articulated=False)


def run_synthetic_lateral_rods(sets, quick, log) -> dict:
    """`synthetic_lateral` with the straight-legged walkers."""
    return run_synthetic(sets, quick, log, lateral_deg=30.0, articulated=False)


def run_count_rods(sets, quick, log) -> dict:
    """`count` with the straight-legged walkers."""
    return run_count(sets, quick, log, articulated=False)


def run_count_any(sets, quick, log) -> dict:
    """`count` with clothing of any grey."""
    return run_count(sets, quick, log, clothing="any")


RUNNERS = {"synthetic": run_synthetic, "count": run_count, "synthetic_any": run_synthetic_any,
           "synthetic_suitcase": run_synthetic_suitcase, "synthetic_lateral": run_synthetic_lateral,
           "synthetic_lateral_suitcase": run_synthetic_lateral_suitcase,
           "synthetic_rods": run_synthetic_rods,
           "synthetic_lateral_rods": run_synthetic_lateral_rods, "count_rods": run_count_rods,
           "synthetic_knees": run_synthetic, "synthetic_lateral_knees": run_synthetic_lateral,
           "count_any": run_count_any, "dev": run_dev,
           "dev_count": run_dev_count, "pets": run_pets, "pets_count": run_pets_count,
           "pets_boxes": run_pets_boxes, "ucsd": run_ucsd, "casia": run_casia}


def available(name: str) -> str | None:
    """Why a source cannot run here (data absent), else None."""
    from rhythmjax.evaluation import datasets

    if name in ("dev", "dev_count") and not (DEV_ROOT / "index.json").is_file():
        return f"{DEV_ROOT} absent"
    if name.startswith("pets") and datasets.pets_root() is None:
        return "PETS absent"
    if name == "ucsd" and datasets.ucsd_root() is None:
        return "UCSD absent"
    if name == "casia" and not (datasets.DATA_ROOT / "casia_b_090").is_dir():
        return "CASIA-B absent"
    return None


def rescore(out: dict) -> dict:
    """A saved run's rows recomputed from what it kept (CASIA's clips, UCSD's totals)."""
    src = out["sources"]
    if "clips" in src.get("casia", {}):
        src["casia"]["verdicts"] = casia_row(src["casia"]["clips"])
    if "total" in src.get("ucsd", {}):
        src["ucsd"]["verdicts"] = ucsd_row(src["ucsd"]["total"])
    return out


def print_table(out: dict) -> None:
    print(HEADER)
    for name, r in out["sources"].items():
        if "skipped" in r:
            print(f"| {name} | {r['skipped']} |" + " |" * 8)
        elif name in OWN_SOURCES:
            for seed, s in r.items():
                print(table_line(f"{name} seed {seed}", s.get("verdicts"), s.get("count")))
        else:
            print(table_line(name, r.get("verdicts"), r.get("count")))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", help="comma-separated sources: " + ", ".join(SOURCES))
    p.add_argument("-o", "--output", default="eval_all.json")
    p.add_argument("--quick", action="store_true", help="3 synthetic scenes per seed, 1 UCSD clip")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="config override for every source (repeatable)")
    p.add_argument("-q", "--quiet", action="store_true")
    p.add_argument("--table", nargs="+", metavar="JSON", help="print the table of saved runs "
                   "(later files' sources win) and exit")
    a = p.parse_args(argv)
    if a.table:
        merged: dict = {"sources": {}}
        for path in a.table:
            with open(path) as fh:
                merged["sources"].update(rescore(json.load(fh))["sources"])
        print_table(merged)
        return 0
    names = SOURCES if not a.only else tuple(s.strip() for s in a.only.split(","))
    bad = [n for n in names if n not in RUNNERS]
    try:
        sets = parse_set(a.set)
    except ValueError as e:
        print(f"eval_all: {e}", file=sys.stderr)
        return 2
    if bad:
        print(f"eval_all: --only: unknown source(s) {', '.join(bad)}", file=sys.stderr)
        return 2
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    log = (lambda s: None) if a.quiet else (lambda s: print(s, file=sys.stderr, flush=True))
    out = {"set": a.set, "quick": a.quick, "sources": {}}
    for n in names:
        why = available(n)
        t0 = time.perf_counter()
        try:
            out["sources"][n] = {"skipped": why} if why else RUNNERS[n](sets, a.quick, log)
        except Exception as e:  # noqa: BLE001  (one source failing leaves the others' rows)
            out["sources"][n] = {"skipped": f"failed: {type(e).__name__}: {e}"}
            log(f"{n} failed: {e!r}")
        out.setdefault("seconds", {})[n] = time.perf_counter() - t0
        log(f"{n}: {out['seconds'][n]:.0f} s")
        with open(a.output, "w") as fh:  # after every source, so a long run keeps what it has
            json.dump(out, fh, indent=1, default=float)
    print_table(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
