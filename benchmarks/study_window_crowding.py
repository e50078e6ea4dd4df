"""What the deciding window of each Pedestrian track holds besides its object: the height rules
26 and 37 read there with and without the rows where another object's feet stand inside the
detection (issue 16, fifty-third round; a study: nothing is chosen here).

For every track judged Pedestrian on the own scenes, over the rows of its deciding window that
`size.row_heights` reads: the median height (m) over all of them; over the rows where no other
track's foot point (measured, else its filter's estimate projected) lies inside the detection
(within 0.75 of its width across, between its top row and 2 px above its foot row); over the
rows where no other true object's foot point does (the truth: what a rule reading the other
tracks would need to see); and the median ground width (m) of the detection, with the kind of
the object the track follows (`sim.evaluate.match_tracks`). Tracked as `eval_synthetic.py`
tracks (cached under -d; the caches of the other studies are the same).

    python benchmarks/study_window_crowding.py SEED[,SEED...] [--lateral] [--scenes 10] -d DIR
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

from eval_synthetic import RECOMMENDED  # noqa: E402
from study_tracks import scenes_of, study_parser  # noqa: E402


ACROSS = 0.75  # another foot point this close across, in detection widths, is inside it
ABOVE_PX = 2.0  # ... and at least this far above its foot row (behind it, farther away)


def inside(u, v, v_top, width, others_u, others_v) -> bool:
    """Whether any of the other foot points (px) stands inside the detection of foot point
    (u, v) px, top row v_top and width px (module doc)."""
    with np.errstate(invalid="ignore"):
        return bool(np.any((np.abs(others_u - u) < ACROSS * width)
                           & (others_v < v - ABOVE_PX) & (others_v > v_top)))


def median(x) -> float:
    return float(np.median(x)) if np.size(x) else float("nan")


def main(argv=None) -> int:
    from rhythmjax.model.camera_np import camera_tuple, ground_of_pixels, image_width_of, project_3d
    from rhythmjax.model.params import config_from_dict, host_float
    from rhythmjax.model.status import Reason, Verdict
    from rhythmjax.sim.evaluate import match_tracks
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.track.size import row_heights

    a = study_parser(__doc__).parse_args(argv)
    cfg = config_from_dict(RECOMMENDED)
    camera, walker_m = camera_tuple(cfg.camera), host_float(cfg.width.height)
    top_inside = synthetic_options().size.top_inside_heights
    for name, tracks, objs, truth in scenes_of(cfg, a):
        owner = match_tracks(tracks, truth)
        tid, frame = np.asarray(tracks["track_id"]), np.asarray(tracks["frame"])
        tu, tv = np.asarray(tracks["u"], float), np.asarray(tracks["v"], float)
        pu, pv = project_3d(camera, np.asarray(tracks["x_est"], float),
                            np.asarray(tracks["y_est"], float), 0.0)[:2]
        fu, fv = np.where(np.isfinite(tu), tu, pu), np.where(np.isfinite(tv), tv, pv)
        for o in objs:
            r = o.result
            if r is None or "window" not in r or int(r["verdict"]) != Verdict.PEDESTRIAN:
                continue
            k0, k1 = (int(k) for k in r["window"])
            rows = o.rows[k0:k1]
            u, v, top, w = (np.array([getattr(q, f) for q in rows], float)
                            for f in ("u", "v", "v_top", "width_px"))
            h, read = row_heights(camera, u, v, top, walker_m, top_inside)
            mine = owner.get(o.track_id)
            by_track, by_truth = np.zeros(len(rows), bool), np.zeros(len(rows), bool)
            for j in np.flatnonzero(read):
                f = int(rows[j].frame)
                at = (frame == f) & (tid != o.track_id)
                by_track[j] = inside(u[j], v[j], top[j], w[j], fu[at], fv[at])
                seen = [ob for ob in truth if ob is not mine and f < len(ob.u) and ob.visible[f]]
                by_truth[j] = inside(u[j], v[j], top[j], w[j], np.array([ob.u[f] for ob in seen]),
                                     np.array([ob.v[f] for ob in seen]))
            ground_y = ground_of_pixels(camera, u, v)[1]
            width_m = w / np.asarray(image_width_of(camera, 1.0, ground_y), float)
            kind = getattr(mine, "kind", "none")
            print(f"{name} track {o.track_id} ({kind}) {Reason(int(r['reason'])).name}: "
                  f"rows read {int(read.sum())}, height {median(h[read]):.2f} m; "
                  f"without other tracks' feet {int((read & ~by_track).sum())}, "
                  f"{median(h[read & ~by_track]):.2f} m; without other objects' feet "
                  f"{int((read & ~by_truth).sum())}, {median(h[read & ~by_truth]):.2f} m; "
                  f"width {median(width_m[np.isfinite(width_m)]):.2f} m")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
