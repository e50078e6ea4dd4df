"""Paired comparison of two counting runs saved by `benchmarks/count_dump.py` on the same clips
(before: one setting, after: another, e.g. `--set blobs.bg_init_s=3`): per pair of dumps and
pooled, the per-clip |errors| summed before and after, their change with a 95 % paired
bootstrap interval over clips (`paired_count.paired_change`), the counted tracks on non-walkers
and on no truth object (`eval_count.owner_of_tracks`).

    python benchmarks/paired_dumps.py BEFORE.pkl AFTER.pkl [BEFORE2.pkl AFTER2.pkl ...]

Nothing is chosen here: it measures.
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from diag_count_width_gate import clip_errors  # noqa: E402
from paired_count import line, paired_change  # noqa: E402


def paired_columns(before: list, after: list, label: str) -> tuple[dict, list[int]]:
    """Per clip: true walkers, |errors| and non-walkers counted before and after; and the
    counted tracks on no truth object before and after. Clips must match by name."""
    if [r["clip"] for r in before] != [r["clip"] for r in after]:
        raise SystemExit(f"{label}: the two runs hold different clips")
    cols: dict[str, list] = {k: [] for k in ("true", "err_a", "err_b", "oth_a", "oth_b")}
    nobody = [0, 0]
    for ra, rb in zip(before, after):
        ea, oa, na = clip_errors(ra, np.asarray(ra["verdicts"]["counted"], bool))
        eb, ob, nb = clip_errors(rb, np.asarray(rb["verdicts"]["counted"], bool))
        for k, x in zip(cols, (ra["true"], ea, eb, oa, ob)):
            cols[k].append(x)
        nobody[0] += na
        nobody[1] += nb
    return {k: np.asarray(v, np.float64) for k, v in cols.items()}, nobody


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+", help="before/after pairs of count_dump.py files")
    a = p.parse_args(argv)
    if len(a.runs) % 2:
        print("give the dumps in before/after pairs", file=sys.stderr)
        return 2
    pooled = []
    print("| pair | clips | before | after | change [95 %] | clips better / worse | others |")
    print("|---|---|---|---|---|---|---|")
    for i in range(0, len(a.runs), 2):
        runs = []
        for name in a.runs[i:i + 2]:
            with open(name, "rb") as f:
                runs.append(pickle.load(f))
        cols, nobody = paired_columns(runs[0], runs[1], a.runs[i])
        pooled.append(cols)
        print(line(os.path.basename(a.runs[i + 1]), paired_change(cols))
              + f" on nothing {nobody[0]} -> {nobody[1]}")
    if len(pooled) > 1:
        cols = {k: np.concatenate([c[k] for c in pooled]) for k in pooled[0]}
        print(line("pooled", paired_change(cols)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
