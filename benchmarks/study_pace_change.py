"""Where a tracker rule moves the walkers' pace: each walker judged Pedestrian both with the
defaults and with the rule, its pace error, deciding window, deciding candidate and the share
of that window's rows predicted and without a rhythm sample, side by side (issue 16,
fifty-third round; a study: nothing is chosen here).

The rule is given as tracker option changes (`--change body.column_rows=0.5`, repeatable, read as
`run --set` reads them), the side it is measured against as the defaults with `--base` changes
(none by default; e.g. `--base body.column_rows=none --base recheck.strongest_pace=false`, the
defaults before decision 55, which the fifty-third round's figures used); a track's pace is the
one it reports (rule 55: its strongest Pedestrian window's); each walker's longest judged track
on each side
(`sim.evaluate.match_tracks`). The own scenes are tracked as `eval_synthetic.py` tracks them,
cached under -d (one folder per side; the cache does not record the changes, so give each rule
its own -d). The last line sums it up: how many walkers' pace errors
grew by more than 0.01 Hz, how many of those changed deciding window or candidate, and the mean
share of the rule's deciding-window rows that are predicted yet carry a sample.

    python benchmarks/study_pace_change.py SEED[,SEED...] [--lateral] --change KEY=VALUE \
        [--base KEY=VALUE] -d DIR
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

from eval_synthetic import RECOMMENDED  # noqa: E402
from study_tracks import scenes_of, study_parser  # noqa: E402


WORSE_HZ = 0.01  # a pace error this much larger counts as moved


def window_of(obj, true_hz: float) -> tuple:
    """(|pace - true| Hz, deciding window (k0, k1), candidate, predicted share, predicted rows
    with a sample share) of a judged track."""
    k0, k1 = (int(k) for k in obj.result["window"])
    rows = obj.rows[k0:k1]
    predicted = np.array([not np.isfinite(q.u) for q in rows])
    sampled = np.array([np.isfinite(q.intensity) for q in rows])
    return (abs(float(obj.result["pace_hz"]) - true_hz), (k0, k1),
            int(obj.result.get("candidate", 0)), float(predicted.mean()),
            float((predicted & sampled).mean()))


def walkers(tracks, objs, truth) -> dict:
    """{walker id: its longest judged track} judged Pedestrian."""
    from rhythmjax.sim.evaluate import match_tracks

    owner, best = match_tracks(tracks, truth), {}
    for o in objs:
        ob = owner.get(o.track_id)
        if ob is None or o.result is None or ob.kind != "pedestrian":
            continue
        if ob.track_id not in best or len(o.rows) > len(best[ob.track_id].rows):
            best[ob.track_id] = o
    return {k: o for k, o in best.items() if int(o.result["verdict"]) == 1}


def main(argv=None) -> int:
    from rhythmjax.cli.option_changes import apply_option_changes
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import synthetic_options

    p = study_parser(__doc__)
    p.add_argument("--change", action="append", default=[], help="KEY=VALUE, a tracker option")
    p.add_argument("--base", action="append", default=[],
                   help="KEY=VALUE, a tracker option of the side measured against")
    a = p.parse_args(argv)
    cfg = config_from_dict(RECOMMENDED)
    base_options, _ = apply_option_changes(synthetic_options(), a.base)
    sides = {"defaults": base_options,
             "rule": apply_option_changes(base_options, a.change)[0]}
    moved = changed = both = 0
    carried = []
    for base, rule in zip(*(scenes_of(cfg, a, o, a.cache / k) for k, o in sides.items())):
        judged = [walkers(*scene[1:]) for scene in (base, rule)]
        true_hz = {ob.track_id: ob.pace_hz for ob in base[3]}
        for w in sorted(set(judged[0]) & set(judged[1])):
            x, y = (window_of(side[w], true_hz[w]) for side in judged)
            both += 1
            carried.append(y[4])
            if y[0] > x[0] + WORSE_HZ:
                moved += 1
                changed += (x[1], x[2]) != (y[1], y[2])
            print(f"{base[0]} {w}: pace error {x[0]:.3f} -> {y[0]:.3f} Hz, window {x[1]} -> "
                  f"{y[1]}, candidate {x[2]} -> {y[2]}, predicted {x[3]:.2f} -> {y[3]:.2f}")
    print(f"walkers judged Pedestrian both ways {both}; pace error up by > {WORSE_HZ} Hz: "
          f"{moved}, of them with another deciding window or candidate: {changed}; the rule's "
          f"deciding-window rows predicted with a sample: {np.mean(carried) if carried else 0:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
