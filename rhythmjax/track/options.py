"""The online tracker's options (`tracker.OnlineTracker`), grouped by concern into small frozen
records: the motion image and glitch frames, the detection window, the body measured in it, new
objects, duplicate tracks, re-acquisition. Lengths are in pixels, in walker widths W (the config's
`width.mean` seen at the foot point) or in walker heights (the config's `width.height_m`); grey
levels for thresholds. Each default says what it was measured against.

Change one setting with `with_changes(TrackerOptions(), {"body": {"high_foot_widths": 0.25}})`
(or `dataclasses.replace` on the group and then on the whole).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar

from ..io.files import ACROSS_CANDIDATES, WINDOW_CANDIDATES


__all__ = ["BodyOptions", "MergeOptions", "MotionOptions", "NewObjectOptions", "RecheckOptions",
           "RelinkOptions", "SizeOptions", "TrackerOptions", "WindowOptions", "with_changes"]


@dataclass(frozen=True)
class MotionOptions:
    """The motion image (|frame difference| > threshold) and glitch frames."""

    diff_threshold: float = 15.0  # |frame difference| threshold, grey levels
    global_change_fraction: float = 0.5  # more than this of the frame changed: a glitch frame
    stabilise: bool = True  # move the previous frame onto the current one by the estimated
    # global translation before the difference (vision.stabilise.align_previous: camera shake).
    # Own synthetic scenes (seeds 4100-7100, benchmarks/eval_window_b.py, docs/window_b.md) with
    # 1 px (std) shake per frame: walkers with a Pedestrian window 3/15 -> 11/16 (12/16 without
    # shake); without shake bit-identical. Costs ~0.2 ms a frame behind the screen below
    # (~15 ms on a shaken frame).
    stabilise_min_shift_px: float = 0.3  # ... only when that shift reaches this many px on an
    # axis (below it the frames are used as they are: a fixed camera's D is unchanged)
    stabilise_screen_px: float = 0.2  # ... and the estimate (~1.8 ms) runs only on frames whose
    # cheap screen (vision.stabilise.screen_shift, ~0.2 ms) reads this many px on an axis; chosen
    # on the own scenes: it passes 40 of 537 still frame pairs, misses 1 of 1 487 shaken ones


@dataclass(frozen=True)
class WindowOptions:
    """The detection window around a tracked object's predicted foot point."""

    widths: float = 2.5  # detection window width, in walker widths W
    heights: float = 1.45  # detection window height, in walker heights (1.7 m)
    raise_heights: float = 0.42  # window centre above the predicted foot point, walker heights
    # (so the window holds the whole body, not only the legs: a legs-only window measured widths
    # of 1-3 px when the legs cross and the width gate (10) rejected them)


@dataclass(frozen=True)
class BodyOptions:
    """Which motion in the window is the body, and which foot point and sample it gives."""

    core_widths: float = 1.2  # the predicted body box (W wide, walker height 1.7 m high at the
    core_heights: float = 1.1  # foot point): only motion regions that belong to it are measured
    parts_widths: float = 1.8  # the parts of one body (motion regions apart: torso outlines,
    # legs, a bag) within this many W are measured together (detect_in_window's body_px; 0: off).
    # Without it a prediction off by part of a body kept only the near half (a foot point on the
    # wrong part): on the synthetic set 20 of 35 walkers had a 64-frame run on one track, 27 with it
    slice_fraction: float = 0.1  # projection slice, fraction of its maximum (0.3 lost the feet:
    # v noisy); also for new objects
    column_fraction: float | None = None  # a number: where a detection is wider than its
    # predicted body box (core_widths W), its foot column u_p is the centre of the columns
    # reaching this fraction of the vertical projection's maximum (the body's core: a trailing
    # suitcase or a bag does not pull it aside; `detect.detect_in_window`); None: the centre of
    # the slice fraction's extent, the paper's reading, everywhere. Width and foot row
    # unchanged; new objects and the shared-blob split's re-detections (as wide as the box)
    # never widen past it. Rule 32b (0.3, a priori): off, it lost walkers and pace on most own
    # sources (docs/rules.md)
    column_rows: float | None = 0.5  # a fraction: with column_fraction None, where a detection
    # is wider than its predicted body box its u_p is the centre of the slice extent of the
    # columns' motion over the top column_rows of its rows (torso and head, above a suitcase
    # and the legs' swing); None: never. Rule 33 (0.5, a priori; docs/rules.md); on since issue
    # 16's fifty-fourth round, with column_filter_only (rule 54), decision 55
    column_filter_only: bool = True  # rule 54: the column column_fraction or column_rows
    # moves is the filter's measurement (the track's foot point) only; window B and its
    # candidates stay at the slice extent's centre, the paper's u_p (`Detection.window_u`),
    # and the detection's box stays the extent's (False with column_rows: rule 33, which moves
    # window B and the box too). On with rule 55 (`RecheckOptions.strongest_pace`) since
    # decision 55 (fresh own 9340001-9890001: walkers 1718 -> 1751 of 1960, non-walkers
    # 20 -> 12 of 840, pace no worse on any pool; dev 8 -> 10 of 10; docs/rules.md, rule 55)
    column_everywhere: bool = False  # rule 54b: the column rules act on every detection with
    # a predicted body box, not only where wid_IMG is wider than it (the moved column then
    # never toggles with the width from frame to frame)
    shared_overlap: float = 0.5  # two tracks' detections overlapping by this fraction of the
    # smaller box are one (merged) blob: it updates only the track whose predicted foot point is
    # nearest its foot point (in W) when the others' are more than twice as far, else none (they
    # predict); a shared blob's frame gives no rhythm sample (NaN). New objects are not sought
    # inside a tracked object's predicted body box or its detection.
    split_shared: bool = True  # a shared blob is split between its sharers: each is detected
    # again in a window as wide as its predicted body box (core_widths W), parts not joined; one
    # whose re-detection overlaps no other sharer's (shared_overlap) and lies within
    # split_near_widths W of its predicted foot point takes it as its measurement (and its
    # rhythm sample); the others as above (track/split.py; docs/rules.md, "Why walkers are
    # missed"). On since issue 16's sixth round, with split_depth_widths 0.5 (alone it lost a
    # walker and added a non-walker on own seed 777001; with the depth split it gains on every
    # source it was not chosen on: docs/rules.md, "A split by depth")
    split_near_widths: float = 0.3  # ... the re-detected foot point's distance to the
    # predicted one, at most, in W; chosen on own training seeds 5555 and 6666 only (0.15-0.5
    # tried, benchmarks/study_missed_walkers.py): 0.3 gains the most walkers (+3, +1) and no
    # non-walker there
    split_depth_widths: float = 0.5  # with split_shared, a sharer left whose predicted foot row
    # lies more than this many W below every other sharer over its columns (in front of them)
    # is re-detected in the rows below their foot rows only (track/split.py `front_split`);
    # 0: off. 0.5 chosen on own training seeds 5555 and 6666 (0.3-0.7 all gain there); on the
    # sources it was not chosen on, walkers judged Pedestrian: own 20240603 31 -> 34, 777001
    # 30 -> 32, PETS09 15 -> 17 of 19, dev, UCSD and CASIA-B unchanged, no non-walker more
    # (docs/rules.md, "A split by depth")
    split_depth_margin_widths: float = 0.1  # ... the strip starts this many W below the
    # lowest of the others' predicted foot rows
    sample_estimate: bool = False  # window B at the measured foot point, the paper's (Sec. 4.1);
    # True: at the filtered one (the measured one scatters ~4 px against a window B of W/5 rows).
    # True was chosen on own seeds 779 and 777 (b02e743) and is off by default since issue 16:
    # on sources it was not chosen on it cost walkers (PETS09 13 -> 11 of 19, UCSD 36 -> 34
    # tracks, own seed 999001 30 -> 28 of 35) and judged a non-walker more Pedestrian on own
    # seeds 777001 and 888001; it gained one dev walker (docs/rules.md)
    lean_column: bool = False  # rule 41: window B's column (and the candidates') on a measured
    # frame moved by u(0) - u(H/2) at the ground point of the foot point, H the config's walker
    # height: an upright body off the image's centre leans outwards, and the motion's extent
    # (u_p its centre) spans it from the feet to the head (track/lean.py). Off: the paper's u_p
    # (docs/rules.md, rule 41)
    mass_column: bool = False  # rule 48: window B's column on a measured frame the mean column of
    # the motion (D > diff_threshold) in the box u_p +- W wide and one walker height high above
    # the foot row (track/lean.py `motion_column`). Off: the paper's u_p (docs/rules.md, rule 48)
    mass_crossing: float = 0.0  # rule 48b: with mass_column, only where the track's ground velocity
    # crosses the camera's line of sight at an angle with at least this sine (`crossing_sine`);
    # 0: everywhere
    side_anchor: bool = False  # a detection whose box reaches the image's left or right side
    # and is narrower than W has its foot column placed W/2 from its inner edge (track/sides.py):
    # a walker entering or leaving is measured at its own centre, not at its visible part's.
    # Off: own training seeds 5555, 6666 walkers 64 -> 64, but own 777001 32 -> 29 of 35 and one
    # UCSD anomaly track more judged Pedestrian (the dev clips, where it was seen: 8 -> 9 of 10;
    # docs/rules.md, rule 16)
    high_foot_widths: float = 0.0  # a settled track's foot point measured more than this many W
    # above its prediction is dropped (no measurement): the motion's bottom was not the feet
    # (0: off; sim.presets.SYNTHETIC_OPTIONS sets 0.25 for the synthetic scenes)
    high_foot_frames: int = 3  # ... for at most this many frames in a row (then the prediction,
    # not the measurement, is taken to be wrong: double support lasts ~2 frames at 15 Hz)
    window_candidates: bool = True  # candidate windows B (issue 16, item 2): I(k) summed also
    # in window B moved by -0.2, -0.1 and +0.1 W (io.files.WINDOW_CANDIDATES), written as the
    # tracks' candidate columns; each rhythm window is judged once per candidate and the one
    # whose strongest spectral peak is highest decides (model.candidates.strongest). Helps
    # where the foot point is a few px off the feet (a shadow, the ground below them). Offsets
    # set a priori, nothing chosen on any source. ON against OFF through this tracker
    # (benchmarks/eval_rules.py run candidates on|off; docs/window_b.md): walkers judged
    # Pedestrian own seeds 5555, 6666, 20240603 +0, 777001 +1; dev clips 6 -> 8 of 9; PETS09
    # 13 -> 15 of 19, its annotated boxes (rhythm --boxes) 17 -> 19; UCSD +2 walker tracks;
    # CASIA 14/14 either way; none fewer anywhere. Non-walkers judged Pedestrian: one dog more
    # on own seed 5555 and UCSD's cart (Test004, a walker crossing it) more. Pace MAE and step
    # error better on every scored source. Costs three window-B sums a row and three more
    # (13)-(15) a rhythm window (bench_pipeline: -4 % fps with 1 object, -14 % with 5)
    window_per_pixel: bool = False  # rule 35 (issue 16): I(k) as the mean of D over window B
    # (grey levels per pixel) instead of its sum (Sec. 4.1), candidate and pace windows alike.
    # Window B is W x W/5 px and a walker's feet fill it alike at any distance, so the sum grows
    # with W^2 as a walker comes nearer: a trend over a rhythm window of one walking towards or
    # away from the camera; the mean has none. Chosen on own scenes with knees (docs/rules.md,
    # rule 35)
    window_mean_refused: bool = True  # rule 35b (issue 16): where a rhythm window judged on the
    # sum I(k) (candidates and rule 37 included) is not Pedestrian, it is judged again on the
    # same windows' mean of D per pixel (rule 35's I(k)), whose Pedestrian outcome then decides;
    # every window the sum judges Pedestrian keeps the sum's outcome (toolkit.match_window).
    # Ignored with window_per_pixel. Found on used radial seeds 4520001-4590001 (rule 35 moved 11
    # walkers to Pedestrian there and none back). On with its gate (rule 35c); alone it judged a
    # bicycle and a cyclist Pedestrian (docs/rules.md)
    mean_refused_gate: bool = True  # rule 35c (issue 16, with window_mean_refused): the mean is
    # read only where the sum's strongest peak lies below half the slowest walking pace (a trend,
    # toolkit.refused_for_trend), and its Pedestrian outcome stands only where neither half of
    # the window moves faster than any walk (toolkit.fast_half). Nothing fitted (Table 1 at
    # k_sigma3); found on used radial 4640001-4710001, 777001 and UCSD Test010; decided on fresh
    # radial 4880001-4950001 (walkers 239 -> 246 of 280, non-walkers 1 -> 1; docs/rules.md)
    pace_window_widths: float = 0.0  # rule 34 (issue 16): I(k) summed also in window B scaled
    # by this (2: 2 W wide, 2 W/5 high, bottom row at the foot row), written as the tracks'
    # `intensity_wide` column; it never decides a verdict, but where a rhythm window says
    # Pedestrian and this window over the same rows does too, the track's pace and stride are
    # read from it (model.candidates.strongest). Off: 2 lowered the pace error of own walkers
    # crossing the view (0.034 -> 0.026, 0.029 -> 0.024 Hz on two fresh pools) but raised it on
    # the dev clips, whose walkers all cross it (0.016 -> 0.024 Hz; docs/rules.md, rule 34)
    across_candidates: bool = True  # rule 50b (issue 16): I(k) summed also in window B moved
    # 0.1 W left and right on its row (io.files.ACROSS_CANDIDATES), written as two more tracks'
    # columns after the candidates'; they decide a rhythm window only where (13)-(15) at their
    # own strongest peak say Pedestrian (never through rule 37, through rule 26 as every window;
    # model.candidates.judged, read by every classifier). Own crossing walkers' pace 0.0025-
    # 0.0041 Hz better on five fresh pools, radial within 0.0002 Hz, no verdict moved on dev,
    # PETS09, CASIA-B (docs/rules.md, rules 50 and 50b; on since the fifty-first round, its
    # decision 51). May be on with the pace window (whose channel stays last)

    def column_rules(self) -> dict:
        """`detect.detect_in_window`'s arguments for the foot column rules (32b, 33, 54b)."""
        return dict(column_fraction=self.column_fraction, column_rows=self.column_rows,
                    column_wide_px=0 if self.column_everywhere else None,
                    column_box=not self.column_filter_only)

    def candidate_offsets(self) -> tuple[tuple[float, ...] | None, tuple[float, ...]]:
        """(window B's candidate offsets down, in W, or None without candidate windows; its
        offsets across, in W, empty unless rule 50b): `io.files`' WINDOW_CANDIDATES and
        ACROSS_CANDIDATES as this record switches them."""
        down = tuple(float(o) for _, o in WINDOW_CANDIDATES) if self.window_candidates else None
        return down, tuple(float(o) for _, o in ACROSS_CANDIDATES) if self.across_candidates \
            else ()


@dataclass(frozen=True)
class NewObjectOptions:
    """Where and how new objects are sought (outside every tracked object)."""

    min_area: int = 40  # motion pixels for a new object; with fewer outside every tracked
    # object's boxes the frame is not searched at all (detect.motion_outside)
    outside_margin_px: int = 8  # ... those boxes grown by this on each side: a walker's own
    # swinging limbs just outside its detection box started the search on 28 % of the frames of
    # bench_pipeline's one-walker scene (42 of 149, each ~0.3 ms, every region found excluded as
    # that walker), 1 of 149 with the margin; synthetic seeds 20240603, 777, 5555, 6666: the
    # same verdicts for every object (0: no margin)
    near_widths: float = 1.0  # a new object whose foot point lies within this many W of a
    # tracked object's predicted foot point is that object, not a new one
    downscale: int = 4  # new objects are labelled on a 4x smaller mask (detect.find_objects)


@dataclass(frozen=True)
class MergeOptions:
    """Two tracks following one object: the younger ends."""

    widths: float = 0.5  # two tracks whose estimated foot points stay within this many W
    frames: int = 2  # for this many frames in a row follow one object: the younger ends
    speed_mps: float = 0.6  # ... and their ground velocities differ by less than this
    # (objects crossing in the image move differently; a duplicate moves alike), unless the
    # younger is still settling (fewer than TrackerOptions.settled_frames rows)


@dataclass(frozen=True)
class RelinkOptions:
    """Re-acquisition of a lost track (`relink.py`)."""

    within_s: float = 3.0  # a track timed out in PREDICT is continued by a new object that
    # appears, within this many s of its last observation, where its ground motion puts it
    # (relink.py; 0: off). Synthetic seeds 20240603, 777, 5555, 6666: bicycles judged 26 -> 29
    # of 40, walkers judged Pedestrian unchanged (122), tracks per walker 1.49 -> 1.34
    gate_w: float = 1.0  # the gate: this many W across ...
    gate_h: float = 0.25  # ... and this many walker heights up or down ...
    gate_per_s: float = 0.5  # ... growing by this fraction per second since then
    side_rows: float = 0.25  # rule 57 (N's fraction, 0: off): at the end, a relink whose rows
    # next to its gap (this many N a side) move faster on a side than the fastest walk (14) is
    # undone, each side judged afresh (`relink.fast_gap`); on since issue 16's 57th round

    def __post_init__(self):
        if not 0.0 <= self.side_rows <= 1.0:
            raise ValueError(f"relink.side_rows is a fraction of N in [0, 1], "
                             f"got {self.side_rows!r}")


HEIGHT_SCOPES = ("window", "track", "window-or-track")  # `size.min_height_scope`


@dataclass(frozen=True)
class SizeOptions:
    """A judged track's measured height against a walker's (rule 26, issue 16; `track.size`)."""

    min_height_heights: float = 0.5  # a track judged Pedestrian whose median height (the top
    # row's height above its foot point through the camera, `camera_np.height_of_top`) is below
    # this many walker heights (`width.height_m`) is Non-pedestrian, reason too-low (0: off,
    # the paper's verdict; 0.5 a priori, half a walker: the own dogs measure 0.5-0.7 m). On
    # since issue 16's thirty-first round, with rules 29 and 30a on (docs/rules.md, rule 26d);
    # it reads heights through the camera, so a wrong camera can refuse walkers
    min_height_rows: int = 10  # ... read on at least this many rows (those with a top row where
    # a walker's head would be inside the image, `size.median_height`; fewer: the verdict stands)
    every_window: bool = True  # rule 45 (issue 16): the tracker applies rule 26 to each rhythm
    # window as it completes (its second look, after rule 37), so a window too low for a walker
    # is refused and the next one judged, as the batch classifier does (`size.batch_size_look`);
    # off: rule 26 on the deciding window at the track's end. Found on own 777001 scene 8 with
    # straight legs; on since the forty-sixth round (fresh 5000001-5110001: walkers 378 -> 379
    # of 420, non-walkers 2 -> 2; docs/rules.md, rule 45)
    min_height_scope: str = "window"  # the rows read: "window", those of the track's deciding
    # rhythm window (rule 26c: a track re-acquired onto another object keeps the height of the
    # one its verdict was judged on); "track", every row (rule 26b); "window-or-track", the
    # window's, every row where the window has fewer than min_height_rows (rule 26f)
    top_inside_heights: float = 0.1  # rule 36 (on since issue 16's thirty-eighth round): a row
    # where a walker's head would leave the image also counts when its measured top row lies at
    # least this many walker heights (px at that row) below the image's top edge: the object's
    # own top is seen, so it is shorter than a walker there (a walker's top is the edge). 0.1 a
    # priori; 0: off (rule 26's rows only)
    twice_pace_heights: float = 0.57  # rule 37 (on since issue 16's thirty-eighth round): a
    # window refused by (14) whose strongest peak passes (14) at half its frequency and twice
    # the step (a walker seen from behind or in front: two bursts a step) is Pedestrian there
    # when its rows' median height is at least this many walker heights (`track.twice`); 0:
    # off. Fitted in the fortieth round (`fit.heights`, walkers against dogs, own knees tracks
    # 5555, 6666, 2830001-2860001; held-out 2870001-2920001 balanced accuracy 0.993, 0.954 at
    # the a priori 0.75); on fresh 2930001-2980001: walkers 182 -> 183 of 210, no non-walker
    # more; dev, PETS09, UCSD, CASIA-B unchanged (docs/rules.md)
    twice_pace_edge: bool = True  # rule 37b: rule 37's height reads also the rows whose
    # motion reached the image's first row (the head above the view, `TrackRow.top_at_edge`),
    # each at the height up to that row, a lower bound (`track.twice.twice_height`). On since
    # issue 16's thirty-ninth round: fresh own knees radial 168 -> 170 of 210 walkers, crossing
    # 62 -> 63 of 70, no non-walker more; dev, PETS09, UCSD, CASIA-B unchanged (docs/rules.md)
    twice_pace_sub: float = 0.0  # rule 49: rule 37 only where the window also has a peak within
    # 0.2 Hz of half its strongest (the walker's own pace) of at least this fraction of its power
    # (`track.twice.reads_twice`); 0: off (docs/rules.md, rule 49)
    twice_pace_quantile: float = 0.5  # rule 53: rule 37's height (and rule 46's) is this
    # quantile of the heights its rows read, not their median (0.5): with 0.25, three quarters
    # of the rows must reach `twice_pace_heights`, so a dog whose moving region merges with a
    # walker just behind it for part of its window (the walker's head read as its top) is not
    # read as tall (`track.twice.twice_height`; docs/rules.md, rule 53)
    stride_peak: bool = True  # rule 56: a window refused by (14) whose strongest peak passes
    # (14) at twice its frequency (a walker's stride frequency, F/2: one foot hidden, by a
    # suitcase seen from behind) is Pedestrian there on rule 37's height (`track.twice`).
    # On since decision 56 (issue 16's fifty-fifth round): fresh own 9900001-10450001 walkers
    # 1758 -> 1770 of 1960 (radial suitcases 242 -> 251 of 280), non-walkers 10 -> 10 of 840

    def __post_init__(self):
        for name in ("top_inside_heights", "twice_pace_heights", "twice_pace_sub"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"size.{name} must be >= 0, got {getattr(self, name)}")
        if not 0.0 <= self.twice_pace_quantile <= 1.0:
            raise ValueError(f"size.twice_pace_quantile must lie in [0, 1], "
                             f"got {self.twice_pace_quantile!r}")
        if self.min_height_scope not in HEIGHT_SCOPES:
            raise ValueError(f"size.min_height_scope must be one of {HEIGHT_SCOPES}, "
                             f"got {self.min_height_scope!r}")


EARLIER_TESTS = ("off", "speed", "any", "resolved", "speed-low")  # `recheck.earlier`


@dataclass(frozen=True)
class RecheckOptions:
    """A Pedestrian track's later rhythm windows (rule 29, issue 16; `track.recheck`)."""

    enabled: bool = True  # at the end, a track judged Pedestrian is split at the first of its
    # windows after the deciding one that moves faster than any walk (14) accepts (2.57 m/s)
    # or has a peak faster than its fastest pace (2.60 Hz): an identity switch onto a bicycle
    # or a dog after the verdict; the rows from it are a new track judged afresh (False: the
    # paper's, one verdict per track; on since issue 16's thirtieth round, docs/rules.md, rule 29)
    tail: bool = True  # rule 30a (with `enabled`): where the windows after the deciding one
    # leave the track's last rows unjudged, the window of its last N rows is judged too (a
    # switch less than N rows before the end); cut at its first row or the deciding window's
    # end, whichever is later (on since issue 16's thirty-first round, docs/rules.md, rule 30a)
    earlier: str = "speed-low"  # the windows before the deciding one judged too, one refused
    # cutting the track at the deciding window's first row (the rows before, a bicycle's or a
    # dog's before the walker's, become a new track judged afresh): "speed-low", by rule 29's
    # speed or by rule 26's height test (`size`'s options; rule 30d, `recheck.low_window`; on
    # since issue 16's forty-fourth round: fresh own radial 4400001-4470001 non-walkers 4 -> 2
    # of 120, walkers 240 -> 241 of 280); "any", by rule 29's speed or pace (rule 30: failed on
    # PETS09 at 7 fps, where walkers' windows peak at 2.8-3.3 Hz); "speed", by its speed alone
    # (rule 30b); "resolved", rule 30's test where the frame rate resolves a walker's second
    # harmonic at the fastest pace, else 30b's (rule 30c, `recheck.pace_resolved`); "off"
    # (docs/rules.md, rules 30, 30b, 30c, 30d)
    halves: bool = False  # rule 42 (with `enabled`): a window is also no walker's where one of
    # its halves (N/2 rows) moves faster than any walk (12), (14): a deciding window holding a
    # walker and then a bicycle is cut at its middle, the verdict kept by the slow half's side,
    # the other side judged afresh; a later or tail window so refused cuts at that half (off:
    # fresh own seeds lost walkers, issue 16's forty-third round; `recheck.mixed_window_row`,
    # docs/rules.md, rule 42)
    halves_around: bool = False  # rule 44 (with `enabled`): rule 42's half test on the windows
    # before and after the deciding one, never on the deciding one: a window before it with a half
    # faster than any walk cuts the track at the deciding window's first row, one after it at that
    # half (`recheck.earlier_switch_row`, `switch_row`); a walker's track that followed a bicycle
    # for less than a window before or after its verdict (docs/rules.md, rule 44)
    pace_tall: bool = True  # rule 46 (with `enabled`): a later or tail window refused by rule
    # 29's pace test alone is kept where its rows are as tall as a walker by rule 37's height
    # test (`size`'s `twice_pace_heights`; `recheck.walker_tall`): a walker read at a multiple of
    # its pace is not a dog (on since issue 16's forty-seventh round: fresh own pools walkers
    # 1496 -> 1497 of 1680, non-walkers equal; UCSD walker tracks no longer cut; docs/rules.md)
    low: bool = False  # rule 43 (with `enabled`): rule 26's height test (`size`'s options:
    # 0.5 walker heights over 10 rows) refuses a later or tail window too, and reads the windows
    # before the verdict (with `earlier`'s test where that is on): a dog's rows before or after
    # its walker's deciding window cut off (`recheck.low_window`; docs/rules.md, rule 43)
    median_pace: bool = False  # rule 47 (with `enabled`, after the cuts): a Pedestrian track's
    # pace and stride are the medians over its windows judged Pedestrian (the deciding one and
    # the later ones, the tail window with `tail`), not the deciding window's alone; its verdict
    # stays the deciding window's (`recheck.median_pace`). Off: fresh own pools' pace MAE fell
    # (radial 0.0198 -> 0.0190, crossing 0.0320 -> 0.0307 Hz) but the own knees radial rose
    # 0.0197 -> 0.0325 Hz (one walker at 1.60 Hz read 2.42 Hz by its later windows) and the
    # dev clips' 0.0163 -> 0.0181 Hz (issue 16's forty-eighth round; docs/rules.md, rule 47)
    strongest_pace: bool = True  # rule 55 (with `enabled`, after the cuts; rule 47 takes its
    # place where on): a Pedestrian track's pace and stride are those of its window judged
    # Pedestrian (as rule 47's) whose chosen peak is the strongest (P of (13)), not the deciding
    # window's; its verdict stays the deciding window's (`recheck.median_pace`). On since issue
    # 16's fifty-fourth round: alone, the pace better on six fresh own pools (crossing 0.0300 ->
    # 0.0267 Hz) and the dev clips (0.0157 -> 0.0080 Hz), no verdict moved (decision 55a);
    # with rule 54 decision 55 (docs/rules.md, rule 55)

    fast_stretch: float = 0.0  # rule 52 (with `enabled`; N's fraction, 0: off): after the
    # deciding window, stretches of this fraction of N rows (one every half stretch, and the
    # track's last) are read too; the first whose filter's ground speed (median) is above the
    # fastest walk (14) (2.57 m/s) cuts the track at its first row, the rows from it judged
    # afresh: a walker's track that a passing bicycle took over for fewer than N rows at its
    # end (`recheck.fast_stretch_row`; docs/rules.md, rule 52)

    def __post_init__(self):
        if not 0.0 <= self.fast_stretch <= 1.0:
            raise ValueError(f"recheck.fast_stretch is a fraction of N in [0, 1], "
                             f"got {self.fast_stretch!r}")
        if self.earlier not in EARLIER_TESTS:
            raise ValueError(f"recheck.earlier must be one of {EARLIER_TESTS}, "
                             f"got {self.earlier!r}")


@dataclass(frozen=True)
class TrackerOptions:
    """Capacity, the settling age, and one record per concern (each frozen)."""

    max_objects: int = 8  # object slots advanced together in one jitted call
    settled_frames: int = 10  # a track with fewer rows is still settling: a duplicate of it
    # merges whatever its speed, its high foot points are kept, it is not re-acquired
    motion: MotionOptions = field(default_factory=MotionOptions)
    window: WindowOptions = field(default_factory=WindowOptions)
    body: BodyOptions = field(default_factory=BodyOptions)
    new: NewObjectOptions = field(default_factory=NewObjectOptions)
    merge: MergeOptions = field(default_factory=MergeOptions)
    relink: RelinkOptions = field(default_factory=RelinkOptions)
    size: SizeOptions = field(default_factory=SizeOptions)
    recheck: RecheckOptions = field(default_factory=RecheckOptions)


Options = TypeVar("Options")


def with_changes(options: Options, changes: Mapping[str, Any]) -> Options:
    """A copy of a grouped options record (`TrackerOptions`, `count.options.CountOptions`) with
    `changes` applied: top-level fields by name, a group's fields as a nested mapping
    (``{"max_objects": 24, "body": {"high_foot_widths": 0.25}}``), or dotted
    (``{"body.high_foot_widths": 0.25}``). An unknown name raises `KeyError` naming it."""
    nested: dict[str, Any] = {}
    for key, value in changes.items():
        group, dot, name = key.partition(".")
        if dot:
            nested.setdefault(group, {})[name] = value
        elif isinstance(value, Mapping):
            nested.setdefault(key, {}).update(value)
        else:
            nested[key] = value
    fields = {f.name for f in dataclasses.fields(options)}
    top = {}
    for key, value in nested.items():
        if key not in fields:
            raise KeyError(f"{type(options).__name__} has no field {key!r} "
                           f"(known: {', '.join(sorted(fields))})")
        if isinstance(value, dict):
            group = getattr(options, key)
            known = {f.name for f in dataclasses.fields(group)}
            for name in value:
                if name not in known:
                    raise KeyError(f"{type(group).__name__} has no field {name!r} "
                                   f"(known: {', '.join(sorted(known))})")
            value = dataclasses.replace(group, **value)
        top[key] = value
    return dataclasses.replace(options, **top)
