"""Per-track outcome codes: data, never exceptions (one bad track never aborts a batch)."""

from __future__ import annotations

import enum


class TrackState(enum.IntEnum):
    """Fig. 3 state machine of the online tracker."""

    NONE = 0
    DETECT = 1
    OBSERVE = 2
    PREDICT = 3


class Verdict(enum.IntEnum):
    UNCLASSIFIED = 0
    PEDESTRIAN = 1
    NON_PEDESTRIAN = 2

    @property
    def label(self) -> str:
        return self.name.lower().replace("_", "-")


class Reason(enum.IntEnum):
    """Why a verdict was reached: the ARCHITECTURE vocabulary, two degradations, the size rule."""

    MATCHED = 0  # (15): R_m > R_thr
    NO_PEAK = 1  # (13): no spectral peak above P_thr
    NO_MODEL_MATCH = 2  # (14): no peak passes the walking model
    BELOW_THRESHOLD = 3  # (15): best R_m <= R_thr
    TOO_SHORT = 4  # fewer than N samples tracked (Sec. 5)
    NO_MEASUREMENTS = 5  # no finite measurement at all
    BAD_SIGNAL = 6  # rhythm window unusable (constant, too many gaps, irregular sampling)
    TOO_LOW = 7  # judged Pedestrian, but the track's measured height is a non-walker's (rule 26)
    MATCHED_TWICE = 8  # (14)-(15) at half the strongest peak, the height a walker's (rule 37)
    MATCHED_DETRENDED = 9  # (13)-(15) with the window's line removed, a trend refused (rule 38)
    MATCHED_STRIDE = 10  # (14)-(15) at twice the strongest peak, the height a walker's (rule 56)

    @property
    def label(self) -> str:
        return self.name.lower().replace("_", "-")


VERDICT_LABELS = {v.value: v.label for v in Verdict}
REASON_LABELS = {r.value: r.label for r in Reason}
