"""The online tracker: Fig. 3's NONE/DETECT/OBSERVE/PREDICT state machine per object over video.

Per frame (norfair's readable loop, STYLE R11): the motion image of Sec. 2; for each tracked
object a detection inside a small window centred on its predicted foot point; connected regions
elsewhere start new objects (DETECT). Then ONE jitted call advances every object slot with the
core's `ekf.step` and the paper's gates (10) and (11) (`gates.PaperGates`), so the per-frame cost
is arithmetic, not tracing. A DETECT becomes OBSERVE when the first measurement lies in the
detection range, else NONE; OBSERVE/PREDICT follow the gate decision; PREDICT ends (NONE) after
`predict_timeout_s` or when the estimate leaves the range. Each tracked frame samples the rhythm
signal I(k) in window B at the foot point; each completed window of N frames (one starts every
`thresholds.hop_samples` frames) is matched with `rhythm.classify_window` until one says
Pedestrian (then matching stops, tracking goes on), the same windows `rhythm.classify_track`
uses on stored tracks, so `rhythmjax classify` re-judges the written tracks alike. A track that
times out is kept for `relink_s` s, and a new object where it would be continues it (relink.py).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from ..model.camera import image_width, measure
from ..model.camera_np import camera_tuple
from ..model.ekf import Carry, empty_carry, predict, step
from ..model.flat_tree import join as _join, split as _split
from ..model.gates import PaperGates
from ..model.params import Config
from ..model.rhythm import MAX_MISSING_FRACTION, classify_window_jit
from ..model.status import VERDICT_LABELS, TrackState, Verdict
from ..vision import detect
from . import relink
from .columns import TRACK_COLUMNS, tracks_columns, verdict_columns  # noqa: F401
from .options import TrackerOptions


@dataclass
class _Object:
    track_id: int
    state: TrackState
    rows: list[tuple] = field(default_factory=list)
    predict_time: float = 0.0
    windows_done: int = 0
    result: dict | None = None  # the deciding (or first) window's outcome
    decided: bool = False
    last_uv: tuple[float, float] = (math.nan, math.nan)  # foot point used for window B, px
    last_W: float = math.nan  # window-B width W, px
    close_frames: int = 0  # frames in a row its estimate coincided with an older track's
    win_start: int = 0  # first row of the next rhythm window
    high_run: int = 0  # frames in a row its measured foot point lay too high (_foot_too_high)
    vel: list = field(default_factory=list)  # EKF ground velocity (vx, vy) m/s per row


def _advance(cfg: Config, carry: Carry, reset, z, width, dt, present):
    """Every slot one frame: reset new slots, `ekf.step` with the paper's gates, and what the
    next frame needs (predicted foot point) and this frame's window-B size W (px)."""
    empty = empty_carry(z.dtype)
    carry = jax.vmap(lambda r, c: jax.tree.map(lambda a, b: jnp.where(r, b, a), c, empty))(
        reset, carry)
    gates = PaperGates(cfg.width, cfg.thresholds)
    run = jax.vmap(step, in_axes=(None, None, None, 0, 0, 0, None, 0))
    carry, out = run(cfg.camera, cfg.noise, gates, carry, z, width, dt, present)
    nxt = jax.vmap(lambda s: predict(cfg.noise, s, jnp.asarray(cfg.camera.dt, z.dtype)))(
        carry.state)
    next_uv = jax.vmap(lambda m: measure(cfg.camera, m))(nxt.mean)
    est_uv = jax.vmap(lambda m: measure(cfg.camera, m))(out.mean)
    W = image_width(cfg.camera, cfg.width.mean, out.mean[:, 2])
    W_next = image_width(cfg.camera, cfg.width.mean, nxt.mean[:, 2])
    host = jnp.concatenate([out.valid[:, None].astype(z.dtype), out.started[:, None].astype(
        z.dtype), out.mean, next_uv, est_uv, W[:, None], W_next[:, None]], axis=1)
    return carry, host  # one (S, 13) array: one device-to-host transfer per frame


@functools.partial(jax.jit, static_argnums=(0, 1))
def _advance_flat(cfg_structure, carry_structure, cfg_leaves, carry_leaves, frame_in):
    """`_advance` on flat leaves; the frame's inputs come packed in one (S, 6) float32 array
    (reset, u, v, width, present, dt): one host-to-device transfer instead of five halves the
    call's cost (~110 to ~50 us a frame)."""
    reset, z, width = frame_in[:, 0] > 0.5, frame_in[:, 1:3], frame_in[:, 3]
    present, dt = frame_in[:, 4] > 0.5, frame_in[0, 5]
    carry, host = _advance(_join(cfg_leaves, cfg_structure), _join(carry_leaves,
                                                                   carry_structure),
                           reset, z, width, dt, present)
    return _split(carry)[0], host


class OnlineTracker:
    """Feed frames with `update(index, t, frame)`; `finish()` returns tracks and verdicts."""

    def __init__(self, cfg: Config, options: TrackerOptions | None = None):
        self.cfg, self.opt = cfg, options or TrackerOptions()
        S = self.opt.max_objects
        carry = jax.tree.map(lambda a: jnp.broadcast_to(a, (S,) + a.shape).copy(),
                             empty_carry())
        self._cfg_leaves, self._cfg_structure = _split(cfg)
        self._carry, self._carry_structure = _split(carry)
        self._slots: list[_Object | None] = [None] * S
        self._next_uv = np.full((S, 2), np.nan)
        self._next_W = np.full(S, np.nan)  # W (px) at the predicted ground point
        self._prev: np.ndarray | None = None
        self._last_t: float | None = None
        self._next_id = 1
        thr = cfg.thresholds  # host copies: a float() of a device scalar costs ~0.1 ms a frame
        self._range = (float(thr.range_min), float(thr.range_max))
        self._timeout = float(thr.predict_timeout)
        self._height_per_W = 1.7 / float(cfg.width.mean)
        self._finished: list[_Object] = []
        self._lost: list[tuple[_Object, tuple, tuple]] = []  # (object, anchor, window state)
        self._pending: tuple | None = None  # the last frame's step, its results not yet read
        self.glitch_frames: list[int] = []
        self.relinked = 0  # tracks continued by `_relink`
        self._camera = camera_tuple(cfg.camera)
        self.duplicate_frames: list[int] = []
        self.n_frames = 0

    # ------------------------------------------------------------------------------------------
    def update(self, index: int, t: float, frame: np.ndarray | None) -> None:
        """Process one frame (None: undecodable, every object predicts)."""
        self.n_frames += 1
        if frame is not None and self._prev is None:
            self._prev, self._last_t = frame, t
            return
        if self._last_t is None:
            return
        dt = t - self._last_t
        self._last_t = t
        S, opt = self.opt.max_objects, self.opt
        frame_in = np.full((S, 6), np.nan, np.float32)  # see _advance_flat
        z, width = frame_in[:, 1:3], frame_in[:, 3]
        present, reset = np.zeros(S, bool), np.zeros(S, bool)
        D = M = None
        glitch = frame is None
        if frame is not None:
            M, D, changed = detect.motion_image_changed(self._prev, frame,
                                                        diff_threshold=opt.diff_threshold)
            self._prev = frame
            if changed == 0 and detect.is_duplicate(D):
                self.duplicate_frames.append(index)
                glitch = True
            elif detect.is_global_change(D, opt.diff_threshold, opt.global_change_fraction,
                                         changed=changed):
                self.glitch_frames.append(index)
                glitch = True
        self._flush()  # the previous frame's step ran meanwhile (XLA dispatch is asynchronous)
        boxes, near, cores, dets = [], [], {}, {}
        for s, obj in enumerate(self._slots):
            if obj is None:
                continue
            present[s] = True
            uv = self._next_uv[s]
            box_w, box_h, Wp = self._window_size(uv, self._next_W[s])
            centre = (uv[0], uv[1] - opt.window_raise * box_h / opt.window_heights)
            if math.isfinite(Wp):
                near.append((uv[0], uv[1], opt.near_widths * Wp))
            if not np.all(np.isfinite(uv)) or not math.isfinite(Wp):
                continue
            core_h = opt.core_heights * box_h / opt.window_heights
            cores[s] = _box((uv[0], uv[1] - 0.45 * core_h), opt.core_widths * Wp, core_h)
            boxes.append(cores[s])
            if glitch:
                continue
            det = detect.detect_in_window(M, centre, (box_w, box_h), fraction=opt.fraction,
                                          core=cores[s], body_px=opt.body_widths * Wp
                                          if opt.body_widths > 0 else None)
            if det is not None:
                dets[s] = det
        shared = detect.shared_detections(dets, opt.shared_overlap)
        shared -= self._nearest_claims(dets, shared)
        held = set()  # slots whose object was seen, its foot point unusable: no time-out
        for s, det in dets.items():
            if s not in shared and self._foot_too_high(s, det):
                held.add(s)
            elif s not in shared:
                z[s], width[s] = (det.u, det.v), det.width
            boxes.append(det.box)
        if not glitch and detect.motion_outside(M, boxes, opt.outside_margin_px) >= opt.min_area:
            free = [s for s, o in enumerate(self._slots) if o is None]
            found = detect.find_objects(M, min_area=opt.min_area, exclude_boxes=boxes,
                                        max_objects=len(free) + len(near),
                                        fraction=opt.fraction, downscale=opt.downscale)
            found = [d for d in found
                     if not any(math.hypot(d.u - nu, d.v - nv) < r for nu, nv, r in near)]
            for det in found[:len(free)]:
                s = free.pop(0)
                self._slots[s] = _Object(track_id=0, state=TrackState.DETECT)
                present[s], reset[s] = True, True
                z[s], width[s] = (det.u, det.v), det.width
        frame_in[:, 0], frame_in[:, 4], frame_in[:, 5] = reset, present, dt
        self._carry, host = _advance_flat(self._cfg_structure, self._carry_structure,
                                          self._cfg_leaves, self._carry, frame_in)
        self._pending = (host, index, t, dt, z, width, D, glitch, shared, held)

    def _flush(self) -> None:
        """Read the last step's results and advance every object's state machine with them.
        `update` calls it once the next frame's motion image is computed, so the step's
        arithmetic overlaps it; `finished`, `snapshot` and `finish` call it first."""
        if self._pending is None:
            return
        host, index, t, dt, z, width, D, glitch, shared, held = self._pending
        self._pending = None
        host = np.asarray(host)
        valid, started, mean = host[:, 0] > 0.5, host[:, 1] > 0.5, host[:, 2:6]
        next_uv, est_uv, W = host[:, 6:8], host[:, 8:10], host[:, 10]
        self._next_uv = next_uv
        self._next_W = host[:, 11]
        for s, obj in enumerate(self._slots):
            if obj is not None:
                self._after_step(s, obj, index, t, dt, z[s], width[s], bool(valid[s]),
                                 bool(started[s]), mean[s], est_uv[s], float(W[s]), D,
                                 glitch or s in shared, s in held)
        self._merge(est_uv, W, mean)

    def _foot_too_high(self, s: int, det) -> bool:
        """A settled track's detection whose foot point lies more than `high_foot_widths` W
        above the predicted one: the feet did not move (the motion's bottom is a knee or the
        torso), so it is no foot point; the slot predicts instead."""
        obj, r = self._slots[s], self.opt.high_foot_widths
        if r <= 0 or obj is None or len(obj.rows) < self.opt.merge_young:
            return False
        high = bool(det.v < self._next_uv[s][1] - r * float(self._next_W[s]))
        obj.high_run = obj.high_run + 1 if high else 0
        return high and obj.high_run <= self.opt.high_foot_frames

    def _nearest_claims(self, dets: dict, shared: set) -> set:
        """Of the slots sharing a blob, those whose predicted foot point is at most half as far
        from their detection's foot point (in units of their W) as any other sharer's."""
        dist = {s: math.hypot(dets[s].u - self._next_uv[s][0], dets[s].v - self._next_uv[s][1])
                / float(self._next_W[s]) for s in shared}
        keep = set()
        for s in shared:
            others = [math.hypot(dets[s].u - self._next_uv[o][0], dets[s].v - self._next_uv[o][1])
                      / float(self._next_W[o]) for o in shared if o != s
                      and detect.box_overlap(dets[s].box, dets[o].box) > 0]
            if all(2 * dist[s] < d for d in others):
                keep.add(s)
        return keep

    def _merge(self, est_uv, W, mean) -> None:
        """Two slots following one object (their estimated foot points within merge_widths W
        and their ground velocities within merge_speed_mps, for merge_frames frames in a row):
        the younger one ends; if it has fewer than N samples it is dropped unrecorded (a
        duplicate, not a track of its own)."""
        live = [s for s, o in enumerate(self._slots)
                if o is not None and o.state != TrackState.DETECT]
        close = set()
        for i, a in enumerate(live):
            for b in live[i + 1:]:
                r = self.opt.merge_widths * float(W[a])
                if math.isfinite(r) and math.hypot(*(est_uv[a] - est_uv[b])) < r:
                    oa, ob = self._slots[a], self._slots[b]
                    young = b if len(ob.rows) < len(oa.rows) else a
                    dv = math.hypot(mean[a][1] - mean[b][1], mean[a][3] - mean[b][3])
                    if (dv < self.opt.merge_speed_mps
                            or len(self._slots[young].rows) < self.opt.merge_young):
                        close.add(young)
        for s in live:
            obj = self._slots[s]
            if obj is None:
                continue
            obj.close_frames = obj.close_frames + 1 if s in close else 0
            if obj.close_frames >= self.opt.merge_frames:
                if len(obj.rows) < self.cfg.thresholds.n and obj.result is None:
                    self._slots[s] = None
                else:
                    self._end(s)

    def _window_size(self, uv, Wp) -> tuple[float, float, float]:
        """(width, height) px of the detection window at the predicted foot point uv, and W
        (px, the walker width at the predicted ground point, from the jitted step)."""
        Wp = float(Wp)
        if not np.all(np.isfinite(uv)) or not math.isfinite(Wp) or Wp <= 0:
            return 0.0, 0.0, math.nan
        height_px = Wp * self._height_per_W
        return self.opt.window_widths * Wp, self.opt.window_heights * height_px, Wp

    def _after_step(self, s, obj, index, t, dt, z, width, valid, started, mean, est_uv, W, D,
                    no_sample, held=False):
        if obj.state == TrackState.DETECT:
            if not started:  # outside the detection range: back to NONE, nothing recorded
                self._slots[s] = None
                return
            if not self._relink(obj, index, t, z, W, mean):
                obj.track_id, self._next_id = self._next_id, self._next_id + 1
            obj.state = TrackState.OBSERVE
        elif valid:
            obj.state, obj.predict_time = TrackState.OBSERVE, 0.0
        else:
            obj.state = TrackState.PREDICT
            obj.predict_time += 0.0 if held else dt
        measured = bool(np.all(np.isfinite(z)))
        fu, fv = (z if measured and not self.opt.sample_estimate else est_uv)
        obj.last_uv, obj.last_W = (float(fu), float(fv)), W
        intensity = math.nan if no_sample or D is None else detect.window_b_intensity(D, fu, fv, W)
        obj.rows.append((index, t, float(z[0]), float(z[1]), float(width), intensity,
                         float(mean[0]), float(mean[2]), int(obj.state)))
        obj.vel.append((float(mean[1]), float(mean[3])))
        jump = self._velocity_jump(obj)
        if jump:  # lost its object: the implausible frames go, the track ends before them
            del obj.rows[-jump:], obj.vel[-jump:]
            obj.win_start = min(obj.win_start, len(obj.rows))
            self._end(s)
            return
        self._match(obj)
        out_of_range = not (self._range[0] <= mean[2] <= self._range[1])
        if out_of_range or obj.predict_time > self._timeout:
            self._end(s, lost=not out_of_range)

    def _velocity_jump(self, obj: _Object) -> int:
        """Rows to drop when the EKF ground velocity changed by more than max_dv_mps over the
        last dv_window_s s (k frames), once the track is 2k frames old (the filter starts at
        rest), else 0."""
        k = max(1, round(self.opt.dv_window_s * float(self.cfg.camera.fps)))
        if self.opt.max_dv_mps <= 0 or len(obj.vel) <= 2 * k:
            return 0
        (vx, vy), (wx, wy) = obj.vel[-1], obj.vel[-1 - k]
        return k if math.hypot(vx - wx, vy - wy) > self.opt.max_dv_mps else 0

    def _match(self, obj: _Object, *, final: bool = False) -> None:
        """(13)-(15) on each completed window of N frames (one every `thresholds.hop_samples`)
        until Pedestrian (Sec. 4.2). `final` (the track ends with N rows or more but no window
        judged, every one having been restarted past missing samples): the N rows with the
        fewest missing are judged."""
        n = self.cfg.thresholds.n
        k = obj.win_start
        if final:
            if obj.result is not None or len(obj.rows) < n:
                return
            bad = np.concatenate([[0], np.cumsum([not math.isfinite(r[5]) for r in obj.rows])])
            k = int(np.argmin(bad[n:] - bad[:-n]))
        elif obj.decided or len(obj.rows) < k + n:
            return
        rows = np.asarray([r[1:9] for r in obj.rows[k:k + n]], np.float64)
        t, intensity, xy = rows[:, 0], rows[:, 4], rows[:, 5:7]
        observed = np.where((rows[:, 7] == TrackState.OBSERVE)[:, None], rows[:, 1:3], np.nan)
        missing = np.flatnonzero(~np.isfinite(intensity))
        if not final and len(missing) > MAX_MISSING_FRACTION * n:  # mixed with a neighbour:
            obj.win_start = k + int(missing[-1]) + 1  # restart after it
            return
        obj.win_start = k + self.cfg.thresholds.hop_samples
        res = classify_window_jit(self.cfg, jnp.asarray(intensity, jnp.float32),
                        jnp.asarray(t - t[0], jnp.float32), jnp.asarray(xy, jnp.float32),
                        jnp.asarray(True), jnp.asarray(observed, jnp.float32))
        obj.windows_done += 1
        pedestrian = int(res.verdict) == Verdict.PEDESTRIAN
        if obj.result is None or pedestrian:
            obj.result = {k_: np.asarray(getattr(res, k_)) for k_ in (
                "verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps", "peak_freq",
                "peak_power", "peak_mask")}
            obj.result["window"] = (k, k + n)
        obj.decided = pedestrian

    @property
    def finished(self) -> list[_Object]:
        """The objects whose tracks have ended, in the order they ended."""
        self._flush()
        return self._finished

    def snapshot(self) -> list[dict]:
        """The objects being tracked now, for drawing: id, foot point, W, state, verdict."""
        self._flush()
        out = []
        for o in self._slots:
            if o is None or o.state == TrackState.DETECT:
                continue
            verdict = None if o.result is None else VERDICT_LABELS[int(o.result["verdict"])]
            out.append({"track_id": o.track_id, "u": o.last_uv[0], "v": o.last_uv[1],
                        "width": o.last_W, "state": o.state.name.lower(), "verdict": verdict})
        return out

    def _end(self, s: int, lost: bool = False) -> None:
        obj = self._slots[s]
        if lost and self.opt.relink_s > 0 and len(obj.rows) >= self.opt.merge_young:
            anchor = relink.last_observed(obj.rows, obj.vel)
            if anchor is not None:
                self._lost.append((obj, anchor, (obj.win_start, obj.result, obj.decided,
                                                  obj.windows_done)))
        self._match(obj, final=True)
        self._finished.append(obj)
        self._slots[s] = None

    def _relink(self, obj: _Object, index: int, t: float, z, W: float, mean) -> bool:
        """A new object (its first frame: foot point z, W px, ground estimate `mean`) that
        continues a recently lost track takes over its id, rows and rhythm windows
        (`relink.py`); False when none fits."""
        self._lost = [e for e in self._lost if t - e[1][0] <= self.opt.relink_s]
        if not self._lost or not np.all(np.isfinite(z)):
            return False
        i = relink.best_match([e[1] for e in self._lost], self._camera, t, z, W,
                              gate_w=self.opt.relink_gate_w, gate_h=self.opt.relink_gate_h,
                              gate_per_s=self.opt.relink_gate_per_s,
                              height_per_W=self._height_per_W)
        if i < 0:
            return False
        old, _, (obj.win_start, obj.result, obj.decided, obj.windows_done) = self._lost.pop(i)
        self._finished.remove(old)
        gap = relink.gap_rows(old.rows[-1], index, t, (mean[0], mean[2]))
        obj.rows = old.rows + gap
        obj.vel = old.vel + [(math.nan, math.nan)] * len(gap)
        obj.track_id = old.track_id
        self.relinked += 1
        return True

    # ------------------------------------------------------------------------------------------
    def finish(self) -> tuple[dict, dict, list[_Object]]:
        """End every track; return (tracks columns, verdict columns, the objects)."""
        self._flush()
        for s, obj in enumerate(self._slots):
            if obj is not None:
                self._end(s)
        objs = sorted(self._finished, key=lambda o: o.track_id)
        return tracks_columns(objs), verdict_columns(objs, self.cfg.thresholds.n), objs


def _box(uv, w, h) -> tuple[int, int, int, int]:
    if not np.all(np.isfinite(uv)) or w <= 0:
        return (0, 0, 0, 0)
    return (int(uv[0] - w / 2), int(uv[1] - h / 2), int(w), int(h))
