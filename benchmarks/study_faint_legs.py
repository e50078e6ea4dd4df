"""How much of a walker's legs the counting mask keeps, per truth object of a dev crowd clip
(issue 16, twenty-eighth round; docs/rules.md, "Rule 24: faint legs grown down from the
counting mask").

The counting front end (`vision.blobs.BackgroundModel` with the config's `blobs` options, the
defaults unless `--set`) runs over the clip; in every frame where a truth box (the MOT truth,
`<clip>_gt.txt`) is at least 4 x 10 px, the box's upper half and lower 40 % (the legs) give the
fraction of their pixels in the mask and the 75th percentile of |I - B| (grey levels), B the
background before the frame's update. Medians over the frames, per object.

    RHYTHMJAX_DATA=../shared/data python benchmarks/study_faint_legs.py dev_crowd_03 \\
        [--set blobs.bg_threshold=12]
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

UPPER = 0.5  # the box's upper half: head and torso
LOWER = 0.6  # from this fraction of the box's height down: the legs


def box_halves(mask: np.ndarray, diff: np.ndarray, box) -> tuple[float, float, float, float]:
    """(mask fill of the upper half, of the lower 40 %, p75 of |diff| there, the same below)
    of the box (x0, y0, w, h) px clipped to the image; NaN where a part holds no pixel."""
    x0, y0, w, h = (int(round(float(b))) for b in box)
    x1, y1 = min(x0 + w, mask.shape[1]), min(y0 + h, mask.shape[0])
    x0, y0 = max(x0, 0), max(y0, 0)
    m, d = mask[y0:y1, x0:x1] > 0, np.abs(diff[y0:y1, x0:x1].astype(np.float64))
    up, low = slice(0, int(UPPER * h)), slice(int(LOWER * h), None)
    part = lambda a, s, f: float(f(a[s])) if a[s].size else float("nan")
    p75 = lambda a: np.percentile(a, 75)
    return part(m, up, np.mean), part(m, low, np.mean), part(d, up, p75), part(d, low, p75)


def run(clip: str, sets: list[str]) -> dict[int, np.ndarray]:
    """Per truth id (MOT), the (frames, 4) rows of `box_halves` over the clip."""
    import eval_all as ea

    from rhythmjax.count.options import CountOptions
    from rhythmjax.track.options import with_changes
    from rhythmjax.vision.blobs import BackgroundModel
    from rhythmjax.vision.video import VideoSource

    opt = with_changes(CountOptions(), {k: json.loads(v) for k, v in
                                        (s.split("=", 1) for s in sets)})
    c = next(c for c in ea._dev_index() if c["clip"] == clip)
    gt, _ = ea.read_gt(ea.DEV_ROOT / c["mot_gt"])
    fps = json.loads((ea.DEV_ROOT / c["truth"]).read_text())["fps"]
    model, rows = None, {}
    for k, _, gray in VideoSource(str(ea.DEV_ROOT / c["video"]), fps=fps):
        if gray is None:
            continue
        if model is None:
            model = BackgroundModel(gray, **opt.blobs.model_kwargs())
            continue
        diff = gray.astype(np.float64) - model.background.astype(np.float64)
        mask = model.apply(gray)
        for j in np.flatnonzero(gt["frame"] == k):
            box = [gt[n][j] for n in ("bb_left", "bb_top", "bb_width", "bb_height")]
            if box[2] >= 4 and box[3] >= 10:
                rows.setdefault(int(gt["id"][j]), []).append(box_halves(mask, diff, box))
    return {i: np.asarray(r) for i, r in sorted(rows.items())}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("clip", help="a dev crowd clip, e.g. dev_crowd_03")
    p.add_argument("--set", action="append", default=[], help="SECTION.KEY=JSON (counting)")
    a = p.parse_args(argv)
    for i, r in run(a.clip, a.set).items():
        med = np.nanmedian(r, axis=0)
        print(f"id {i}: {len(r)} frames; mask fill upper {med[0]:.2f}, legs {med[1]:.2f}; "
              f"|I - B| p75 upper {med[2]:.0f}, legs {med[3]:.0f} grey levels")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
