"""What the windows after a Pedestrian verdict that rule 29 refuses hold (issue 16, forty-seventh
round; a study: nothing is chosen here).

Rule 29 (`track.recheck`, on) cuts a Pedestrian track at its first later window that is no walk
(`recheck.not_a_walk`: its speed (12) above the fastest walk, or a peak above P_thr at a pace
above the fastest, (14) at +k_sigma3). Chosen in the thirtieth round on straight-legged walkers,
whose later windows never broke either bound. This tracks own scenes with the recheck off and
prints, per later window (with the tail, `recheck.later_windows`) of every Pedestrian track:
the object it followed (`sim.evaluate.window_objects`), which test refuses it (speed, pace or
none), its speed, the deciding window's pace, its peaks (Hz, P) above P_thr and its
median height (m, `track.size.rows_height`) with the rows read:

    python benchmarks/study_later_paces.py SEED [SEED ...] [--scenes 10] [--lateral] [-o ROWS.json]
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402
from study_later_heights import followed, study_arguments  # noqa: E402
from study_switches import tracked_scenes  # noqa: E402

from rhythmjax.model.camera_np import camera_tuple  # noqa: E402
from rhythmjax.model.params import config_from_dict, walking_top_pace, walking_top_speed  # noqa: E402
from rhythmjax.model.status import Reason, Verdict  # noqa: E402
from rhythmjax.sim.presets import synthetic_options  # noqa: E402
from rhythmjax.track.options import with_changes  # noqa: E402
from rhythmjax.track.recheck import later_windows, too_fast, too_quick  # noqa: E402
from rhythmjax.track.size import rows_height  # noqa: E402


def refused_by(result: dict, top_speed: float, top_pace: float) -> str:
    """'speed', 'pace' or 'none': the test of `recheck.not_a_walk` that refuses `result`
    (`recheck.too_fast` first, then `recheck.too_quick`)."""
    if too_fast(result, top_speed):
        return "speed"
    return "pace" if too_quick(result, top_pace) else "none"


def main(argv: list[str]) -> int:
    a = study_arguments(argv, __doc__)
    cfg = config_from_dict(es.RECOMMENDED)
    top_speed, top_pace = walking_top_speed(cfg), walking_top_pace(cfg)
    p_thr = float(cfg.thresholds.p_thr)
    options = with_changes(synthetic_options(), {"recheck.enabled": False})
    cam, walker_m = camera_tuple(cfg.camera), float(cfg.width.height)
    top = options.size.top_inside_heights
    rows = []
    for seed, s, scene, tracks, _, objs, _, _ in tracked_scenes(
            cfg, a.seeds, a.scenes, options, lateral_deg=30.0 if a.lateral else None):
        for o in objs:
            if o.result is None or int(o.result["verdict"]) != Verdict.PEDESTRIAN:
                continue
            f_dec = float(o.result["pace_hz"])
            for r in later_windows(cfg, o, tail=True):
                a0, b0 = (int(k) for k in r["window"])
                peaks = [(round(float(f), 2), round(float(w), 1)) for f, w, m in zip(
                    r["peak_freq"], r["peak_power"], r["peak_mask"]) if m and w >= p_thr]
                row = {"seed": seed, "scene": s, "track": int(o.track_id), "first": a0,
                       "kind": followed(o, tracks, scene.truth, a0, b0).split(":")[-1],
                       "refused": refused_by(r, top_speed, top_pace),
                       "speed": round(float(r["speed_mps"]), 2), "deciding_pace": round(f_dec, 2),
                       "reason": Reason(int(r["reason"])).label, "peaks": peaks}
                h, n = rows_height(cam, o.rows[a0:b0], walker_m, top)
                row["height_m"], row["height_rows"] = (round(h, 2) if math.isfinite(h) else None), n
                rows.append(row)
                print(*row.values(), flush=True)
    if a.out:
        a.out.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
