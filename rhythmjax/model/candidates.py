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

Rule 38b (`thresholds.trend_max_cycles` > 0, `trend_min_hz`): a peak that completes fewer
than that many cycles over the window is a trend, not a periodicity. Where the paper's choice
is a window that is not Pedestrian and whose strongest peak is such a trend (a walker's image
growing as it comes nearer), the candidates are compared again without the trend peaks, so that
a candidate that holds the gait can win.

Rule 50b (`across` > 0: the last candidates are window B moved across its row, `io.files.
ACROSS_CANDIDATES`): those decide a window only where the strongest of all the candidates is
one of them and says Pedestrian; rule 37's second look (a refused window read at half its
pace) is not taken on them, rule 26's height test is. Every other window is judged on the
candidates before them, then the second look: `judged`, shared by every classifier.

Measured before it was built (docs/window_b.md, "candidate windows"): walkers with a Pedestrian
window, today -> candidates, own seeds +1, +1, 0, 0; dev clips +2; PETS09 through the tracker +1;
one dog more on one own training seed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from .params import Config
from .status import Verdict


def trend_min_hz(cfg: Config) -> float:
    """The lowest frequency (Hz) `strongest` compares: `thresholds.trend_cycles` cycles over a
    window of N samples at the camera's frame rate (rule 38b); 0 (every peak) when off."""
    t = cfg.thresholds
    return float(t.trend_cycles) * float(cfg.camera.fps) / t.n if t.trend_cycles else 0.0


def strongest_power(result: Mapping[str, np.ndarray], min_hz: float = 0.0) -> np.ndarray:
    """Per window (leading axis), the power of its strongest peak of (13) (`peak_power` where
    `peak_mask`) at `min_hz` Hz or above, 0 where the spectrum has no such peak."""
    power = np.asarray(result["peak_power"], np.float64)
    mask = np.asarray(result["peak_mask"], bool)
    if min_hz > 0:
        mask = mask & (np.asarray(result["peak_freq"], np.float64) >= min_hz)
    return np.max(np.where(mask, power, 0.0), axis=-1, initial=0.0)


def strongest(results: Sequence[Mapping[str, np.ndarray]], *,
              pace_last: bool = False, min_hz: float = 0.0) -> tuple[dict, np.ndarray]:
    """The per-window results of C candidates (dicts of NumPy arrays with a leading window axis,
    the same keys and shapes; `results[0]` the paper's window B) merged into one: per window the
    result of the candidate whose strongest peak is highest (the first such on ties, so the
    paper's window B wins a tie and a window without peaks keeps it). Returns the merged dict
    and the chosen candidate per window (int64, 0 = the paper's window). `pace_last`: the last
    result is the pace window's (module doc), not a candidate. `min_hz` > 0 (rule 38b,
    `trend_min_hz`): where the chosen candidate's window is not Pedestrian and its strongest
    peak lies below `min_hz` (a trend), the candidates are compared again with the peaks below
    `min_hz` left out (a window with none keeps window B); every other window keeps the paper's
    choice."""
    if pace_last:
        merged, best = strongest(results[:-1], min_hz=min_hz)
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
    stacked = {k: np.stack([np.asarray(r[k]) for r in results]) for k in results[0]}
    if min_hz > 0:  # rule 38b: a refused window chosen for a trend is chosen again without it
        chosen = {k: v[best, cols] for k, v in stacked.items()}
        freq = np.asarray(chosen["peak_freq"], np.float64)
        top = np.argmax(np.where(chosen["peak_mask"], chosen["peak_power"], -np.inf), axis=-1)
        trend = (np.any(chosen["peak_mask"], axis=-1) & (freq[cols, top] < min_hz)
                 & (np.asarray(chosen["verdict"]) != Verdict.PEDESTRIAN))
        again = np.argmax(np.stack([strongest_power(r, min_hz) for r in results]), axis=0)
        best = np.where(trend, again, best)
    merged = {k: v[best, cols] for k, v in stacked.items()}
    return merged, best.astype(np.int64)


def judged(results: Sequence[Mapping[str, np.ndarray]], look=None, *, across: int = 0,
           pace_last: bool = False, min_hz: float = 0.0) -> tuple[dict, np.ndarray]:
    """`strongest` of the candidates' results, then the second look `look` (res, twice=True)
    -> res (rules 37 then 26 on each window; `twice` False: rule 26 only; None: no look).
    `across` > 0 (rule 50b, module doc): the last `across` candidates (before the pace window's
    result where `pace_last`) are the windows moved across; a window whose strongest candidate
    is one of them and says Pedestrian keeps it (looked at with twice False), every other is
    judged on the candidates before them. Returns the merged dict and the chosen candidate per
    window, as `strongest`."""
    pace = list(results[-1:]) if pace_last else []
    n_cands = len(results) - len(pace)
    inner = list(results[:n_cands - across]) + pace
    merged, best = strongest(inner, pace_last=pace_last, min_hz=min_hz)
    if look is not None:
        merged = look(merged)
    if not across:
        return merged, best
    every, best_all = strongest(results, pace_last=pace_last, min_hz=min_hz)
    take = (best_all >= n_cands - across) & (np.asarray(every["verdict"]) == Verdict.PEDESTRIAN)
    if not take.any():
        return merged, best
    if look is not None:
        every = look(every, twice=False)
    out = {}
    for k, v in merged.items():
        v, w = np.asarray(v), np.asarray(every[k])
        out[k] = np.where(take.reshape(take.shape + (1,) * (v.ndim - 1)), w, v)
    return out, np.where(take, best_all, best).astype(np.int64)
