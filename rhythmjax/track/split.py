"""Splitting a shared blob between the tracks that share it (`body.split_shared`, default off).

Two objects passing within about 1 W of each other give overlapping detections: each track's
detection window (`window.widths` W wide, the body's parts joined over `body.parts_widths` W)
takes in both, and the tracker treats the two detections as one shared blob
(`vision.detect.shared_detections`): no measurement and no rhythm sample for either
(docs/rules.md, "Why walkers are missed"). Here each sharer is detected again in a narrower
window around ITS OWN predicted foot point: as wide as its predicted body box (`body.core_widths`
W), as high as the usual window, its parts not joined (`body_px=None`), so the other object's
motion outside that box is left out. A sharer takes its re-detection as its measurement when it
no longer overlaps another sharer's re-detection (by `body.shared_overlap` of the smaller box)
and its foot point lies within `body.split_near_widths` W of its predicted foot point; the
others keep today's behaviour. With windows 1.2 W wide, sharers whose predicted foot points lie
less than about 0.6 W apart (one object, or two fully merged) are never split.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import NamedTuple

import numpy as np

from ..vision.detect import Detection, WindowBox, detect_in_window, shared_detections


__all__ = ["Predicted", "split_shared"]


class Predicted(NamedTuple):
    """Where one track expects its object this frame (px)."""

    centre: tuple[float, float]  # (u, v) px: the detection window's centre (above the feet)
    height: float  # the detection window's height px
    core: WindowBox  # the predicted body box (x0, y0, w, h) px, `body.core_widths` W wide
    foot: tuple[float, float]  # the predicted foot point (u, v) px
    W: float  # the walker width W px at the predicted ground point


def split_shared(motion: np.ndarray, shared: Iterable[int], predicted: Mapping[int, Predicted],
                 *, overlap: float, near_widths: float, fraction: float
                 ) -> dict[int, Detection]:
    """The sharers (keys of `shared`, each in `predicted`) that can take a measurement of their
    own, with it: each is re-detected in a window `core` wide (its predicted body box's width)
    and `height` high at `centre` in the motion image `motion` (`detect_in_window`, the regions
    of `core`, parts not joined, projections sliced at `fraction`). Kept: re-detections that
    overlap no other sharer's re-detection by `overlap` of the smaller box and whose foot point
    lies within `near_widths` W of the predicted one `foot`."""
    again = {}
    for s in shared:
        p = predicted[s]
        det = detect_in_window(motion, p.centre, (p.core[2], p.height), fraction=fraction,
                               core=p.core, body_px=None)
        if det is not None:
            again[s] = det
    still = shared_detections(again, overlap)
    return {s: det for s, det in again.items() if s not in still
            and math.hypot(det.u - predicted[s].foot[0], det.v - predicted[s].foot[1])
            <= near_widths * predicted[s].W}
