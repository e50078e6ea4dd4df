"""Where window B should sit on a walker: the tracker's rhythm windows judged again with window
B at other placements (issue 16 item 2, forty-second round; a study, nothing chosen).

Behind truth boxes the classifier judges more own walkers Pedestrian than the tracker does
(`study_tracker_gap.py`). Part of the difference is tracking (fragments, close passes); this
measures the rest: window B's placement in the very rows and frames the tracker judged. Per own
scene of `eval_synthetic.scene_specs` (radial), tracked as `study_rescue_windows.py` tracks and
caches it (``-d DIR``), each classifiable walker's (`sim.clean`) longest assigned track of N
rows or more is replayed (`fp_replay.replay`, every window, the candidates) with I(k) and the
candidate windows' I(k) recomputed from the tracker's difference images
(`eval_window_b.differences`) at each placement, W the walker width at the placement's foot
point (`vision.window_b.walker_width_px`):
- `tracker`: the tracker's measured foot point (u, v) (a self-check: I(k) there against the
  tracker's own, which used W at its filtered ground point, so close, not equal);
- `box`: the truth box's bottom centre, as `rhythm --boxes` takes it (`eval_count.truth_boxes`:
  the body's ground point's column, the silhouette's lowest row);
- `tracker column, box row` and `box column, tracker row`: one coordinate from each;
- `filter column, tracker row`: the column of the EKF's ground estimate (x_est, y_est)
  projected by (3), the row measured;
- `tracker, column moved half a frame's motion`: the measured point with u moved by half the
  filter's column change since the previous row (the motion image's extent is the union of
  the object's two positions, so u_p lags the object by du/2: `vision.detect`'s doc);
- `tracker, column less the half-height lean`: the measured point with u moved by u(0) -
  u(H/2), the column of the ground point under (u, v) less that of the point half a walker's
  height H above it, both through (3) (rule 41's `track.lean.lean_px`: an upright body seen
  off the image's centre leans outwards; the motion's horizontal extent spans its upper parts
  too);
- `tracker, column of the motion's lower half`: the measured row, u the centre of the slice
  extent (`body.slice_fraction` of the maximum) of the motion image's vertical projection over
  the lower half of the measured box (rows from halfway between its top row v_top and v down
  to v; columns u -+ width/2, 2 px more each side): the legs' columns, where the lean is small
  and the arms do not reach.
Printed per placement: walkers with a window judged Pedestrian, and the median over walkers of
the best window's strongest-peak P. Rows the tracker left unsampled (NaN) stay unsampled.

    python benchmarks/study_window_placement.py 3380001,3390001,3400001,3410001 [-d /tmp/rescue]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np


sys.path.insert(0, os.path.dirname(__file__))

PLACEMENTS = ("tracker", "box", "tracker column, box row", "box column, tracker row",
              "filter column, tracker row", "tracker, column moved half a frame's motion",
              "tracker, column less the half-height lean",
              "tracker, column of the motion's lower half")


def box_feet(mot: dict, actor_id: int) -> dict[int, tuple[float, float]]:
    """{frame: (u, v) px} of one object's truth boxes, each read as `rhythm --boxes` reads a
    box (`track.boxes.foot_points`: its bottom centre)."""
    from rhythmjax.track.boxes import foot_points

    mine = np.asarray(mot["id"]).astype(int) == actor_id
    u, v = foot_points(*(np.asarray(mot[k])[mine]
                         for k in ("bb_left", "bb_top", "bb_width", "bb_height")))
    return {int(f): (float(a), float(b))
            for f, a, b in zip(np.asarray(mot["frame"])[mine], u, v)}


def lower_half_column(M: np.ndarray, u: float, v: float, width: float, v_top: float,
                      fraction: float) -> float:
    """The centre (px) of the columns whose motion over the lower half of the box (rows
    round((v + v_top) / 2) .. round(v), columns u -+ (width / 2 + 2)) reaches `fraction` of the
    largest column's; u itself where the box or its motion is empty or v_top is not finite."""
    if not all(math.isfinite(q) for q in (u, v, width, v_top)):
        return u
    r0, r1 = max(int(round(0.5 * (v + v_top))), 0), min(int(round(v)), M.shape[0] - 1)
    c0 = max(int(math.floor(u - width / 2 - 2)), 0)
    c1 = min(int(math.ceil(u + width / 2 + 2)), M.shape[1] - 1)
    if r1 < r0 or c1 < c0:
        return u
    cols = M[r0:r1 + 1, c0:c1 + 1].sum(axis=0, dtype=np.int64)
    if cols.max() <= 0:
        return u
    idx = np.flatnonzero(cols >= fraction * cols.max())
    return c0 + 0.5 * (idx[0] + idx[-1])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("seeds")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("-d", "--cache", default="/tmp/study_rescue")
    a = p.parse_args(argv)

    import eval_count as ec
    import eval_synthetic as es
    from eval_window_b import differences
    from fp_replay import replay
    from study_rescue_windows import walker_tracks

    from rhythmjax.io.files import WINDOW_CANDIDATES
    from rhythmjax.model.camera_np import camera_tuple, project_3d
    from rhythmjax.model.candidates import strongest_power
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.clean import classifiable
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.sim.scene import render_scene
    from rhythmjax.track.lean import lean_px
    from rhythmjax.vision.detect import motion_from_diff
    from rhythmjax.vision.window_b import walker_width_px, window_b_candidates, window_b_intensity

    cfg, opt = config_from_dict(es.RECOMMENDED), synthetic_options()
    n, camera = int(cfg.thresholds.n), camera_tuple(cfg.camera)
    walker_m = float(cfg.width.height)
    offsets = tuple(off for _, off in WINDOW_CANDIDATES)
    none = (math.nan,) * len(offsets)
    best = {k: [] for k in PLACEMENTS}
    judged = dict.fromkeys(PLACEMENTS, 0)
    check = []
    for seed in (int(s) for s in a.seeds.split(",") if s):
        specs = es.scene_specs(seed, a.scenes, camera=cfg.camera)
        by_scene: dict[int, list] = {}
        for idx, truth, obj in walker_tracks(cfg, seed, a.scenes, False, Path(a.cache)):
            by_scene.setdefault(idx, []).append((truth, obj))
        for idx, walkers in sorted(by_scene.items()):
            scene = render_scene(*specs[idx])
            D = differences(scene.frames, opt)
            M = [None if d is None else motion_from_diff(
                d, diff_threshold=opt.motion.diff_threshold) for d in D]
            mot, _ = ec.truth_boxes(scene)
            clean = classifiable(scene, n=n)
            names = [t.track_id for t in scene.truth]
            for truth, obj in walkers:
                if not clean[truth.track_id][1]:
                    continue
                feet = box_feet(mot, names.index(truth.track_id) + 1)
                for place in PLACEMENTS:
                    rows, cands = [], []
                    prev_fu = math.nan
                    for r in obj.rows:
                        bu, bv = feet.get(int(r.frame), (math.nan, math.nan))
                        fu = float(project_3d(camera, r.x_est, r.y_est, 0.0)[0])
                        half = 0.5 * (fu - prev_fu) if math.isfinite(prev_fu) else 0.0
                        prev_fu = fu
                        lean = lean_px(camera, r.u, r.v, walker_m)  # rule 41's
                        u, v = {"tracker": (r.u, r.v), "box": (bu, bv),
                                "tracker column, box row": (r.u, bv),
                                "box column, tracker row": (bu, r.v),
                                "filter column, tracker row": (fu, r.v),
                                "tracker, column moved half a frame's motion":
                                    (r.u + half, r.v),
                                "tracker, column less the half-height lean":
                                    (r.u - lean, r.v),
                                "tracker, column of the motion's lower half":
                                    (r.u if M[int(r.frame)] is None else lower_half_column(
                                        M[int(r.frame)], r.u, r.v, r.width_px, r.v_top,
                                        opt.body.slice_fraction), r.v)}[place]
                        Dk = D[int(r.frame)]
                        if (Dk is None or not math.isfinite(r.intensity)
                                or not (math.isfinite(u) and math.isfinite(v))):
                            rows.append(r._replace(intensity=math.nan))
                            cands.append(none)
                            continue
                        W = walker_width_px(cfg.camera, cfg.width, u, v)
                        intensity = window_b_intensity(Dk, u, v, W)
                        if place == "tracker":
                            check.append(abs(intensity - r.intensity) / max(1.0, r.intensity))
                        rows.append(r._replace(intensity=intensity))
                        cands.append(window_b_candidates(Dk, u, v, W, offsets))
                    moved = SimpleNamespace(track_id=obj.track_id, rows=rows,
                                            candidate_rows=cands, result=None, vel=obj.vel)
                    windows = replay(cfg, moved, stop=False)
                    best[place].append(max((float(strongest_power(w["out"]))
                                            for w in windows), default=0.0))
                    judged[place] += any(w["ped"] for w in windows)
    print(f"classifiable walkers with a track of N rows or more: {len(best['tracker'])}; "
          f"I(k) at the tracker's point against its own: median relative difference "
          f"{np.median(check):.3f}, 90th percentile {np.quantile(check, 0.9):.3f}")
    print("| window B at | walkers with a Pedestrian window | median best P |")
    print("|---|---|---|")
    for place in PLACEMENTS:
        print(f"| {place} | {judged[place]} | {np.median(best[place]):.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
