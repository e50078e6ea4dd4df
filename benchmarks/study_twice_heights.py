"""Rule 37's height over the deciding windows that it judged Pedestrian, by the object each
track followed (issue 16, fifty-second round; a study: rule 53's lower quartile was suggested by
it on used seeds 8100001-8190001 and 8260001-8330001).

Rule 37 judges a window at half its strongest peak where its rows are as tall as a walker
(`track.twice.twice_height`: the median over the rows `size.median_height` reads and the rows at
the image's first row, read as lower bounds; at least 0.57 walker heights over 10 rows). This
prints, per track whose deciding window rule 37 decided (reason matched-twice), the kind of the
object its rows follow (`sim.evaluate.match_tracks`), the window's height (m), the rows read
(those at the image's edge apart), the 0.1, 0.25 and 0.5 quantiles of the heights read, the
pace and each row's nearest true object (`study_tracks.nearest_per_row`): why a dog passes a
walker's height.

    python benchmarks/study_twice_heights.py SEED[,SEED...] [--lateral] [--scenes 10] -d DIR
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

from eval_synthetic import RECOMMENDED  # noqa: E402
from study_tracks import nearest_per_row, scenes_of, study_parser  # noqa: E402


QUANTILES = (0.1, 0.25, 0.5)  # of the heights rule 37 reads (m), printed per window; the
# median last


def main(argv=None) -> int:
    from rhythmjax.model.camera_np import camera_tuple
    from rhythmjax.model.params import config_from_dict, host_float
    from rhythmjax.model.status import Reason
    from rhythmjax.sim.evaluate import match_tracks
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.track.size import row_heights
    from rhythmjax.track.twice import twice_height

    a = study_parser(__doc__).parse_args(argv)
    cfg = config_from_dict(RECOMMENDED)
    size = synthetic_options().size
    camera, walker_m = camera_tuple(cfg.camera), host_float(cfg.width.height)
    for name, tracks, objs, truth in scenes_of(cfg, a):
        owner = match_tracks(tracks, truth)
        for o in objs:
            if o.result is None or int(o.result["reason"]) != Reason.MATCHED_TWICE:
                continue
            k0, k1 = (int(k) for k in o.result["window"])
            c = np.asarray([(r.u, r.v, r.v_top, r.top_at_edge) for r in o.rows[k0:k1]],
                           np.float64)
            q = [twice_height(camera, c[:, 0], c[:, 1], c[:, 2],
                              c[:, 3] if size.twice_pace_edge else None, walker_m,
                              size.top_inside_heights, x) for x in QUANTILES]
            height, n = q[-1]  # the median, rule 37's default
            _, read = row_heights(camera, c[:, 0], c[:, 1], c[:, 2], walker_m,
                                  size.top_inside_heights)
            kind = getattr(owner.get(o.track_id), "kind", "none")
            print(f"{name} track {o.track_id} ({kind}) rows {k0}-{k1} of {len(o.rows)}: "
                  f"height {height:.2f} m over {n} rows ({int(read.sum())} read, "
                  f"{n - int(read.sum())} at the edge), quantiles "
                  f"{' '.join(f'{h:.2f}' for h, _ in q)}, pace "
                  f"{float(o.result['pace_hz']):.2f} Hz  {nearest_per_row(o, k0, k1, truth)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
