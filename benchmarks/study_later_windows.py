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

Figures: docs/rules.md, "Later windows: a Pedestrian track cut where it stops being a walk".
"""

from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

import jax


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402

from rhythmjax.model.params import config_from_dict, walking_top_pace, walking_top_speed  # noqa: E402
from rhythmjax.model.status import Reason, Verdict  # noqa: E402
from rhythmjax.sim.evaluate import deciding_windows, match_tracks, window_objects  # noqa: E402
from rhythmjax.sim.presets import synthetic_options  # noqa: E402
from rhythmjax.sim.scene import render_scene  # noqa: E402
from rhythmjax.track import track_frames  # noqa: E402
from rhythmjax.track.options import with_changes  # noqa: E402
from rhythmjax.track.recheck import not_a_walk  # noqa: E402
from rhythmjax.track.toolkit import match_window  # noqa: E402


def kind(obj) -> str:
    return "none" if obj is None else obj.kind[:3]


def later_windows(cfg, obj, tracks, truth) -> list[tuple]:
    """Each window of `obj` after its deciding one: (first row, object followed, reason,
    verdict, pace, stride, speed, refused)."""
    top = (walking_top_speed(cfg), walking_top_pace(cfg))
    probe = copy.copy(obj)
    probe.win_start, n, out = int(obj.result["window"][1]), cfg.thresholds.n, []
    while probe.win_start + n <= len(probe.rows):
        start = probe.win_start
        probe.result, probe.decided = None, False
        match_window(cfg, probe)
        r = probe.result
        if r is not None:
            a, b = r["window"]
            span = {obj.track_id: (int(obj.rows[a][0]), int(obj.rows[b - 1][0]))}
            seen = window_objects(tracks, truth, span).get(obj.track_id)
            out.append((a, kind(seen), Reason(int(r["reason"])).label,
                        Verdict(int(r["verdict"])).label, round(float(r["pace_hz"]), 2),
                        round(float(r["stride_m"]), 2), round(float(r["speed_mps"]), 2),
                        not_a_walk(r, *top)))
        if probe.win_start == start:
            break
    return out


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("seeds", type=int, nargs="+")
    p.add_argument("--scenes", type=int, default=10)
    a = p.parse_args(argv)
    cfg = config_from_dict(es.RECOMMENDED)
    options = with_changes(synthetic_options(), {"recheck.enabled": False})
    with jax.enable_x64(True):
        for seed in a.seeds:
            for s, spec in es.scene_specs(seed, a.scenes, camera=cfg.camera):
                scene = render_scene(s, spec)
                frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
                tracks, _, objs, _ = track_frames(cfg, frames, progress=False, options=options)
                by_track = match_tracks(tracks, scene.truth)
                by_window = window_objects(tracks, scene.truth, deciding_windows(objs))
                for o in objs:
                    if o.result is None or int(o.result["verdict"]) != Verdict.PEDESTRIAN:
                        continue
                    print(seed, s, o.track_id, "scored on", kind(by_track.get(o.track_id)),
                          "deciding window on", kind(by_window.get(o.track_id)),
                          tuple(o.result["window"]), len(o.rows),
                          later_windows(cfg, o, tracks, scene.truth), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
