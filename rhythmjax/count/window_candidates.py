"""Candidate windows B in counting (issue 16, item 2; `verdicts.window_candidates`): besides
I(k) in window B at its foot point, each pedestrian samples I(k) in window B moved vertically by
each offset of `io.files.WINDOW_CANDIDATES` (-0.2, -0.1, +0.1 W; negative: up), one tuple a
row (`Pedestrian.candidate_rows`, NaN exactly where the row's intensity is). They become the
tracks' candidate columns (`io.files.CANDIDATE_COLUMNS`, `track.columns.candidate_table`),
and the classifier judges each rhythm window once per candidate and keeps the one whose
strongest spectral peak is highest (`model.candidates.strongest`). Units: px, grey levels,
walker widths W (the patch width at the foot point)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..io.files import WINDOW_CANDIDATES
from ..vision.window_b import window_b_candidates


if TYPE_CHECKING:
    from .pedestrian import Pedestrian


__all__ = ["OFFSETS", "align_candidates", "candidates_by_row", "sample_candidates"]

OFFSETS = tuple(off for _, off in WINDOW_CANDIDATES)  # W, in `CANDIDATE_COLUMNS` order


def sample_candidates(D: np.ndarray | None, u: float, v: float, W: float,
                      intensity: float) -> tuple[float, ...]:
    """I(k) (grey levels) of the candidate windows B of one row: `vision.window_b.
    window_b_candidates` on the frame difference D at foot point (u, v) px with walker width W
    px and the offsets `OFFSETS` (read when called); all NaN where the row's own `intensity`
    (window B's) is NaN (no frame difference, no foot point), so a candidate is NaN exactly
    where window B is."""
    if D is None or not math.isfinite(intensity):
        return (math.nan,) * len(OFFSETS)
    return window_b_candidates(D, u, v, W, OFFSETS)


def candidates_by_row(peds: list[Pedestrian]) -> dict[int, tuple[float, ...]]:
    """Each row's candidate tuple keyed by the identity of its `TrackRow` object (`id`), for
    the pedestrians that sample candidates: `align_candidates` puts them back after stitching,
    which joins the pieces' rows (`stitch.stitch_level`). Valid while the rows are alive."""
    return {id(r): c for p in peds if p.candidate_rows is not None
            for r, c in zip(p.rows, p.candidate_rows, strict=True)}


def align_candidates(peds: list[Pedestrian], by_row: dict[int, tuple[float, ...]]
                     ) -> list[Pedestrian]:
    """Each pedestrian's `candidate_rows` rebuilt from `by_row` (`candidates_by_row` before
    stitching) along its rows, so a stitched track carries every piece's candidates in row
    order; pedestrians without candidates are left alone. Returns `peds`."""
    for p in peds:
        if p.candidate_rows is not None:
            p.candidate_rows = [by_row[id(r)] for r in p.rows]
    return peds
