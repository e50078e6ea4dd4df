"""A pedestrian's time without measurement and when it ends by time-out (`pedestrian_level`).

The rhythm paper's PREDICT state ends a track after `thresholds.predict_timeout_s` (1 s) of
prediction. Masoud & Papanikolopoulos keep a pedestrian related to its blob through a merge.
With `life.merge_hold_s` > 0 the two meet: a pedestrian that keeps its prediction because the
blob it shares is too narrow for them side by side (`Pedestrian.merged`, set by the level's
placement) and that has had no unmeasured frame outside such a merge since its last
measurement is *held*: its hold time (`Pedestrian.held`, s) grows instead of its coast, and it
ends when the hold passes `merge_hold_s`. Outside merges, and for one that arrived coasting,
the coast grows as before. With `merge_hold_s` 0 (the default) the coast grows every
unmeasured frame, as the paper's PREDICT time-out.
"""

from __future__ import annotations

from .pedestrian import Pedestrian


__all__ = ["advance_coast", "timed_out"]


def advance_coast(p: Pedestrian, measured: bool, dt: float, hold_s: float) -> None:
    """Advance `p`'s coast and hold (s) by one frame of `dt` s: both 0 when `measured`; else
    the hold grows when `hold_s` > 0, `p.merged` and its coast is 0 (it entered the merge
    measured), otherwise the coast."""
    if measured:
        p.coast = p.held = 0.0
    elif hold_s > 0 and p.merged and p.coast == 0.0:
        p.held += dt
    else:
        p.coast += dt


def timed_out(p: Pedestrian, coast_s: float, hold_s: float) -> bool:
    """`p` has predicted for longer than `coast_s` s outside merges, or (`hold_s` > 0) has been
    held in a merge for longer than `hold_s` s since its last measurement."""
    return p.coast > coast_s or (hold_s > 0 and p.held > hold_s)
