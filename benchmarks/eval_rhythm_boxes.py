"""The rhythm classifier behind annotated boxes (`rhythmjax rhythm`, issue 16 item 1): the
classifier measured apart from the tracker. Nothing here is chosen on these sources.

- PETS09-S2L1: Milan's CVML boxes scaled to the 480x360 video (`datasets.pets_boxes`) as MOT
  text, the camera `rhythmjax camera --tsai View_001.xml --video vtest_480x360.avi --fps 7`
  writes; one box track per person (19).
- UCSD Ped2 Test002/004/006/010: the anomaly boxes (cyclists, the cart; no ids: linked here
  frame to frame by the nearest box centre within LINK_PX, a gap of up to LINK_GAP frames), the
  guessed camera `eval_real_video.UCSD_CAMERA`, 30 fps, window 32/30 s (N = 32).
- Dev clips (`../shared/data/dev`, an independent renderer): each object's truth, twice: the
  true foot point (`*_truth.csv`, rows with the foot point in the image) and the bottom centre
  of the silhouette box (the truth JSON's bbox, as MOT text), with the dev camera (f 0.004 m,
  a = b = 125000 px/m, h 1 m, tilt 15 deg, principal point 255.5, 255.5).
- Own scenes (`--only own --seeds S,...`): `eval_synthetic.scene_specs` (10 scenes a seed, the
  walkers with knees; `--lateral`: paths within 30 deg of crossing the view, eval_all's
  synthetic_lateral), each object's truth box (`eval_count.truth_boxes`: clipped to the image,
  so a head above the view gives a box at the image's first row) as MOT text, the frames as a
  lossless PNG folder, the demo's config (`eval_synthetic.RECOMMENDED`). Per object its box
  track's verdict; walkers / non-walkers judged Pedestrian and the walkers' pace MAE.

`--set SECTION.KEY=VALUE` (repeatable) writes a key into every config, as in eval_all.py;
`--flag=FLAG` (repeatable) adds a `rhythm` flag to every run (e.g. `--no-across-candidates`);
`--twice-pace-heights H` and `--min-height-heights H` are passed to every run (rules 37 and 26;
0: off). Every run is
`rhythmjax rhythm VIDEO --boxes BOXES -c CONFIG -o DIR --no-camera-check` (the check only adds
notes). Prints one line per box track and writes eval_rhythm_boxes.json.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import sys
import tempfile

import numpy as np


sys.path.insert(0, os.path.dirname(__file__))

from eval_all_score import apply_set, parse_set  # noqa: E402

from rhythmjax.cli.main import main as cli  # noqa: E402
from rhythmjax.evaluation import datasets  # noqa: E402
from rhythmjax.io.mot import write_mot  # noqa: E402


LINK_PX = 30.0  # UCSD: a box continues a track whose last box centre is this close (px)
LINK_GAP = 3  # UCSD: frames a track may miss and still be continued
DEV = os.environ.get("RHYTHMJAX_DEV", "/work/shared/data/dev")
DEV_CAMERA = {"f_m": 0.004, "a_px_per_m": 125000.0, "b_px_per_m": 125000.0, "h_m": 1.0,
              "theta_deg": 15.0, "uc_px": 255.5, "vc_px": 255.5}


SETS: list = []  # (section, key, value) of --set, written into every config
EXTRA: list = []  # further arguments of every `rhythm` run


def run(video, boxes, config: dict, work: str, name: str, fps=None) -> list[dict]:
    cfg = os.path.join(work, f"{name}.json")
    with open(cfg, "w") as f:
        json.dump(apply_set(config, SETS), f)
    out = os.path.join(work, name)
    argv = ["rhythm", str(video), "--boxes", str(boxes), "-c", cfg, "-o", out, "--quiet",
            "--json", "--no-camera-check"] + (["--fps", str(fps)] if fps else []) + EXTRA
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = cli(argv)
    if rc != 0:
        raise SystemExit(f"{name}: rhythm exited {rc}")
    with open(os.path.join(out, "verdicts.csv")) as f:
        return list(csv.DictReader(f))


def pets(work: str) -> dict:
    from eval_real_video import pets_config_dict

    b = datasets.pets_boxes()
    mot = os.path.join(work, "pets_gt.txt")
    write_mot(mot, {"frame": b["frame"] + 1, "id": b["id"], "bb_left": b["bb_left"],
                    "bb_top": b["bb_top"], "bb_width": b["bb_width"],
                    "bb_height": b["bb_height"]})
    rows = run(datasets.pets_video(), mot, pets_config_dict(), work, "pets", datasets.PETS_FPS)
    n_ped = sum(r["verdict"] == "pedestrian" for r in rows)
    return {"people": len(rows), "pedestrian": n_ped, "tracks": rows}


def link(boxes: dict) -> np.ndarray:
    """Ids for id-less boxes: each box (by frame) continues the track whose last box centre is
    nearest within LINK_PX and at most LINK_GAP frames back, else starts a new track."""
    cu, cv = boxes["x"] + boxes["w"] / 2, boxes["y"] + boxes["h"] / 2
    ids = np.zeros(len(cu), np.int64)
    last: dict[int, tuple[int, float, float]] = {}
    for fr in np.unique(boxes["frame"]):
        taken = set()
        for i in np.flatnonzero(boxes["frame"] == fr):
            best = min(((np.hypot(cu[i] - u, cv[i] - v), k) for k, (f, u, v) in last.items()
                        if 0 < fr - f <= LINK_GAP and k not in taken), default=(np.inf, 0))
            k = best[1] if best[0] <= LINK_PX else len(last) + 1
            ids[i], last[k] = k, (int(fr), cu[i], cv[i])
            taken.add(k)
    return ids


def ucsd(work: str) -> dict:
    from eval_real_video import UCSD_CAMERA

    out = {}
    for clip in datasets.UCSD_CLIPS:
        folder, b = datasets.ucsd_clip(clip)
        mot = os.path.join(work, f"ucsd_{clip}.txt")
        write_mot(mot, {"frame": b["frame"] + 1, "id": link(b), "bb_left": b["x"],
                        "bb_top": b["y"], "bb_width": b["w"], "bb_height": b["h"]})
        # fps in the config, not --fps: open_source checks the config at its own fps (15 by
        # default) before --fps applies, and N = 16 refuses the AR order 15
        conf = {"camera": {**UCSD_CAMERA, "fps": 30.0}, "thresholds": {"window_s": 32 / 30}}
        out[clip] = run(folder, mot, conf, work, f"ucsd_{clip}")
    return out


def dev(work: str) -> dict:
    index = json.load(open(os.path.join(DEV, "index.json")))
    out = {}
    for c in index["clips"]:
        clip = c["clip"]
        truth = json.load(open(os.path.join(DEV, c["truth"])))
        kinds = {str(o["id"]): (o["kind"], bool(o["classifiable"])) for o in truth["objects"]}
        # the true foot point: the truth CSV as the tracks format (intensity to be measured)
        with open(os.path.join(DEV, c["truth_csv"])) as f:
            rows = [r for r in csv.DictReader(f) if r["in_image"] == "1"]
        tr = os.path.join(work, f"{clip}_truth.csv")
        with open(tr, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["track_id", "frame", "t", "u", "v", "width_px", "intensity", "label"])
            for r in rows:
                w.writerow([r["track_id"], r["frame"], r["t"], r["u"], r["v"], r["width_px"], "",
                            r["label"]])
        # the silhouette box's bottom centre: MOT text (1-based frames, id + 1)
        cols: dict[str, list] = {k: [] for k in ("frame", "id", "bb_left", "bb_top", "bb_width",
                                                 "bb_height")}
        for o in truth["objects"]:
            t = o["track"]
            for fr, bb, inside in zip(t["frame"], t["bbox"], t["in_image"]):
                if not inside:
                    continue
                u0, v0 = max(bb[0], 0.0), max(bb[1], 0.0)
                u1, v1 = min(bb[2], 511.0), min(bb[3], 511.0)
                for k, x in zip(cols, (fr + 1, o["id"] + 1, u0, v0, u1 + 1 - u0, v1 + 1 - v0)):
                    cols[k].append(x)
        mot = os.path.join(work, f"{clip}_boxes.txt")
        write_mot(mot, {k: np.asarray(v) for k, v in cols.items()})
        video = os.path.join(DEV, c["video"])
        conf = {"camera": DEV_CAMERA}
        res = {"foot": run(video, tr, conf, work, f"{clip}_foot"),
               "box": run(video, mot, conf, work, f"{clip}_box")}
        for r in res["box"]:
            r["track_id"] = str(int(r["track_id"]) - 1)
        out[clip] = {"objects": kinds, **res}
    return out


def own(work: str, seeds: list[int], lateral: bool) -> dict:
    """Per own scene ("own_SEED_I"): each truth box track's kind, verdict, reason, pace and
    stride with the truth's (module doc); the frames are written to `work` and removed."""
    import cv2
    import eval_count as ec
    import eval_synthetic as es

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.clean import classifiable
    from rhythmjax.sim.scene import render_scene

    conf = es.RECOMMENDED
    camera = config_from_dict(conf).camera
    out = {}
    for seed in seeds:
        specs = es.scene_specs(seed, 10, camera=camera, lateral_deg=30.0 if lateral else None)
        for i, (scene_seed, spec) in enumerate(specs):
            scene = render_scene(scene_seed, spec)
            name = f"own_{seed}_{i}"
            folder = os.path.join(work, name + "_frames")
            os.makedirs(folder)
            for k, frame in enumerate(scene.frames):
                cv2.imwrite(os.path.join(folder, f"{k:05d}.png"), np.asarray(frame))
            truth, kinds = ec.truth_boxes(scene)
            mot = os.path.join(work, name + ".txt")
            write_mot(mot, {**truth, "frame": truth["frame"] + 1})
            rows = run(folder, mot, conf, work, name, fps=scene.fps)
            clean = classifiable(scene, n=int(config_from_dict(conf).thresholds.n))
            res = []
            for r in rows:
                o = scene.truth[int(r["track_id"]) - 1]  # MOT id = actor index + 1
                res.append({"kind": kinds[int(r["track_id"])], "verdict": r["verdict"],
                            "classifiable": clean[o.track_id][1],
                            "reason": r["reason"], "pace": float(r["pace_hz"] or "nan"),
                            "pace_true": float(o.pace_hz), "stride": float(r["stride_m"] or "nan"),
                            "stride_true": float(o.step_length_m)})
            out[name] = res
            shutil.rmtree(folder)
    return out


def own_table(d: dict) -> dict:
    """Walkers / non-walkers judged Pedestrian (of all box tracks; walkers also of the
    classifiable ones, `sim.clean`) and the walkers' pace MAE."""
    rows = [r for res in d.values() for r in res]
    walk = [r for r in rows if r["kind"] == "pedestrian"]
    cl = [r for r in walk if r.get("classifiable", True)]
    other = [r for r in rows if r["kind"] != "pedestrian"]
    ped = [r for r in walk if r["verdict"] == "pedestrian"]
    err = [abs(r["pace"] - r["pace_true"]) for r in ped if np.isfinite(r["pace"])]
    return {"walkers": len(walk), "walkers_pedestrian": len(ped),
            "walkers_unclassified": sum(r["verdict"] == "unclassified" for r in walk),
            "walkers_classifiable": len(cl),
            "classifiable_pedestrian": sum(r["verdict"] == "pedestrian" for r in cl),
            "others": len(other),
            "others_pedestrian": sum(r["verdict"] == "pedestrian" for r in other),
            "matched_twice": sum(r["reason"] == "matched-twice" for r in rows),
            "pace_mae_hz": float(np.mean(err)) if err else float("nan")}


def dev_table(d: dict) -> dict:
    """Per variant: (kind, classifiable) -> verdict counts."""
    tab: dict = {}
    for r in d.values():
        for var in ("foot", "box"):
            for row in r[var]:
                kind, cl = r["objects"][row["track_id"]]
                key = f"{var} {kind} {'cl' if cl else 'not-cl'}"
                tab.setdefault(key, {}).setdefault(row["verdict"], 0)
                tab[key][row["verdict"]] += 1
    return tab


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--only", choices=("pets", "ucsd", "dev", "own"))
    p.add_argument("--seeds", default="", help="own scenes' seeds, comma-separated (--only own)")
    p.add_argument("--lateral", action="store_true", help="own scenes crossing the view")
    p.add_argument("--twice-pace-heights", type=float, default=None, metavar="H",
                   help="rule 37 in every run (`rhythm --twice-pace-heights`; default: its own)")
    p.add_argument("--min-height-heights", type=float, default=None, metavar="H",
                   help="rule 26 in every run (`rhythm --min-height-heights`; default: its own)")
    p.add_argument("-o", "--output", default="eval_rhythm_boxes.json")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="override a config key in every run (eval_all.py's --set)")
    p.add_argument("--flag", action="append", default=[], metavar="FLAG",
                   help="a further `rhythm` flag in every run (--flag=--no-across-candidates)")
    a = p.parse_args(argv)
    SETS[:] = parse_set(a.set)
    EXTRA.extend(a.flag)
    for flag in ("twice_pace_heights", "min_height_heights"):
        if getattr(a, flag) is not None:
            EXTRA.extend(["--" + flag.replace("_", "-"), str(getattr(a, flag))])
    out = {}
    with tempfile.TemporaryDirectory() as work:
        if a.only in (None, "pets"):
            r = out["pets"] = pets(work)
            print(f"PETS: {r['pedestrian']} of {r['people']} people judged pedestrian")
            for t in r["tracks"]:
                print(f"  person {t['track_id']:>3}: {t['verdict']:>14} {t['reason']:>15} "
                      f"pace {float(t['pace_hz']):.2f} Hz stride {float(t['stride_m']):.2f} m "
                      f"{t['n_samples']} samples")
        if a.only in (None, "ucsd"):
            r = out["ucsd"] = ucsd(work)
            for clip, rows in r.items():
                for t in rows:
                    print(f"UCSD {clip} box track {t['track_id']}: {t['verdict']} "
                          f"({t['reason']}), {t['n_samples']} samples, pace {t['pace_hz']}")
        if a.only in (None, "dev"):
            r = out["dev"] = dev(work)
            for clip, res in r.items():
                for var in ("foot", "box"):
                    for t in res[var]:
                        kind, cl = res["objects"][t["track_id"]]
                        print(f"dev {clip} {var} obj {t['track_id']} {kind}"
                              f"{' (cl)' if cl else ''}: {t['verdict']} ({t['reason']}) pace "
                              f"{t['pace_hz']} stride {t['stride_m']}")
            out["dev_table"] = dev_table(r)
            print(json.dumps(out["dev_table"], indent=1))
        if a.only == "own":
            r = out["own"] = own(work, [int(x) for x in a.seeds.split(",") if x], a.lateral)
            for name, rows in r.items():
                print(name, " ".join(f"{t['kind'][:4]}:{t['verdict'][:7]}/{t['reason']}"
                                     for t in rows))
            out["own_table"] = own_table(r)
            print(json.dumps(out["own_table"], indent=1))
    with open(a.output, "w") as f:
        json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
