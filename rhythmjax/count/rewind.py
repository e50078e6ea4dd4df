"""A pedestrian that goes on after a velocity jump (`life.jump_rewind`, "3d" only; off by default).

The pedestrians level ends a track whose EKF ground velocity changed by more than
`life.max_dv_mps` within `life.dv_window_s` s (`track.toolkit.velocity_jump`) and drops the k
rows of that window: no walker turns or brakes that hard, so the patch lost its walker. Measured
on the synthetic pools (docs/rules.md, twentieth round), in two of three such ends the patch was
still on its own walker and only its foot row was off for a few frames (a merged blob): the end
then splits one walker into two pieces. With the option the k rows still go, but the track does
not end: its filter slot goes back to the state it had at the last kept row (mean and covariance,
kept per row in `Pedestrian.states`) and predicts on from there (`slot_filter.Restore`, the one
EKF's `ekf_fused.predict`); its coast counts from its last measured kept row, so one that keeps
jumping times out after `thresholds.predict_timeout_s` like any other. The states of the last
2k + 1 rows are kept; a jump with fewer than k + 1 of them (a track younger than that) ends the
track as without the option.

With `life.rewind_off_rows` (off) not all k rows go: only those from the first whose measured foot
row lay more than the level's row tolerance (`occlusion.foot_row_tolerance`, 3 r_v) from the
prediction it was placed against (`rows_to_drop`; measured on the pools, the foot row leaves its
walker only in the last one to four of the k frames, docs/rules.md, twenty-first round); a jump
with no such row among them ends the track as without the option. With `life.rewind_predict`
(off) the rewound pedestrian then predicts while its placed foot row stays beyond that
tolerance (the merged blob still below it).

Units: s, m, m/s, px.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from ..model.camera_np import project_3d
from ..model.status import TrackState
from .pedestrian import Pedestrian
from .slot_filter import FilterOut, Restore


__all__ = ["keep_state", "rewind", "rewind_requests", "rows_to_drop", "state_store"]


def state_store(k: int) -> deque:
    """The per-row filter states a pedestrian keeps with the option on: the last 2k + 1 rows
    (k: the rows of `life.dv_window_s`), enough to go back k rows once."""
    return deque(maxlen=2 * int(k) + 1)


def keep_state(p: Pedestrian, out: FilterOut, t: float, off: bool = False) -> None:
    """Store slot `p.slot`'s state of this frame (t s; mean (4) and covariance (16) of `out`)
    with the row just appended, and whether its measured foot row was off its prediction (`off`,
    beyond the row tolerance); nothing when `p.states` is None (option off)."""
    if p.states is not None:
        s = p.slot
        p.states.append((float(t), np.concatenate([out.mean[s], out.cov[s]]), bool(off)))


def rows_to_drop(p: Pedestrian, k: int, only_off: bool) -> tuple[int, bool]:
    """(rows to drop, whether the track may go on) at a velocity jump over its last k rows: (k,
    True) unless `only_off`; with it the rows from the first of the last k whose foot row was
    off (`keep_state`) to the newest, or (k, False) when none was or no state before it is
    kept: the track ends as without the option."""
    if not only_off or p.states is None or k <= 0:
        return k, True
    flags = [q[2] for q in list(p.states)[-k:]]
    first = next((i for i, off in enumerate(flags) if off), None)
    if first is None or len(p.states) < len(flags) - first + 1:
        return k, False
    return len(flags) - first, True


def rewind(p: Pedestrian, k: int, t: float, camera, dt_next: float) -> bool:
    """After its last k rows were dropped at time t s (the jump frame): ask for its slot to go
    back to its state at the row now last (`p.restore`: that state and the lead t - t_then s),
    move its estimated and next foot points (`p.est_uv`, `p.next_uv`, px) to that state's
    prediction for t and t + dt_next (ground point moved at its velocity, projected by (3)),
    and count its coast from its last measured row. False (nothing changed but the states
    dropped) when no such state is kept or no measured row is left: the track ends."""
    states = p.states
    if states is None or len(states) < k + 1:
        return False
    for _ in range(k):
        states.pop()
    measured = [r.t for r in p.rows if r.state == TrackState.OBSERVE]
    if not measured:
        return False
    t_then, state, _ = states[-1]
    lead = t - t_then
    x, vx, y, vy = (float(q) for q in state[:4])
    p.restore = (state, lead)
    p.est_uv = tuple(project_3d(camera, x + vx * lead, y + vy * lead, 0.0))
    ahead = lead + dt_next
    p.next_uv = tuple(project_3d(camera, x + vx * ahead, y + vy * ahead, 0.0))
    p.step_uv = (p.next_uv[0] - p.est_uv[0], p.next_uv[1] - p.est_uv[1])
    p.coast = t - measured[-1]
    p.z = (math.nan, math.nan)
    p.win_start = min(p.win_start, len(p.rows))
    p.rewind_times.append(float(t))
    return True


def rewind_requests(peds: list[Pedestrian], slots: int) -> Restore | None:
    """The `slot_filter.Restore` of the pedestrians that asked to go back (`rewind`), their
    requests cleared; None when none did."""
    asking = [p for p in peds if p.restore is not None]
    if not asking:
        return None
    r = Restore.none(slots)
    for p in asking:
        state, lead = p.restore
        r.slots[p.slot], r.state[p.slot], r.lead[p.slot] = True, state, lead
        p.restore = None
    return r
