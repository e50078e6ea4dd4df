"""UCSD Ped2's walkers by direction: are walkers seen from the front or back judged Pedestrian less
often than walkers crossing the view? (issue 16, thirty-seventh round; a study, nothing chosen).

Each of the four clips (`datasets.UCSD_CLIPS`) is tracked as `eval_real_video` does (its guessed
camera, 30 fps, the 32-sample window; `rhythmjax run`'s defaults otherwise). A track that is off
the anomaly boxes (`score_ucsd`'s rule: less than `OVERLAP_FRACTION` of its rows inside a box)
and has a verdict is sorted by the least-squares slope of its image row over its frames:
"radial" where |dv/dk| > `RADIAL_PX_PER_FRAME` (towards the camera: v grows; away: v falls),
"crossing" otherwise. Prints the verdicts per direction and each radial track judged
Non-pedestrian (pace, reason, rows). Compare the own scenes with knees and with straight legs
(`eval_all.py --only synthetic,synthetic_lateral` and `synthetic_rods,synthetic_lateral_rods`;
docs/validation.md, "Thirty-seventh round").

    RHYTHMJAX_DATA=../shared/data/real python benchmarks/study_radial_walkers.py [-o ROWS.json]
"""

from __future__ import annotations

import collections
import json
import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

import eval_real_video as ev  # noqa: E402
from eval_all_score import apply_set  # noqa: E402

from rhythmjax.evaluation import datasets  # noqa: E402


RADIAL_PX_PER_FRAME = 0.05  # |dv/dk| above this: towards or away from the camera


def direction(frames: np.ndarray, v: np.ndarray) -> str:
    """"towards", "away" or "crossing" from the slope of the image row v (px) over frames."""
    if len(frames) < 3:
        return "crossing"
    slope = float(np.polyfit(frames, v, 1)[0])
    if abs(slope) <= RADIAL_PX_PER_FRAME:
        return "crossing"
    return "towards" if slope > 0 else "away"


def clip_rows(clip: str) -> list[dict]:
    """One row per walker track (off the anomaly boxes, with a verdict) of one clip."""
    d = apply_set({"camera": ev.UCSD_CAMERA, "thresholds": {"window_s": 32 / 30}}, [])
    folder, boxes = datasets.ucsd_clip(clip)
    cfg = ev.video_config(d, folder, 30.0)
    tracks, verdicts = ev.track(cfg, folder, 30.0)
    tid, frame = np.asarray(tracks["track_id"]), np.asarray(tracks["frame"])
    v = np.asarray(tracks["v"])
    inside = ev.rows_in_boxes(tracks, boxes)
    ids = [int(t) for t in verdicts["track_id"]]
    rows = []
    for t in np.unique(tid):
        sel = (tid == t) & np.isfinite(v)
        if not sel.any() or inside[sel].mean() >= ev.OVERLAP_FRACTION:
            continue
        i = ids.index(int(t))
        verdict = str(verdicts["verdict"][i])
        if verdict == "unclassified":
            continue
        rows.append({"clip": clip, "track": int(t), "verdict": verdict,
                     "reason": str(verdicts["reason"][i]),
                     "pace_hz": float(verdicts["pace_hz"][i]), "rows": int(sel.sum()),
                     "direction": direction(frame[sel], v[sel])})
    return rows


def main(argv: list[str]) -> int:
    if datasets.ucsd_root() is None:
        print("UCSD Ped2 absent (set RHYTHMJAX_DATA)", file=sys.stderr)
        return 1
    rows = [r for clip in datasets.UCSD_CLIPS for r in clip_rows(clip)]
    counts = collections.Counter((r["direction"], r["verdict"]) for r in rows)
    for way in ("towards", "away", "crossing"):
        ped = counts[(way, "pedestrian")]
        n = ped + counts[(way, "non-pedestrian")]
        print(f"{way:9s} judged Pedestrian {ped:3d} of {n:3d}")
    for r in rows:
        if r["direction"] != "crossing" and r["verdict"] == "non-pedestrian":
            print(f"  {r['clip']} track {r['track']:3d} {r['direction']:8s} pace "
                  f"{r['pace_hz']:.2f} Hz  {r['reason']}  {r['rows']} rows")
    if "-o" in argv:
        Path(argv[argv.index("-o") + 1]).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
