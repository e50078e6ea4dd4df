"""Judge a counting run saved by `benchmarks/count_dump.py` again with another classifier setting,
the tracks unchanged, and count it again: the counting tracker judges its tracks only once, at
the end, from its tracks table (`count.judge.judge_tracks`), so with `explain` off (the
default) this gives exactly what `count` would report with the setting. Writes a dump of the
same form (atomically) for `paired_dumps.py`. Issue 16, twenty-fourth round (docs/rules.md).

Settings (module constants of `model.rhythm`, read when the classifier is traced):
- `--detrend line`: each rhythm window's least-squares line removed before Burg (`DETREND`).
- `--gaps segments`: missing samples left out of Burg's sums (`GAPS`).
And `--width patch`: gate (10) reads an average walker's width, not the blob's (twenty-seventh
round: whether the width gate keeps long counting tracks unjudged).

    python benchmarks/reclassify_dumps.py RUN.pkl OUT.pkl --source count [--focal-px 500] \\
        --detrend line
    python benchmarks/reclassify_dumps.py DEV.pkl OUT.pkl --source dev_count --detrend line
    python benchmarks/paired_dumps.py RUN.pkl OUT.pkl

With no setting it judges with the library's and must give the saved verdicts (`--check`
fails otherwise). Nothing is chosen here.
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
import tempfile

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

JUDGED = ("verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps", "n_samples",
          "window_frame")  # the columns `judge_tracks` writes (and "candidate" with them)


def configs(source: str, focal_px: float = 0.0):
    """A function clip name -> the config `count_dump.py` ran that clip of `source` with."""
    if source == "count":
        import copy

        from rhythmjax.model.params import config_from_dict
        from rhythmjax.sim.presets import SYNTHETIC_CONFIG

        d = copy.deepcopy(SYNTHETIC_CONFIG)
        if focal_px > 0:
            d["camera"] = {"a_px_per_m": focal_px / 0.008, "b_px_per_m": focal_px / 0.008}
        cfg = config_from_dict(d)
        return lambda clip: cfg
    if source in ("dev_count", "pets"):
        from count_dump import clips_of

        by_clip = {name: cfg for name, cfg, *_ in clips_of(source, 0, 0)}
        return by_clip.__getitem__
    raise SystemExit(f"unknown source {source!r}: count, dev_count or pets")


def rejudged(record: dict, cfg, width: str = "measured") -> dict:
    """The record's verdicts with the judged columns from `judge_tracks` on its tracks and
    `counted` recomputed (`count.counting.counted`); every other column as saved. `width`
    "patch": the W_IMG of the width gate (10) is an average walker's at each measured row's foot
    point (the gate passes every row) instead of the blob's measured width."""
    from rhythmjax.count.counting import counted
    from rhythmjax.count.judge import judge_tracks

    v = dict(record["verdicts"])
    tracks = record["tracks"]
    if not len(v["track_id"]):
        return v
    if width == "patch":
        from rhythmjax.model.camera_np import upright_size

        tracks = dict(tracks)
        w = upright_size(cfg.camera, tracks["u"], tracks["v"], float(cfg.width.mean), 1.0)[0]
        tracks["width_px"] = np.where(np.isfinite(tracks["width_px"]), w, np.nan)
    new = judge_tracks(cfg, tracks, candidates="intensity_up20" in tracks)
    if not np.array_equal(new["track_id"], np.asarray(v["track_id"])):
        raise ValueError(f"clip {record['clip']}: the tracks' ids do not match the verdicts'")
    for k in JUDGED + (("candidate",) if "candidate" in new else ()):
        v[k] = new[k]
    v["counted"] = counted(v)
    return v


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run")
    ap.add_argument("out")
    ap.add_argument("--source", required=True, choices=("count", "dev_count", "pets"))
    ap.add_argument("--focal-px", type=float, default=0.0)
    ap.add_argument("--detrend", choices=("mean", "line"))
    ap.add_argument("--gaps", choices=("interpolate", "segments", "segments_taper"))
    ap.add_argument("--width", choices=("measured", "patch"), default="measured",
                    help="W_IMG of the width gate (10): the blob's measured width (the "
                         "default) or an average walker's at the foot point (the gate passes)")
    ap.add_argument("--check", action="store_true",
                    help="fail unless every verdict and count equals the saved one")
    a = ap.parse_args(argv)
    import rhythmjax.model.rhythm as rh

    rh.DETREND, rh.GAPS = a.detrend or rh.DETREND, a.gaps or rh.GAPS  # before the first trace
    with open(a.run, "rb") as f:
        records = pickle.load(f)
    config_of = configs(a.source, a.focal_px)
    before = after = changed = 0
    for r in records:
        v = rejudged(r, config_of(r["clip"]), a.width)
        old = r["verdicts"]
        diff = int(np.sum(np.asarray(v["verdict"]) != np.asarray(old["verdict"])))
        if a.check and (diff or not np.array_equal(v["counted"], old["counted"])):
            raise SystemExit(f"clip {r['clip']}: {diff} verdicts differ from the saved run")
        before += int(np.sum(old["counted"]))
        after += int(np.sum(v["counted"]))
        changed += diff
        r["verdicts"] = v
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(a.out)), suffix=".tmp")
    with os.fdopen(fd, "wb") as f:
        pickle.dump(records, f)
    os.replace(tmp, a.out)
    print(f"{a.run}: {len(records)} clips, {changed} verdicts changed, counted {before} -> "
          f"{after} (detrend {rh.DETREND}, gaps {rh.GAPS})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
