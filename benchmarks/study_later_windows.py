"""The rhythm windows after a track's Pedestrian verdict, and what each followed (issue 16, rule
29; a study).

The tracker stops judging a track's windows once one says Pedestrian. This judges, for every
track judged Pedestrian on own scenes, the windows after the deciding one as `track.recheck`
does (N rows, one every `thresholds.hop_samples`, from the deciding window's end) and prints one
line per track: seed, scene, track id, the object the track is scored on (its longest share,
`sim.evaluate.match_tracks`) and the one its deciding window followed
(`sim.evaluate.window_objects`), then per later window (first row, object followed, reason,
verdict, pace Hz, stride m, speed m/s, refused by `recheck.not_a_walk`). Run it with the rule
off (the tracks as they were before the cut):

    python benchmarks/study_later_windows.py SEED [SEED ...] [--scenes 10]

--rest (rule 30): the tracks with rule 29 on and rule 30 off; per Pedestrian track the window of
its last N rows (`later_windows(tail=True)`'s last, where the others leave rows unjudged) and the
windows before its deciding one (`earlier_windows`), each described as above.

Figures: docs/rules.md, "Later windows: a Pedestrian track cut where it stops being a walk" and
"The last window and the windows before the verdict".
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import jax


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402
from study_switches import tracked_scenes  # noqa: E402

from rhythmjax.model.params import config_from_dict, walking_top_pace, walking_top_speed  # noqa: E402
from rhythmjax.model.status import Reason, Verdict  # noqa: E402
from rhythmjax.sim.evaluate import window_objects  # noqa: E402
from rhythmjax.sim.presets import synthetic_options  # noqa: E402
from rhythmjax.track.options import with_changes  # noqa: E402
from rhythmjax.track.recheck import earlier_windows, later_windows, not_a_walk  # noqa: E402


def kind(obj) -> str:
    return "none" if obj is None else obj.kind[:3]


def describe(cfg, obj, tracks, truth, windows) -> list[tuple]:
    """Each of `windows` (outcomes with their "window") of `obj`: (first row, object followed,
    reason, verdict, pace, stride, speed, refused by `not_a_walk`)."""
    top = (walking_top_speed(cfg), walking_top_pace(cfg))
    out = []
    for r in windows:
        a, b = r["window"]
        span = {obj.track_id: (int(obj.rows[a][0]), int(obj.rows[b - 1][0]))}
        seen = window_objects(tracks, truth, span).get(obj.track_id)
        out.append((a, kind(seen), Reason(int(r["reason"])).label,
                    Verdict(int(r["verdict"])).label, round(float(r["pace_hz"]), 2),
                    round(float(r["stride_m"]), 2), round(float(r["speed_mps"]), 2),
                    not_a_walk(r, *top)))
    return out


def last_window(cfg, obj) -> list[dict]:
    """The window of `obj`'s last N rows as rule 30a judges it (none where the windows after
    the deciding one cover every row)."""
    plain = list(later_windows(cfg, obj))
    every = list(later_windows(cfg, obj, tail=True))
    return every[len(plain):]


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("seeds", type=int, nargs="+")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--rest", action="store_true",
                   help="rule 29 on: the last window and the windows before the deciding one")
    a = p.parse_args(argv)
    cfg = config_from_dict(es.RECOMMENDED)
    rules = ({"recheck.enabled": True, "recheck.tail": False, "recheck.earlier": "off"}
             if a.rest else {"recheck.enabled": False})
    options = with_changes(synthetic_options(), rules)
    with jax.enable_x64(True):
        for seed, s, scene, tracks, _, objs, by_track, by_window in tracked_scenes(
                cfg, a.seeds, a.scenes, options):
            for o in objs:
                if o.result is None or int(o.result["verdict"]) != Verdict.PEDESTRIAN:
                    continue
                head = (seed, s, o.track_id, "scored on", kind(by_track.get(o.track_id)),
                        "deciding window on", kind(by_window.get(o.track_id)),
                        tuple(o.result["window"]), len(o.rows))
                if a.rest:
                    print(*head, "last", describe(cfg, o, tracks, scene.truth, last_window(cfg, o)),
                          "before", describe(cfg, o, tracks, scene.truth, earlier_windows(cfg, o)),
                          flush=True)
                else:
                    print(*head, describe(cfg, o, tracks, scene.truth, later_windows(cfg, o)),
                          flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
