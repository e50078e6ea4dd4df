"""`count.count_frames` on the development crowd clips of an independent renderer
(`/work/shared/data/dev/dev_crowd_0*.avi`, 512x512, 15 fps; camera from each truth JSON,
principal point (255.5, 255.5); detection range derived from the camera as `rhythmjax count`
does, `config_setup.config_for`). A REPORT-ONLY source: nothing may be chosen on it (its
README).

Per clip: walkers counted (the count rule's `walkers`, with its range [judged only, judged + all
unjudged] when the counts carry one) against the true walkers (the json's `pedestrian`
objects seen in the MOT truth), tracks, and MOTA / IDF1 / IDSW against the pedestrian boxes
(class 1 of `<clip>_gt.txt`, 1-based frames; IoU >= 0.5, `evaluation.motscore.score_mot`).
Summed: counted / true, per-clip |errors| summed over the true walkers.

    python benchmarks/eval_count_dev.py [--data DIR] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys

import numpy as np


DATA = "/work/shared/data/dev"


def dev_config(meta: dict):
    """The Config of a dev clip: its camera (the truth JSON's eq. (3) parameters), its fps and
    image size; the detection range derived from the camera (`config_for`)."""
    from rhythmjax.model.config_setup import config_for

    c = meta["camera"]
    cam = {"f_m": c["f_m"], "h_m": c["h_m"], "theta_deg": c["theta_deg"],
           "a_px_per_m": c["a_px_per_m"], "b_px_per_m": c["b_px_per_m"], "uc_px": c["uc_px"],
           "vc_px": c["vc_px"]}
    return config_for({"camera": cam}, image_size=(c["width_px"], c["height_px"]),
                      fps=float(meta["fps"]))


def read_gt(path: str, classes=(1,)) -> dict[str, np.ndarray]:
    """MOT truth rows of the given classes (1 pedestrian), frame 1-based as in the file."""
    a = np.loadtxt(path, delimiter=",", ndmin=2)
    a = a[np.isin(a[:, 7].astype(int), classes)]
    return {"frame": a[:, 0].astype(np.int64), "id": a[:, 1].astype(np.int64),
            "bb_left": a[:, 2], "bb_top": a[:, 3], "bb_width": a[:, 4], "bb_height": a[:, 5]}


def eval_clip(video: str, log) -> dict:
    from rhythmjax.count import count_frames
    from rhythmjax.count.counting import walker_ids
    from rhythmjax.evaluation.motscore import score_mot
    from rhythmjax.vision.video import VideoSource

    stem = video[:-4]
    with open(stem + ".json") as f:
        meta = json.load(f)
    cfg = dev_config(meta)
    truth = read_gt(stem + "_gt.txt")
    n_walk = int(np.unique(truth["id"]).size)
    with VideoSource(video, fps=float(meta["fps"])) as src:
        frames = list(src)
    res = count_frames(cfg, iter(frames), n_frames=len(frames))
    s = score_mot(truth, res.mot, frame_offset=0, walking_ids=walker_ids(res.verdicts))
    row = {"clip": os.path.basename(stem), "walkers": n_walk, "counted": res.counts["walkers"],
           "count_error": res.counts["walkers"] - n_walk, "counts": res.counts,
           "mota": s.mota, "idf1": s.idf1, "id_switches": s.id_switches,
           "recall": s.recall, "precision": s.precision}
    log(json.dumps(row, default=float))
    return row


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default=DATA)
    p.add_argument("--json")
    a = p.parse_args(argv)
    clips = sorted(glob.glob(os.path.join(a.data, "dev_crowd_*.avi")))
    if not clips:
        print(f"no dev_crowd_*.avi under {a.data}", file=sys.stderr)
        return 2
    rows = [eval_clip(c, lambda s: print(s, file=sys.stderr, flush=True)) for c in clips]
    nw = sum(r["walkers"] for r in rows)
    out = {"clips": rows, "walkers": nw, "counted": sum(r["counted"] for r in rows),
           "sum_abs_count_error_rel": sum(abs(r["count_error"]) for r in rows) / nw,
           "mota_mean": float(np.mean([r["mota"] for r in rows])),
           "idf1_mean": float(np.mean([r["idf1"] for r in rows]))}
    print("| clip | walkers | counted | counts | MOTA | IDF1 | IDSW |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        c = r["counts"]
        rng = f" [{c['walkers_low']}, {c['walkers_high']}]" if "walkers_low" in c else ""
        print(f"| {r['clip']} | {r['walkers']} | {r['counted']}{rng} | "
              f"{c['pedestrians']} ped, {c['unclassified']} unclassified, "
              f"{c['non_pedestrians']} non-ped | {r['mota']:.3f} | {r['idf1']:.3f} | "
              f"{r['id_switches']} |")
    print(f"\nwalkers {out['counted']} counted / {nw} true; per-clip |errors| summed "
          f"{100 * out['sum_abs_count_error_rel']:.1f} %; mean MOTA {out['mota_mean']:.3f}, "
          f"IDF1 {out['idf1_mean']:.3f}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
