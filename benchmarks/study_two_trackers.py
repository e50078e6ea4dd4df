"""What the rhythm tracker sees that the counting tracker misses, on the counting scenes (issue 16,
counting; a study: nothing is chosen here).

Each counting scene of `eval_count.scene_specs(SEED)` is run through both trackers with their
defaults: `count.count_frames` (the Masoud-Papanikolopoulos tracker and `count.COUNT_RULE`) and
`track.track_frames` (the rhythm tracker, the synthetic scenes' options). A rhythm track judged
Pedestrian is *covered* when, in at least half its rows with a foot point, that point lies in the
box of a track `COUNT_RULE` counts in the same frame (the box widened by `margin` of its width
each side and below). Three rules read both trackers, measured against the counted walkers:

- **add**: count + the rhythm Pedestrian tracks covered by no counted track (a walker the
  counting tracker lost, or judged Non-pedestrian, that the rhythm tracker judged Pedestrian);
- **merge**: counted tracks that one rhythm Pedestrian track covers in turn (each
  holds >= half of the other's rows in the rows they share, and at most 5 shared frames
  between the counted tracks) count once: fragments of one walker joined by the other tracker;
- **add+merge**: both.

Per scene: the walkers, the counted walkers, and what each rule changes, with the truth object
each added or merged track follows (`sim.evaluate.match_tracks` for rhythm tracks,
`eval_count.owner_of_tracks` for counted ones). Errors are per-clip errors summed, over the
walkers (eval_count's figure).

    python benchmarks/study_two_trackers.py --seed S [--scenes 10] [-d CACHE] [--margin 0.25]
    RHYTHMJAX_DATA=../shared/data/real python benchmarks/study_two_trackers.py --real [-d CACHE]

On the real clips the truth boxes name the counted tracks' people; the rhythm tracks' objects
are not named (no foot-point truth).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from eval_count import SEED, owner_of_tracks, scene_specs, truth_boxes  # noqa: E402


def run_both(cfg, items: list, options, f: Path, truth, kinds, offset: int,
             objects=()) -> dict:
    """Both trackers' outputs on one clip's `(index, t, gray)` items, pickled as `f`."""
    if f.exists():
        with open(f, "rb") as fh:
            return pickle.load(fh)
    from rhythmjax.count import count_frames, walker_ids
    from rhythmjax.track import track_frames

    res = count_frames(cfg, iter(items), n_frames=len(items))
    tracks, verdicts, _, _ = track_frames(cfg, iter(items), progress=False, options=options)
    out = {"mot": {k: np.asarray(v) for k, v in res.mot.items()},
           "counted": walker_ids(res.verdicts), "truth": truth, "kinds": kinds,
           "offset": offset, "tracks": {k: np.asarray(v) for k, v in tracks.items()},
           "verdicts": {k: list(v) for k, v in verdicts.items()}, "objects": tuple(objects)}
    f.parent.mkdir(parents=True, exist_ok=True)
    with open(f, "wb") as fh:
        pickle.dump(out, fh)
    return out


def own_clips(seed: int, n: int, cache: Path):
    """(name, record) of the counting scenes (the synthetic scenes' config and options)."""
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG, synthetic_options
    from rhythmjax.sim.scene import render_scene

    cfg = config_from_dict(SYNTHETIC_CONFIG)
    for s, spec in scene_specs(n, seed=seed, camera=cfg.camera):
        f = cache / f"two_{s}.pkl"
        if f.exists():
            yield str(s), run_both(cfg, [], None, f, None, None, -1)
            continue
        scene = render_scene(s, spec)
        truth, kinds = truth_boxes(scene)
        items = [(k, k / scene.fps, g) for k, g in enumerate(scene.frames)]
        yield str(s), run_both(cfg, items, synthetic_options(), f, truth, kinds, -1, scene.truth)


def real_clips(cache: Path):
    """(name, record) of PETS09-S2L1 and the dev crowd clips (report-only sources), with the
    library's default tracker options, configured as `eval_all.py` does."""
    import eval_real_video as ev
    from eval_all import DEV_ROOT, _dev_index, apply_set, dev_camera, read_gt

    from rhythmjax.evaluation import datasets
    from rhythmjax.track.options import TrackerOptions
    from rhythmjax.vision.video import VideoSource

    if datasets.pets_root() is not None:
        cfg = ev.video_config(apply_set(ev.pets_config_dict(), []), datasets.pets_video(),
                              datasets.PETS_FPS)
        truth = datasets.pets_boxes()
        kinds = {int(i): "pedestrian" for i in np.unique(truth["id"])}
        items = list(VideoSource(str(datasets.pets_video()), fps=datasets.PETS_FPS))
        yield "pets", run_both(cfg, items, TrackerOptions(), cache / "two_pets.pkl", truth,
                               kinds, -1)
    if DEV_ROOT.is_dir():
        for c in _dev_index():
            if not c.get("count"):
                continue
            meta = json.loads((DEV_ROOT / c["truth"]).read_text())
            path = DEV_ROOT / c["video"]
            cfg = ev.video_config(apply_set(dev_camera(meta), []), path, meta["fps"])
            gt, kinds = read_gt(DEV_ROOT / c["mot_gt"])
            items = list(VideoSource(str(path), fps=meta["fps"]))
            rec = run_both(cfg, items, TrackerOptions(), cache / f"two_{c['clip']}.pkl", gt,
                           kinds, 0)
            rec["true"] = int(c["count"]["n_walkers"])
            yield c["clip"], rec


def boxes_by_frame(mot: dict, ids: list[int], margin: float) -> dict[int, np.ndarray]:
    """{0-based frame: rows (id, u0, v0, u1, v1)} of the counted tracks' boxes, widened by
    `margin` of their width left, right and below (MOT frames are 1-based)."""
    keep = np.isin(mot["id"], ids)
    f = np.asarray(mot["frame"])[keep] - 1
    x, y = np.asarray(mot["bb_left"])[keep], np.asarray(mot["bb_top"])[keep]
    w, h = np.asarray(mot["bb_width"])[keep], np.asarray(mot["bb_height"])[keep]
    rows = np.stack([np.asarray(mot["id"])[keep], x - margin * w, y, x + w + margin * w,
                     y + h + margin * w], 1)
    return {int(k): rows[f == k] for k in np.unique(f)}


def covering(track_rows, boxes: dict) -> dict[int, int]:
    """{counted id: rows of the rhythm track whose foot point lies in its box}."""
    hits: dict[int, int] = {}
    for fr, u, v in track_rows:
        for b in boxes.get(int(fr), ()):
            if b[1] <= u <= b[3] and b[2] <= v <= b[4]:
                hits[int(b[0])] = hits.get(int(b[0]), 0) + 1
    return hits


def rhythm_pedestrians(rec: dict) -> dict[int, np.ndarray]:
    """{rhythm track id judged Pedestrian: rows (frame, u, v) with a foot point}."""
    v = rec["verdicts"]
    ped = {int(t) for t, w in zip(v["track_id"], v["verdict"]) if str(w) == "pedestrian"}
    tr = rec["tracks"]
    out = {}
    for t in ped:
        k = (tr["track_id"] == t) & np.isfinite(tr["u"]) & np.isfinite(tr["v"])
        out[t] = np.stack([tr["frame"][k], tr["u"][k], tr["v"][k]], 1)
    return out


def frames_of(mot: dict, i: int) -> set[int]:
    return set((np.asarray(mot["frame"])[np.asarray(mot["id"]) == i] - 1).tolist())


def two_tracker_rules(rec: dict, margin: float = 0.25) -> dict:
    """The rhythm Pedestrian tracks covered by no counted track (`added`) and the groups of
    counted tracks one rhythm Pedestrian track joins (`merged`: lists of counted ids)."""
    boxes = boxes_by_frame(rec["mot"], rec["counted"], margin)
    added, merged = [], []
    for t, rows in sorted(rhythm_pedestrians(rec).items()):
        if not len(rows):
            continue
        hits = covering(rows, boxes)
        if sum(hits.values()) < 0.5 * len(rows):
            added.append(t)
        group = []
        for i, n in sorted(hits.items(), key=lambda p: -p[1]):
            fi = frames_of(rec["mot"], i)
            shared = sum(int(fr) in fi for fr, _, _ in rows)
            if shared and n >= 0.5 * shared and all(
                    len(fi & frames_of(rec["mot"], j)) <= 5 for j in group):
                group.append(i)
        if len(group) > 1:
            merged.append(group)
    return {"added": added, "merged": merged}


def main(argv=None) -> int:
    from rhythmjax.sim.evaluate import match_tracks

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seed", type=int, default=SEED)
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--real", action="store_true",
                   help="PETS09-S2L1 and the dev crowd clips instead (RHYTHMJAX_DATA)")
    p.add_argument("-d", "--cache", type=Path, default=Path("/tmp/study_two"))
    p.add_argument("--margin", type=float, default=0.25)
    a = p.parse_args(argv)
    tot = {"walkers": 0, "count": 0, "add": 0, "merge": 0, "add_merge": 0}
    clips = real_clips(a.cache) if a.real else own_clips(a.seed, a.scenes, a.cache)
    for i, (s, rec) in enumerate(clips):
        kinds, truth = rec["kinds"], rec["truth"]
        seen = set(np.asarray(truth["id"]).tolist())
        n_walk = rec.get("true", sum(1 for t, k in kinds.items()
                                     if k == "pedestrian" and t in seen))
        rule = two_tracker_rules(rec, a.margin)
        objs = list(rec["objects"])
        rhythm_owner = match_tracks(rec["tracks"], objs) if objs else {}
        count_owner = owner_of_tracks(truth, rec["mot"], rec["offset"])
        n = len(rec["counted"])
        n_add = n + len(rule["added"])
        n_joined = sum(len(g) - 1 for g in rule["merged"])
        n_merge, n_both = n - n_joined, n_add - n_joined
        added = [f"{t}->{getattr(rhythm_owner.get(t), 'kind', 'none')}"
                 f"{objs.index(rhythm_owner[t]) + 1 if t in rhythm_owner else ''}"
                 for t in rule["added"]]
        merged = [[f"{c}->{count_owner.get(c)}" for c in g] for g in rule["merged"]]
        print(f"clip {i} ({s}): walkers {n_walk} counted {n} add {n_add} "
              f"merge {n_merge} add+merge {n_both}; added {added} merged {merged}")
        tot["walkers"] += n_walk
        for k, c in (("count", n), ("add", n_add), ("merge", n_merge), ("add_merge", n_both)):
            tot[k] += abs(c - n_walk)
    w = max(tot["walkers"], 1)
    print(f"walkers {tot['walkers']}; per-clip errors summed: count {tot['count'] / w:.1%}, "
          f"add {tot['add'] / w:.1%}, merge {tot['merge'] / w:.1%}, "
          f"add+merge {tot['add_merge'] / w:.1%}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
