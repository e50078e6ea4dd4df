"""The measured width of a pedestrian's patch (`count.widths.measured_width`, the W_IMG of gate
(10) in count's tracks) and its top row (`measured_top`, the tracks' `v_top`): hand-worked cases
and plain-loop references on random label images."""

from __future__ import annotations

import math

import numpy as np

from rhythmjax.count.widths import column_runs, measured_top, measured_width, top_and_edge


def _reference(labels, related, claimed, u, v, w, h, reach):
    """Column by column in plain Python (the module doc's rule)."""
    H, W = labels.shape
    y0, y1 = max(0, math.floor(v - h + 0.5)), min(H, math.floor(v) + 1)
    a0, a1 = math.floor(u - w / 2 + 0.5), math.floor(u + w / 2 + 0.5)
    x0, x1 = max(0, math.floor(a0 - reach)), min(W, math.ceil(a1 + reach))
    occupied = []
    for x in range(x0, x1):
        occupied.append(any(int(labels[y, x]) in related
                            and not (claimed is not None and claimed[y, x])
                            for y in range(y0, y1)))
    runs, start = [], None
    for i, c in enumerate(occupied + [False]):
        if c and start is None:
            start = i
        elif not c and start is not None:
            runs.append((x0 + start, x0 + i))
            start = None
    best, width = 0, math.nan
    for s, e in runs:
        ov = min(e, a1) - max(s, a0)
        if ov > best:
            best, width = ov, float(e - s)
    return width


def test_column_runs_by_hand():
    assert column_runs(np.array([0, 1, 1, 0, 0, 1, 0, 1, 1, 1], bool)) == [(1, 3), (5, 6),
                                                                           (7, 10)]
    assert column_runs(np.array([1, 0, 0, 1], bool)) == [(0, 1), (3, 4)]
    assert column_runs(np.array([1, 1], bool)) == [(0, 2)]
    assert column_runs(np.zeros(3, bool)) == [] and column_runs(np.zeros(0, bool)) == []


def test_lone_blob_wider_than_the_patch():
    """A 17 px wide blob (columns 40..56, rows 20..60) under a 10 px patch centred at 48: 17."""
    labels = np.zeros((80, 100), np.int32)
    labels[20:61, 40:57] = 3
    assert measured_width(labels, [3], None, 48.0, 60.0, 10.0, 40.0, 10.0) == 17.0
    # the search reaches only reach_px past the patch's columns [43, 53): columns 41..54, 14
    assert measured_width(labels, [3], None, 48.0, 60.0, 10.0, 40.0, 2.0) == 14.0
    # an unrelated label, rows above the patch, or claimed pixels do not count
    assert math.isnan(measured_width(labels, [4], None, 48.0, 60.0, 10.0, 40.0, 10.0))
    assert math.isnan(measured_width(labels, [3], None, 48.0, 15.0, 10.0, 10.0, 10.0))
    claimed = np.zeros(labels.shape, bool)
    claimed[:, 40:46] = True
    assert measured_width(labels, [3], claimed, 48.0, 60.0, 10.0, 40.0, 10.0) == 11.0


def test_the_run_under_the_patch_wins():
    """Two bodies 4 columns apart: the one the patch overlaps most is measured."""
    labels = np.zeros((50, 100), np.int32)
    labels[10:40, 20:32] = 1  # 12 wide
    labels[10:40, 36:44] = 1  # 8 wide, same blob label (joined elsewhere)
    assert measured_width(labels, [1], None, 40.0, 39.0, 8.0, 29.0, 12.0) == 8.0
    assert measured_width(labels, [1], None, 26.0, 39.0, 8.0, 29.0, 12.0) == 12.0


def test_matches_the_plain_loop_on_random_images():
    rng = np.random.default_rng(11)
    for _ in range(200):
        H, W = rng.integers(20, 60, 2)
        labels = (rng.random((H, W)) < 0.15).astype(np.int32) * rng.integers(1, 4, (H, W))
        claimed = rng.random((H, W)) < 0.2 if rng.random() < 0.5 else None
        related = [int(q) for q in rng.choice([1, 2, 3], rng.integers(1, 3), replace=False)]
        u, v = rng.uniform(-5, W + 5), rng.uniform(0, H + 5)
        w, h, reach = rng.uniform(2, 15), rng.uniform(3, 30), rng.uniform(0, 10)
        got = measured_width(labels, related, claimed, u, v, w, h, reach)
        want = _reference(labels, set(related), claimed, u, v, w, h, reach)
        assert (math.isnan(got) and math.isnan(want)) or got == want, (u, v, w, h, reach)


def _top_reference(labels, related, claimed, u, v, w, reach, edge=False):
    """Row by row from the top in plain Python (`measured_top`'s rule; `edge`: with
    `top_and_edge`'s flag, the topmost on the image's first row)."""
    H, W = labels.shape
    y0, y1 = max(0, math.floor(v - reach + 0.5)), min(H, math.floor(v) + 1)
    a0, a1 = max(0, math.floor(u - w / 2 + 0.5)), min(W, math.floor(u + w / 2 + 0.5))
    for y in range(y0, y1):
        if any(int(labels[y, x]) in related and not (claimed is not None and claimed[y, x])
               for x in range(a0, a1)):
            top = math.nan if y == y0 else float(y)
            return (top, y == 0) if edge else top
    return (math.nan, False) if edge else math.nan


def test_top_of_a_lone_blob():
    """A body on rows 20..60 in columns 40..56, the patch 10 px wide at u 48 on row 60: its top
    row 20; a head (rows 12..19) off the patch's columns [43, 53) is not seen; cut tops are
    not given."""
    labels = np.zeros((80, 100), np.int32)
    labels[20:61, 40:57] = 3
    labels[12:20, 54:57] = 3  # an arm raised beside the patch's columns
    assert measured_top(labels, [3], None, 48.0, 60.0, 10.0, 60.0) == 20.0
    assert measured_top(labels, [3], None, 55.0, 60.0, 4.0, 60.0) == 12.0  # columns 53..56
    # searched from row floor(60 - 40.2 + 0.5) = 20: the top on the first row searched is cut
    assert math.isnan(measured_top(labels, [3], None, 48.0, 60.0, 10.0, 40.2))
    assert measured_top(labels, [3], None, 48.0, 60.0, 10.0, 41.0) == 20.0
    claimed = np.zeros(labels.shape, bool)
    claimed[:31, :] = True  # an older patch took the upper part
    assert measured_top(labels, [3], claimed, 48.0, 60.0, 10.0, 60.0) == 31.0
    assert math.isnan(measured_top(labels, [4], None, 48.0, 60.0, 10.0, 60.0))
    labels[0:20, 40:57] = 3  # reaching the image's first row: cut, at the edge
    assert math.isnan(measured_top(labels, [3], None, 48.0, 60.0, 10.0, 200.0))
    top, edge = top_and_edge(labels, [3], None, 48.0, 60.0, 10.0, 200.0)
    assert math.isnan(top) and edge
    # cut by the search (from row 20), not by the image: not at the edge
    top, edge = top_and_edge(labels, [3], None, 48.0, 60.0, 10.0, 40.2)
    assert math.isnan(top) and not edge
    assert top_and_edge(labels, [4], None, 48.0, 60.0, 10.0, 200.0)[1] is False  # none


def test_top_matches_the_plain_loop_on_random_images():
    rng = np.random.default_rng(12)
    for _ in range(200):
        H, W = rng.integers(20, 60, 2)
        labels = (rng.random((H, W)) < 0.05).astype(np.int32) * rng.integers(1, 4, (H, W))
        claimed = rng.random((H, W)) < 0.2 if rng.random() < 0.5 else None
        related = [int(q) for q in rng.choice([1, 2, 3], rng.integers(1, 3), replace=False)]
        u, v = rng.uniform(-5, W + 5), rng.uniform(0, H + 5)
        w, reach = rng.uniform(2, 15), rng.uniform(0, 40)
        got = measured_top(labels, related, claimed, u, v, w, reach)
        want = _top_reference(labels, set(related), claimed, u, v, w, reach)
        assert (math.isnan(got) and math.isnan(want)) or got == want, (u, v, w, reach)
        got_edge = top_and_edge(labels, related, claimed, u, v, w, reach)[1]
        assert got_edge == _top_reference(labels, set(related), claimed, u, v, w, reach,
                                          edge=True)[1], (u, v, w, reach)
