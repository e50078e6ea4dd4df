"""Replaying a stored track's rhythm windows, and the rules `study_false_positives.py` tries on
them (issue 16; a study's helper, not the library).

`replay` re-judges every rhythm window of a tracked object as `rhythmjax.track.toolkit.
match_window` does: N rows, one window every hop, windows with more than a quarter of their
samples missing skipped, each window judged once per candidate window B and the strongest peak
kept (`rhythmjax.model.candidates.judged`, the windows moved across deciding only where they say
Pedestrian; without the tracker's second look), the first Pedestrian window deciding. A rule
(`RULES`) is a post hoc test on a Pedestrian window: False refuses it.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from rhythmjax.model.candidates import judged, trend_min_hz
from rhythmjax.model.rhythm import (
    MAX_MISSING_FRACTION,
    classify_window_candidates_jit,
    classify_window_jit,
)
from rhythmjax.model.status import TrackState, Verdict


FIELDS = ("verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps", "peak_freq",
          "peak_power", "peak_mask")


def _outcome(res) -> dict:
    return {k: np.asarray(getattr(res, k)) for k in FIELDS}


def filled(x: np.ndarray) -> np.ndarray:
    """x with its NaN entries linearly interpolated as `rhythm.fill_gaps` does (ends held at
    the nearest known value); x itself when none is known."""
    known = np.isfinite(x)
    if known.all() or not known.any():
        return x
    i = np.arange(len(x))
    return np.where(known, x, np.interp(i, i[known], x[known]))


def judge(cfg, obj, k: int, candidates: bool = True,
          fill: bool = False) -> tuple[dict, int, list[dict]]:
    """The rhythm window of rows k..k+N-1 as `match_window` judges it: (merged outcome, the
    deciding candidate, every candidate's outcome). fill: every signal's missing samples are
    interpolated here (`filled`, the same values `rhythm.fill_gaps` gives the spectrum), so
    the classifier's own missing-fraction test (`MAX_MISSING_FRACTION`) passes: the window is
    judged as it would be with a larger fraction allowed."""
    n = cfg.thresholds.n
    w = obj.rows[k:k + n]
    t = np.asarray([r.t for r in w], np.float64)
    xy = jnp.asarray([(r.x_est, r.y_est) for r in w], jnp.float32)
    obs = jnp.asarray([(r.u, r.v) if r.state == TrackState.OBSERVE else (math.nan, math.nan)
                       for r in w], jnp.float32)
    tt = jnp.asarray(t - t[0], jnp.float32)
    sigs = [np.asarray([r.intensity for r in w], np.float64)]
    if candidates and obj.candidate_rows is not None:
        for c in range(len(obj.candidate_rows[k])):
            sigs.append(np.asarray([cr[c] for cr in obj.candidate_rows[k:k + n]], np.float64))
    if fill:
        sigs = [filled(x) for x in sigs]
    if len(sigs) == 1:
        outs = [_outcome(classify_window_jit(cfg, jnp.asarray(sigs[0], jnp.float32), tt, xy,
                                             jnp.asarray(True), obs))]
    else:  # as match_window: every candidate in one call
        every = _outcome(classify_window_candidates_jit(
            cfg, jnp.asarray(np.stack(sigs), jnp.float32), tt, xy, jnp.asarray(True), obs))
        outs = [{f: v[c] for f, v in every.items()} for c in range(len(sigs))]
    many = len(sigs) > 1  # rule 50b's windows moved across and rule 34's pace window, as there
    merged, best = judged([{f: v[None] for f, v in r.items()} for r in outs],
                          across=getattr(obj, "across", 0) if many else 0,
                          pace_last=getattr(obj, "pace_window", False) and many,
                          min_hz=trend_min_hz(cfg))
    return {f: np.asarray(merged[f][0]) for f in FIELDS}, int(best[0]), outs


def replay(cfg, obj, *, candidates: bool = True, rule=None, stop: bool = True,
           max_missing: float = MAX_MISSING_FRACTION) -> list[dict]:
    """Every rhythm window `match_window` judges on the stored rows (with `stop`, up to the
    first Pedestrian one), each {k, out, cand, outs, ped}; `rule(window, obj, k)` (True: keep a
    Pedestrian verdict) applies a post-hoc rule to each Pedestrian window. max_missing: the
    largest fraction of a window's N samples that may be missing (NaN) for it to be judged
    (the library's `MAX_MISSING_FRACTION`, 0.25, by default); a window with more than
    `MAX_MISSING_FRACTION` but at most max_missing missing is judged on its interpolated
    signals (`judge` with fill)."""
    n, hop, rows = cfg.thresholds.n, cfg.thresholds.hop_samples, obj.rows
    intens = np.asarray([r.intensity for r in rows], np.float64)
    res, k = [], 0
    while k + n <= len(rows):
        missing = np.flatnonzero(~np.isfinite(intens[k:k + n]))
        if len(missing) > max_missing * n:
            k = k + int(missing[-1]) + 1
            continue
        fill = len(missing) > MAX_MISSING_FRACTION * n
        out, cand, outs = judge(cfg, obj, k, candidates, fill)
        ped = int(out["verdict"]) == Verdict.PEDESTRIAN
        w = {"k": k, "out": out, "cand": cand, "outs": outs, "ped": ped}
        if ped and rule is not None:
            w["ped"] = ped = bool(rule(w, obj, k))
        res.append(w)
        if ped and stop:
            break
        k += hop
    if not res and len(rows) >= n:  # `final`: the N rows with the fewest missing
        bad = np.concatenate([[0], np.cumsum(~np.isfinite(intens))])
        k = int(np.argmin(bad[n:] - bad[:-n]))
        few = MAX_MISSING_FRACTION * n < bad[k + n] - bad[k] <= max_missing * n
        out, cand, outs = judge(cfg, obj, k, candidates, bool(few))
        ped = int(out["verdict"]) == Verdict.PEDESTRIAN
        w = {"k": k, "out": out, "cand": cand, "outs": outs, "ped": ped}
        if ped and rule is not None:
            w["ped"] = bool(rule(w, obj, k))
        res.append(w)
    return res


def deciding(res: list[dict]) -> dict | None:
    """The deciding window of a replay: the first Pedestrian one, else the first."""
    for w in res:
        if w["ped"]:
            return w
    return res[0] if res else None


def half_ratio(out) -> float:
    """Power of the strongest peak within 10 % of 2F over the matched peak's power (F the
    window's pace; `rhythm.half_pace`'s measure)."""
    f, p, m = (np.asarray(out[k]) for k in ("peak_freq", "peak_power", "peak_mask"))
    F = float(out["pace_hz"])
    if not math.isfinite(F):
        return math.nan
    i = int(np.argmin(np.where(m, np.abs(f - F), np.inf)))
    near = m & (np.abs(f - 2 * F) <= 0.2 * F)
    return float(np.max(np.where(near, p, 0.0)) / p[i]) if p[i] > 0 else math.nan


def peaks_text(out, top: int = 4) -> str:
    f, p, m = (np.asarray(out[k]) for k in ("peak_freq", "peak_power", "peak_mask"))
    return " ".join(f"{fi:.2f}:{pi:.0f}" for fi, pi, mi in list(zip(f, p, m))[:top] if mi)


# ----------------------------------------------------------------------------------------------
# the false positives



def _half_at(out, F: float) -> float:
    """power near 2F (within 0.2 F) / power of the peak nearest F (within 0.1 F) of one
    candidate's outcome; 0 where it has no peak near F."""
    f, p, m = (np.asarray(out[k]) for k in ("peak_freq", "peak_power", "peak_mask"))
    near_f = m & (np.abs(f - F) <= 0.1 * F)
    if not near_f.any():
        return 0.0
    pf = float(np.max(np.where(near_f, p, 0.0)))
    p2 = float(np.max(np.where(m & (np.abs(f - 2 * F) <= 0.2 * F), p, 0.0)))
    return p2 / pf if pf > 0 else 0.0


def _half_any(v):
    """the half-pace test at ratio v on every candidate window's spectrum: a Pedestrian window
    (pace F) is refused when the peak near F of any candidate window B, the paper's included,
    has a peak near 2F holding >= v of its power (post hoc: the window is refused, no other
    peak is tried)"""
    return lambda w, obj, k: not any(_half_at(o, float(w["out"]["pace_hz"])) >= v
                                     for o in w["outs"])


def _half0(v):
    """the same on the paper's window B (candidate 0) only"""
    return lambda w, obj, k: not (_half_at(w["outs"][0], float(w["out"]["pace_hz"])) >= v)


def _min_speed(v):
    return lambda w, obj, k: float(w["out"]["speed_mps"]) >= v


def _min_ratio(v):
    return lambda w, obj, k: float(w["out"]["ratio"]) > v


RULES = {"half_any": _half_any, "half0": _half0, "min_speed": _min_speed,
         "min_ratio": _min_ratio}
