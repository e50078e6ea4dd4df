"""One tracked pedestrian of the pedestrians level (`pedestrian_level.PedestrianLevel`): its
per-frame records and the state the level carries between frames. Units: px, frames, s."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from ..track.rows import TrackRow
from .appearance import Appearance
from .rows import BoxRow, GroundRow


__all__ = ["Pedestrian", "finite_uv"]


@dataclass
class Pedestrian:
    slot: int
    born: int  # frame index
    track_id: int = 0  # 0 while tentative
    blobs: set = field(default_factory=set)  # related blobs (indices into the last frame's)
    rows: list[TrackRow] = field(default_factory=list)  # the tracks format, per frame
    ground: list[GroundRow] = field(default_factory=list)  # per row: the filter's state
    boxes: list[BoxRow] = field(default_factory=list)  # per row: the patch, a MOT row
    hits: int = 0
    misses: int = 0
    coast: float = 0.0  # s without a measurement (outside merges with `life.merge_hold_s`)
    held: float = 0.0  # `life.merge_hold_s`: s held in a merge since its last measurement
    merged: bool = False  # this frame it kept its prediction in a merge (`count.coast`)
    unseen: bool = False  # this frame its shared placement's row was refused (`count.occlusion`)
    next_uv: tuple = (math.nan, math.nan)  # predicted foot point for the next frame, px
    est_uv: tuple = (math.nan, math.nan)
    size: tuple = (math.nan, math.nan)  # patch (w, h) px at est_uv
    step_uv: tuple = (0.0, 0.0)  # predicted image motion per frame, px
    close: int = 0
    win_start: int = 0  # first row of the next rhythm window (`match_window`)
    windows_done: int = 0
    result: dict | None = None
    decided: bool = False
    end_reason: str = ""  # why it ended (`pedestrian_level.END_REASONS`); "" while it runs
    z: tuple = (math.nan, math.nan)  # this frame's measurement
    z_width: float = math.nan  # its measured width px (`widths.measured_width`), gate (10)
    z_top: float = math.nan  # its measured top row px (`widths.measured_top`; its blobs unshared)
    z_top_u: float = math.nan  # its head's column px at z_top: z's u + `widths.measured_lean`
    z_top_edge: bool = False  # its blobs reached the image's first row (`widths.top_and_edge`)
    look: Appearance | None = None  # `appearance.enabled`: its descriptor (unshared frames)
    candidate_rows: list[tuple[float, ...]] | None = None  # `verdicts.window_candidates`: per
    # row, I(k) of the candidate windows B (`io.files.WINDOW_CANDIDATES` order, grey levels; NaN
    # where the row's intensity is), read by `track.toolkit.match_window`; None: option off
    states: deque | None = None  # `life.jump_rewind`: (t s, filter mean (4) + cov (16), foot
    # row off its prediction) of its last rows (`rewind.keep_state`); None: option off
    restore: tuple | None = None  # (state (20,), lead s): its slot goes back there next step
    rewind_times: list[float] = field(default_factory=list)  # t s of each `rewind.rewind`
    rewound: bool = False  # `life.rewind_across` / `rewind_predict`: rewound, measured across
    # only (or predicting) while its placed foot row lies beyond the level's row tolerance


def finite_uv(uv) -> bool:
    """Both coordinates of a foot point (u, v) px are finite."""
    return math.isfinite(uv[0]) and math.isfinite(uv[1])
