"""What the two online trackers share (the rhythm paper's `tracker.OnlineTracker` and the tracking
paper's `count.pedestrian_level.PedestrianLevel`; `count` imports `track`, never the reverse):

- `SlotSteps`: S filters advanced by ONE jitted call per frame, their carry kept on the device as
  flat leaves (`model.flat_tree`: jax's C++ dispatch then skips the Python flattening of the
  Config and Carry pytrees) and the per-frame outputs packed in one array (`rows.Layout`);
- `PendingStep`: a frame's device result held until the host reads it (`flush`), so the step
  computes while the host prepares the next frame (XLA dispatch is asynchronous);
- `velocity_jump`: the filter's ground velocity changed faster than a walker or a cyclist can
  (its measurements slid onto another object): the rows to drop before the track ends;
- `rows_speed`, `half_speeds`, `fast_half`: the speed (12) of rows and of a window's two
  halves (rules 42, 44, 35c, 52);
- `match_window`: (13)-(15) of the rhythm paper (Sec. 4.2) on the next completed window of N
  rows of a track (`model.rhythm.classify_window_jit`), one every `thresholds.hop_samples`,
  until one says Pedestrian; where the object carries candidate windows B, once per candidate
  and the strongest kept (`model.candidates.strongest`); `window_signal` gives the I(k) that
  decided.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol, runtime_checkable

import jax
import jax.numpy as jnp
import numpy as np

from ..model.candidates import judged, trend_min_hz
from ..model.ekf import empty_carry
from ..model.flat_tree import join, split
from ..model.params import Config, walking_pace_band, walking_top_speed
from ..model.rhythm import (
    MAX_MISSING_FRACTION,
    classify_window_candidates_jit,
    classify_window_jit,
    window_speed,
)
from ..model.status import TrackState, Verdict
from .rows import Layout, TrackRow


RESULT_FIELDS = ("verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps", "peak_freq",
                 "peak_power", "peak_mask")  # the window outcome a tracker keeps (`match_window`)
# ... plus "window" (first row, end row) and, where the object has candidate windows B,
# "candidate" (0: the paper's window B, c: candidate c - 1 of its `candidate_rows`)


# ----------------------------------------------------------------------------------------------
# the jitted per-frame step


@functools.partial(jax.jit, static_argnums=(0, 1, 2, 3))
def _flat_step(advance, static, params_structure, carry_structure, params_leaves, carry_leaves,
               *inputs):
    """`advance(*static, params, carry, *inputs) -> (carry, out)` on flat leaves."""
    carry, out = advance(*static, join(params_leaves, params_structure),
                         join(carry_leaves, carry_structure), *inputs)
    return split(carry)[0], out


class SlotSteps:
    """`slots` filters (each an `ekf.Carry`, all starting empty) advanced together: calling it
    with a frame's inputs runs `advance(*static, params, carry, *inputs)` jitted (compiled once
    per `advance`, `static` and structure) and returns its device output without waiting.
    `advance` must be a module-level function (it is a static argument of the jit)."""

    def __init__(self, advance: Callable, params: Any, slots: int, static: tuple = ()):
        self.slots = int(slots)
        self._advance, self._static = advance, tuple(static)
        self._params, self._params_structure = split(params)
        carry = jax.tree.map(lambda a: jnp.broadcast_to(a, (self.slots,) + a.shape).copy(),
                             empty_carry())
        self._carry, self._carry_structure = split(carry)

    def __call__(self, *inputs) -> jax.Array:
        self._carry, out = _flat_step(self._advance, self._static, self._params_structure,
                                      self._carry_structure, self._params, self._carry, *inputs)
        return out


class PendingStep:
    """One frame's device output and the host context it is to be applied with, held until
    `flush` reads it (as `dtype`), unpacks it (`layout`) and calls `apply(result, *context)`."""

    __slots__ = ("layout", "dtype", "_held")

    def __init__(self, layout: Layout, dtype=None):
        self.layout, self.dtype, self._held = layout, dtype, None

    def hold(self, out, *context) -> None:
        self._held = (out, context)

    def flush(self, apply: Callable) -> None:
        """Apply the held result, if any (once)."""
        if self._held is None:
            return
        out, context = self._held
        self._held = None
        apply(self.layout.unpack(np.asarray(out, self.dtype)), *context)


# ----------------------------------------------------------------------------------------------
# the host-side rules


def dv_frames(dv_window_s: float, fps: float) -> int:
    """The frames k of a velocity-jump span of `dv_window_s` s (at least 1)."""
    return max(1, round(dv_window_s * float(fps)))


def velocity_jump(velocities: Sequence, k: int, max_dv_mps: float, sigma: float = 0.0) -> int:
    """Rows to drop (k) when the ground velocity (items with .vx, .vy m/s) changed by more than
    `max_dv_mps` between the last row and k rows before it, else 0. Only once there are more
    than 2k rows (a filter starts at rest and takes time to reach its object's speed).

    `sigma` > 0: the change dv must also exceed `sigma` standard deviations of the two
    estimates' own noise, dv^T (P_a + P_b)^-1 dv > sigma^2, P the velocity's posterior
    covariance (items' .var_vx, .cov_vxy, .var_vy (m/s)^2; their correlation ignored, so the
    noise is, if anything, overstated). Far from the camera a pixel of foot-row noise is metres
    of depth: the filter's P says so, and a swing it does not trust ends nothing. A covariance
    that is not finite or not positive definite leaves the m/s test alone."""
    if len(velocities) <= 2 * k:
        return 0
    a, b = velocities[-1], velocities[-1 - k]
    dx, dy = a.vx - b.vx, a.vy - b.vy
    if not math.hypot(dx, dy) > max_dv_mps:
        return 0
    if sigma > 0:
        sxx, sxy, syy = (a.var_vx + b.var_vx, a.cov_vxy + b.cov_vxy, a.var_vy + b.var_vy)
        det = sxx * syy - sxy * sxy
        if math.isfinite(det) and det > 0 and sxx > 0:  # dv^T S^-1 dv by the 2x2 inverse
            if (syy * dx * dx - 2.0 * sxy * dx * dy + sxx * dy * dy) / det <= sigma * sigma:
                return 0
    return k


def image_velocity_jump(velocities: Sequence, width_px: float, k: int, max_dv_w: float) -> int:
    """Rows to drop (k) when the foot point's image velocity (items with .du, .dv px/s) changed
    by more than `max_dv_w` patch widths per second (`width_px`: the patch width W px at the
    last row) between the last row and k rows before it, else 0; only once there are more than
    2k rows. The image counterpart of `velocity_jump`: a pixel of foot-row noise far from the
    camera is metres on the ground but a small fraction of W in the image."""
    if len(velocities) <= 2 * k or not width_px > 0:
        return 0
    a, b = velocities[-1], velocities[-1 - k]
    return k if math.hypot(a.du - b.du, a.dv - b.dv) > max_dv_w * width_px else 0


def rows_speed(cfg: Config, rows) -> float:
    """Speed (12), m/s, of `rows` (`TrackRow`s; NaN for fewer than 2): `rhythm.window_speed`
    of their OBSERVE rows' foot points taken to the ground when they are at least half of
    them, else of the filter's ground positions."""
    if len(rows) < 2:
        return math.nan
    t = np.asarray([r.t for r in rows], np.float64)
    xy = np.asarray([(r.x_est, r.y_est) for r in rows], np.float64)
    seen = np.asarray([(r.u, r.v) if r.state == TrackState.OBSERVE else (math.nan, math.nan)
                       for r in rows], np.float64)
    return float(window_speed(cfg, jnp.asarray(t - t[0], jnp.float32),
                              jnp.asarray(xy, jnp.float32), jnp.asarray(seen, jnp.float32)))


def half_speeds(cfg: Config, rows) -> tuple[float, float]:
    """Speed (12), m/s, of the first and the last len(rows) // 2 of `rows` (a window's
    `TrackRow`s; NaN for a half of fewer than 2 rows): `rows_speed` of each."""
    h = len(rows) // 2
    return rows_speed(cfg, rows[:h]), rows_speed(cfg, rows[h:])


def fast_half(cfg: Config, rows, top_speed: float) -> int | None:
    """Rule 42: the index (0 or len(rows) // 2) of the first half of `rows` (a window's
    `TrackRow`s) whose speed (12) (`half_speeds`) exceeds `top_speed` (m/s); None where
    neither does."""
    for start, speed in zip((0, len(rows) // 2), half_speeds(cfg, rows)):
        if math.isfinite(speed) and speed > top_speed:
            return start
    return None


def refused_for_trend(cfg: Config, outcome: dict) -> bool:
    """Rule 35c: True where a window's outcome (`RESULT_FIELDS`) has its strongest spectral
    peak (a local maximum, `peak_freq[0]`) below half the slowest pace the walking model accepts
    (`params.walking_pace_band`: 0.75 Hz with Table 1). Neither a walker's pace nor its stride
    frequency lies there: the window's variance is held by a trend (a walker's image growing or
    shrinking as it walks radially; 0.75 Hz is 3.2 cycles over 64 samples at 15 fps)."""
    mask, freq = np.asarray(outcome["peak_mask"]), np.asarray(outcome["peak_freq"], np.float64)
    return bool(mask[0]) and float(freq[0]) < walking_pace_band(cfg)[0] / 2


@runtime_checkable
class RhythmWindows(Protocol):
    """What `match_window` reads and updates on a tracked object."""

    rows: list[TrackRow]
    win_start: int  # first row of the next window
    windows_done: int  # windows judged
    result: dict | None  # the deciding (or first) window's outcome, `RESULT_FIELDS` + window
    decided: bool  # a window said Pedestrian: matching stops
    # optional, not part of the protocol: `candidate_rows`, per row a tuple of the candidate
    # windows' I(k) (`track.tracker`, `body.window_candidates`); absent or None: window B only;
    # `pace_window` True: each tuple's last entry is the pace window's (rule 34);
    # `second_look`, a callable (outcome, rows) -> outcome or None (rule 37, `track.twice`)


def window_signal(obj, start: int, end: int, candidate: int = 0) -> np.ndarray:
    """I(k) (grey levels, float64, NaN = no sample) of rows start..end-1 of `obj`: candidate 0
    is window B's `intensity` (the paper's), candidate c >= 1 the (c-1)-th entry of the
    object's `candidate_rows` (`match_window`'s result["candidate"] names the one that
    decided)."""
    if candidate == 0:
        return np.asarray([r.intensity for r in obj.rows[start:end]], np.float64)
    return np.asarray([c[candidate - 1] for c in obj.candidate_rows[start:end]], np.float64)


def _outcome(res) -> dict:
    """A `classify_window_jit` result as `RESULT_FIELDS` of NumPy arrays."""
    return {name: np.asarray(getattr(res, name)) for name in RESULT_FIELDS}


def _judged(cfg: Config, obj, window, sigs, rest: tuple, candidates: bool
            ) -> tuple[dict, int | None]:
    """(outcome, chosen candidate or None) of one rhythm window of `obj` on its I(k) channels
    `sigs` (window B's, then each candidate's and the pace window's; `rest` the times, ground
    track, valid flag and foot points of `classify_window_jit`), after `obj`'s second look.
    With candidates every channel is judged in one call and `model.candidates.judged` keeps
    the strongest; `obj.across` > 0 (rule 50b): the last that many channels are windows moved
    across, deciding only where the strongest and Pedestrian (rule 37's look not taken)."""
    look = getattr(obj, "second_look", None)
    if not (candidates and len(sigs) > 1):
        out = _outcome(classify_window_jit(cfg, jnp.asarray(sigs[0], jnp.float32), *rest))
        return (out if look is None else look(out, window)), None
    every = _outcome(classify_window_candidates_jit(cfg, jnp.asarray(np.stack(sigs), jnp.float32),
                                                    *rest))

    def windows_look(res: dict, twice: bool = True) -> dict:  # one window, leading axis 1
        one = look({name: v[0] for name, v in res.items()}, window, twice=twice)
        return {name: np.asarray(v)[None] for name, v in one.items()}

    merged, best = judged([{f: v[c][None] for f, v in every.items()} for c in range(len(sigs))],
                          None if look is None else windows_look,
                          across=getattr(obj, "across", 0),
                          pace_last=getattr(obj, "pace_window", False), min_hz=trend_min_hz(cfg))
    return {name: np.asarray(merged[name][0]) for name in RESULT_FIELDS}, int(best[0])


def match_window(cfg: Config, obj: RhythmWindows, *, final: bool = False,
                 skip_missing: bool = True, measured_speed: bool = True) -> None:
    """(13)-(15) on the next completed window of N rows of `obj` (one starts every
    `thresholds.hop_samples` rows) until one says Pedestrian (Sec. 4.2): at most one window per
    call; the first window's outcome is kept, replaced by the first Pedestrian one.

    skip_missing: a window with more than `MAX_MISSING_FRACTION` of its rhythm samples missing
    (mixed with a neighbour) is not judged; the next starts after its last missing sample.
    measured_speed: the speed of (12) from the foot points of the OBSERVE rows (else the
    filtered ground positions only). final (the track ends with N rows or more and no window
    judged, every one having been skipped): the N rows with the fewest missing are judged.
    Candidate windows B (`obj.candidate_rows`, not None): the window is judged once on window
    B's I(k) and once on each candidate's (the same times, ground track and foot points), and
    the candidate whose strongest peak is highest decides (`model.candidates.strongest`; window
    B on ties), every candidate judged in one call (`rhythm.classify_window_candidates_jit`);
    the missing-sample rules read window B's I(k) only (a candidate is NaN exactly where it
    is). The pace window (`obj.pace_window`, rule 34) is judged in the same call and gives a
    Pedestrian window's pace and stride where it says Pedestrian too (`strongest`'s
    pace_last). The object's `second_look(outcome, rows)`, where it has one, may change a
    window's outcome from its rows before it decides (`track.twice`, rule 37). Rule 35b (the
    object's `mean_rows`, where not None: per row, window B's and its candidate_rows' windows'
    I(k) per pixel): a window so judged not Pedestrian is judged again, the same way, on those,
    and their outcome decides where it is Pedestrian. Rule 35c (the object's `mean_gate` True,
    with rule 35b): only where the sum's strongest peak is a trend (`refused_for_trend`), and
    the mean's Pedestrian outcome only where neither half of the window moves faster than any
    walk (`fast_half`, `params.walking_top_speed`)."""
    n = cfg.thresholds.n
    rows = obj.rows
    k = obj.win_start
    if final:
        if obj.result is not None or len(rows) < n:
            return
        bad = np.concatenate([[0], np.cumsum([not math.isfinite(r.intensity) for r in rows])])
        k = int(np.argmin(bad[n:] - bad[:-n]))
    elif obj.decided or len(rows) < k + n:
        return
    window = rows[k:k + n]
    t = np.asarray([r.t for r in window], np.float64)
    intensity = np.asarray([r.intensity for r in window], np.float64)
    xy = np.asarray([(r.x_est, r.y_est) for r in window], np.float64)
    missing = np.flatnonzero(~np.isfinite(intensity))
    if skip_missing and not final and len(missing) > MAX_MISSING_FRACTION * n:
        obj.win_start = k + int(missing[-1]) + 1
        return
    obj.win_start = k + cfg.thresholds.hop_samples
    rest = (jnp.asarray(t - t[0], jnp.float32), jnp.asarray(xy, jnp.float32), jnp.asarray(True))
    if measured_speed:
        observed = np.asarray([(r.u, r.v) if r.state == TrackState.OBSERVE
                               else (math.nan, math.nan) for r in window], np.float64)
        rest += (jnp.asarray(observed, jnp.float32),)
    cands = getattr(obj, "candidate_rows", None)
    sigs = [intensity] + ([] if cands is None else
                          [window_signal(obj, k, k + n, c) for c in range(1, len(cands[k]) + 1)])
    out, chosen = _judged(cfg, obj, window, sigs, rest, cands is not None)
    means, gate = getattr(obj, "mean_rows", None), getattr(obj, "mean_gate", False)
    if (means is not None and int(out["verdict"]) != Verdict.PEDESTRIAN  # rule 35b
            and (not gate or refused_for_trend(cfg, out))):  # rule 35c
        per_pixel = np.asarray(means[k:k + n], np.float64).T  # (channels, n)
        again, which = _judged(cfg, obj, window, list(per_pixel), rest, cands is not None)
        if int(again["verdict"]) == Verdict.PEDESTRIAN and not (
                gate and fast_half(cfg, window, walking_top_speed(cfg)) is not None):
            out, chosen = again, which
    obj.windows_done += 1
    pedestrian = int(out["verdict"]) == Verdict.PEDESTRIAN
    if obj.result is None or pedestrian:
        obj.result = out
        obj.result["window"] = (k, k + n)
        if chosen is not None:
            obj.result["candidate"] = chosen
    obj.decided = pedestrian
