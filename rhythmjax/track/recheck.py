"""Where a track judged Pedestrian went on with something else (rules 29, 30a, 30d, 52; issue
16; `options.RecheckOptions`, on by default).

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

Rule 42 (`RecheckOptions.halves`, off) reads the halves of a window too: a half of N/2 rows
whose speed (12) exceeds the fastest walk makes the window no walker's (`toolkit.fast_half`). A
later or tail window so refused cuts the track at that half's first row (or the deciding window's
end, if later); a deciding window so refused (`mixed_window_row`: a walker and a bicycle in one
window, its Theil-Sen speed the walker's) cuts the track at its middle row, the verdict staying
with the slow half's side and the fast half's side judged afresh (`split_at_switches`).

Rule 30a (`RecheckOptions.tail`, on) judges with the same test the window of the track's last N
rows where the windows above leave rows unjudged (a switch less than N rows before the end), cut
at its first row or the deciding window's end, whichever is later. Rule 30's other half
(`RecheckOptions.earlier` "any", off: it cut walkers' tracks on PETS09 at 7 fps, docs/rules.md)
judges the windows before the deciding one (a bicycle's or a dog's rows before the walker's,
`earlier_switch_row`), cut at the deciding window's first row; rule 30b ("speed") the same by
the speed test alone; rule 30c ("resolved") rule 30's test where the frame rate resolves a
walker's second harmonic at the fastest pace (`pace_resolved`), else 30b's; rule 30d
("speed-low", the default since issue 16's forty-fourth round) by the speed test or rule 26's
height test (`low_window`, rule 43's): a bicycle's or a dog's rows, never the pace.

Rule 44 (`RecheckOptions.halves_around`, off) reads rule 42's halves in the windows before and
after the deciding one, never in the deciding one: a window before it with a half faster than
any walk cuts the track at the deciding window's first row (`earlier_switch_row`), a later or
tail window as rule 42's does (`switch_row`). A walker's track that followed a bicycle for less
than a window before or after its verdict: the whole window's Theil-Sen speed stays under the
bound, its bicycle half does not.

Rule 46 (`RecheckOptions.pace_tall`, on since issue 16's forty-seventh round) keeps a later
or tail window that the pace test alone refuses where its rows are as tall as a walker by rule
37's height test (`walker_tall`: 0.57 walker heights, fitted, over at least 10 rows): a walker
whose knees and rolling feet put its window's strongest peak at twice or three times its pace
(the own scenes' walkers since issue 16's thirty-eighth round; UCSD's walkers at 30 fps) is not
another object, while a dog at its trot (0.5-0.7 m) still is. The speed test is unchanged.

Rule 43 (`RecheckOptions.low`, off) gives every window the recheck reads rule 26's height test
as well (`low_window`: its rows' median height below `size.min_height_heights` walker heights,
`track.size.too_low`): a later or tail window so refused cuts as rule 29's; the windows before
the verdict are read by this test (with `earlier`'s where that is on), a refused one cutting at
the deciding window's first row (a dog's rows before its walker's).

Rule 52 (`RecheckOptions.fast_stretch`, a fraction of N) reads stretches of that many rows
after the deciding window (one every half stretch, and the track's last), cut at the first row
of the first whose filter's ground speed (its median over the stretch, `stretch_speed`) is above
the fastest walk (`fast_stretch_row`): a walker's track that a passing bicycle
took over for fewer than N rows at its end keeps, without it, the walker's verdict, since the
tail window's Theil-Sen speed (the median slope over N rows) is still the walker's.

Rule 47 (`RecheckOptions.median_pace`, off: the dev clips' pace read worse) reports a
Pedestrian track's pace F and stride T (`median_pace`) as the medians over its windows judged
Pedestrian: the deciding one and each of `later_windows` (with the tail window where `tail` is
on) that (13)-(15) judge Pedestrian. The verdict, its reason, ratio and speed stay the deciding
window's (Sec. 4.2). Rule 55 (`RecheckOptions.strongest_pace`, on; rule 47 takes its place
where that is on) reports instead the pace and stride of the one of those windows whose chosen
peak is the strongest (`chosen_peak_power`): a walker's first Pedestrian window is not always
its cleanest (another window or candidate may pass first, with its pace off)."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable

import numpy as np

from ..model.camera_np import camera_tuple
from ..model.params import Config, host_float, walking_top_pace, walking_top_speed
from ..model.status import Reason, Verdict
from .options import RecheckOptions, SizeOptions
from .size import rows_height, too_low
from .toolkit import RhythmWindows, fast_half, match_window
from .twice import rows_tall_enough


__all__ = ["chosen_peak_power", "earlier_switch_row", "earlier_windows", "fast_stretch_row",
           "keep_rows", "later_windows", "low_window", "median_pace", "mixed_window_row",
           "not_a_walk", "pace_resolved", "split_at_switches", "stretch_speed", "stretch_starts",
           "switch_row", "too_fast", "too_quick", "walker_tall"]


def not_a_walk(result: dict, top_speed: float, top_pace: float) -> bool:
    """True where a window's outcome (`toolkit.RESULT_FIELDS`) is not a walker's: its speed
    (m/s) is above `top_speed` (`too_fast`), or it found a peak (reason other than no-peak)
    whose pace (Hz) is above `top_pace` (`too_quick`)."""
    return too_fast(result, top_speed) or too_quick(result, top_pace)


def too_fast(result: dict, top_speed: float) -> bool:
    """Rule 29's speed test: the window's speed (12), m/s, is above `top_speed`."""
    speed = float(result["speed_mps"])
    return math.isfinite(speed) and speed > top_speed


def too_quick(result: dict, top_pace: float) -> bool:
    """Rule 29's pace test: the window found a peak (reason other than no-peak) whose pace, Hz,
    is above `top_pace`."""
    pace = float(result["pace_hz"])
    peak = int(result["reason"]) != Reason.NO_PEAK
    return peak and math.isfinite(pace) and pace > top_pace


def walker_tall(cfg: Config, rows, size: SizeOptions | None) -> bool:
    """Rule 46: True where `rows` (`TrackRow`s) are as tall as a walker by rule 37's test
    (`twice.rows_tall_enough`: at least `size.min_height_rows` rows read,
    their median at least `size.twice_pace_heights` walker heights, 0.57 x 1.7 m fitted; the
    rows at the image's first row read as lower bounds where `size.twice_pace_edge`); False
    where `size` is None or rule 37 is off."""
    if size is None or size.twice_pace_heights <= 0:
        return False
    return rows_tall_enough(rows, camera_tuple(cfg.camera), host_float(cfg.width.height), size)


def low_window(cfg: Config, rows, size: SizeOptions | None) -> bool:
    """Rule 43: True where rule 26 (`size.too_low`, its `size` options; None or
    `min_height_heights` 0: never) would refuse a Pedestrian window on `rows` (`TrackRow`s): the
    median height (`size.rows_height`, rule 36's rows) of its readable rows below
    `size.min_height_heights` x `width.height_m` over at least `size.min_height_rows` rows."""
    if size is None or size.min_height_heights <= 0:
        return False
    walker_m = host_float(cfg.width.height)
    height, n = rows_height(camera_tuple(cfg.camera), rows, walker_m, size.top_inside_heights)
    return too_low(Verdict.PEDESTRIAN, height, n, walker_m, size)


def mixed_window_row(cfg: Config, obj: RhythmWindows) -> int | None:
    """Rule 42: the first row of the half of `obj`'s deciding window that moves faster than any
    walk (`fast_half`), where `obj` is judged Pedestrian; else None."""
    if not _pedestrian(obj):
        return None
    k0, k1 = (int(k) for k in obj.result["window"])
    half = fast_half(cfg, obj.rows[k0:k1], walking_top_speed(cfg))
    return None if half is None else k0 + half


def pace_resolved(cfg: Config) -> bool:
    """Rule 30c: whether the frame rate resolves a walker's second harmonic at the fastest pace
    the walking model accepts (Nyquist fps / 2 above 2 x `walking_top_pace`, 5.2 Hz with Table
    1): 15 fps does, 7 or 10 fps does not (a walker's 2F aliases below Nyquist and its window
    can peak above the fastest pace)."""
    return float(cfg.camera.fps) / 2 > 2 * walking_top_pace(cfg)


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


def switch_row(cfg: Config, obj: RhythmWindows, *, tail: bool = False,
               halves: bool = False, low: SizeOptions | None = None,
               tall: SizeOptions | None = None) -> int | None:
    """The first row of the first of `later_windows` that `not_a_walk` refuses (the deciding
    window's end where that window starts inside it: `tail`); None where the track is not
    judged Pedestrian or no later window is refused. halves (rule 42): a window one of whose
    halves is faster than any walk (`fast_half`) is refused too, cut at that half's first row
    (the deciding window's end where that is later). low (rule 43): a window `low_window`
    refuses with these size options is refused too. tall (rule 46): a window the pace test
    alone refuses (`too_quick`, not `too_fast`) is kept where its rows are a walker's height
    (`walker_tall` with these size options): a walker read at a multiple of its pace."""
    if not _pedestrian(obj):
        return None
    top_speed, top_pace = walking_top_speed(cfg), walking_top_pace(cfg)
    decided_end = int(obj.result["window"][1])
    for result in later_windows(cfg, obj, tail=tail):
        a, b = (int(k) for k in result["window"])
        refused = too_fast(result, top_speed) or (
            too_quick(result, top_pace) and not walker_tall(cfg, obj.rows[a:b], tall))
        if refused or low_window(cfg, obj.rows[a:b], low):
            return max(a, decided_end)
        half = fast_half(cfg, obj.rows[a:b], top_speed) if halves else None
        if half is not None:
            return max(a + half, decided_end)
    return None


def stretch_starts(start: int, end: int, m: int) -> list[int]:
    """First rows of rule 52's stretches of `m` rows in rows start..end-1: one every m // 2
    rows from `start`, and the last m rows; none where fewer than m rows."""
    out = list(range(start, end - m + 1, max(1, m // 2)))
    if end - m >= start and (not out or out[-1] != end - m):
        out.append(end - m)
    return out


def stretch_speed(obj: RhythmWindows, start: int, m: int) -> float:
    """Rule 52's speed of rows start..start+m-1 of `obj`: the median over them of the filter's
    ground speed |(vx, vy)| (m/s, `obj.vel`; rows without a finite velocity left out, NaN where
    none has one). The filter's velocity, not the foot points' Theil-Sen slope (12): over 16
    rows a walker's foot points read up to 4.3 m/s on the own scenes, its filter 2.5 m/s at
    most (`benchmarks/study_tail_speed.py`)."""
    vel = np.asarray(obj.vel[start:start + m], np.float64).reshape(-1, 2)
    speed = np.hypot(vel[:, 0], vel[:, 1])
    speed = speed[np.isfinite(speed)]
    return float(np.median(speed)) if len(speed) else math.nan


def fast_stretch_row(cfg: Config, obj: RhythmWindows, fraction: float) -> int | None:
    """Rule 52: the first row of the first stretch of m = max(2, round(`fraction` N)) rows after
    `obj`'s deciding window (`stretch_starts` from its end) whose speed (`stretch_speed`)
    exceeds the fastest walk (14) accepts (`params.walking_top_speed`, 2.57 m/s with Table 1);
    None where `obj` is not judged Pedestrian, `fraction` is 0 or no stretch is that fast. A
    bicycle that took over a walker's track for fewer than N rows at its end moves at 3 m/s
    there, while the Theil-Sen speed of the tail window (rule 30a), the median slope over N
    rows, stays the walker's."""
    if fraction <= 0 or not _pedestrian(obj):
        return None
    m = max(2, round(fraction * cfg.thresholds.n))
    top = walking_top_speed(cfg)
    for k in stretch_starts(int(obj.result["window"][1]), len(obj.rows), m):
        speed = stretch_speed(obj, k, m)
        if math.isfinite(speed) and speed > top:
            return k
    return None


def earlier_switch_row(cfg: Config, obj: RhythmWindows, *, pace: bool = True,
                       speed: bool = True, low: SizeOptions | None = None,
                       halves: bool = False) -> int | None:
    """Rule 30: the deciding window's first row where one of `earlier_windows` is refused by
    `not_a_walk` (the rows before it followed something else; pace False, rule 30b: by its
    speed alone; speed and pace False: by neither), with `low` (rule 43) by `low_window`, or with
    `halves` (rule 44) by `fast_half`; None where the track is not judged Pedestrian, its
    deciding window starts at row 0, or no earlier window is refused."""
    if not _pedestrian(obj):
        return None
    fastest_walk = walking_top_speed(cfg)
    top_speed = fastest_walk if speed else math.inf
    top_pace = walking_top_pace(cfg) if pace and speed else math.inf
    for r in earlier_windows(cfg, obj):
        a, b = (int(k) for k in r["window"])
        if (not_a_walk(r, top_speed, top_pace) or low_window(cfg, obj.rows[a:b], low)
                or (halves and fast_half(cfg, obj.rows[a:b], fastest_walk) is not None)):
            return int(obj.result["window"][0])
    return None


def chosen_peak_power(result: dict) -> float:
    """P (relative to white noise, (13)) of the peak a window's outcome chose as its pace: the
    power of the reported peak (`peak_mask`) nearest its pace_hz; NaN where it has none."""
    freq, power = np.asarray(result["peak_freq"], float), np.asarray(result["peak_power"], float)
    mask = np.asarray(result["peak_mask"], bool) & np.isfinite(freq)
    pace = float(result["pace_hz"])
    if not (mask.any() and math.isfinite(pace)):
        return math.nan
    return float(power[mask][np.argmin(np.abs(freq[mask] - pace))])


def median_pace(cfg: Config, obj: RhythmWindows, opt: RecheckOptions) -> dict | None:
    """Rule 47 (`opt.median_pace`, with `opt.enabled`): `obj`'s result with pace_hz (F, Hz) and
    stride_m (T, m, (12)) the medians over its deciding window and each of its `later_windows`
    (`opt.tail`'s tail window too) judged Pedestrian. Rule 55 (`opt.strongest_pace`, where rule
    47 is off): pace and stride of the one of those windows whose chosen peak is the strongest
    (`chosen_peak_power`; the earliest of equals), whose rows and candidate it names
    (pace_window: (first row, end row); pace_candidate: 0 window B, c candidate c - 1). Every
    other field the deciding window's; the result unchanged where both are off or the track is
    not judged Pedestrian."""
    if not (opt.enabled and (opt.median_pace or opt.strongest_pace) and _pedestrian(obj)):
        return obj.result
    judged = [obj.result] + [r for r in later_windows(cfg, obj, tail=opt.tail)
                             if int(r["verdict"]) == Verdict.PEDESTRIAN]
    if opt.median_pace:
        paces = [float(r["pace_hz"]) for r in judged]
        strides = [float(r["stride_m"]) for r in judged]
        return dict(obj.result, pace_hz=float(np.median(paces)),
                    stride_m=float(np.median(strides)))
    powers = [chosen_peak_power(r) for r in judged]
    best = judged[int(np.argmax(np.where(np.isfinite(powers), powers, -np.inf)))]
    return dict(obj.result, pace_hz=float(best["pace_hz"]), stride_m=float(best["stride_m"]),
                pace_window=tuple(best["window"]), pace_candidate=int(best.get("candidate", 0)))


def keep_rows(obj, rows: slice) -> None:
    """Keep only `rows` (a slice with a step of 1) of `obj`'s per-row lists (`rows`, `vel`,
    `candidate_rows` and `mean_rows` where not None) and shift its deciding window
    (result["window"]) by the rows dropped before them: the window must lie inside `rows`."""
    first = rows.start or 0
    obj.rows, obj.vel = obj.rows[rows], obj.vel[rows]
    if getattr(obj, "candidate_rows", None) is not None:
        obj.candidate_rows = obj.candidate_rows[rows]
    if getattr(obj, "mean_rows", None) is not None:
        obj.mean_rows = obj.mean_rows[rows]
    if obj.result is not None and "window" in obj.result:
        a, b = obj.result["window"]
        if not (first <= a and b - first <= len(obj.rows)):
            raise ValueError(f"track {getattr(obj, 'track_id', '?')}: its deciding window "
                             f"{(a, b)} is not inside the rows kept {rows}")
        obj.result = dict(obj.result, window=(a - first, b - first))


def split_at_switches(cfg: Config, obj: RhythmWindows, opt: RecheckOptions,
                      judge_afresh: Callable[[RhythmWindows, slice], None],
                      size: SizeOptions | None = None) -> None:
    """The end of a track (`opt`: `options.RecheckOptions`; `judge_afresh(obj, rows)` makes a
    new track of `obj`'s `rows`, a slice, judged as online). Rule 42 (`opt.halves`): where the
    deciding window of a Pedestrian track has a half no walker's (`mixed_window_row`), the track
    is cut at the window's middle row: the fast half's side (the rows before the middle, or
    from it) is judged afresh, and the verdict stays with the other side, its deciding window
    the slow half. Rules 30, 30b, 30c, 30d (`opt.earlier`) and 43 (`opt.low`; 30d and 43 with
    `size`, rule 26's options): where a window before the deciding one is no walker's, rows
    ..k-1 (k: the deciding window's first row) become a new track; rule 44
    (`opt.halves_around`) reads the halves there too. Rules 29, 30a, 42, 43, 44, 46
    (`switch_row`; 46: `opt.pace_tall` with `size`) and 52 (`fast_stretch_row`,
    `opt.fast_stretch`): where a later window or stretch is no walker's, rows k.. (the first
    such one's first row) become a new track. `obj` keeps the rest."""
    k = mixed_window_row(cfg, obj) if opt.halves else None
    if k is not None:
        a, b = (int(r) for r in obj.result["window"])
        mid = a + (b - a) // 2
        fast_first = k == a
        obj.result = dict(obj.result, window=(mid, b) if fast_first else (a, mid))
        judge_afresh(obj, slice(None, mid) if fast_first else slice(mid, None))
        keep_rows(obj, slice(mid, None) if fast_first else slice(None, mid))
    low = size if opt.low else None
    low_before = size if opt.low or opt.earlier == "speed-low" else None  # rules 43, 30d
    if opt.earlier != "off" or low_before is not None or opt.halves_around:
        pace = opt.earlier == "any" or (opt.earlier == "resolved" and pace_resolved(cfg))
        k = earlier_switch_row(cfg, obj, pace=pace, speed=opt.earlier != "off", low=low_before,
                               halves=opt.halves_around)
        if k is not None:
            judge_afresh(obj, slice(None, k))
            keep_rows(obj, slice(k, None))
    k = switch_row(cfg, obj, tail=opt.tail, halves=opt.halves or opt.halves_around, low=low,
                   tall=size if opt.pace_tall else None)
    fast = fast_stretch_row(cfg, obj, opt.fast_stretch)  # rule 52
    k = fast if k is None else k if fast is None else min(k, fast)
    if k is not None:
        judge_afresh(obj, slice(k, None))
        keep_rows(obj, slice(None, k))
