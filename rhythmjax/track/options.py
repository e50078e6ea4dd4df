"""The online tracker's options (`tracker.TrackerOptions`): detection settings in pixels and
grey levels, the rules that keep one track on one object, and capacity. Each default says what
it was measured against."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TrackerOptions:
    """Detection settings (px, grey levels) and capacity."""

    diff_threshold: float = 15.0  # |frame difference| threshold, grey levels
    min_area: int = 40  # motion pixels for a new object; with fewer outside every tracked
    # object's boxes the frame is not searched at all (detect.motion_outside)
    outside_margin_px: int = 8  # ... those boxes grown by this on each side: a walker's own
    # swinging limbs just outside its detection box started the search on 28 % of the frames of
    # bench_pipeline's one-walker scene (42 of 149, each ~0.3 ms, every region found excluded as
    # that walker), 1 of 149 with the margin; synthetic seeds 20240603, 777, 5555, 6666: the
    # same verdicts for every object (0: no margin)
    max_objects: int = 8  # object slots advanced together in one jitted call
    window_widths: float = 2.5  # detection window width, in walker widths W
    window_heights: float = 1.45  # detection window height, in walker heights (1.7 m)
    window_raise: float = 0.42  # window centre above the predicted foot point, walker heights
    # (so the window holds the whole body, not only the legs: a legs-only window measured widths
    # of 1-3 px when the legs cross and the width gate (10) rejected them)
    core_widths: float = 1.2  # the predicted body box (W wide, walker height 1.7 m high at the
    core_heights: float = 1.1  # foot point): only motion regions that belong to it are measured
    body_widths: float = 1.8  # the parts of one body (motion regions apart: torso outlines,
    # legs, a bag) within this many W are measured together (detect_in_window's body_px; 0: off).
    # Without it a prediction off by part of a body kept only the near half (a foot point on the
    # wrong part): on the synthetic set 20 of 35 walkers had a 64-frame run on one track, 27 with it
    sample_estimate: bool = True  # window B at the filtered foot point, not the measured one:
    # the measured one scatters ~4 px (20 px when the feet do not move) against a window B of
    # W/5 rows (7 px at 12 m), so the window left the feet (False: the measured one, as before)
    fraction: float = 0.1  # projection slice, fraction of its maximum (0.3 lost the feet: v noisy)
    near_widths: float = 1.0  # a new object whose foot point lies within this many W of a
    # tracked object's predicted foot point is that object, not a new one
    merge_widths: float = 0.5  # two tracks whose estimated foot points stay within this many W
    merge_frames: int = 2  # for this many frames in a row follow one object: the younger ends
    merge_speed_mps: float = 0.6  # ... and their ground velocities differ by less than this
    # (objects crossing in the image move differently; a duplicate moves alike), unless the
    # younger is still settling (fewer than merge_young frames)
    merge_young: int = 10
    shared_overlap: float = 0.5  # two tracks' detections overlapping by this fraction of the
    # smaller box are one (merged) blob: it updates only the track whose predicted foot point is
    # nearest its foot point (in W) when the others' are more than twice as far, else none (they
    # predict); a shared blob's frame gives no rhythm sample (NaN). New objects are not sought
    # inside a tracked object's predicted body box or its detection.
    downscale: int = 4  # new objects are labelled on a 4x smaller mask (detect.find_objects)
    global_change_fraction: float = 0.5  # more than this of the frame changed: a glitch frame
    high_foot_widths: float = 0.0  # a settled track's foot point measured more than this many W
    # above its prediction is dropped (no measurement): the motion's bottom was not the feet
    # (0: off; cli_video.SYNTHETIC_OPTIONS sets 0.25 for the synthetic scenes)
    high_foot_frames: int = 3  # ... for at most this many frames in a row (then the prediction,
    # not the measurement, is taken to be wrong: double support lasts ~2 frames at 15 Hz)
    max_dv_mps: float = 0.0  # a track whose EKF ground velocity changes by more than this
    dv_window_s: float = 1.0  # ... within this long (once 2 spans old) lost its object: it ends
    # without those frames (0: off; 1.8 m/s: synthetic walkers +3 on training seeds, not kept)
    relink_s: float = 3.0  # a track timed out in PREDICT is continued by a new object that
    # appears, within this many s of its last observation, where its ground motion puts it
    # (relink.py; 0: off). Synthetic seeds 20240603, 777, 5555, 6666: bicycles judged 26 -> 29
    # of 40, walkers judged Pedestrian unchanged (122), tracks per walker 1.49 -> 1.34
    relink_gate_w: float = 1.0  # the gate: this many W across ...
    relink_gate_h: float = 0.25  # ... and this many walker heights up or down ...
    relink_gate_per_s: float = 0.5  # ... growing by this fraction per second since then
