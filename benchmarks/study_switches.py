"""Non-walkers judged Pedestrian by track: was the deciding window on them? (issue 16; a study).

eval_all.py scores the own scenes by track: a track is given to the object it followed most
(`sim.evaluate.match_tracks`) and that object takes the track's verdict. A track that followed
a walker through its deciding rhythm window and then switched to a passing bicycle gives the
bicycle a Pedestrian verdict. This prints, per own seed, each non-walker judged Pedestrian by
track with the object the track followed during its deciding window
(`sim.evaluate.window_objects`) and its height (rule 26's median, `track.size.median_height`).

    python benchmarks/study_switches.py SEED [SEED ...] [--scenes 10]

Figures: docs/rules.md, "A Pedestrian too low for a walker (rule 26)".
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import jax
import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402

from rhythmjax.model.params import config_from_dict  # noqa: E402
from rhythmjax.sim.evaluate import deciding_windows, match_tracks, window_objects  # noqa: E402
from rhythmjax.sim.presets import synthetic_options  # noqa: E402
from rhythmjax.sim.scene import render_scene  # noqa: E402
from rhythmjax.track import track_frames  # noqa: E402
from rhythmjax.track.size import median_height  # noqa: E402


def switched(by_track: dict, by_window: dict, verdicts: dict) -> list[tuple[int, str, str]]:
    """(track id, kind by track, kind during the deciding window or "none") of every track
    judged Pedestrian whose object by track (`by_track`: id -> object) is not a walker."""
    out = []
    for t, v in zip(verdicts["track_id"], verdicts["verdict"]):
        obj = by_track.get(int(t))
        if v == "pedestrian" and obj is not None and obj.kind != "pedestrian":
            seen = by_window.get(int(t))
            out.append((int(t), obj.kind, "none" if seen is None else seen.kind))
    return out


def tracked_scenes(cfg, seeds, n_scenes: int, options, lateral_deg: float | None = None):
    """Per own scene of `seeds` (`eval_synthetic.scene_specs`, `n_scenes` each, `lateral_deg`
    its), tracked with `options`: (seed, scene seed, scene, tracks, verdicts, objects, by_track,
    by_window), the last two the object each track is scored on (`match_tracks`) and the one its
    deciding window followed (`window_objects`)."""
    for seed in seeds:
        for s, spec in es.scene_specs(seed, n_scenes, camera=cfg.camera, lateral_deg=lateral_deg):
            scene = render_scene(s, spec)
            frames = ((i, i / scene.fps, f) for i, f in enumerate(scene.frames))
            tracks, verdicts, objs, _ = track_frames(cfg, frames, progress=False,
                                                     options=options)
            yield (seed, s, scene, tracks, verdicts, objs, match_tracks(tracks, scene.truth),
                   window_objects(tracks, scene.truth, deciding_windows(objs)))


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("seeds", type=int, nargs="+")
    p.add_argument("--scenes", type=int, default=10)
    a = p.parse_args(argv)
    cfg = config_from_dict(es.RECOMMENDED)
    with jax.enable_x64(True):
        for seed, s, _, tracks, verdicts, _, by_track, by_window in tracked_scenes(
                cfg, a.seeds, a.scenes, synthetic_options()):
            tid = np.asarray(tracks["track_id"])
            for t, kind, seen in switched(by_track, by_window, verdicts):
                rows = tid == t
                h, n = median_height(cfg.camera, tracks["u"][rows], tracks["v"][rows],
                                     tracks["v_top"][rows], float(cfg.width.height))
                print(f"seed {seed} scene {s} track {t}: {kind} by track, {seen} in its "
                      f"deciding window; height {h:.2f} m over {n} rows", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
