"""The pedestrians level of Masoud & Papanikolopoulos over frames (`PedestrianLevel`): per frame
the three levels, then refinement; `count.count_frames` drives it and judges the tracks.

Per frame (`PedestrianLevel.update`):
1. Images: `blobs.BackgroundModel` (running average, selective update) gives the 0/1 mask.
2. Blobs: `blobs.find_blobs`, then `blobgraph.blob_graph` between frames i-1 and i. A frame
   whose blob box covers `blobs.crowd_fraction` of the image (`blobs.is_crowd`: a dense crowd, a
   camera jump) is not used for detection: every pedestrian predicts, the frame is listed in
   `crowd_frames`.
3. Pedestrians: relations propagate through the blob graph (related to blob i of frame i-1:
   related to i's children; a shared blob that splits: its pedestrians go to its children by
   the Hungarian method on predicted foot point to bottom centre); one with no related blob
   takes the blobs its predicted patch overlaps (re-acquisition). Patches are placed
   (`patches.place_patch`) older first (nearest first with `placement.depth_order`,
   `count.occlusion`), each claiming its pixels from those after it (groups).
   Pedestrians sharing a blob too narrow for them side by side (< `placement.merge_widths` x
   their summed widths: walking past each other) keep their predictions (identities survive
   the merge). One jitted call advances every filter (`slot_filter.SlotFilter`).
4. Refinement: blob columns no pedestrian explains (`new.walker_widths` W around each foot point: a
   walker's blob spans its stance foot to its leading arm), at least `new.min_widths` W wide, full
   enough and reaching the blob's bottom (feet, not arms) or, lifted above it, `new.lifted_height`
   of its patch tall (a farther walker merged with a nearer object), with the foot point's ground
   point in the detection range (`new.in_range`), start pedestrians, one per `new.walker_widths` W
   of the run (`refinement.new_pedestrians`; with `new.head_feet`, a run too tall for a walker
   standing on its bottom starts with the feet its top row implies, `head_feet`); confirmed after
   `life.confirm_hits` measured frames (dropped at `life.tentative_misses` misses). One ends: after
   predicting for predict_timeout_s (held in a merge up to `life.merge_hold_s`, `coast`); ("3d")
   when its ground velocity changes by more than `life.max_dv_mps` within `life.dv_window_s` s (no
   walker or cyclist turns or brakes that fast: it lost its walker and ends without those frames,
   `track.toolkit.velocity_jump`; with `life.max_dv_w` the image velocity in W/s instead,
   `image_velocity_jump`, off; with `life.jump_sigma` only a change the filter's own velocity noise
   does not explain; with `life.jump_rewind` it goes on from its state before the change instead,
   `rewind`); when its foot point stayed put for `life.still_s` s (`still.is_still`: a ghost or a
   stopped object, copied into the background under its patch); two within `life.duplicate_widths` W
   with the same image velocity for `life.duplicate_frames` frames are one: the younger ends.
   Relations for the next frame: the blobs the placed patch overlaps. The background starts from
   `background` (the first seconds' median, `still.peek_background`), else from the first frame.
Every frame each pedestrian samples I(k) in window B at its foot point
(`detect.window_b_intensity` on the frame difference, W = its patch width; with
`verdicts.window_candidates` also in window B moved by each offset of `io.files.
WINDOW_CANDIDATES`: `window_candidates`) and keeps its ground state (`Pedestrian.ground`) for
stitching, and, where its blobs are its own, their top row in its columns (`widths.measured_top`
up to `TOP_REACH` patch heights above the feet: the tracks' `v_top`, the head row that the
height cue of `rhythmjax-fit selfcal` reads, and the head's column there, `u_top`, the foot
point's column plus the silhouette's lean, `widths.measured_lean`, which its slant cue reads);
an ended one loses its trailing predicted frames, and `count` stitches, judges and counts the
ended tracks.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..model.params import Config
from ..model.status import TrackState
from ..track.rows import TrackRow
from ..track.toolkit import (
    PendingStep,
    dv_frames,
    image_velocity_jump,
    match_window,
    velocity_jump,
)
from ..vision.blobs import box_table, meeting
from ..vision.detect import window_b_intensity
from .appearance import look_of_frame
from .coast import advance_coast, timed_out
from .foot_gate import gated
from .occlusion import foot_row_tolerance, is_wide, placement_order, row_gated
from .patches import ShapeModel, ground_point, patch_box, place_patch
from .pedestrian import Pedestrian as Pedestrian, finite_uv
from .refinement import in_range, new_pedestrians
from .rewind import keep_state, rewind, rewind_requests, rows_to_drop, state_store
from .rows import BlobRow, BoxRow, GroundRow
from .slot_filter import FILTER_OUT, FilterOut, SlotFilter, filter_config
from .still import duplicates, is_still
from .widths import measured_lean, measured_width, top_and_edge
from .window_candidates import sample_candidates


if TYPE_CHECKING:
    from .options import CountOptions

END_REASONS = ("timeout", "velocity-jump", "still", "left-image", "duplicate", "clip-end")
# why a pedestrian ended (`Pedestrian.end_reason`): predicted for predict_timeout_s, its ground
# velocity jumped (`life.max_dv_mps`), it stayed put (`life.still_s`), its patch left the
# image, it was the younger of a duplicate pair, or the frames ran out; the CountResult's
# summary counts the confirmed tracks' ends by reason (before stitching)
TOP_REACH = 3.0  # patch heights above the feet searched for the top row (`widths.measured_top`):
# a camera whose patch is a third of the walker's image height still finds the head; set a priori


class PedestrianLevel:
    """Feed frames with `update(index, t, gray)`; `finish()` returns the `CountResult`. `defer`:
    a frame's filter results reach its pedestrians (`_flush`) only in the next `update`, after
    that frame's images and blobs levels, which so run while the jitted step computes; the same
    results, but `snapshot` then lags a frame (count_frames defers without an overlay)."""

    def __init__(self, cfg: Config, opt: CountOptions, defer: bool = False,
                 background: np.ndarray | None = None):
        self.cfg, self.opt = cfg, opt
        self.bg_init, self.absorb = background, []  # first background; boxes to absorb
        fps = float(cfg.camera.fps)  # `still.is_still` over still_s s in 1 s blocks
        self.still_rows, self.block = round(opt.life.still_s * fps), max(1, round(fps))
        self.shape = ShapeModel.from_config(cfg, opt.dynamics)
        self.filter = SlotFilter(filter_config(cfg, opt.placement.noise), opt.dynamics,
                                 opt.max_pedestrians, outlier_gate=opt.placement.outlier_gate)
        self.coast_s = float(cfg.thresholds.predict_timeout)
        self.peds: list[Pedestrian] = []
        self.finished: list[Pedestrian] = []
        self.bg = self.prev = self.gray = self.last_t = None  # last_t: the last frame's t, s
        self.prev_blobs: list = []
        self.next_id, self.n_frames = 1, 0
        self.crowd_frames: list[int] = []
        self.missing_frames: list[int] = []
        self.full_frames: list[int] = []  # frames where a new pedestrian found no free slot
        self.stitched = self.ghosts = 0  # tracks joined (count.stitch_level), never moved
        self.rewinds = 0  # velocity jumps gone on from before (`life.jump_rewind`)
        self.detections: list[BlobRow] = []
        self.gated: dict[str, int] = {}  # placements gated by `count.foot_gate`, by reason
        self.row_tolerance = foot_row_tolerance(cfg)  # `count.occlusion` (wide_widths), px
        self.image_shape: tuple[int, int] | None = None
        self._dv_frames = dv_frames(opt.life.dv_window_s, float(cfg.camera.fps))
        self.defer, self._pending = defer, PendingStep(FILTER_OUT, np.float64)

    # ------------------------------------------------------------------------------------------
    def update(self, index: int, t: float, gray: np.ndarray | None) -> None:
        from ..vision.blobgraph import blob_graph
        from ..vision.blobs import BackgroundModel, find_blobs, is_crowd
        from ..vision.detect import frame_difference

        self.n_frames += 1
        opt = self.opt
        if gray is not None and self.bg is None:
            b = opt.blobs
            first = gray if self.bg_init is None else self.bg_init
            self.bg = BackgroundModel(first, **b.model_kwargs())
            self.prev, self.last_t, self.image_shape = gray, t, gray.shape
            return
        if self.last_t is None:
            return
        dt, self.last_t = t - self.last_t, t
        blobs, labels, D, graph = [], None, None, None
        if gray is None:
            self.missing_frames.append(index)
        else:
            while self.absorb:  # still pedestrians' patches (`_after`)
                self.bg.absorb(gray, self.absorb.pop())
            mask = self.bg.apply(gray)
            self.gray = gray  # for the descriptors (`appearance.look_of_frame`)
            D, self.prev = frame_difference(self.prev, gray), gray
            blobs, labels = find_blobs(mask, min_area=opt.blobs.min_area)
            if is_crowd(blobs, mask.shape, fraction=opt.blobs.crowd_fraction):
                self.crowd_frames.append(index)
                blobs, labels = [], None
            else:
                graph = blob_graph(self.prev_blobs, blobs)
                self.detections += [BlobRow(index, *b.box, b.area) for b in blobs]
        self._flush()
        for p in self.peds:
            p.z, p.z_width = (math.nan, math.nan), math.nan  # unless placed
            p.z_top, p.z_top_u, p.merged, p.unseen = math.nan, math.nan, False, False
            p.z_top_edge = False
        boxes = box_table(blobs)
        rel = self._relate(graph, blobs, boxes)
        S = self.filter.slots
        z = np.full((S, 2), np.nan)
        present, reset = np.zeros(S, bool), np.zeros(S, bool)
        if labels is not None:
            self._place(rel, blobs, labels)
        for p in self.peds:
            present[p.slot] = True
            z[p.slot] = p.z
        if labels is not None:
            for p in self._new_pedestrians(blobs, labels):
                present[p.slot] = reset[p.slot] = True
                z[p.slot] = p.z
        back = rewind_requests(self.peds, S)  # `life.jump_rewind`
        self._pending.hold(self.filter.dispatch(reset, z, present, dt, restore=back), index, t,
                           dt, boxes, D)
        if not self.defer:
            self._flush()
        self.prev_blobs = blobs

    def _flush(self) -> None:
        """The end of the pending frame: its filter results to each pedestrian, duplicates."""
        self._pending.flush(self._apply_filter)

    def _apply_filter(self, out: FilterOut, index, t, dt, boxes, D) -> None:
        for p in list(self.peds):
            self._after(p, out, index, t, dt, boxes, D)
        self._duplicates()

    def _relate(self, graph, blobs, boxes) -> dict[int, set]:
        """Relations of frame i: through the blob graph, Hungarian on shared splits, then
        re-acquisition by overlap for pedestrians left without a blob."""
        from scipy.optimize import linear_sum_assignment

        rel: dict[int, set] = {id(p): set() for p in self.peds}
        if graph is not None:
            by_parent: dict[int, list[Pedestrian]] = {}
            for p in self.peds:
                for i in p.blobs:
                    by_parent.setdefault(i, []).append(p)
            for i, peds in by_parent.items():
                kids = list(graph.children(i))
                if len(peds) > 1 and len(kids) > 1:
                    cost = np.array([[self._dist(p, blobs[k]) for k in kids] for p in peds])
                    r, c = linear_sum_assignment(cost)
                    for a, b in zip(r, c):
                        rel[id(peds[a])].add(kids[b])
                    for a in set(range(len(peds))) - set(r.tolist()):
                        rel[id(peds[a])].add(kids[int(np.argmin(cost[a]))])
                else:
                    for p in peds:
                        rel[id(p)].update(kids)
        for p in self.peds:
            if rel[id(p)] or not finite_uv(p.next_uv):
                continue
            rel[id(p)].update(meeting(self.patch_at(p.next_uv), boxes, 0.2))
        return rel

    def _dist(self, p: Pedestrian, b) -> float:
        if not finite_uv(p.next_uv):
            return 1e6
        bu, bv = b.bottom_center
        return math.hypot(p.next_uv[0] - bu, p.next_uv[1] - bv)

    def patch_at(self, uv) -> tuple:
        """The patch box (x0, y0, x1, y1) px of a pedestrian with foot point `uv`; all 0 where
        the camera gives it no size."""
        w, h = (float(q) for q in self.shape.size(*uv))
        return patch_box(uv[0], uv[1], w, h) if math.isfinite(w) else (0, 0, 0, 0)

    def _place(self, rel, blobs, labels) -> None:
        """Measurements: each related pedestrian's patch placement (older first, claiming)."""
        opt = self.opt
        users: dict[int, int] = {}
        for p in self.peds:
            for j in rel[id(p)]:
                users[j] = users.get(j, 0) + 1
        claimed = None  # pixels taken by shared placements, made on the first one
        for p in placement_order(self.peds, opt.placement.depth_order):  # `count.occlusion`
            mine = rel[id(p)]
            if not mine or not finite_uv(p.next_uv):
                continue
            w0 = float(self.shape.size(*p.next_uv)[0])
            k = max(users[j] for j in mine)
            if k > 1:
                boxes = [blobs[j].box for j in mine if users[j] > 1]
                width = max(b[2] for b in boxes) - min(b[0] for b in boxes)
                if width < opt.placement.merge_widths * k * w0:
                    p.merged = True  # walking past each other: keep the prediction
                    continue
            bx = [blobs[j].box for j in mine]
            bbox = (min(b[0] for b in bx), min(b[1] for b in bx), max(b[2] for b in bx),
                    max(b[3] for b in bx))
            # alone on blobs far wider than a walker (`placement.wide_widths`): placed as shared
            wide = k == 1 and is_wide(bbox, w0, opt.placement.wide_widths)
            radius = w0 * (opt.placement.shared_search_widths if k > 1 or wide
                           else opt.placement.search_widths)
            lab = np.asarray([blobs[j].label for j in mine])
            # a new pedestrian alone on its blobs stands on their bottom, however far its first
            # prediction is; a confirmed one looks within `band` H of its prediction (so it does
            # not jump to a nearer person its blob has merged with)
            v_max = None if k > 1 or wide or p.track_id else float(max(blobs[j].box[3] - 1
                                                                        for j in mine))
            pl = place_patch(labels, lab, claimed, self.shape, *p.next_uv, radius_px=radius,
                             v_max=v_max, min_cover=opt.placement.min_cover, bbox=bbox)
            if pl is None or (z := gated(self, p, pl)) is None:  # `count.foot_gate`
                continue
            z = row_gated(self, p, pl, z, shared=k > 1, wide=wide, claimed=claimed)
            if z is None:  # `count.occlusion`: its row another object's, it predicts
                continue
            p.rewound = p.rewound and z[1] != pl.v  # ... until a row within the tolerance
            p.z = z  # the object's width: its blob's run, a patch width around
            p.z_width = measured_width(labels, lab, claimed, pl.u, pl.v, pl.w, pl.h, pl.w)
            if k == 1:  # its blobs not shared: their top in its columns is its head
                p.z_top, p.z_top_edge = top_and_edge(labels, lab, claimed, pl.u, pl.v, pl.w,
                                                     TOP_REACH * pl.h)
                p.z_top_u = p.z[0] + measured_lean(labels, lab, claimed, pl.u, pl.v, pl.w,
                                                   p.z_top, 0.5 * pl.w)
            if k == 1 and opt.appearance.enabled:  # its blobs not shared: its descriptor
                a = opt.appearance
                p.look = look_of_frame(p.look, self.gray, labels, lab, claimed, pl.u, pl.v,
                                       pl.w, pl.h, a.bins, a.min_fill)
            if k > 1:
                x0, y0, x1, y1 = (int(round(q)) for q in (pl.u - pl.w / 2, pl.v - pl.h,
                                                          pl.u + pl.w / 2, pl.v + 1))
                if claimed is None:
                    claimed = np.zeros(labels.shape, bool)
                claimed[max(0, y0):max(0, y1), max(0, x0):max(0, x1)] = True

    def _new_pedestrians(self, blobs, labels) -> list[Pedestrian]:
        """Refinement: new pedestrians on unexplained blob columns (`refinement`)."""
        return new_pedestrians(self, blobs, labels)

    def _in_range(self, uv) -> bool:
        """`refinement.in_range`: the foot point's ground point in the detection range."""
        return in_range(self, uv)

    def new_pedestrian(self, slot: int) -> Pedestrian:
        """A pedestrian born this frame in filter slot `slot` (sampling the candidate windows B
        when `verdicts.window_candidates` is on)."""
        rewinds = self.opt.life.jump_rewind and self.opt.dynamics == "3d"
        return Pedestrian(slot=slot, born=self.n_frames,
                          candidate_rows=[] if self.opt.verdicts.window_candidates else None,
                          states=state_store(self._dv_frames) if rewinds else None)

    def _after(self, p: Pedestrian, out: FilterOut, index, t, dt, boxes, D) -> None:
        s = p.slot
        if out.started[s] < 0.5:  # the first measurement had no ground point (above the horizon)
            self.peds.remove(p)
            return
        measured = finite_uv(p.z) and out.used[s] > 0.5  # the filter took it (`outlier_gate`)
        if not measured:
            p.z = (math.nan, math.nan)  # none, or refused: it predicts
        off = bool(measured and abs(p.z[1] - p.next_uv[1]) > self.row_tolerance)  # row vs placed
        p.hits, p.misses = p.hits + measured, 0 if measured else p.misses + 1
        advance_coast(p, bool(measured), dt, self.opt.life.merge_hold_s)  # `count.coast`
        (eu, ev), (nu, nv) = out.est_uv[s], out.next_uv[s]
        p.est_uv, p.next_uv = (eu, ev), (nu, nv)
        p.step_uv = (nu - eu, nv - ev)
        w, h = (float(q) for q in self.shape.size(*p.est_uv))
        p.size = (w, h)
        if self.opt.dynamics == "3d":
            (gx, gy), ok = out.ground[s], True
        else:
            gx, gy, ok = (float(q) for q in ground_point(self.shape.camera, *p.est_uv))
        fu, fv = p.z if measured else p.est_uv
        if measured and self.opt.placement.window_column == "estimate":
            fu = eu  # window B on the filter's column, the measured foot row
        W = float(self.shape.size(fu, fv)[0])
        unsampled = p.unseen and self.opt.placement.shared_row_unsampled  # `count.occlusion`
        inten = math.nan if D is None or unsampled else window_b_intensity(D, fu, fv, W)
        if p.candidate_rows is not None:  # `verdicts.window_candidates`
            p.candidate_rows.append(sample_candidates(D, fu, fv, W, inten))
        state = TrackState.OBSERVE if measured else TrackState.PREDICT
        p.rows.append(TrackRow(index, t, p.z[0], p.z[1], p.z_width if measured else math.nan,
                               inten, gx, gy, int(state), p.z_top if measured else math.nan,
                               p.z_top_u if measured else math.nan,
                               measured and p.z_top_edge))
        p.boxes.append(BoxRow(index, eu - w / 2, ev - h, w, h, 1.0 if measured else 0.5, gx,
                              gy, bool(ok)))
        vx, vy = out.velocity[s] if self.opt.dynamics == "3d" else (math.nan, math.nan)
        p.ground.append(GroundRow(gx, gy, vx, vy, *out.image_velocity[s], *(
            out.velocity_cov[s] if self.opt.dynamics == "3d" else (math.nan,) * 3)))
        keep_state(p, out, t, off)  # `life.jump_rewind`
        p.blobs = meeting(self.patch_at(p.est_uv), boxes, 0.1)
        if p.track_id == 0:
            if p.hits >= self.opt.life.confirm_hits:
                p.track_id, self.next_id = self.next_id, self.next_id + 1
            elif p.misses >= self.opt.life.tentative_misses:
                self.peds.remove(p)
                return
        elif self.opt.verdicts.online:
            self._match(p)
        still = self._still(p)  # a ghost or a stopped object: no walker's frames, its patch
        jump = self.still_rows if still else self._velocity_jump(p)  # into the background
        jump, goes_on = rows_to_drop(p, jump, self.opt.life.rewind_off_rows and not still)
        if jump:  # lost its object: the implausible frames go, the track ends before them
            p.rows, p.boxes, p.ground = p.rows[:-jump], p.boxes[:-jump], p.ground[:-jump]
            if p.candidate_rows is not None:
                p.candidate_rows = p.candidate_rows[:-jump]
            if goes_on and not still and rewind(p, jump, t, self.shape.camera,
                                                self.filter.dt_nominal):
                jump, self.rewinds = 0, self.rewinds + 1  # ... or goes on from before them:
                p.rewound = self.opt.life.rewind_across or self.opt.life.rewind_predict
                w, h = p.size = tuple(float(q) for q in self.shape.size(*p.est_uv))  # there,
                p.blobs = meeting(self.patch_at(p.est_uv), boxes, 0.1)  # related to its blobs
        H, Wi = self.image_shape
        u, v = p.est_uv
        outside = not (math.isfinite(w) and -0.5 * w <= u <= Wi + 0.5 * w and 0 <= v <= H + h)
        if still:
            self.absorb.append((u - w, v - 1.2 * h, u + w, v + 0.1 * h))
        if timed_out(p, self.coast_s, self.opt.life.merge_hold_s) or outside or jump:
            self._end(p, "still" if still else "velocity-jump" if jump else
                      "left-image" if outside else "timeout")

    def _still(self, p: Pedestrian) -> bool:
        """Its measured foot points stayed put for `life.still_s` s (`still.is_still`)."""
        n, lf = self.still_rows, self.opt.life
        return 0 < n <= len(p.rows) and is_still([(r.u, r.v) for r in p.rows[-n:]], p.size,
                                                 self.block, lf.still_widths, lf.still_heights)

    def _velocity_jump(self, p: Pedestrian) -> int:
        """"3d": the rows to drop when its EKF ground velocity changed by more than
        `life.max_dv_mps` within `life.dv_window_s` s (`track.toolkit.velocity_jump`), or with
        `life.max_dv_w` > 0 its image velocity by more than that many W/s (W: its last box's
        width; `image_velocity_jump`), else 0. `life.jump_sigma` > 0: the m/s change must also
        exceed that many standard deviations of the filter's velocity noise."""
        if self.opt.dynamics != "3d":
            return 0
        if self.opt.life.max_dv_w > 0:
            return image_velocity_jump(p.ground, p.boxes[-1].w if p.boxes else math.nan,
                                       self._dv_frames, self.opt.life.max_dv_w)
        return velocity_jump(p.ground, self._dv_frames, self.opt.life.max_dv_mps,
                             self.opt.life.jump_sigma)

    def _match(self, p: Pedestrian) -> None:
        """Online verdict (drawn on the overlay): `track.toolkit.match_window` on its windows
        as `rhythm.classify_track` takes them (one every hop_samples rows, none skipped)."""
        match_window(self.cfg, p, skip_missing=False, measured_speed=False)

    def _duplicates(self) -> None:
        life = self.opt.life
        for p in duplicates(self.peds, life.duplicate_widths, life.duplicate_frames):
            self._end(p, "duplicate")

    def _end(self, p: Pedestrian, reason: str) -> None:
        """End `p` for `reason` (one of `END_REASONS`): its trailing predicted rows go; a
        confirmed one with a measured row left joins `finished`."""
        if p in self.peds:
            self.peds.remove(p)
        p.end_reason = reason
        last = max((i for i, r in enumerate(p.rows) if r.state == TrackState.OBSERVE),
                   default=-1)
        if p.track_id == 0 or last < 0:  # tentative, or no measured row left (still_s)
            return
        p.rows, p.boxes, p.ground = p.rows[:last + 1], p.boxes[:last + 1], p.ground[:last + 1]
        if p.candidate_rows is not None:
            p.candidate_rows = p.candidate_rows[:last + 1]
        self.finished.append(p)

    def snapshot(self) -> list[dict]:
        """Pedestrians now, for drawing: id (0 tentative), box, measured, verdict label."""
        from ..model.status import VERDICT_LABELS

        out = []
        for p in self.peds:
            if not p.boxes:
                continue
            b = p.boxes[-1]
            verdict = None if p.result is None else VERDICT_LABELS[int(p.result["verdict"])]
            out.append({"track_id": p.track_id, "box": (b.left, b.top, b.w, b.h),
                        "measured": b.conf == 1.0, "verdict": verdict})
        return out

    def end_all(self) -> list[Pedestrian]:
        """End every pedestrian; the ended tracks in id order (`counting.finish_count` stitches
        and judges them)."""
        self._flush()
        for p in list(self.peds):
            self._end(p, "clip-end")
        return sorted(self.finished, key=lambda q: q.track_id)
