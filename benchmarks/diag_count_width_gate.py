"""Two rules on unjudged tracks, re-applied offline to counting runs saved by
`benchmarks/count_dump.py` (same tracks with the rule off, the run's own `counted`, and on):

- `--rule width`: an unclassified track is counted only when its median measured width at the
  foot point (verdicts `width_m`) lies inside the paper's width gate (10), |w - mean| <=
  k_sigma1 std (verdicts `width_ok`, already in every count's verdicts.csv);
- `--rule slow`: an unclassified track is not counted when its ground speed (verdicts
  `track_speed_mps`) is below the slowest the walking model's test (14) accepts for any rhythm,
  (pace_mean - k_sigma3 pace_std) x (stride_mean - k_sigma3 stride_std) with the default config's
  Table 1 (0.675 m/s; every counting source here uses Table 1): the mirror of the too-fast cut.

Per dump file: walkers counted / true, per-clip
|errors| summed, counted tracks on a non-walker and on no truth object; with several files the
paired-bootstrap change over their clips pooled (`paired_count.paired_change`).

    python benchmarks/diag_count_width_gate.py RUN.pkl [RUN.pkl ...] [--rule width|slow] \
        [--detail] [--json OUT]

--detail lists each unjudged counted track the rule removes, with the truth object it follows
(`eval_count.owner_of_tracks`: none, a walker another counted track holds, or a walker it alone
holds). Nothing is chosen here: it measures.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from eval_count import owner_of_tracks  # noqa: E402
from paired_count import line, paired_change  # noqa: E402


def walking_bottom_speed() -> float:
    """The slowest ground speed (m/s) (14) accepts with the default config's walking model."""
    from rhythmjax.model.params import config_from_dict

    cfg = config_from_dict({})
    w, k = cfg.walking, float(cfg.thresholds.k_sigma3)
    return (float(w.pace_mean) - k * float(w.pace_std)) * \
        (float(w.stride_mean) - k * float(w.stride_std))


RULE = "width"


def counted_with_gate(verdicts: dict) -> np.ndarray:
    """The run's counted tracks less the unclassified ones the rule (`RULE`) refuses."""
    v = np.asarray([str(x) for x in verdicts["verdict"]], dtype=object)
    c = np.asarray(verdicts["counted"], bool)
    if RULE == "width":
        keep = np.asarray(verdicts["width_ok"], bool)
    else:  # NaN speeds (spans under 0.5 s) stay counted, as with the too-fast cut
        keep = ~(np.asarray(verdicts["track_speed_mps"], np.float64) < walking_bottom_speed())
    return c & ((v != "unclassified") | keep)


def clip_errors(row: dict, c: np.ndarray) -> tuple[int, int, int]:
    """(|counted - true|, counted tracks on a non-walker, counted tracks on nothing)."""
    own = owner_of_tracks(row["truth"], row["mot"], row["offset"])
    ids = [int(i) for i in row["verdicts"]["track_id"]]
    other = sum(1 for i, ci in zip(ids, c) if ci and own.get(i) is not None
                and row["kinds"].get(own.get(i)) != "pedestrian")
    nobody = sum(1 for i, ci in zip(ids, c) if ci and own.get(i) is None)
    return abs(int(c.sum()) - int(row["true"])), other, nobody


def removed(row: dict) -> list[str]:
    """What each track the rule removes was on."""
    v = row["verdicts"]
    ids = [int(i) for i in v["track_id"]]
    off, on = np.asarray(v["counted"], bool), counted_with_gate(v)
    own = owner_of_tracks(row["truth"], row["mot"], row["offset"])
    out = []
    for k in np.flatnonzero(off & ~on):
        i, o = ids[k], own.get(ids[k])
        if o is None:
            what = "no truth object"
        elif row["kinds"].get(o) != "pedestrian":
            what = f"a {row['kinds'].get(o)} ({o})"
        else:
            held = any(on[j] and own.get(ids[j]) == o for j in range(len(ids)))
            what = f"walker {o}, " + ("also held by a counted track" if held else "its only one")
        out.append(f"{row['clip']}: track {i} width {float(v['width_m'][k]):.2f} m, speed "
                   f"{float(v['track_speed_mps'][k]):.2f} m/s: {what}")
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+")
    p.add_argument("--rule", choices=("width", "slow"), default="width")
    p.add_argument("--detail", action="store_true")
    p.add_argument("--json")
    a = p.parse_args(argv)
    global RULE
    RULE = a.rule
    cols: dict[str, list] = {k: [] for k in ("true", "err_a", "err_b", "oth_a", "oth_b")}
    out = {}
    print("| run | clips | before | after | change [95 %] | clips better / worse | others |")
    print("|---|---|---|---|---|---|---|")
    for name in a.runs:
        with open(name, "rb") as f:
            rows = pickle.load(f)
        mine: dict[str, list] = {k: [] for k in cols}
        nobody = [0, 0]
        for r in rows:
            ea, oa, na = clip_errors(r, np.asarray(r["verdicts"]["counted"], bool))
            eb, ob, nb = clip_errors(r, counted_with_gate(r["verdicts"]))
            for k, x in zip(("true", "err_a", "err_b", "oth_a", "oth_b"),
                            (r["true"], ea, eb, oa, ob)):
                mine[k].append(x)
            nobody[0] += na
            nobody[1] += nb
            if a.detail:
                for s in removed(r):
                    print("   ", s)
        res = paired_change({k: np.asarray(v, np.float64) for k, v in mine.items()})
        res["nobody_before"], res["nobody_after"] = nobody
        out[name] = res
        print(line(os.path.basename(name), res) + f" on nothing {nobody[0]} -> {nobody[1]}")
        for k in cols:
            cols[k] += mine[k]
    if len(a.runs) > 1:
        out["pooled"] = paired_change({k: np.asarray(v, np.float64) for k, v in cols.items()})
        print(line("pooled", out["pooled"]))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
