"""A walker read at twice its pace (rule 37, issue 16; `SizeOptions.twice_pace_heights`, on).

Seen from behind or in front, a walker whose swinging foot rises out of window B (W x W/5 px at
the feet) and lands in it again gives I(k) two bursts a step, so the MEM spectrum's strongest
peak sits at 2F and its step length reads T/2: (14) refuses it (own scenes with knees,
`sim.legs`: 19 of 59 radial walkers not judged Pedestrian, issue 16's thirty-eighth round). A
trotting dog at its own pace gives the same (f, T) as such a walker does, so the window is
judged at half its strongest peak only where the object is as tall as a walker: a window whose
verdict is Non-pedestrian with reason no-model-match, whose strongest peak f1 (Hz) is above
P_thr (13) with R above R_thr (15), fails (14) at (f1, v/f1) and passes it at (f1/2, 2 v/f1),
is Pedestrian with pace f1/2, stride 2 v/f1 (v: the window's speed of (12), m/s) and reason
matched-twice when its rows' median height (`size.rows_height`, rules 26 and 36's rows) is at
least `twice_pace_heights` walker heights over at least `min_height_rows` rows."""

from __future__ import annotations

import math

import numpy as np

from ..model.gates import walking_ok
from ..model.params import Config, host_float
from ..model.status import Reason, Verdict
from .options import SizeOptions
from .size import rows_height


__all__ = ["judge_at_half", "second_look"]


def judge_at_half(out: dict, cfg: Config, rows: list, camera, walker_height_m: float,
                  options: SizeOptions) -> dict:
    """`out` (a window's outcome: `toolkit.RESULT_FIELDS`) judged at half its strongest peak
    when rule 37 says so (module doc) for the window's `rows` (`rows.TrackRow`); `out` itself
    otherwise (and when `options.twice_pace_heights` is 0, off)."""
    if (options.twice_pace_heights <= 0 or int(out["verdict"]) != Verdict.NON_PEDESTRIAN
            or int(out["reason"]) != Reason.NO_MODEL_MATCH):
        return out
    thr = cfg.thresholds
    f1, p1, ok = (float(np.asarray(out[k])[0]) for k in ("peak_freq", "peak_power", "peak_mask"))
    speed, r1 = float(out["speed_mps"]), float(out["ratio"])
    if not (ok and f1 > 0 and p1 > float(thr.p_thr) and r1 > float(thr.r_thr)
            and math.isfinite(speed)):
        return out
    k3 = float(thr.k_sigma3)
    if bool(walking_ok(cfg.walking, k3, f1, speed / f1)) or \
            not bool(walking_ok(cfg.walking, k3, f1 / 2, 2 * speed / f1)):
        return out
    height, n = rows_height(camera, rows, walker_height_m, options.top_inside_heights)
    if n < options.min_height_rows or not height >= options.twice_pace_heights * walker_height_m:
        return out
    return {**out, "verdict": np.asarray(int(Verdict.PEDESTRIAN), np.int32),
            "reason": np.asarray(int(Reason.MATCHED_TWICE), np.int32),
            "pace_hz": np.asarray(f1 / 2), "stride_m": np.asarray(2 * speed / f1)}


def second_look(cfg: Config, camera, options: SizeOptions):
    """A tracked object's `second_look` (`toolkit.match_window` calls it on each window) for a
    tracker with `cfg`, `camera` (`camera_np.camera_tuple`) and size `options`: `judge_at_half`
    on a window's outcome and rows; None when rule 37 is off (`options.twice_pace_heights` 0)."""
    if options.twice_pace_heights <= 0:
        return None
    walker_m = host_float(cfg.width.height)
    return lambda out, rows: judge_at_half(out, cfg, rows, camera, walker_m, options)
