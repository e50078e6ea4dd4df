"""Where a track judged Pedestrian went on with something else (rule 29, issue 16;
`options.RecheckOptions`, on by default).

Once a rhythm window has said Pedestrian the tracker stops judging windows (Sec. 4.2), so a
track that then follows a bicycle or a dog passing its walker (after a PREDICT stretch, a
crossing or a re-acquisition) carries the walker's verdict onto it. At the end, the windows of
N rows after the deciding one (starting at its end, one every `thresholds.hop_samples` rows,
judged by (13)-(15) exactly as online: `toolkit.match_window`) are read until one is not a
walker's (`not_a_walk`): its measured speed (12) exceeds the fastest walk the walking model
(14) accepts for any rhythm (`params.walking_top_speed`, 2.57 m/s with Table 1), or it has a
peak above P_thr (13) at a pace above the model's fastest (`params.walking_top_pace`, 2.60 Hz).
Both limits are the paper's own model at +k_sigma3; nothing is fitted. The track is cut at
that window's first row (`switch_row`); the rows before keep the verdict, the tracker judges
the rows from it afresh as a new track."""

from __future__ import annotations

import copy
import math

from ..model.params import Config, walking_top_pace, walking_top_speed
from ..model.status import Reason, Verdict
from .toolkit import RhythmWindows, match_window


__all__ = ["later_windows", "not_a_walk", "switch_row"]


def not_a_walk(result: dict, top_speed: float, top_pace: float) -> bool:
    """True where a window's outcome (`toolkit.RESULT_FIELDS`) is not a walker's: its speed
    (m/s) is above `top_speed`, or it found a peak (reason other than no-peak) whose pace (Hz)
    is above `top_pace`."""
    speed, pace = float(result["speed_mps"]), float(result["pace_hz"])
    if math.isfinite(speed) and speed > top_speed:
        return True
    peak = int(result["reason"]) != Reason.NO_PEAK
    return peak and math.isfinite(pace) and pace > top_pace


def later_windows(cfg: Config, obj: RhythmWindows):
    """Each window after `obj`'s deciding window (its result["window"]) judged as online
    (`match_window`: N rows, one every `thresholds.hop_samples` from the deciding window's end,
    windows with too many missing samples skipped): yields each outcome (`RESULT_FIELDS` plus
    "window"); nothing where `obj` names no deciding window. `obj` is not changed (a copy is
    judged)."""
    if obj.result is None or "window" not in obj.result:
        return
    probe = copy.copy(obj)
    probe.win_start, n = int(obj.result["window"][1]), cfg.thresholds.n
    while probe.win_start + n <= len(probe.rows):
        start = probe.win_start
        probe.result, probe.decided = None, False
        match_window(cfg, probe)
        if probe.result is not None:
            yield probe.result
        if probe.win_start == start:
            return


def switch_row(cfg: Config, obj: RhythmWindows) -> int | None:
    """The first row of the first of `later_windows` that `not_a_walk` refuses; None where the
    track is not judged Pedestrian or no later window is refused."""
    if obj.result is None or int(obj.result["verdict"]) != Verdict.PEDESTRIAN:
        return None
    top_speed, top_pace = walking_top_speed(cfg), walking_top_pace(cfg)
    for result in later_windows(cfg, obj):
        if not_a_walk(result, top_speed, top_pace):
            return int(result["window"][0])
    return None
