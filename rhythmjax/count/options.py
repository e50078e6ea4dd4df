"""`CountOptions`: the settings of the tracking paper's three levels, of stitching and of the
counting rule (px, grey levels, frames, patch widths W / heights H)."""

from __future__ import annotations

from dataclasses import dataclass

from .patches import DYNAMICS, PEDESTRIAN_HEIGHT_M


__all__ = ["CountOptions"]


@dataclass
class CountOptions:
    """Settings of the three levels (px, grey levels, frames, patch widths W / heights H)."""

    dynamics: str = "3d"  # "2d" | "3d-shape" | "3d" (ground-plane EKF of ekf.py)
    height_m: float = PEDESTRIAN_HEIGHT_M  # average pedestrian height; width: cfg.width.mean
    max_pedestrians: int = 32  # filter slots advanced together in one jitted call
    bg_alpha: float = 0.05  # background learning rate where nothing moves
    bg_threshold: float = 20.0  # |frame - background| threshold, grey levels
    open_px: int = 1
    close_px: int = 2
    min_blob_area: int = 30  # px
    search_widths: float = 0.75  # placement search radius, W (a pedestrian alone on its blobs)
    shared_search_widths: float = 0.3  # ... when it shares a blob with others
    merge_widths: float = 0.75  # shared blob narrower than this x summed W: predict only
    min_cover: float = 0.08  # a placement must cover this fraction of its patch
    new_min_widths: float = 0.6  # unexplained blob columns needed to start a pedestrian, W
    new_min_fill: float = 0.15  # ... holding at least this fraction of a patch area in pixels
    new_min_height: float = 0.5  # ... spanning at least this many H
    new_max_lift: float = 0.25  # ... reaching down to within this many H of the blob's bottom,
    new_lifted_height: float = 0.55  # ... or, lifted higher, spanning this fraction of its H
    # (clipped at the image top) at its own foot point: a farther walker merged with a nearer one
    new_in_range: bool = True  # ... standing in the config's detection range (ground y, m)
    confirm_hits: int = 3
    tentative_misses: int = 2
    coast_s: float | None = None  # default: cfg.thresholds.predict_timeout (s)
    walker_widths: float = 1.8  # blob width of one walking pedestrian (stance foot to the
    # leading arm: ~2 W measured on synthetic walkers); a patch explains that much of a blob
    duplicate_widths: float = 0.6  # foot points closer than this many W ...
    duplicate_frames: int = 3
    crowd_fraction: float = 0.5  # one blob box covering this fraction: no detection that frame
    min_track_frames: int = 10  # shorter tracks are dropped from outputs and counts
    online_verdicts: bool = True  # with an overlay: judge each N-frame window as it completes
    # (the labels drawn); without one it is skipped (saves a compilation)
    classify: bool = True  # judge the tracks at the end (False: all unclassified, no compile)
    max_dv_mps: float = 1.5  # "3d": a track whose ground velocity changes by more than this
    dv_window_s: float = 0.5  # ... within this long lost its object: it ends before the change
    # (1.5 m/s in 0.5 s is 3 m/s^2: no walker turns or brakes that hard, while a patch moving
    # between two walkers crossing at right angles at 1.4 m/s changes by 2 m/s)
    stitch: bool = True  # join fragments of one walker (count.stitch_pieces)
    stitch_max_gap_s: float = 5.0  # from a track's last measured frame to the next one's first
    # (a walker passing behind a near one stays hidden for seconds: a 0.5 m wide walker 3 m
    # away hides 2.5 m at 15 m, 1.8 s of a 1.4 m/s crossing, longer behind a group; measured
    # on the synthetic scenes, correct links with 3-5 s gaps fit within 0.3-0.7 of the gate)
    stitch_gate_w: float = 0.9  # foot point misfit allowed at zero gap: this many W across ...
    stitch_gate_h: float = 0.45  # ... and this many H up or down ...
    stitch_gate_per_s: float = 0.5  # ... growing by this fraction per second of gap
    stitch_max_dv_w: float = 2.0  # image velocity misfit allowed, W/s
    stitch_fit_s: float = 1.0  # measured foot points fitted at a track's start (and end)

    def __post_init__(self):
        if self.dynamics not in DYNAMICS:
            raise ValueError(f"dynamics must be one of {DYNAMICS}, got {self.dynamics!r}")
