"""Splitting a shared blob between the tracks that share it (`body.split_shared`, on).

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
others keep the shared rule. With windows 1.2 W wide, sharers whose predicted foot points lie
less than about 0.6 W apart across (one object, or one in front of the other) are not split
so; of those, a sharer whose predicted foot row lies more than `body.split_depth_widths` W below
the others' (in front of them) is measured in the rows below their feet (`front_split`). Both
chosen on own training seeds 5555 and 6666; on the other sources docs/rules.md ("A split by
depth").
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import NamedTuple

import numpy as np

from ..vision.detect import Detection, WindowBox, detect_in_window, shared_detections


__all__ = ["Predicted", "front_split", "split_shared"]


class Predicted(NamedTuple):
    """Where one track expects its object this frame (px)."""

    centre: tuple[float, float]  # (u, v) px: the detection window's centre (above the feet)
    height: float  # the detection window's height px
    core: WindowBox  # the predicted body box (x0, y0, w, h) px, `body.core_widths` W wide
    foot: tuple[float, float]  # the predicted foot point (u, v) px
    W: float  # the walker width W px at the predicted ground point


def split_shared(motion: np.ndarray, shared: Iterable[int], predicted: Mapping[int, Predicted],
                 *, overlap: float, near_widths: float, fraction: float,
                 depth_widths: float = 0.0, margin_widths: float = 0.1
                 ) -> dict[int, Detection]:
    """The sharers (keys of `shared`, each in `predicted`) that can take a measurement of their
    own, with it: each is re-detected in a window `core` wide (its predicted body box's width)
    and `height` high at `centre` in the motion image `motion` (`detect_in_window`, the regions
    of `core`, parts not joined, projections sliced at `fraction`). Kept: re-detections that
    overlap no other sharer's re-detection by `overlap` of the smaller box and whose foot point
    lies within `near_widths` W of the predicted one `foot`. With `depth_widths` > 0, the
    sharers left then go through `front_split`."""
    shared = list(shared)
    out = split_across(motion, shared, predicted, overlap=overlap, near_widths=near_widths,
                       fraction=fraction)
    if depth_widths > 0:
        out.update(front_split(motion, [s for s in shared if s not in out], shared, predicted,
                               depth_widths=depth_widths, margin_widths=margin_widths,
                               near_widths=near_widths, fraction=fraction))
    return out


def split_across(motion: np.ndarray, shared: Iterable[int], predicted: Mapping[int, Predicted],
                 *, overlap: float, near_widths: float, fraction: float
                 ) -> dict[int, Detection]:
    """`split_shared`'s first step: each sharer re-detected in its own body box's columns."""
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


def front_split(motion: np.ndarray, left: Iterable[int], shared: Iterable[int],
                predicted: Mapping[int, Predicted], *, depth_widths: float,
                margin_widths: float, near_widths: float, fraction: float
                ) -> dict[int, Detection]:
    """The FRONT sharers of `left` (sharers not split across) re-detected below the others: a
    sharer whose predicted foot row lies more than `depth_widths` W below that of every other
    sharer whose body box overlaps its own in columns is nearer the camera and occludes them,
    so its legs and feet are the motion between `margin_widths` W below the lowest of their
    predicted foot rows and the bottom of its detection window. The foot point is measured in
    that strip of its body box's columns, the width and top row in its whole body box (parts
    not joined); kept within `near_widths` W of its predicted foot point. A back sharer gets
    nothing (its feet are behind the front object's legs). Prototyped on own training seeds
    5555 and 6666 (`benchmarks/study_depth_split.py`; docs/rules.md)."""
    shared = list(shared)
    out = {}
    for s in left:
        p = predicted[s]
        others = [predicted[o] for o in shared if o != s and columns_overlap(p.core,
                                                                             predicted[o].core)]
        if not others or any(p.foot[1] - q.foot[1] <= depth_widths * p.W for q in others):
            continue  # not in front of every sharer over its columns
        top = float(max(q.foot[1] for q in others) + margin_widths * p.W)
        bottom = float(p.centre[1] + p.height / 2.0)  # the detection window's bottom row
        det = detect_in_rows(motion, p, top, bottom, fraction)
        if det is None or math.hypot(det.u - p.foot[0], det.v - p.foot[1]) > near_widths * p.W:
            continue
        whole = detect_in_window(motion, p.centre, (p.core[2], p.height), fraction=fraction,
                                 core=p.core, body_px=None)
        out[s] = det if whole is None else dataclasses.replace(
            det, width=whole.width, top=whole.top, top_at_edge=whole.top_at_edge)
    return out


def columns_overlap(a: WindowBox, b: WindowBox) -> bool:
    """Whether boxes (x0, y0, w, h) px share a column."""
    return a[0] < b[0] + b[2] and b[0] < a[0] + a[2]


def detect_in_rows(motion: np.ndarray, p: Predicted, top: float, bottom: float,
                   fraction: float) -> Detection | None:
    """`detect_in_window` in the columns of p's body box between rows `top` and `bottom` px
    (the body box clipped to those rows keeps the regions that belong to it); None for a strip
    under 4 rows."""
    if bottom - top < 4:
        return None
    x0, y0, w, h = p.core
    r0, r1 = max(y0, int(math.floor(top))), min(y0 + h, int(math.ceil(bottom)))
    if r1 - r0 < 2:
        return None
    return detect_in_window(motion, (x0 + w / 2, (top + bottom) / 2), (w, bottom - top),
                            fraction=fraction, core=(x0, r0, w, r1 - r0), body_px=None)
