"""Where a track judged Pedestrian went on with something else (rules 29 and 30a, issue 16;
`options.RecheckOptions`, on by default).

Once a rhythm window has said Pedestrian the tracker stops judging windows (Sec. 4.2), so a
track that then follows a bicycle or a dog passing its walker (after a PREDICT stretch, a
crossing or a re-acquisition) carries the walker's verdict onto it. At the end, the windows of
N rows after the deciding one (starting at its end, one every `thresholds.hop_samples` rows,
judged by (13)-(15) exactly as online: `toolkit.match_window`, with the object's
`second_look`, rule 37, where it has one) are read until one is not a
walker's (`not_a_walk`): its measured speed (12) exceeds the fastest walk the walking model
(14) accepts for any rhythm (`params.walking_top_speed`, 2.57 m/s with Table 1), or it has a
peak above P_thr (13) at a pace above the model's fastest (`params.walking_top_pace`, 2.60 Hz).
Both limits are the paper's own model at +k_sigma3; nothing is fitted. The track is cut at
that window's first row (`switch_row`); the rows before keep the verdict, the tracker judges
the rows from it afresh as a new track.

Rule 30a (`RecheckOptions.tail`, on) judges with the same test the window of the track's last N
rows where the windows above leave rows unjudged (a switch less than N rows before the end), cut
at its first row or the deciding window's end, whichever is later. Rule 30's other half
(`RecheckOptions.earlier` "any", off: it cut walkers' tracks on PETS09 at 7 fps, docs/rules.md)
judges the windows before the deciding one (a bicycle's or a dog's rows before the walker's,
`earlier_switch_row`), cut at the deciding window's first row; rule 30b ("speed") the same by
the speed test alone."""

from __future__ import annotations

import copy
import math

from ..model.params import Config, walking_top_pace, walking_top_speed
from ..model.status import Reason, Verdict
from .toolkit import RhythmWindows, match_window


__all__ = ["earlier_switch_row", "earlier_windows", "keep_rows", "later_windows", "not_a_walk",
           "switch_row"]


def not_a_walk(result: dict, top_speed: float, top_pace: float) -> bool:
    """True where a window's outcome (`toolkit.RESULT_FIELDS`) is not a walker's: its speed
    (m/s) is above `top_speed`, or it found a peak (reason other than no-peak) whose pace (Hz)
    is above `top_pace`."""
    speed, pace = float(result["speed_mps"]), float(result["pace_hz"])
    if math.isfinite(speed) and speed > top_speed:
        return True
    peak = int(result["reason"]) != Reason.NO_PEAK
    return peak and math.isfinite(pace) and pace > top_pace


def _judged(cfg: Config, obj: RhythmWindows, start: int) -> tuple[dict | None, int]:
    """(outcome, next first row) of `obj`'s window from row `start` (`match_window` on a copy):
    outcome None where the window is skipped for missing samples or runs past the track, the
    next first row `start` + `thresholds.hop_samples`, or past the last missing sample."""
    probe = copy.copy(obj)
    probe.win_start, probe.result, probe.decided = start, None, False
    match_window(cfg, probe)
    return probe.result, probe.win_start


def later_windows(cfg: Config, obj: RhythmWindows, *, tail: bool = False):
    """Each window after `obj`'s deciding window (its result["window"]) judged as online
    (`match_window`: N rows, one every `thresholds.hop_samples` from the deciding window's end,
    windows with too many missing samples skipped): yields each outcome (`RESULT_FIELDS` plus
    "window"); nothing where `obj` names no deciding window. tail (rule 30a): where these leave
    the track's last rows unjudged, the window of its last N rows follows (it may overlap the
    deciding window). `obj` is not changed (copies are judged)."""
    if obj.result is None or "window" not in obj.result:
        return
    n, end = cfg.thresholds.n, len(obj.rows)
    start = covered = int(obj.result["window"][1])
    while start + n <= end:
        result, after = _judged(cfg, obj, start)
        if result is not None:
            covered = int(result["window"][1])
            yield result
        if after == start:
            break
        start = after
    if tail and covered < end:
        result, _ = _judged(cfg, obj, end - n)
        if result is not None:
            yield result


def earlier_windows(cfg: Config, obj: RhythmWindows):
    """Each window before `obj`'s deciding one judged as online (from row 0, one every
    `thresholds.hop_samples`, skipped as `match_window` skips; first row before the deciding
    window's): yields each outcome with its "window". Nothing where no deciding window."""
    if obj.result is None or "window" not in obj.result:
        return
    first, start = int(obj.result["window"][0]), 0
    while start < first:
        result, after = _judged(cfg, obj, start)
        if result is not None:
            yield result
        if after == start:
            return
        start = after


def _pedestrian(obj: RhythmWindows) -> bool:
    return (obj.result is not None and "window" in obj.result
            and int(obj.result["verdict"]) == Verdict.PEDESTRIAN)


def switch_row(cfg: Config, obj: RhythmWindows, *, tail: bool = False) -> int | None:
    """The first row of the first of `later_windows` that `not_a_walk` refuses (the deciding
    window's end where that window starts inside it: `tail`); None where the track is not
    judged Pedestrian or no later window is refused."""
    if not _pedestrian(obj):
        return None
    top_speed, top_pace = walking_top_speed(cfg), walking_top_pace(cfg)
    decided_end = int(obj.result["window"][1])
    for result in later_windows(cfg, obj, tail=tail):
        if not_a_walk(result, top_speed, top_pace):
            return max(int(result["window"][0]), decided_end)
    return None


def earlier_switch_row(cfg: Config, obj: RhythmWindows, *, pace: bool = True) -> int | None:
    """Rule 30: the deciding window's first row where one of `earlier_windows` is refused by
    `not_a_walk` (the rows before it followed something else; pace False, rule 30b: by its
    speed alone); None where the track is not judged Pedestrian, its deciding window starts at
    row 0, or no earlier window is refused."""
    if not _pedestrian(obj):
        return None
    top_speed, top_pace = walking_top_speed(cfg), walking_top_pace(cfg) if pace else math.inf
    if any(not_a_walk(r, top_speed, top_pace) for r in earlier_windows(cfg, obj)):
        return int(obj.result["window"][0])
    return None


def keep_rows(obj, rows: slice) -> None:
    """Keep only `rows` (a slice with a step of 1) of `obj`'s per-row lists (`rows`, `vel`,
    `candidate_rows` where not None) and shift its deciding window (result["window"]) by the
    rows dropped before them: the window must lie inside `rows`."""
    first = rows.start or 0
    obj.rows, obj.vel = obj.rows[rows], obj.vel[rows]
    if getattr(obj, "candidate_rows", None) is not None:
        obj.candidate_rows = obj.candidate_rows[rows]
    if obj.result is not None and "window" in obj.result:
        a, b = obj.result["window"]
        if not (first <= a and b - first <= len(obj.rows)):
            raise ValueError(f"track {getattr(obj, 'track_id', '?')}: its deciding window "
                             f"{(a, b)} is not inside the rows kept {rows}")
        obj.result = dict(obj.result, window=(a - first, b - first))
