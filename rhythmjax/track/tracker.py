"""The online tracker: Fig. 3's NONE/DETECT/OBSERVE/PREDICT state machine per object over video.

Per frame (norfair's readable loop, STYLE R11): the motion image of Sec. 2, the previous frame
first moved onto this one where the camera shook (`vision.stabilise`); for each tracked
object a detection inside a small window centred on its predicted foot point; connected regions
elsewhere start new objects (DETECT); two objects' overlapping detections are one shared
blob, measured by neither unless one is clearly nearest (or, with `body.split_shared`, each
re-detects its own part, split.py). Then ONE jitted call advances every object slot with the
core's EKF step (`ekf_fused.step`: `ekf.step` entry by entry) and the paper's gates (10) and
(11) (`gates.PaperGates`; `slot_step.advance_slots`), so the per-frame cost is arithmetic, not
tracing. A DETECT becomes OBSERVE when the first measurement lies in the detection range, else
NONE; OBSERVE/PREDICT follow the gate decision; PREDICT ends (NONE) after `predict_timeout_s`
or when the estimate leaves the range. Each tracked frame samples the rhythm signal I(k) in
window B at the foot point (also moved by `io.files.WINDOW_CANDIDATES` and, rule 50b, across);
each completed window of N frames (one every `thresholds.hop_samples`) is matched with
`rhythm.classify_window` until one says Pedestrian (then matching stops; a window at twice a
walking pace looked at again, twice.py); a timed-out track waits `relink.within_s` s for a relink
(undone at the end where a side moves faster than any walk: rule 57, `relink.side_rows`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..model.camera_np import camera_tuple, upright_size
from ..model.params import Config, host_float
from ..model.status import VERDICT_LABELS, TrackState
from ..vision import detect, stabilise
from ..vision.window_b import window_b_extras, window_b_means
from . import relink, sides
from .columns import TRACK_COLUMNS, tracks_columns, verdict_columns  # noqa: F401
from .lean import window_b_foot
from .looks import tracker_look
from .options import TrackerOptions
from .recheck import median_pace, split_at_switches
from .rows import NAN_VELOCITY, TrackRow, Velocity
from .size import refuse_low
from .slot_step import FRAME_IN, STEP_OUT, StepOut, advance_slots
from .split import Predicted, split_shared
from .toolkit import PendingStep, SlotSteps, match_window


@dataclass
class _Object:
    track_id: int
    state: TrackState
    rows: list[TrackRow] = field(default_factory=list)
    predict_time: float = 0.0
    windows_done: int = 0
    result: dict | None = None  # the deciding (or first) window's outcome
    decided: bool = False
    last_uv: tuple[float, float] = (math.nan, math.nan)  # foot point used for window B, px
    last_W: float = math.nan  # window-B width W, px
    close_frames: int = 0  # frames in a row its estimate coincided with an older track's
    win_start: int = 0  # first row of the next rhythm window
    high_run: int = 0  # frames in a row its measured foot point lay too high (_foot_too_high)
    vel: list[Velocity] = field(default_factory=list)  # EKF ground velocity m/s per row
    top: float = math.nan  # top row px of the last detection (`detect.Detection.top`)
    top_at_edge: bool = False  # ... its extent reached the image's first row (`Detection`)
    candidate_rows: list[tuple[float, ...]] | None = None  # per row, I(k) of the candidate windows
    # B (`WINDOW_CANDIDATES`, then across), then the pace window's; NaN where `intensity` is
    pace_window: bool = False  # the last entry of each candidate_rows tuple is the pace window
    across: int = 0  # rule 50b: window B moved across, the `across` entries before the pace one
    second_look: Callable | None = None  # `match_window`'s look at each window (rules 37, 45)
    mean_rows: list[tuple[float, ...]] | None = None  # rule 35b: per row, window B's and the
    # candidate_rows' windows' I(k) per pixel (`vision.window_b.window_b_means`)
    mean_gate: bool = False  # rule 35c: `match_window` reads mean_rows only behind its gate


class _Lost(NamedTuple):
    """A track that timed out in PREDICT, kept for `relink.within_s` s (`_relink`)."""

    obj: _Object
    anchor: relink.Anchor  # its last observed ground state
    windows: tuple  # its rhythm windows then: (win_start, result, decided, windows_done)


class OnlineTracker:
    """Feed frames with `update(index, t, frame)`; `finish()` returns tracks and verdicts."""

    def __init__(self, cfg: Config, options: TrackerOptions | None = None):
        self.cfg, self.opt = cfg, options or TrackerOptions()
        S = self.opt.max_objects
        self._steps = SlotSteps(advance_slots, cfg, S)  # every slot's filter, one jitted call
        self._slots: list[_Object | None] = [None] * S
        self._next_uv = np.full((S, 2), np.nan)
        self._next_W = np.full(S, np.nan)  # W (px) at the predicted ground point
        self._prev: np.ndarray | None = None
        self._stabiliser = stabilise.Stabiliser(
            min_shift_px=self.opt.motion.stabilise_min_shift_px,
            screen_px=self.opt.motion.stabilise_screen_px) if self.opt.motion.stabilise else None
        self._last_t: float | None = None
        self._next_id = 1
        thr = cfg.thresholds  # host copies: a float() of a device scalar costs ~0.1 ms a frame
        self._range = (float(thr.range_min), float(thr.range_max))
        self._timeout = float(thr.predict_timeout)
        self._height_per_W = cfg.width.height_per_width()  # walker height / W (1.7 / 0.5 m)
        self._finished: list[_Object] = []
        self._lost: list[_Lost] = []  # timed-out tracks a new object may continue
        self._pending = PendingStep(STEP_OUT)  # the last frame's step, not yet read
        self.glitch_frames: list[int] = []
        self.relinked = 0  # tracks continued by `_relink`
        self.switches = 0  # tracks split by `_split_at_switch` (rule 29) or rule 57
        self.relinks_undone = 0  # relinks undone by rule 57 (`relink.undo_fast_relinks`)
        self._camera = camera_tuple(cfg.camera)
        self._walker_m = host_float(cfg.width.height)  # rule 41's body height (m)
        self._look = tracker_look(cfg, self._camera, self.opt.size)  # rules 37 and 45
        self.duplicate_frames: list[int] = []
        self.n_frames = 0
        self._offsets, self._across = self.opt.body.candidate_offsets()  # in W: + down, right
        self._pace_scale = float(self.opt.body.pace_window_widths)  # rule 34; 0: off
        self._extra = len(self._offsets or ()) + len(self._across) + (self._pace_scale > 0)
        self._second_mean = self.opt.body.window_mean_refused and not self.opt.body.window_per_pixel

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
        frame_in = FRAME_IN.empty(S)
        fin = FRAME_IN.unpack(frame_in)  # writable views of frame_in
        z, width = fin.z, fin.width
        present, reset = np.zeros(S, bool), np.zeros(S, bool)
        D = M = None
        glitch = frame is None
        if frame is not None:
            prev = self._prev if self._stabiliser is None else self._stabiliser.align(
                self._prev, frame)
            M, D, changed = detect.motion_image_changed(prev, frame,
                                                        diff_threshold=opt.motion.diff_threshold)
            self._prev = frame
            if changed == 0 and detect.is_duplicate(D):
                self.duplicate_frames.append(index)
                glitch = True
            elif detect.is_global_change(D, opt.motion.diff_threshold,
                                         opt.motion.global_change_fraction, changed=changed):
                self.glitch_frames.append(index)
                glitch = True
        self._flush()  # the previous frame's step ran meanwhile (XLA dispatch is asynchronous)
        boxes, near, cores, dets, predicted = [], [], {}, {}, {}
        for s, obj in enumerate(self._slots):
            if obj is None:
                continue
            present[s] = True
            uv = self._next_uv[s]
            box_w, box_h, Wp = self._window_size(uv, self._next_W[s])
            centre = (uv[0], uv[1] - opt.window.raise_heights * box_h / opt.window.heights)
            if math.isfinite(Wp):
                near.append((uv[0], uv[1], opt.new.near_widths * Wp))
            if not np.all(np.isfinite(uv)) or not math.isfinite(Wp):
                continue
            core_h = opt.body.core_heights * box_h / opt.window.heights
            cores[s] = _box((uv[0], uv[1] - 0.45 * core_h), opt.body.core_widths * Wp, core_h)
            boxes.append(cores[s])
            if glitch:
                continue
            det = detect.detect_in_window(M, centre, (box_w, box_h),
                                          fraction=opt.body.slice_fraction, core=cores[s],
                                          body_px=opt.body.parts_widths * Wp
                                          if opt.body.parts_widths > 0 else None,
                                          **opt.body.column_rules())
            if det is not None:
                dets[s] = det
                predicted[s] = Predicted(centre, box_h, cores[s], (uv[0], uv[1]), Wp)
        shared = detect.shared_detections(dets, opt.body.shared_overlap)
        claims = self._nearest_claims(dets, shared)
        split = split_shared(M, shared, predicted, overlap=opt.body.shared_overlap,
                             near_widths=opt.body.split_near_widths,
                             fraction=opt.body.slice_fraction,
                             depth_widths=opt.body.split_depth_widths,
                             margin_widths=opt.body.split_depth_margin_widths
                             ) if shared and opt.body.split_shared else {}
        shared -= claims | split.keys()
        held = set()  # slots whose object was seen, its foot point unusable: no time-out
        sample_du = np.zeros(S)  # window B's column less the measured one (rules 16, 54)
        for s, det in dets.items():
            cut = own = split.get(s, det)  # a sharer split off measures its own re-detection
            if opt.body.side_anchor:
                own = sides.anchor_at_side(cut, float(self._next_W[s]), M.shape[1])
            # window B stays on the visible feet (rule 16), on the extent (rule 54)
            sample_du[s] = cut.window_u(opt.body.column_filter_only) - own.u
            if s not in shared and self._foot_too_high(s, own):
                held.add(s)
            elif s not in shared:
                z[s], width[s] = (own.u, own.v), own.width
                self._slots[s].top, self._slots[s].top_at_edge = own.top, own.top_at_edge
            boxes.append(det.box)
        outside = 0 if glitch else detect.motion_outside(M, boxes, opt.new.outside_margin_px)
        if not glitch and outside >= opt.new.min_area:
            free = [s for s, o in enumerate(self._slots) if o is None]
            found = detect.find_objects(M, min_area=opt.new.min_area, exclude_boxes=boxes,
                                        max_objects=len(free) + len(near),
                                        fraction=opt.body.slice_fraction,
                                        downscale=opt.new.downscale)
            found = [d for d in found
                     if not any(math.hypot(d.u - nu, d.v - nv) < r for nu, nv, r in near)]
            for det in found[:len(free)]:
                s = free.pop(0)
                self._slots[s] = _Object(track_id=0, state=TrackState.DETECT, top=det.top,
                                         candidate_rows=[] if self._extra else None,
                                         across=len(self._across), second_look=self._look,
                                         pace_window=self._pace_scale > 0,
                                         mean_rows=[] if self._second_mean else None,
                                         mean_gate=self.opt.body.mean_refused_gate)
                present[s], reset[s] = True, True
                if opt.body.side_anchor:
                    cut, det = det, sides.anchor_at_side(det, self._walker_px(det.u, det.v),
                                                         M.shape[1])
                    sample_du[s] = cut.u - det.u
                z[s], width[s] = (det.u, det.v), det.width
        fin.reset[:], fin.present[:], fin.dt[:] = reset, present, dt
        self._pending.hold(self._steps(frame_in), index, t, dt, z, width, D, glitch, shared,
                           held, sample_du)

    def _flush(self) -> None:
        """Read the last step's results and advance every object's state machine with them.
        `update` calls it once the next frame's motion image is computed, so the step's
        arithmetic overlaps it; `finished`, `snapshot` and `finish` call it first."""
        self._pending.flush(self._apply_step)

    def _apply_step(self, out: StepOut, index, t, dt, z, width, D, glitch, shared, held,
                    sample_du):
        valid, started = out.valid > 0.5, out.started > 0.5
        self._next_uv, self._next_W = out.next_uv, out.W_next
        for s, obj in enumerate(self._slots):
            if obj is not None:
                self._after_step(s, obj, index, t, dt, z[s], width[s], bool(valid[s]),
                                 bool(started[s]), out.mean[s], out.est_uv[s], float(out.W[s]),
                                 D, glitch or s in shared, s in held, float(sample_du[s]))
        self._merge(out.est_uv, out.W, out.mean)

    def _foot_too_high(self, s: int, det) -> bool:
        """A settled track's detection whose foot point lies more than `body.high_foot_widths` W
        above the predicted one: the feet did not move (the motion's bottom is a knee or the
        torso), so it is no foot point; the slot predicts instead."""
        obj, r = self._slots[s], self.opt.body.high_foot_widths
        if r <= 0 or obj is None or len(obj.rows) < self.opt.settled_frames:
            return False
        high = bool(det.v < self._next_uv[s][1] - r * float(self._next_W[s]))
        obj.high_run = obj.high_run + 1 if high else 0
        return high and obj.high_run <= self.opt.body.high_foot_frames

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
                r = self.opt.merge.widths * float(W[a])
                if math.isfinite(r) and math.hypot(*(est_uv[a] - est_uv[b])) < r:
                    oa, ob = self._slots[a], self._slots[b]
                    young = b if len(ob.rows) < len(oa.rows) else a
                    dv = math.hypot(mean[a][1] - mean[b][1], mean[a][3] - mean[b][3])
                    if (dv < self.opt.merge.speed_mps
                            or len(self._slots[young].rows) < self.opt.settled_frames):
                        close.add(young)
        for s in live:
            obj = self._slots[s]
            if obj is None:
                continue
            obj.close_frames = obj.close_frames + 1 if s in close else 0
            if obj.close_frames >= self.opt.merge.frames:
                if len(obj.rows) < self.cfg.thresholds.n and obj.result is None:
                    self._slots[s] = None
                else:
                    self._end(s)

    def _walker_px(self, u: float, v: float) -> float:
        """W (px): the mean walker width at the foot point (u, v) px through the camera (3)."""
        w, _, _ = upright_size(self._camera, u, v, float(self.cfg.width.mean), 1.0)
        return float(w)

    def _window_size(self, uv, Wp) -> tuple[float, float, float]:
        """(width, height) px of the detection window at the predicted foot point uv, and W
        (px, the walker width at the predicted ground point, from the jitted step)."""
        Wp = float(Wp)
        if not np.all(np.isfinite(uv)) or not math.isfinite(Wp) or Wp <= 0:
            return 0.0, 0.0, math.nan
        height_px = Wp * self._height_per_W
        return self.opt.window.widths * Wp, self.opt.window.heights * height_px, Wp

    def _after_step(self, s, obj, index, t, dt, z, width, valid, started, mean, est_uv, W, D,
                    no_sample, held=False, sample_du=0.0):
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
        fu, fv = window_b_foot(z, est_uv, measured, sample_du, self.opt, self._camera,
                               self._walker_m, D, (W, W * self._height_per_W), mean)
        obj.last_uv, obj.last_W = (float(fu), float(fv)), W
        per_pixel = self.opt.body.window_per_pixel  # rule 35
        intensity = (math.nan if no_sample or D is None
                     else detect.window_b_intensity(D, fu, fv, W, mean=per_pixel))
        if obj.candidate_rows is not None:  # NaN exactly where `intensity` is
            obj.candidate_rows.append((math.nan,) * self._extra if math.isnan(intensity) else
                                      window_b_extras(D, fu, fv, W, self._offsets or (),
                                                      self._pace_scale, mean=per_pixel,
                                                      across=self._across))
        if obj.mean_rows is not None:  # rule 35b, NaN exactly where `intensity` is
            obj.mean_rows.append(window_b_means(D, fu, fv, W, self._offsets or (), self._pace_scale,
                                                math.isfinite(intensity), self._across))
        top, obj.top = (obj.top if measured else math.nan), math.nan  # this frame's only
        edge, obj.top_at_edge = measured and obj.top_at_edge, False
        obj.rows.append(TrackRow(index, t, float(z[0]), float(z[1]), float(width), intensity,
                                 float(mean[0]), float(mean[2]), int(obj.state), float(top),
                                 top_at_edge=bool(edge)))
        obj.vel.append(Velocity(float(mean[1]), float(mean[3])))
        match_window(self.cfg, obj)
        out_of_range = not (self._range[0] <= mean[2] <= self._range[1])
        if out_of_range or obj.predict_time > self._timeout:
            self._end(s, lost=not out_of_range)

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
        if lost and self.opt.relink.within_s > 0 and len(obj.rows) >= self.opt.settled_frames:
            anchor = relink.last_observed(obj.rows, obj.vel)
            if anchor is not None:
                self._lost.append(_Lost(obj, anchor, (obj.win_start, obj.result, obj.decided,
                                                      obj.windows_done)))
        match_window(self.cfg, obj, final=True)
        self._finished.append(obj)
        self._slots[s] = None

    def _relink(self, obj: _Object, index: int, t: float, z, W: float, mean) -> bool:
        """A new object (its first frame: foot point z, W px, ground estimate `mean`) that
        continues a recently lost track takes over its id, rows and rhythm windows
        (`relink.py`); False when none fits."""
        self._lost = [e for e in self._lost if t - e.anchor.t <= self.opt.relink.within_s]
        if not self._lost or not np.all(np.isfinite(z)):
            return False
        i = relink.best_match([e.anchor for e in self._lost], self._camera, t, z, W,
                              gate_w=self.opt.relink.gate_w, gate_h=self.opt.relink.gate_h,
                              gate_per_s=self.opt.relink.gate_per_s,
                              height_per_W=self._height_per_W)
        if i < 0:
            return False
        old, _, (obj.win_start, obj.result, obj.decided, obj.windows_done) = self._lost.pop(i)
        self._finished.remove(old)
        kept = sum(1 for r in old.rows if r.frame < index)  # a track lost in this very frame
        rows, vel = old.rows[:kept], old.vel[:kept]  # has a predicted row here: superseded
        obj.win_start = min(obj.win_start, kept)
        gap = relink.gap_rows(rows[-1], index, t, (mean[0], mean[2]))
        obj.rows, obj.vel = rows + gap, vel + [NAN_VELOCITY] * len(gap)
        if old.candidate_rows is not None:
            obj.candidate_rows = old.candidate_rows[:kept] + [(math.nan,) * self._extra] * len(gap)
        if old.mean_rows is not None:
            obj.mean_rows = old.mean_rows[:kept] + [(math.nan,) * (self._extra + 1)] * len(gap)
        obj.track_id, self.relinked = old.track_id, self.relinked + 1
        return True

    def finish(self) -> tuple[dict, dict, list[_Object]]:
        """End every track; return (tracks columns, verdict columns, the objects)."""
        self._flush()
        for s, obj in enumerate(self._slots):
            if obj is not None:
                self._end(s)
        self.relinks_undone = relink.undo_fast_relinks(  # rule 57 (off: relink.side_rows 0)
            self.cfg, self._finished, self.opt.relink.side_rows, self._judge_afresh)
        if self.opt.recheck.enabled:  # rules 29, 30a, 30d: a switch cut off (on)
            for o in list(self._finished):
                self._split_at_switch(o)
        objs = sorted(self._finished, key=lambda o: o.track_id)
        for o in objs:  # rule 26: a Pedestrian too low for a walker; rules 47, 55: its pace
            if o.result is not None:
                o.result = refuse_low(o.result, self._camera, o.rows, self._walker_m, self.opt.size)
                o.result = median_pace(self.cfg, o, self.opt.recheck)
        return (tracks_columns(objs, candidates=self._offsets is not None,
                               pace=self._pace_scale > 0, across=bool(self._across)),
                verdict_columns(objs, self.cfg.thresholds.n), objs)

    def _split_at_switch(self, obj: _Object) -> None:
        """Rules 29, 30a, 30d, 46 (on), 30, 30b, 30c, 42-44, 52 (off): a window no walker's cuts
        the track, its side judged afresh (`recheck.split_at_switches`, rule 26's `size`)."""
        split_at_switches(self.cfg, obj, self.opt.recheck, self._judge_afresh, self.opt.size)

    def _judge_afresh(self, obj: _Object, rows: slice, track_id: int | None = None) -> None:
        """A track of `obj`'s `rows` (id `track_id`, else new), judged online, then at its end."""
        cands, means = obj.candidate_rows, obj.mean_rows
        part = _Object(track_id=track_id or self._next_id, state=obj.state, rows=obj.rows[rows],
                       vel=obj.vel[rows], candidate_rows=None if cands is None else cands[rows],
                       pace_window=obj.pace_window, second_look=obj.second_look, across=obj.across,
                       mean_rows=None if means is None else means[rows], mean_gate=obj.mean_gate)
        self._next_id += 1
        while not part.decided and len(part.rows) >= part.win_start + self.cfg.thresholds.n:
            match_window(self.cfg, part)
        match_window(self.cfg, part, final=True)
        self._finished.append(part)
        self.switches += track_id is None


def _box(uv, w, h) -> detect.WindowBox:
    """The (x0, y0, w, h) px window of size w x h centred on uv; empty when uv is not finite."""
    ok = np.all(np.isfinite(uv)) and w > 0
    return (int(uv[0] - w / 2), int(uv[1] - h / 2), int(w), int(h)) if ok else (0, 0, 0, 0)
