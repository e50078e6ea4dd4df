"""The tracker's own gap: the same own scenes' objects judged behind their truth boxes and by the
online tracker, object by object (issue 16; a study, nothing chosen).

`eval_rhythm_boxes.py --only own --seeds S,...` judges each object of `eval_synthetic`'s scenes
behind its truth box track (`rhythmjax rhythm --boxes`); an `eval_all.py` / `eval_rules.py` run
(or one re-scored by `rescore_classifiable.py`) of the same seeds holds the tracker's verdict
per object (its longest judged assigned track, `sim.evaluate.score`), with `classifiable` (the
dev clips' convention, `sim.clean`). Both list a scene's objects in the truth's order. This
pairs them and prints, per kind, the cross table of the two verdicts (classifiable walkers
apart), then every classifiable walker judged Pedestrian behind its box and not by the tracker,
with how the tracker missed it: `unclassified` (no track of N rows to judge: fragments),
`non-pedestrian` (a judged track said so) or `missed` (no track). `study_missed_walkers.py` on
the same seeds gives each one's tracks and windows.

    python benchmarks/eval_rhythm_boxes.py --only own --seeds 2930001,2940001 -o BOXES_DIR
    python benchmarks/study_tracker_gap.py BOXES_DIR/eval_rhythm_boxes.json RUN.json [RUN2.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter


def tracker_objects(paths: list[str]) -> dict[tuple[str, int], list[dict]]:
    """{(seed, scene index): object rows} of the tracker's runs (every own synthetic source in
    them: the seeds must not repeat across the files)."""
    out: dict[tuple[str, int], list[dict]] = {}
    for path in paths:
        with open(path) as f:
            run = json.load(f)
        for source, seeds in run.get("sources", {}).items():
            if not source.startswith("synthetic"):
                continue
            for seed, res in seeds.items():
                for row in res.get("objects", []):
                    out.setdefault((str(seed), int(row["scene"])), []).append(row)
    return out


def pairs(boxes: dict, tracked: dict) -> list[dict]:
    """One record per object of every scene in both: kind, classifiable (the tracker run's
    flag), the tracker's verdict and reason and the box track's verdict and reason."""
    recs = []
    for key, box_rows in boxes.items():
        _, seed, scene = key.rsplit("_", 2)
        rows = tracked.get((seed, int(scene)))
        if rows is None:
            continue
        if len(rows) != len(box_rows) or any(a["kind"] != b["kind"]
                                             for a, b in zip(rows, box_rows)):
            raise SystemExit(f"scene {key}: the runs list different objects "
                             f"({len(rows)} tracked, {len(box_rows)} boxed)")
        for a, b in zip(rows, box_rows):
            recs.append({"scene": f"{seed}:{scene}", "object": a["object"], "kind": a["kind"],
                         "classifiable": bool(a.get("classifiable", True)),
                         "tracker": a["verdict"], "boxes": b["verdict"],
                         "boxes_reason": b.get("reason", "")})
    return recs


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("boxes", help="eval_rhythm_boxes.json of --only own")
    p.add_argument("runs", nargs="+", help="eval_all / eval_rules / rescore JSON, same seeds")
    a = p.parse_args(argv)
    with open(a.boxes) as f:
        boxes = json.load(f).get("own", {})
    recs = pairs(boxes, tracker_objects(a.runs))
    if not recs:
        print("no scene in both runs", file=sys.stderr)
        return 1
    print(f"{len(recs)} objects in {len({r['scene'] for r in recs})} scenes\n")
    print("| kind | classifiable | tracker | boxes | objects |")
    print("|---|---|---|---|---|")
    table = Counter((r["kind"], r["classifiable"], r["tracker"], r["boxes"]) for r in recs)
    for (kind, cl, trk, box), n in sorted(table.items()):
        print(f"| {kind} | {'yes' if cl else 'no'} | {trk} | {box} | {n} |")
    walkers = [r for r in recs if r["kind"] == "pedestrian" and r["classifiable"]]
    both = sum(r["tracker"] == "pedestrian" for r in walkers)
    boxed = sum(r["boxes"] == "pedestrian" for r in walkers)
    print(f"\nclassifiable walkers judged Pedestrian: tracker {both}/{len(walkers)}, "
          f"boxes {boxed}/{len(walkers)}")
    gap = [r for r in walkers if r["boxes"] == "pedestrian" and r["tracker"] != "pedestrian"]
    print(f"behind the boxes only: {len(gap)} "
          f"({dict(Counter(r['tracker'] for r in gap))}); by the tracker only: "
          f"{sum(r['boxes'] != 'pedestrian' and r['tracker'] == 'pedestrian' for r in walkers)}")
    for r in gap:
        print(f"  {r['scene']} {r['object']}: tracker {r['tracker']}, boxes {r['boxes_reason']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
