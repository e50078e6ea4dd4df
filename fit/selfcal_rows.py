"""Which rows of a track self-calibration (`fit.selfcal`) measures: the tracker's observed rows.

The tracker (`rhythmjax.track.tracker`, Fig. 3) writes a row for every frame of a track and its
state after the gates: ``observe`` (the gates accepted the measurement), ``predict`` (no
measurement, or one the gates refused: the row keeps the refused detection's foot point u, v
px, width_px and top row v_top, so that `rhythmjax classify` can gate again), ``none`` (a gap
row, nothing measured). A refused detection is one the gates, judging through the tracking
camera, did not take for this walker's foot point: the bottom of a merged blob, a knee, another
person, or a good foot point that a rough camera's gates refuse. On the development clips
(`dev/`, tracked with the rough camera of benchmarks/selfcal_real.py) 2368 of the 3631 rows
with a finite foot point are such ``predict`` rows.

The rule (rows used: measured and observed; `rhythmjax-fit selfcal --observed-only`, off by
default): where the tracks give the state (the tracks format's optional ``state`` column,
`rhythmjax.io.Tracks.state`), the geometric cues (foot points, widths, top rows: every cue but
the pace) use only the rows whose state is ``observe``; every other row's u, v, width_px, v_top
and u_top are made missing. The rhythm signal I(k) is kept on every row (the gait windows need
contiguous rows; the classifier reads it there too). Rows whose state is not given (an empty
cell, or no column: `simulate`'s and hand-made tracks) are used as before, wherever they hold
a foot point.

Off by default (docs/selfcal.md, "Rows used"): the gates judge with the tracking camera, so
with a rough one they refuse good foot points too, and on PETS09-S2L1 the rule did not bring
the tilt closer to Tsai's (the motivation) while the video command's first round lost most of
its scale (h 5.45 -> 3.02 m) and its rounds then disagreed (refused). The default: every row
with a foot point, as before.
"""

from __future__ import annotations

import dataclasses

import numpy as np


USED_STATE = "observe"  # the only state whose foot point, width and top row are used


def unobserved(tracks) -> np.ndarray:
    """(rows,) mask of a `rhythmjax.io.Tracks`' rows the rule leaves out: a state given (not
    empty) and not ``observe`` (module doc). All False when the tracks have no state."""
    state = getattr(tracks, "state", None)
    if state is None:
        return np.zeros(len(tracks.frame), bool)
    s = np.asarray(state, dtype=object)
    given = np.array([x is not None and x == x and str(x) != "" for x in s], bool)
    return given & (s.astype(str) != USED_STATE)


def observed_rows(tracks):
    """(the tracks with the foot point u, v px, width_px, v_top and u_top px made missing (NaN)
    on the rows `unobserved` marks, how many of those rows held a foot point). The intensity
    (the rhythm signal), times and the state are kept. The same tracks object when nothing
    changes."""
    drop = unobserved(tracks)
    held = drop & np.isfinite(np.asarray(tracks.u, np.float64)) & np.isfinite(
        np.asarray(tracks.v, np.float64))
    if not held.any():
        return tracks, 0
    nan = lambda a: None if a is None else np.where(drop, np.nan, a).astype(  # noqa: E731
        np.asarray(a).dtype)
    return dataclasses.replace(tracks, u=nan(tracks.u), v=nan(tracks.v),
                               width_px=nan(tracks.width_px), v_top=nan(tracks.v_top),
                               u_top=nan(tracks.u_top)), int(
                                   held.sum())
