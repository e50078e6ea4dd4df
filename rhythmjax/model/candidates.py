"""Candidate windows B (issue 16, item 2): per rhythm window, the candidate with the strongest
periodicity.

The rhythm signal I(k) of Sec. 4.1 is summed in window B, W px wide and W/5 rows high, its
bottom row at the foot row. Where the foot point is a few px off the feet (a shadow, the ground
below them, camera shake), the window misses the legs and no spectral peak reaches P_thr. A
tracks file may therefore carry I(k) of window B moved by a fraction of W (`io.files.
WINDOW_CANDIDATES`); every classifier then judges each rhythm window once per candidate (the
paper's window B first) and keeps, per window, the candidate whose strongest peak of (13) is
highest: `strongest`. With no candidate columns nothing changes (the paper's window B alone).

The pace window (rule 34, `io.files.PACE_COLUMN`) is the last result where `pace_last`: it
never decides. Where the chosen window says Pedestrian and the pace window over the same rows
says Pedestrian too, the window's pace F (Hz) and stride T = D / (F N dt) (m, (14)) are the pace
window's; every other field (verdict, reason, ratio, speed, peaks) stays the chosen one's.
A walker crossing the view has its feet a step apart (0.6-0.9 m), more than W = 0.5 m: window B
sees one foot's swing at a time, the wide window both. Off by default: it read the own crossing
walkers' pace better and the dev clips' worse (docs/rules.md, rule 34).

Measured before it was built (docs/window_b.md, "candidate windows"): walkers with a Pedestrian
window, today -> candidates, own seeds +1, +1, 0, 0; dev clips +2; PETS09 through the tracker +1;
one dog more on one own training seed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from .status import Verdict


def strongest_power(result: Mapping[str, np.ndarray]) -> np.ndarray:
    """Per window (leading axis), the power of its strongest peak of (13) (`peak_power` where
    `peak_mask`), 0 where the spectrum has no peak."""
    power = np.asarray(result["peak_power"], np.float64)
    mask = np.asarray(result["peak_mask"], bool)
    return np.max(np.where(mask, power, 0.0), axis=-1, initial=0.0)


def strongest(results: Sequence[Mapping[str, np.ndarray]], *,
              pace_last: bool = False) -> tuple[dict, np.ndarray]:
    """The per-window results of C candidates (dicts of NumPy arrays with a leading window axis,
    the same keys and shapes; `results[0]` the paper's window B) merged into one: per window the
    result of the candidate whose strongest peak is highest (the first such on ties, so the
    paper's window B wins a tie and a window without peaks keeps it). Returns the merged dict
    and the chosen candidate per window (int64, 0 = the paper's window). `pace_last`: the last
    result is the pace window's (module doc), not a candidate."""
    if pace_last:
        merged, best = strongest(results[:-1])
        pace = results[-1]
        take = ((np.asarray(merged["verdict"]) == Verdict.PEDESTRIAN)
                & (np.asarray(pace["verdict"]) == Verdict.PEDESTRIAN))
        for k in ("pace_hz", "stride_m"):
            merged[k] = np.where(take, np.asarray(pace[k]), np.asarray(merged[k]))
        return merged, best
    if len(results) == 1:
        first = results[0]
        n = len(np.asarray(first["peak_power"]))
        return dict(first), np.zeros(n, np.int64)
    power = np.stack([strongest_power(r) for r in results])  # (C, W)
    best = np.argmax(power, axis=0)  # the first maximum: candidate 0 on ties
    cols = np.arange(power.shape[1])
    merged = {k: np.stack([np.asarray(r[k]) for r in results])[best, cols] for k in results[0]}
    return merged, best.astype(np.int64)
