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
matched-twice when its rows' median height (rule 53: a lower quantile, `twice_pace_quantile`;
`twice_height`: `size.median_height`'s rows, rules 26 and 36's, and rows whose moving region
reached the image's first row, each read as the height up to that row, a lower bound) is at
least `twice_pace_heights` walker heights over at least `min_height_rows` rows. The rows at
the image's edge (`TrackRow.top_at_edge`: the tracker's `detect.Detection.top_at_edge`, count's
`widths.top_and_edge`) are read where
`options.twice_pace_edge` (rule 37b): near the camera walkers' heads leave the view (own
scenes: 54-75 % of walker boxes), and without them rule 37 has no height to read there (issue
16, thirty-ninth round).

Rule 56 (`SizeOptions.stride_peak`, issue 16's fifty-fifth round) is the other way round: a
walker one of whose feet window B does not see (walking away with a suitcase pulled behind,
which hides a foot) gives I(k) one burst a stride, so the strongest peak sits at F/2 and (14)
reads a stride of 2T. Such a window (refused with no-model-match, f1 above P_thr with R above
R_thr, failing (14) at (f1, v/f1) and passing it at (2 f1, v/(2 f1))) is Pedestrian with pace
2 f1, stride v/(2 f1) and reason matched-stride on rule 37's height test. A trotting dog's
peak, at its leg cycle (3-5 Hz) or half it, fails (14) at twice it (3-10 Hz); rule 37 is
tried first.

The tracker looks at each window as it completes (`second_look`, read by
`toolkit.match_window`); the batch classifier (`model.batch.classify_tracks`, which `count`
judges its tracks with) at each window it classifies (`batch_second_look`, from the batch's
foot points and top rows `v_top`), so both judge a window the same way."""

from __future__ import annotations

import numpy as np

from ..model.camera_np import camera_tuple, height_of_top
from ..model.gates import walking_ok
from ..model.params import Config, host_float
from ..model.status import Reason, Verdict
from .options import SizeOptions
from .size import row_heights


__all__ = ["SUB_HZ", "batch_second_look", "judge_at_half", "judged_at", "judged_at_half",
           "reads_at", "reads_stride", "reads_twice", "rows_tall_enough", "second_look",
           "tall_enough", "twice_height"]


SUB_HZ = 0.2  # rule 49: a peak this close (Hz) to f1/2 is the walker's own pace (a priori,
# half the resolution 1 / (N dt) = 0.39 Hz of N = 64 samples at 25 frames/s)


def reads_at(res: dict, cfg: Config, factor: float, sub_ratio: float = 0.0) -> np.ndarray:
    """Per window of `res` (window outcomes, `toolkit.RESULT_FIELDS` with a leading window
    axis: verdict (W,), peak_freq (W, peaks), ...), whether its peaks let the window be judged
    at `factor` times its strongest peak before the height is read: refused with
    no-model-match, strongest peak f1 > 0 above P_thr with R above R_thr and a finite speed,
    (14) failing at (f1, v/f1) and passing at (factor f1, v / (factor f1)). Rule 37 reads
    factor 1/2 (`reads_twice`), rule 56 factor 2 (`reads_stride`). With `sub_ratio` > 0 (rule
    49, `SizeOptions.twice_pace_sub`) also a peak within `SUB_HZ` of factor f1 whose power is at
    least `sub_ratio` times f1's: a walker's steps differ left and right, so its spectrum keeps
    its true pace; a dog's leg cycle need not. Bool (W,)."""
    thr = cfg.thresholds
    verdict, reason = (np.atleast_1d(np.asarray(res[k])) for k in ("verdict", "reason"))
    first = {k: np.asarray(res[k]).reshape(len(verdict), -1)[:, 0]
             for k in ("peak_freq", "peak_power", "peak_mask")}
    f1 = first["peak_freq"].astype(np.float64)
    speed = np.atleast_1d(np.asarray(res["speed_mps"], np.float64))
    ratio = np.atleast_1d(np.asarray(res["ratio"], np.float64))
    with np.errstate(invalid="ignore", divide="ignore"):
        maybe = ((verdict == Verdict.NON_PEDESTRIAN) & (reason == Reason.NO_MODEL_MATCH)
                 & first["peak_mask"].astype(bool) & (f1 > 0)
                 & (first["peak_power"] > float(thr.p_thr)) & (ratio > float(thr.r_thr))
                 & np.isfinite(speed))
        f = np.where(maybe, f1, 1.0)
        v = np.where(maybe, speed, 0.0)
        k3 = float(thr.k_sigma3)
        at_f1 = np.asarray(walking_ok(cfg.walking, k3, f, v / f))
        at_factor = np.asarray(walking_ok(cfg.walking, k3, factor * f, v / (factor * f)))
    if sub_ratio > 0:
        freq, power, mask = (np.asarray(res[k]).reshape(len(verdict), -1)
                             for k in ("peak_freq", "peak_power", "peak_mask"))
        with np.errstate(invalid="ignore"):
            near = mask.astype(bool) & (np.abs(freq - factor * f1[:, None]) < SUB_HZ) & \
                (power >= sub_ratio * first["peak_power"][:, None])
        maybe = maybe & near.any(axis=1)
    return maybe & ~at_f1 & at_factor


def reads_twice(res: dict, cfg: Config, sub_ratio: float = 0.0) -> np.ndarray:
    """Rule 37's `reads_at`: the window read at half its strongest peak (module doc)."""
    return reads_at(res, cfg, 0.5, sub_ratio)


def reads_stride(res: dict, cfg: Config) -> np.ndarray:
    """Rule 56's `reads_at`: the window read at twice its strongest peak, f1 the walker's stride
    frequency F/2 (module doc)."""
    return reads_at(res, cfg, 2.0)


def judged_at(res: dict, which: np.ndarray, factor: float, reason: Reason) -> dict:
    """`res` with windows `which` (bool, leading window axis) Pedestrian with `reason`, pace
    factor f1 and stride v / (factor f1)."""
    f1 = np.asarray(res["peak_freq"], np.float64).reshape(len(which), -1)[:, 0]
    speed = np.atleast_1d(np.asarray(res["speed_mps"], np.float64))
    out = dict(res)
    with np.errstate(invalid="ignore", divide="ignore"):
        for key, value in (("verdict", int(Verdict.PEDESTRIAN)), ("reason", int(reason)),
                           ("pace_hz", factor * f1), ("stride_m", speed / (factor * f1))):
            old = np.asarray(res[key])
            out[key] = np.where(which, value, np.atleast_1d(old)).astype(old.dtype) \
                .reshape(old.shape)
    return out


def judged_at_half(res: dict, which: np.ndarray) -> dict:
    """`res` with windows `which` (bool, leading window axis) Pedestrian, reason
    matched-twice, pace f1/2 and stride 2 v/f1 (rule 37)."""
    return judged_at(res, which, 0.5, Reason.MATCHED_TWICE)


def twice_height(camera, u, v, v_top, at_edge, walker_height_m: float,
                 top_inside_heights: float, quantile: float = 0.5) -> tuple[float, int]:
    """(height m, rows read) of rule 37 over rows with foot points (u, v) px, top rows v_top px
    (NaN where not measured) and `at_edge` (bool, or None: no row): the `quantile` (0.5: the
    median, `np.median`'s; rule 53: `size.twice_pace_quantile`) of the heights of each row that
    `size.median_height` reads, at its height, and of each other row whose moving region
    reached the image's first row (`at_edge`), at the height of the upright segment on its foot
    point whose top is that row (`camera_np.height_of_top` at v_top = 0): the object is at
    least that tall there, so the quantile over both is at most that of its true heights."""
    H, read = row_heights(camera, u, v, v_top, walker_height_m, top_inside_heights)
    heights = H[read]
    if at_edge is not None:
        edge = np.asarray(at_edge, np.float64) > 0.5
        u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
        bound, ok = height_of_top(camera, u, v, np.zeros_like(v))
        heights = np.concatenate([heights, np.asarray(bound)[edge & np.asarray(ok) & ~read]])
    if not heights.size:
        return float("nan"), 0
    return float(np.median(heights) if quantile == 0.5 else np.quantile(heights, quantile)), \
        int(heights.size)


def tall_enough(height_m: float, rows: int, walker_height_m: float,
                options: SizeOptions) -> bool:
    """Rule 37's height test: at least `min_height_rows` rows read, their height (`twice_height`
    with `twice_pace_quantile`: the median by default) at least `twice_pace_heights` walker
    heights."""
    return rows >= options.min_height_rows and \
        height_m >= options.twice_pace_heights * walker_height_m


def rows_tall_enough(rows: list, camera, walker_height_m: float, options: SizeOptions) -> bool:
    """`tall_enough` on the `twice_height` of `rows` (`rows.TrackRow`: u, v, v_top and, where
    `options.twice_pace_edge`, top_at_edge): rule 37's height test on a window's rows (rule 46
    reads it too, `recheck.walker_tall`)."""
    cols = np.asarray([(r.u, r.v, r.v_top, r.top_at_edge) for r in rows],
                      np.float64).reshape(-1, 4)
    height, n = twice_height(camera, cols[:, 0], cols[:, 1], cols[:, 2],
                             cols[:, 3] if options.twice_pace_edge else None,
                             walker_height_m, options.top_inside_heights,
                             options.twice_pace_quantile)
    return tall_enough(height, n, walker_height_m, options)


def judge_at_half(out: dict, cfg: Config, rows: list, camera, walker_height_m: float,
                  options: SizeOptions) -> dict:
    """`out` (a window's outcome: `toolkit.RESULT_FIELDS`) judged at half its strongest peak
    when rule 37 says so (module doc) for the window's `rows` (`rows.TrackRow`), else, with
    rule 56 (`options.stride_peak`), at twice it when rule 56 says so; `out` itself otherwise
    (and when `options.twice_pace_heights` is 0: both off)."""
    if options.twice_pace_heights <= 0:
        return out
    if bool(reads_twice(out, cfg, options.twice_pace_sub)[0]):
        factor, reason = 0.5, Reason.MATCHED_TWICE
    elif options.stride_peak and bool(reads_stride(out, cfg)[0]):
        factor, reason = 2.0, Reason.MATCHED_STRIDE
    else:
        return out
    if not rows_tall_enough(rows, camera, walker_height_m, options):
        return out
    return judged_at(out, np.ones(1, bool), factor, reason)


def second_look(cfg: Config, camera, options: SizeOptions):
    """A tracked object's `second_look` (`toolkit.match_window` calls it on each window) for a
    tracker with `cfg`, `camera` (`camera_np.camera_tuple`) and size `options`: `judge_at_half`
    on a window's outcome and rows (`twice` False: the outcome as it is, rule 50b's windows moved
    across); None when rule 37 is off (`options.twice_pace_heights` 0)."""
    if options.twice_pace_heights <= 0:
        return None
    walker_m = host_float(cfg.width.height)
    return lambda out, rows, twice=True: (judge_at_half(out, cfg, rows, camera, walker_m, options)
                                          if twice else out)


def batch_second_look(cfg: Config, batch, options: SizeOptions):
    """`model.batch.classify_tracks`' `second_look` for `batch` (a `TrackBatch` with top rows
    `v_top`): a callable (res, track, start, twice=True) -> res that judges the windows of `res`
    (leading window axis; window w holds rows start[w] .. start[w] + N - 1 of track track[w])
    as `judge_at_half` does (`twice` False: `res` as it is), the rows' foot points from
    `batch.z` (and, with `options.twice_pace_edge`, the rows at the image's edge from
    `batch.top_at_edge` where the batch has them). None when rule 37 is off or the batch has no
    `v_top`."""
    if options.twice_pace_heights <= 0 or getattr(batch, "v_top", None) is None:
        return None
    camera = camera_tuple(cfg.camera)
    walker_m = host_float(cfg.width.height)
    n = int(cfg.thresholds.n)
    edges = getattr(batch, "top_at_edge", None) if options.twice_pace_edge else None

    def look(res: dict, track: np.ndarray, start: np.ndarray, twice: bool = True) -> dict:
        if not twice:
            return res
        which = reads_twice(res, cfg, options.twice_pace_sub)
        stride = reads_stride(res, cfg) & ~which if options.stride_peak else np.zeros_like(which)
        which = which | stride
        for w in np.flatnonzero(which):
            rows = slice(int(start[w]), int(start[w]) + n)
            uv = batch.z[int(track[w]), rows]
            height, count = twice_height(
                camera, uv[:, 0], uv[:, 1], batch.v_top[int(track[w]), rows],
                None if edges is None else edges[int(track[w]), rows], walker_m,
                options.top_inside_heights, options.twice_pace_quantile)
            which[w] = tall_enough(height, count, walker_m, options)
        if stride.any():
            res = judged_at(res, which & stride, 2.0, Reason.MATCHED_STRIDE)
        return judged_at_half(res, which & ~stride) if (which & ~stride).any() else res

    return look
