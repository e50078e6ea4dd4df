"""Scores of counting runs saved by `benchmarks/count_dump.py`, for the noise-adaptive
foreground threshold's ON / OFF table (docs/rules.md, "Noise-adaptive foreground threshold").
Per run file (one source): walkers counted / true, per-clip |errors| summed over the true
walkers (%), counted tracks on a non-walker and on no truth object (`eval_count.owner_of_tracks`:
IoU >= 0.3 in most of the track's frames), true walkers no track owns ("no track"), and MOTA /
IDF1 (`evaluation.motscore.score_mot`, IoU >= 0.5, every truth box; mean over the clips).

    python benchmarks/count_dump.py count OFF.pkl --seed 42024
    python benchmarks/count_dump.py count ON.pkl --seed 42024 --set blobs.noise_k=3.89
    python benchmarks/eval_count_noise.py OFF.pkl ON.pkl [...]
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def score_run(rows: list) -> dict:
    """The summed scores of one run's clips (module doc)."""
    from eval_count import owner_of_tracks

    from rhythmjax.count import walker_ids
    from rhythmjax.evaluation.motscore import score_mot

    tot = {"true": 0, "counted": 0, "abs_err": 0, "nonwalker": 0, "nobody": 0, "no_track": 0}
    mota, idf1 = [], []
    for r in rows:
        truth, kinds, off = r["truth"], r["kinds"], r["offset"]
        walk = walker_ids(r["verdicts"])
        own = owner_of_tracks(truth, r["mot"], off)
        seen = set(np.asarray(truth["id"]).tolist())
        twalk = [t for t in seen if kinds.get(t) == "pedestrian"]
        s = score_mot(truth, r["mot"], frame_offset=off, walking_ids=walk,
                      truth_walking_ids=twalk)
        mota.append(s.mota)
        idf1.append(s.idf1)
        owned = {o for o in own.values() if o is not None}
        tot["true"] += r["true"]
        tot["counted"] += len(walk)
        tot["abs_err"] += abs(len(walk) - r["true"])
        tot["nonwalker"] += sum(1 for h in walk if own.get(h) and kinds[own[h]] != "pedestrian")
        tot["nobody"] += sum(1 for h in walk if own.get(h) is None)
        tot["no_track"] += sum(1 for t in twalk if t not in owned)
    tot["error_pct"] = 100.0 * tot["abs_err"] / max(1, tot["true"])
    tot["mota"], tot["idf1"] = float(np.mean(mota)), float(np.mean(idf1))
    return tot


def line(s: dict) -> str:
    return (f"{s['counted']}/{s['true']} ({s['error_pct']:.1f} %; {s['nonwalker']}, "
            f"{s['nobody']}; no track {s['no_track']}; {s['mota']:.3f}, {s['idf1']:.3f})")


def main(argv=None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("runs", nargs="+")
    a = p.parse_args(argv)
    print("run: counted/true (per-clip |errors| %; non-walkers counted, counted on nothing; "
          "walkers with no track; MOTA, IDF1)")
    for path in a.runs:
        with open(path, "rb") as f:
            rows = pickle.load(f)
        print(f"{os.path.basename(path)}: {line(score_run(rows))}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
