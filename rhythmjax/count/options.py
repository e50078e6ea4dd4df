"""`CountOptions`: the settings of the tracking paper's three levels, of stitching and of the
counting rule, grouped by concern into small frozen records: background and blobs, patch
placement, new pedestrians, a pedestrian's life (confirmation, duplicates, ends), stitching,
verdicts. Units: px, grey levels, frames, s, patch widths W and heights H (the config's
`width.mean` and `width.height_m` seen at the foot point).

Change one setting with `track.options.with_changes(CountOptions(), {"stitch.enabled": False})`
(or `dataclasses.replace` on the group and then on the whole).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..track.options import with_changes
from ..vision.fg_threshold import check_noise_options
from .patches import DYNAMICS
from .slot_filter import OUTLIER_GATES, check_noise


__all__ = ["AppearanceOptions", "BlobOptions", "CountOptions", "ExplainOptions", "LifeOptions",
           "NewPedestrianOptions", "PlacementOptions", "StitchOptions", "VerdictOptions",
           "WINDOW_COLUMNS", "with_changes"]


SPEED_FITS = ("lsq", "theil-sen")  # `verdicts.speed_fit`, `count.track_speed`
WINDOW_COLUMNS = ("measured", "estimate")  # `placement.window_column`


@dataclass(frozen=True)
class BlobOptions:
    """The images and blobs levels: background model, foreground mask, blobs, crowd frames."""

    bg_alpha: float = 0.05  # background learning rate where nothing moves
    bg_threshold: float = 20.0  # |frame - background| threshold, grey levels
    open_px: int = 1
    close_px: int = 2
    min_area: int = 30  # px
    crowd_fraction: float = 0.5  # one blob box covering this fraction: no detection that frame
    bg_init_s: float = 0.0  # > 0: background from the temporal median of the first seconds
    bg_init_frames: int = 31  # ... of at most this many frames, evenly spaced (0 s: frame 0;
    # `still.peek_background`, which holds every frame of those seconds in memory until the
    # count has read them again: 0.3 MB a second at 640x480 and 1 fps, so 7.7 MB at 25 fps)
    # noise-adaptive threshold (`vision.fg_threshold`, docs/rules.md "Noise-adaptive foreground
    # threshold"): noise_k > 0 replaces bg_threshold by max(noise_floor, noise_k x sigma), sigma
    # the frame's robust (MAD) noise of frame - background, grey levels; 0: fixed bg_threshold
    noise_k: float = 0.0
    noise_floor: float = 6.0  # grey levels
    hysteresis: float = 0.0  # in (0, 1): also pixels above this x the threshold ...
    hysteresis_px: int = 2  # ... within this many px of one above it (0: off)

    def __post_init__(self):
        check_noise_options(self.noise_k, self.noise_floor, self.hysteresis, self.hysteresis_px)

    def model_kwargs(self) -> dict:
        """The keyword arguments of `vision.blobs.BackgroundModel` these settings give."""
        return {"alpha": self.bg_alpha, "threshold": self.bg_threshold, "open_px": self.open_px,
                "close_px": self.close_px, "noise_k": self.noise_k,
                "noise_floor": self.noise_floor, "hysteresis": self.hysteresis,
                "hysteresis_px": self.hysteresis_px}


@dataclass(frozen=True)
class PlacementOptions:
    """Placing a tracked pedestrian's patch on its blobs."""

    search_widths: float = 0.75  # placement search radius, W (a pedestrian alone on its blobs)
    shared_search_widths: float = 0.3  # ... when it shares a blob with others
    merge_widths: float = 0.75  # shared blob narrower than this x summed W: predict only
    min_cover: float = 0.08  # a placement must cover this fraction of its patch
    # gates on the placed foot point (`count.foot_gate`): a gated placement is no measurement
    in_range: bool = False  # (a) its ground point at/above the horizon or beyond range_max
    gate_heights: float = 0.0  # (a) > 0: its ground point this many walker heights (width.height
    # m) or more from the predicted foot point's
    lift_heights: float = 0.0  # (b) > 0: the blob bottom under the patch this many H above the
    # predicted foot row (legs not visible)
    lift_keep_u: bool = False  # (b) ... then measured across only, at the predicted foot row
    outlier_gate: str = "none"  # "3d": a gate on every measurement (`OUTLIER_GATES`): "paper",
    # the rhythm paper's (11); "innovation", nu^T S^-1 nu; both at thresholds.k_sigma2; a
    # refused measurement is not used, the pedestrian predicts
    depth_order: bool = False  # patches placed nearest first; a shared one whose feet stand on
    # a nearer patch's claimed pixels measured across only (`count.occlusion`)
    wide_widths: float = 0.0  # > 0: one alone on blobs wider than this many W is placed as a
    # shared one, its foot row used only within k_sigma2 r_std_v of the prediction (occlusion)
    shared_row_gate: bool = False  # one sharing its blob whose placed foot row lies beyond
    # k_sigma2 r_std_v of the prediction takes no measurement: it predicts (`count.occlusion`)
    shared_row_unsampled: bool = False  # ... and such a row gives no rhythm sample (NaN I(k))
    window_column: str = "measured"  # window B's column on a measured frame (`WINDOW_COLUMNS`):
    # "measured", the placed foot point's; "estimate", the filter's posterior column (the foot
    # row stays the measured one; issue 16, twenty-fourth round)
    noise: tuple | list = ()  # (q_x, q_y m/s/sqrt(s), r_u, r_v px, r_corr): the counting filter's
    # noise instead of the config's (`slot_filter.filter_config`; () the config's)

    def __post_init__(self):
        object.__setattr__(self, "noise", tuple(float(x) for x in self.noise))  # JSON lists
        if self.window_column not in WINDOW_COLUMNS:
            raise ValueError(f"placement.window_column must be one of {WINDOW_COLUMNS}, "
                             f"got {self.window_column!r}")


@dataclass(frozen=True)
class NewPedestrianOptions:
    """Starting pedestrians on blob columns no patch explains (refinement)."""

    walker_widths: float = 1.8  # blob width of one walking pedestrian (stance foot to the
    # leading arm: ~2 W measured on synthetic walkers); a patch explains that much of a blob
    min_widths: float = 0.6  # unexplained blob columns needed to start a pedestrian, W
    min_fill: float = 0.15  # ... holding at least this fraction of a patch area in pixels
    min_height: float = 0.5  # ... spanning at least this many H
    max_lift: float = 0.25  # ... reaching down to within this many H of the blob's bottom,
    lifted_height: float = 0.55  # ... or, lifted higher, spanning this fraction of its H
    # (clipped at the image top) at its own foot point: a farther walker merged with a nearer one
    in_range: bool = True  # ... standing in the config's detection range (ground y, m)
    head_feet: float = 0.0  # > 0: a run taller than this many H of a walker standing on its
    # bottom (legs lost in the mask) starts its walker with the feet where its top row is a
    # head (`count.head_feet`; 1.25 = `head_feet.TALL_HEIGHTS` when on)
    head_feet_out_of_range: bool = False  # ... only where a walker standing on the run's bottom
    # would have no size or stand outside the detection range (`refinement.starts_on`: the legs
    # lost, the bottom the hips near the horizon); a run whose bottom starts one in range is
    # left as it is (issue 16, twenty-fifth round)
    cover_to_feet: bool = True  # a cover explains its columns only down to its pedestrian's
    # foot row plus the row tolerance (k_sigma2 r_v px); blob pixels lower there are free (a
    # nearer walker in front of it: `refinement.free_runs`; issue 16, twenty-sixth round, on;
    # False: the whole column, as before)
    join_gap_widths: float = 0.0  # > 0: runs of free columns of one blob less than this many W
    # apart (W at the blob's bottom row) are one run: a walker's two legs under another's cover
    # (`refinement.free_runs`; issue 16, twenty-sixth round; off)
    fill_exposed: bool = False  # a run under a cover asks `min_fill` of its patch's part below
    # the covers only (`refinement.free_runs`; issue 16, twenty-sixth round; off)


@dataclass(frozen=True)
class LifeOptions:
    """A pedestrian's life: confirmation, duplicates, and the end of one that lost its walker
    (one without measurement coasts for the config's `thresholds.predict_timeout_s`)."""

    confirm_hits: int = 3
    tentative_misses: int = 2
    duplicate_widths: float = 0.6  # foot points closer than this many W ...
    duplicate_frames: int = 3
    max_dv_mps: float = 1.5  # "3d": a track whose ground velocity changes by more than this
    dv_window_s: float = 0.5  # ... within this long lost its object: it ends before the change
    # (1.5 m/s in 0.5 s is 3 m/s^2: no walker turns or brakes that hard, while a patch moving
    # between two walkers crossing at right angles at 1.4 m/s changes by 2 m/s)
    max_dv_w: float = 0.0  # > 0: the same test in the image instead, the foot point's image
    # velocity changing by more than this many W/s (`track.toolkit.image_velocity_jump`; off)
    jump_sigma: float = 0.0  # > 0 ("3d"): the m/s test fires only on a change also over this
    # many standard deviations of the filter's own velocity noise (`velocity_jump`'s sigma; off)
    jump_rewind: bool = False  # "3d": at a velocity jump the track does not end: its implausible
    # rows go and its filter goes back to its state at the last kept row (`count.rewind`; off)
    rewind_across: bool = False  # ... and it is then measured across only (u placed, v its
    # predicted row) while its placed foot row is beyond `occlusion.foot_row_tolerance` (off)
    rewind_off_rows: bool = False  # ... only the rows from the first whose foot row was beyond
    # that tolerance of its prediction go (`count.rewind`; off)
    rewind_predict: bool = False  # ... and it predicts while its placed row stays off (off)
    merge_hold_s: float = 0.0  # > 0: one keeping its prediction in a merge it entered measured
    # does not run the PREDICT time-out, for up to this many s (`count.coast`; 0: off)
    still_s: float = 5.0  # a pedestrian whose foot point stays put this long ends (0: never)
    still_widths: float = 0.15  # ... its 1 s block means within this many W across
    still_heights: float = 0.04  # ... and this many H up or down (`still.is_still`)


@dataclass(frozen=True)
class StitchOptions:
    """Joining fragments of one walker (`count.stitch_pieces`)."""

    enabled: bool = True  # join fragments of one walker (count.stitch_pieces)
    max_gap_s: float = 5.0  # from a track's last measured frame to the next one's first
    # (a walker passing behind a near one stays hidden for seconds: a 0.5 m wide walker 3 m
    # away hides 2.5 m at 15 m, 1.8 s of a 1.4 m/s crossing, longer behind a group; measured
    # on the synthetic scenes, correct links with 3-5 s gaps fit within 0.3-0.7 of the gate)
    gate_w: float = 0.9  # foot point misfit allowed at zero gap: this many W across ...
    gate_h: float = 0.45  # ... and this many H up or down ...
    gate_per_s: float = 0.5  # ... growing by this fraction per second of gap
    max_dv_w: float = 2.0  # image velocity misfit allowed, W/s
    fit_s: float = 1.0  # measured foot points fitted at a track's start (and end)
    reid: bool = False  # also re-identify on the ground plane: a later track whose first foot
    # point lies where the ended one's last ground state, moved on at constant velocity for the
    # whole gap, puts it (same gate: gate_w W, gate_h H, growing gate_per_s per s of gap)
    # continues it (`count.stitch.reid_distance`, `track.relink.gate_distance`)
    reid_max_dv_w: float = 2.0  # ... with image velocities within this many W/s (inf: any)
    max_dv_mps: float = math.inf  # finite: a joined pair's ground velocities (A's at its end,
    # B's at its start) within this many m/s, the misfit ranking the pairs instead of the
    # image's W/s (`count.stitch.ground_dv_misfit`); inf: off (1.5, life.max_dv_mps, measured)

    def __post_init__(self):
        if not self.max_dv_mps > 0:  # NaN too
            raise ValueError(f"stitch.max_dv_mps must be > 0 m/s (inf: off), got "
                             f"{self.max_dv_mps!r}")


@dataclass(frozen=True)
class AppearanceOptions:
    """Joining fragments of one walker by appearance (`count.appearance`, `count.stitch`): a
    later track B continues an ended one A, after every geometric pair, when B starts within
    `max_gap_s` s of A's end at most `reach_widths` body widths (the config's width.mean m) +
    `reach_speed_mps` x the gap from A's last ground point, and their descriptors (grey-level
    histograms of the patch's upper and lower halves, foreground only, mean over the frames
    whose blobs no other pedestrian shares) differ by at most `max_distance` (mean Hellinger).
    `max_distance` fitted on own counting seed 42024's fragment pairs, checked on 31337
    (docs/rules.md, "Joining a walker's fragments by appearance")."""

    enabled: bool = False  # compute descriptors and join by appearance
    bins: int = 8  # grey-level bins per half (0-255)
    min_fill: float = 0.1  # a half counts in a frame with this fraction of it foreground
    max_gap_s: float = 10.0  # s from A's last measured frame to B's first
    reach_widths: float = 2.0  # body widths ...
    reach_speed_mps: float = 2.0  # ... + this speed x the gap (m/s): where A's walker can be
    max_distance: float = 0.387  # descriptors at most this far apart (0-1; fitted: balanced
    # accuracy on own seed 42024's pairs within reach, 0.873; held out on 31337: 0.788, AUC
    # 0.871); 0: no joins by appearance alone (the descriptors serve the veto only)
    veto_distance: float = float("inf")  # a geometric join farther apart than this is refused


@dataclass(frozen=True)
class VerdictOptions:
    """Which tracks are output and judged, and when."""

    min_track_frames: int = 10  # shorter tracks are dropped from outputs and counts
    online: bool = True  # with an overlay: judge each N-frame window as it completes
    # (the labels drawn); without one it is skipped (saves a compilation)
    classify: bool = True  # judge the tracks at the end (False: all unclassified, no compile)
    speed_fit: str = "theil-sen"  # the too-fast rule's track speed (`count.track_speed`):
    # "theil-sen" (median pairwise slope) | "lsq" (least squares, the default until issue 16's
    # twenty-eighth round). A few rows placed off the feet made a least-squares speed too fast
    # for walkers and too slow for bicycles; on a fresh pool 220001-8 (confirmatory test,
    # docs/rules.md rule 25) Theil-Sen counted non-walkers 61 -> 46, tracks on no object 116 ->
    # 110, walkers with a counted track 1211 -> 1220, per-clip errors -0.9 [-1.9, +0.1] points
    head_speed: bool = True  # the too-fast rule reads an unjudged track's speed under its
    # heads where its foot rows are mostly not its feet (`head_feet.head_ground_points`: the
    # legs lost in the mask, the foot row the hips); verdicts["head_speed_mps"]. Issue 16,
    # rule 31 (docs/rules.md), on since the thirty-second round: on two fresh pools 11 tracks
    # counted more, 8 of them walkers no other counted track follows, no non-walker; False:
    # the count before
    window_candidates: bool = False  # candidate windows B (issue 16, item 2): I(k) summed also
    # in window B moved by -0.2, -0.1 and +0.1 W (io.files.WINDOW_CANDIDATES; count.
    # window_candidates), written as the tracks' candidate columns; each rhythm window is judged
    # once per candidate and the one whose strongest spectral peak is highest decides (model.
    # candidates.strongest; verdicts["candidate"]). Default decided by measurement,
    # docs/window_b.md. Costs one window-B sum a row and one (13)-(15) a window per candidate
    twice_pace_heights: float = 0.57  # rule 37 in the verdicts (the tracker's `size.
    # twice_pace_heights`, `track.twice`): a window refused by (14) whose strongest peak passes
    # it at half its frequency is Pedestrian when its rows' median height (from the tracks'
    # v_top) is at least this many walker heights; 0: off. On since issue 16's thirty-ninth
    # round, as the tracker's; its fitted value since the fortieth: on fresh own counting seeds
    # 2990001-3020001 197 -> 198 of 210 counted, errors 15.7 -> 15.2 %, no non-walker more;
    # dev crowds and PETS09 unchanged (docs/rules.md)
    twice_pace_edge: bool = True  # ... reading also the rows whose blobs reach the image's
    # first row, at the height up to it (a lower bound; `track.twice.twice_height`; tracks
    # column top_at_edge). On since issue 16's thirty-ninth round: on fresh own counting seeds
    # 2490001-2520001 the per-clip errors 20.7 -> 16.3 %, no non-walker more; dev crowds and
    # PETS09 unchanged; one bicycle counted more on an own reporting source (docs/rules.md)
    min_height_heights: float = 0.5  # rule 26 in the verdicts (the tracker's `size.
    # min_height_heights`, `track.size.batch_size_look`): a window judged Pedestrian whose
    # rows' median height (from the tracks' v_top, rule 36's rows) is below this many walker
    # heights over at least 10 rows is Non-pedestrian, reason too-low (a trotting dog); 0: off.
    # On since issue 16's fortieth round, as the tracker's: on fresh own counting seeds
    # 2730001-2760001, the dev crowds and PETS09 it changed no verdict (docs/rules.md)
    stride_peak: bool = False  # rule 56 in the verdicts (the tracker's `size.stride_peak`,
    # `track.twice`): a window refused by (14) whose strongest peak passes it at twice its
    # frequency (a walker's stride frequency) is Pedestrian there on rule 37's height. Off:
    # its screen counted PETS09 27 -> 30 for 19 (dev crowds 14 of 18 both ways)


@dataclass(frozen=True)
class ExplainOptions:
    """An unjudged track another counted track explains is not counted (`count.explain`,
    (E1)-(E2)). Values chosen on own counting seeds 42024 and 31337; left off: on the sources
    it was not chosen on it removed distinct walkers (docs/rules.md, "Unjudged tracks explained
    by another track")."""

    enabled: bool = False
    duplicate_widths: float = 1.0  # (E1) ground points within this many body widths ...
    duplicate_fraction: float = 0.5  # ... in at least this fraction of its measured frames
    continue_widths: float = 2.0  # (E2) start within this many body widths of the other's end
    speed_mps: float = 0.5  # ... plus this speed x the gap (m/s)
    max_gap_s: float = 5.0  # ... for gaps up to this long (s; 0: no continuation)
    precedes: bool = True  # (E2) also a track that ends where a stronger one starts later


@dataclass(frozen=True)
class CountOptions:
    """The dynamics, the capacity, and one record per concern (each frozen)."""

    dynamics: str = "3d"  # "2d" | "3d-shape" | "3d" (ground-plane EKF of ekf.py)
    max_pedestrians: int = 32  # filter slots advanced together in one jitted call
    blobs: BlobOptions = field(default_factory=BlobOptions)
    placement: PlacementOptions = field(default_factory=PlacementOptions)
    new: NewPedestrianOptions = field(default_factory=NewPedestrianOptions)
    life: LifeOptions = field(default_factory=LifeOptions)
    stitch: StitchOptions = field(default_factory=StitchOptions)
    appearance: AppearanceOptions = field(default_factory=AppearanceOptions)
    verdicts: VerdictOptions = field(default_factory=VerdictOptions)
    explain: ExplainOptions = field(default_factory=ExplainOptions)

    def __post_init__(self):
        if self.verdicts.speed_fit not in SPEED_FITS:
            raise ValueError(f"verdicts.speed_fit must be one of {SPEED_FITS}, "
                             f"got {self.verdicts.speed_fit!r}")
        if self.dynamics not in DYNAMICS:
            raise ValueError(f"dynamics must be one of {DYNAMICS}, got {self.dynamics!r}")
        if self.placement.outlier_gate not in OUTLIER_GATES:
            raise ValueError(f"placement.outlier_gate must be one of {OUTLIER_GATES}, "
                             f"got {self.placement.outlier_gate!r}")
        check_noise(self.placement.noise)
        for key, value in (("placement.wide_widths", self.placement.wide_widths),
                           ("life.max_dv_w", self.life.max_dv_w),
                           ("life.jump_sigma", self.life.jump_sigma),
                           ("life.merge_hold_s", self.life.merge_hold_s),
                           ("verdicts.twice_pace_heights", self.verdicts.twice_pace_heights),
                           ("verdicts.min_height_heights", self.verdicts.min_height_heights)):
            if not (value >= 0 and math.isfinite(value)):  # NaN too
                raise ValueError(f"{key} must be >= 0 (0: off), got {value!r}")
