"""The speed of short stretches of a Pedestrian track after its deciding window, by the object
each stretch followed (issue 16, fifty-second round; a study: rule 52's measure, the filter's
speed, and its stretch, N/4 rows, were chosen with it on used seeds 7800001-7830001 and
7960001-7980001).

A walker's track that a passing bicycle takes over for its last 17-48 rows keeps the walker's
verdict: no later window of N rows is judged, and rule 30a's tail window, whose Theil-Sen speed
(12) is the median slope, still reads the walker's speed. This prints, for every track judged
Pedestrian, the speed of each stretch of `m` rows after the deciding window (one every m/2 rows,
and the track's last m; `--measure`: feet, the speed (12) of `track.toolkit.rows_speed`, the
measured foot points taken to the ground where they are at least half of the rows; filter, rule
52's median of the filter's ground speed, `track.recheck.stretch_speed`; filter-positions, the
Theil-Sen slope of the filter's ground positions), with the kind of the true object nearest most
of the stretch's rows (`study_tracks`'s nearest foot point), and per m the fastest walker
stretch and the non-walker stretches above the fastest walk (14) accepts
(`model.params.walking_top_speed`, 2.57 m/s with Table 1).

    python benchmarks/study_tail_speed.py SEED[,SEED...] [--lateral] [--measure filter] -d DIR
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

from eval_synthetic import RECOMMENDED  # noqa: E402
from study_tracks import nearest_objects, scenes_of, study_parser  # noqa: E402


def nearest_kind(rows, truth) -> tuple[str, float]:
    """The kind of the true object nearest most of `rows`' measured foot points
    (`study_tracks.nearest_objects`), and the fraction of the measured rows it is nearest
    ('none' where no row is measured)."""
    kinds = ["none" if o is None else o.kind for o in nearest_objects(rows, truth)]
    if not kinds:
        return "none", 0.0
    kind, n = Counter(kinds).most_common(1)[0]
    return kind, n / len(kinds)


def filter_theil_sen(rows) -> float:
    """Median over row pairs of the filter's ground displacement over their time apart, m/s."""
    t = np.asarray([r.t for r in rows], np.float64)
    xy = np.asarray([(r.x_est, r.y_est) for r in rows], np.float64)
    i, j = np.triu_indices(len(rows), 1)
    return float(np.nanmedian(np.hypot(*(xy[j] - xy[i]).T) / (t[j] - t[i])))


def main(argv=None) -> int:
    from rhythmjax.model.params import config_from_dict, walking_top_speed
    from rhythmjax.model.status import Verdict
    from rhythmjax.track.recheck import stretch_speed, stretch_starts
    from rhythmjax.track.toolkit import rows_speed

    p = study_parser(__doc__)
    p.add_argument("--lengths", default="8,16,24,32")
    p.add_argument("--measure", choices=("feet", "filter", "filter-positions"), default="feet",
                   help="feet: speed (12) of the measured foot points (`toolkit.rows_speed`); "
                   "filter: rule 52's median filter speed (`recheck.stretch_speed`); "
                   "filter-positions: Theil-Sen of the filter's ground positions")
    a = p.parse_args(argv)
    cfg = config_from_dict(RECOMMENDED)
    top = walking_top_speed(cfg)
    lengths = [int(x) for x in a.lengths.split(",")]
    fastest = {m: (0.0, "") for m in lengths}
    above = {m: [] for m in lengths}
    print(f"fastest walk (14): {top:.2f} m/s")
    for name, _, objs, truth in scenes_of(cfg, a):
        for o in objs:
            if (o.result is None or "window" not in o.result
                    or int(o.result["verdict"]) != Verdict.PEDESTRIAN):
                continue
            k1 = int(o.result["window"][1])
            for m in lengths:
                for k in stretch_starts(k1, len(o.rows), m):
                    speed = (stretch_speed(o, k, m) if a.measure == "filter" else
                             filter_theil_sen(o.rows[k:k + m])
                             if a.measure == "filter-positions"
                             else rows_speed(cfg, o.rows[k:k + m]))
                    kind, frac = nearest_kind(o.rows[k:k + m], truth)
                    where = f"{name} track {o.track_id} rows {k}-{k + m} of {len(o.rows)}"
                    if kind == "pedestrian" and speed > fastest[m][0]:
                        fastest[m] = (speed, where)
                    if speed > top:
                        above[m].append(f"{where} {kind} ({frac:.2f}) {speed:.2f} m/s")
    for m in lengths:
        print(f"m={m}: fastest walker stretch {fastest[m][0]:.2f} m/s ({fastest[m][1]}); "
              f"{len(above[m])} stretches above {top:.2f} m/s")
        for line in above[m]:
            print("   ", line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
