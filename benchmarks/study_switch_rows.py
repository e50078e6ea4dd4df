"""Non-walkers judged Pedestrian on an eval run's own scenes: which objects their track's rows
lie on (issue 16, fifty-sixth round; a study: nothing is chosen here).

`eval_rules.py run` (and `eval_all.py`) score each own object by the track assigned to it
(`sim.evaluate.match_tracks`). For every bicycle or dog so judged Pedestrian in the given result
files, this tracks its scene again (`study_tracks.track_scene`, as `eval_synthetic.py` does,
cached under -d) and, for each track given to that object (with its verdict; the figures count
those judged Pedestrian), walks the track's observed rows: a row is on the object where its
foot point lies within max(10 px, W/2) across and 10 px down of the object's true foot point
(`on_object`); a row elsewhere is given to the true object nearest it
(`study_tracks.nearest_objects`). It prints the rows on the object and off it, which came
first, the other objects by rows, whether the track was lost (state NONE) between two observed
rows (re-acquisition, `relink`), and the track's pace and speed of (12).

    python benchmarks/study_switch_rows.py D/trend-off-seeds-*.json -d CACHE [--kinds bicycle,dog]

Figures: docs/rules.md, "Who the non-walkers judged Pedestrian are; rule 42' against them".
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402
from study_tracks import nearest_objects, track_scene  # noqa: E402


# each own source's scenes (`eval_all.py`'s run_synthetic_* keyword arguments)
SOURCE_SCENES = {"synthetic": {}, "synthetic_any": {"clothing": "any"},
                 "synthetic_suitcase": {"suitcase_fraction": 0.5},
                 "synthetic_lateral": {"lateral_deg": 30.0},
                 "synthetic_lateral_suitcase": {"lateral_deg": 30.0, "suitcase_fraction": 0.5},
                 "synthetic_rods": {"articulated": False}}
NEAR_PX, NEAR_ROWS_PX = 10.0, 10.0


def on_object(u, v, width, tu, tv) -> np.ndarray:
    """Per row, whether the foot point (u, v) px lies on the object whose true foot point is
    (tu, tv): |u - tu| < max(10, width / 2) and |v - tv| < 10 (NaN: not on it)."""
    u, v, width, tu, tv = (np.asarray(a, np.float64) for a in (u, v, width, tu, tv))
    with np.errstate(invalid="ignore"):
        return (np.abs(u - tu) < np.maximum(NEAR_PX, width / 2)) & (np.abs(v - tv) < NEAR_ROWS_PX)


def row_profile(frames, u, v, width, state, truth_uv, nearest) -> dict:
    """The rows of one track against its object's truth. `frames` (int), `u`, `v`, `width`
    (px, NaN where not observed) and `state` (`TrackState` ints) per row; `truth_uv` (2, F) the
    object's true foot point per frame (NaN out of view); `nearest` per observed row the name of
    the true object nearest it (`study_tracks.nearest_objects`; None: none visible). Returns on,
    off (observed rows), first ("object", "other" or None), relink (a NONE row between the
    first and last observed rows) and others (Counter of the off rows' nearest names)."""
    frames = np.asarray(frames, int)
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    obs = np.flatnonzero(np.isfinite(u))
    if not obs.size:
        return {"on": 0, "off": 0, "first": None, "relink": False, "others": Counter()}
    truth_uv = np.asarray(truth_uv, np.float64)
    seen = frames[obs] < truth_uv.shape[1]
    k = np.where(seen, frames[obs], 0)
    near = seen & on_object(u[obs], v[obs], np.asarray(width, np.float64)[obs],
                            truth_uv[0][k], truth_uv[1][k])
    others = Counter(n for n, on in zip(nearest, near) if not on and n is not None)
    inner = np.asarray(state)[obs[0]:obs[-1] + 1]
    return {"on": int(near.sum()), "off": int((~near).sum()),
            "first": "object" if near[0] else "other", "relink": bool(np.any(inner == 0)),
            "others": others}


def main(argv: list[str]) -> int:
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.evaluate import match_tracks

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("results", nargs="+", help="eval_rules.py / eval_all.py result files (JSON)")
    p.add_argument("--kinds", default="bicycle,dog")
    p.add_argument("-d", "--cache", type=Path, required=True,
                   help="folder of the tracked scenes (`study_tracks.track_scene`)")
    a = p.parse_args(argv)
    kinds = set(a.kinds.split(","))
    cfg = config_from_dict(es.RECOMMENDED)
    for path in a.results:
        for src, res in json.loads(Path(path).read_text())["sources"].items():
            if src not in SOURCE_SCENES or "skipped" in res:
                continue
            for seed, r in res.items():
                for o in (o for o in r["objects"]
                          if o["kind"] in kinds and o["verdict"] == "pedestrian"):
                    s, spec = es.scene_specs(int(seed), **SOURCE_SCENES[src])[o["scene"]]
                    tracks, verdicts, objs, truth = track_scene(cfg, s, spec, a.cache / src)
                    own = next(t for t in truth if t.track_id == o["object"])
                    ids = [int(t) for t in verdicts["track_id"]]
                    for t, obj in match_tracks(tracks, truth).items():
                        if obj.track_id != o["object"]:
                            continue
                        i = ids.index(t)
                        rows = next(x for x in objs if x.track_id == t).rows
                        nearest = [None if n is None else n.track_id
                                   for n in nearest_objects(rows, truth)]
                        prof = row_profile([q.frame for q in rows], [q.u for q in rows],
                                           [q.v for q in rows], [q.width_px for q in rows],
                                           [int(q.state) for q in rows],
                                           np.stack([own.u, own.v]), nearest)
                        print(f"{src} {seed} scene {s} {o['object']} track {t} "
                              f"{verdicts['verdict'][i]}: rows on it {prof['on']}, off "
                              f"{prof['off']}, first {prof['first']}, relink {prof['relink']}, "
                              f"others {dict(prof['others'].most_common(2))}, pace "
                              f"{verdicts['pace_hz'][i]:.2f} Hz, speed "
                              f"{verdicts['speed_mps'][i]:.2f} m/s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
