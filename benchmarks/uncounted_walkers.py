"""The walkers counted in a saved counting run (`benchmarks/count_dump.py`) against the truth, and
the walkers no counted track follows although a track does: per run, how the tracks that follow
them were judged (verdict, reason, too fast). A track follows the walker its boxes overlap with
IoU >= 0.3 in at least half its frames (`eval_count.owner_of_tracks`); for those judged
"no-peak", the medians of their rows, the fraction of them predicted and the fraction without
I(k). Issue 16, twenty-third round (docs/rules.md).

    python benchmarks/uncounted_walkers.py RUN.pkl [RUN2.pkl ...]

Nothing is chosen here: it measures.
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
from collections import Counter

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def uncounted(record: dict, owner_of=None) -> Counter:
    """(verdict, reason, "too fast" or "") of every uncounted track that follows a walker no
    counted track follows, counted over one clip's record. `owner_of(record)` gives each track's
    walker id or None (default `eval_count.owner_of_tracks` on the record's truth and boxes)."""
    if owner_of is None:
        from eval_count import owner_of_tracks

        def owner_of(r):
            return owner_of_tracks(r["truth"], r["mot"], r["offset"])

    own, v, kinds = owner_of(record), record["verdicts"], record["kinds"]
    rows = list(zip((int(t) for t in v["track_id"]), v["verdict"], v["reason"], v["counted"],
                    v["too_fast"]))
    followed = {own.get(t) for t, *_, c, _ in rows if c}
    out: Counter = Counter()
    for t, verdict, reason, c, fast in rows:
        o = own.get(t)
        if c or o is None or kinds.get(o) != "pedestrian" or o in followed:
            continue
        out[(str(verdict), str(reason), "too fast" if fast else "")] += 1
    return out


def no_peak_rows(record: dict, owner_of=None) -> list[tuple[int, float, float]]:
    """(rows, fraction predicted, fraction with NaN I(k)) of every uncounted "no-peak" track on
    a walker no counted track follows (as `uncounted`), from the record's tracks."""
    if owner_of is None:
        from eval_count import owner_of_tracks

        def owner_of(r):
            return owner_of_tracks(r["truth"], r["mot"], r["offset"])

    own, v, kinds, tr = owner_of(record), record["verdicts"], record["kinds"], record["tracks"]
    followed = {own.get(int(t)) for t, c in zip(v["track_id"], v["counted"]) if c}
    ids, state = np.asarray(tr["track_id"]), np.asarray(tr["state"])
    inten = np.asarray(tr["intensity"], np.float64)
    out = []
    for t, reason, c in zip(v["track_id"], v["reason"], v["counted"]):
        o = own.get(int(t))
        if c or reason != "no-peak" or o is None or kinds.get(o) != "pedestrian" or o in followed:
            continue
        k = ids == t
        out.append((int(k.sum()), float(np.mean(state[k] == "predict")),
                    float(np.mean(np.isnan(inten[k])))))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+")
    a = ap.parse_args(argv)
    for path in a.runs:
        with open(path, "rb") as f:
            records = pickle.load(f)
        total = sum((uncounted(r) for r in records), Counter())
        counted = sum(int(np.sum(r["verdicts"]["counted"])) for r in records)
        print(f"{path}: {len(records)} clips, {counted} counted for "
              f"{sum(r['true'] for r in records)} walkers; uncounted tracks on walkers no "
              f"counted track follows: {dict(sorted(total.items()))}")
        rows = [x for r in records for x in no_peak_rows(r)]
        if rows:
            n, pred, nan = np.median(np.asarray(rows, np.float64), axis=0)
            print(f"  no-peak: {len(rows)} tracks, medians {n:.0f} rows, {pred:.2f} predicted, "
                  f"{nan:.2f} without I(k)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
