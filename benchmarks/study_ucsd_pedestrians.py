"""UCSD Ped2's tracks judged Pedestrian, one line each: whether `eval_all.py` counts it as an
anomaly track (a cyclist's or the cart's) and how wide it is (issue 16; a study, nothing chosen).

The tracker runs on Test002/004/006/010 exactly as `eval_all.run_ucsd` runs it (the guessed
camera `eval_real_video.UCSD_CAMERA`, 30 fps, N = 32); a track is an anomaly track where at
least `eval_real_video.OVERLAP_FRACTION` of its measured foot points lie inside an anomaly box
(`eval_real_video.score_ucsd`). Per track judged Pedestrian: its frames, that fraction, its
reason, pace (Hz), stride (m) and speed (m/s), and its measured width over W (the walker width
at its foot point through the camera, `vision.window_b.walker_width_px`), median and 90th
percentile: does a width tell the cyclists from the walkers? ``--hop-divisor 4`` runs with
rhythm windows every N/4 samples (rule 39; 2 is the default N/2), patched in this process as
`eval_rules.py` does.

    RHYTHMJAX_DATA=../shared/data/real python benchmarks/study_ucsd_pedestrians.py [--hop-divisor 4]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(__file__))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--hop-divisor", type=int, default=2)
    a = p.parse_args(argv)

    import eval_real_video as ev
    from eval_all import apply_set

    from rhythmjax.evaluation import datasets
    from rhythmjax.model.params import Thresholds
    from rhythmjax.vision.window_b import walker_width_px

    if a.hop_divisor != 2:
        Thresholds.hop_samples = property(lambda self: max(1, self.n // a.hop_divisor))
    d = apply_set({"camera": ev.UCSD_CAMERA, "thresholds": {"window_s": 32 / 30}}, [])
    print("| clip | track | group | frames | in anomaly boxes | reason | pace Hz | stride m | "
          "speed m/s | width / W median, p90 |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for clip in datasets.UCSD_CLIPS:
        folder, boxes = datasets.ucsd_clip(clip)
        cfg = ev.video_config(d, folder, 30.0)
        tracks, verdicts = ev.track(cfg, folder, 30.0)
        tid, u, v, w, frame = (np.asarray(tracks[k], np.float64)
                               for k in ("track_id", "u", "v", "width_px", "frame"))
        inside = ev.rows_in_boxes(tracks, boxes)
        rel = w / walker_width_px(cfg.camera, cfg.width, u, v)
        ids = [int(t) for t in verdicts["track_id"]]
        for t in np.unique(tid):
            i = ids.index(int(t))
            if str(verdicts["verdict"][i]) != "pedestrian":
                continue
            rows = (tid == t) & np.isfinite(u)
            frac = float(inside[rows].mean()) if rows.any() else 0.0
            group = "anomaly" if frac >= ev.OVERLAP_FRACTION else "other"
            f = frame[tid == t]
            print(f"| {clip} | {int(t)} | {group} | {int(f.min())}-{int(f.max())} | {frac:.2f} | "
                  f"{verdicts['reason'][i]} | {float(verdicts['pace_hz'][i]):.2f} | "
                  f"{float(verdicts['stride_m'][i]):.2f} | {float(verdicts['speed_mps'][i]):.2f} "
                  f"| {np.nanmedian(rel[rows]):.2f}, {np.nanquantile(rel[rows], 0.9):.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
