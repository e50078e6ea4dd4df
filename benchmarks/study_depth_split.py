"""A depth split of shared blobs (the prototype, issue 16, of `track.split.front_split`).

`body.split_shared` (track/split.py) re-detects each sharer of a shared blob in a window as wide
as its predicted body box; it cannot separate sharers whose predicted foot points lie less than
about 0.6 W apart across, yet half the frames that stay shared have foot points over 0.5 W
apart in v (one object in front of the other). Here `split_shared` is monkeypatched (as the
tracker imports it: `rhythmjax.track.tracker.split_shared`) with a version that first does
today's split and then, for each sharer still unsplit whose predicted foot row differs from
that of another sharer overlapping its body box in columns by more than `--dv` W:
- the FRONT sharer (the larger predicted foot row v, nearer the camera; it occludes the other)
  is re-detected in a strip of its body box's columns from `--margin` W below the lowest back
  sharer's predicted foot row down to the usual window's bottom: only its legs and feet, the
  back object's feet being above the strip. Its width is taken from a re-detection in the
  whole body box when there is one;
- the BACK sharer (mode `both`) is re-detected in its body box's columns in a window of the
  usual height whose bottom is cut `--margin` W above the front sharer's predicted foot row;
  mode `front` gives the back sharer no measurement (today's behaviour).
A re-detection is kept only if its foot point lies within `body.split_near_widths` W of the
sharer's prediction (as split_shared does). Scored by track as study_missed_walkers.py does.

    python benchmarks/study_depth_split.py 5555 6666 --variant off --variant split \
        --variant depth:0.3:both --variant depth:0.5:both --variant depth:0.5:front
Training seeds 5555 and 6666; 20240603 and 777001 reported only.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).parent))

import study_missed_walkers as smw  # noqa: E402
from eval_synthetic import RECOMMENDED  # noqa: E402

import rhythmjax.track.split as split_mod  # noqa: E402
import rhythmjax.track.tracker as tracker_mod  # noqa: E402
from rhythmjax.model.params import config_from_dict  # noqa: E402
from rhythmjax.track.options import WindowOptions  # noqa: E402
from rhythmjax.track.split import columns_overlap, detect_in_rows  # noqa: E402
from rhythmjax.vision.detect import detect_in_window  # noqa: E402


TODAY = split_mod.split_shared
STATS = collections.Counter()
_WIN = WindowOptions()
# the usual window reaches this many predicted box heights below the foot point
BELOW = 0.5 - _WIN.raise_heights / _WIN.heights


def make_depth_split(dv_widths: float, margin_widths: float, mode: str):
    """split_shared: today's split, then the depth split for the sharers left."""

    def split_depth(motion, shared, predicted, *, overlap, near_widths, fraction,
                    depth_widths=0.0, margin_widths=0.1):  # the library's own depth split off
        shared = list(shared)
        out = TODAY(motion, shared, predicted, overlap=overlap, near_widths=near_widths,
                    fraction=fraction, depth_widths=0.0)
        left = [s for s in shared if s not in out]
        STATS["sharer_frames"] += len(shared)
        STATS["split_today"] += len(out)
        STATS["left"] += len(left)
        for s in left:
            p = predicted[s]
            others = [predicted[o] for o in shared if o != s
                      and columns_overlap(p.core, predicted[o].core)]
            if not others:
                continue
            W = p.W
            fv = p.foot[1]
            back = [q for q in others if fv - q.foot[1] > dv_widths * W]
            front = [q for q in others if q.foot[1] - fv > dv_widths * W]
            if len(back) == len(others):  # s is the front sharer
                STATS["front_cand"] += 1
                top = max(q.foot[1] for q in back) + margin_widths * W
                det = detect_in_rows(motion, p, top, fv + BELOW * p.height, fraction)
                if det is None:
                    continue
                if math.hypot(det.u - p.foot[0], det.v - fv) > near_widths * W:
                    STATS["front_far"] += 1
                    continue
                whole = detect_in_window(motion, p.centre, (p.core[2], p.height),
                                         fraction=fraction, core=p.core, body_px=None)
                if whole is not None:
                    det = type(det)(det.u, det.v, whole.width, det.box, det.area, whole.top)
                out[s] = det
                STATS["front_split"] += 1
            elif front and mode == "both":  # s is a back sharer
                STATS["back_cand"] += 1
                bottom = min(q.foot[1] for q in front) - margin_widths * W
                det = detect_in_rows(motion, p, bottom - p.height, bottom, fraction)
                if det is None:
                    continue
                if math.hypot(det.u - p.foot[0], det.v - fv) > near_widths * W:
                    STATS["back_far"] += 1
                    continue
                out[s] = det
                STATS["back_split"] += 1
        return out

    return split_depth


def parse_variant(v: str):
    """'off' | 'split' | 'depth:DV[:MODE[:MARGIN]]' -> (label, changes, patch or None)."""
    if v == "off":
        return v, {"body.split_shared": False}, None
    on = {"body.split_shared": True, "body.split_depth_widths": 0.0}  # today's split alone
    if v == "split":
        return v, on, None
    parts = v.split(":")
    dv = float(parts[1])
    mode = parts[2] if len(parts) > 2 else "both"
    margin = float(parts[3]) if len(parts) > 3 else 0.1
    return f"depth_{dv:g}_{mode}_{margin:g}", on, make_depth_split(dv, margin, mode)


def run(seed: int, label: str, changes: dict, patch, n_scenes: int, root: Path) -> dict:
    cache = root / f"depth_{label}"
    stats_f = cache / f"stats_{seed}.json"
    tracker_mod.split_shared = patch or TODAY
    STATS.clear()
    cfg = config_from_dict(RECOMMENDED)
    tally = collections.Counter()
    missed = []
    for name, c, tracks, objs, truth, _ in smw.own_source(cfg, seed, n_scenes, cache, False,
                                                           changes):
        recs, t = smw.missed_walkers(name, c, tracks, objs, truth, None)
        tally.update(t)
        missed += [f"{r['scene']} {r['object']} {r['cat'][0]}" for r in recs]
    if STATS:
        stats_f.write_text(json.dumps(dict(STATS)))
    stats = json.loads(stats_f.read_text()) if stats_f.exists() else {}
    tracker_mod.split_shared = TODAY
    return {"seed": seed, "variant": label, "ped": tally["ped"], "judged": tally["judged"],
            "walkers": tally["walkers"], "others_ped": tally["others_ped"], "stats": stats,
            "missed": missed}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("seeds", nargs="+", type=int)
    p.add_argument("--variant", action="append", default=[])
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("-d", "--cache", default="/tmp/study_fp")
    p.add_argument("--json", help="append the results here (one JSON line each)")
    a = p.parse_args(argv)
    rows = []
    for v in a.variant or ["off", "split", "depth:0.5"]:
        label, changes, patch = parse_variant(v)
        for seed in a.seeds:
            r = run(seed, label, changes, patch, a.scenes, Path(a.cache))
            rows.append(r)
            print(json.dumps(r), flush=True)
            if a.json:
                with open(a.json, "a") as fh:
                    fh.write(json.dumps(r) + "\n")
    print("\n| variant | seed | walkers Ped./judged | Ped./all | non-walkers Ped. | "
          "depth split (front / back of candidates) |\n|---|---|---|---|---|---|")
    for r in rows:
        s = r["stats"]
        d = (f"{s.get('front_split', 0)}/{s.get('front_cand', 0)} / "
             f"{s.get('back_split', 0)}/{s.get('back_cand', 0)} "
             f"(sharer-frames {s.get('sharer_frames', 0)}, left {s.get('left', 0)})"
             if "front_cand" in s else "-")
        print(f"| {r['variant']} | {r['seed']} | {r['ped']}/{r['judged']} | "
              f"{r['ped']}/{r['walkers']} | {r['others_ped']} | {d} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
