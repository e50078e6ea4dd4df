"""Faint legs grown down from the foreground mask (`vision.fg_threshold.grow_down`,
`blobs.BackgroundModel` legs_weak / legs_rows_fraction; issue 16, rule 24): exactly a NumPy
loop's downward 3-neighbour flood, bounded in rows; a hand-worked walker whose legs lie under
the threshold; the options' validation."""

from __future__ import annotations

import numpy as np
import pytest

from rhythmjax.count.options import BlobOptions, CountOptions
from rhythmjax.track.options import with_changes
from rhythmjax.vision.blobs import BackgroundModel
from rhythmjax.vision.fg_threshold import grow_down


def _ref_grow_down(mask: np.ndarray, weak: np.ndarray, max_rows: int) -> np.ndarray:
    """Loop reference: a weak pixel joins at step k when one of the three pixels above it
    (up-left, up, up-right) joined at step k - 1 (step 0: the mask), k = 1..max_rows."""
    h, w = mask.shape
    out = mask.astype(bool).copy()
    front = out.copy()
    for _ in range(max_rows):
        nxt = np.zeros((h, w), bool)
        for r in range(1, h):
            for c in range(w):
                if weak[r, c] and not out[r, c] and any(
                        front[r - 1, cc] for cc in (c - 1, c, c + 1) if 0 <= cc < w):
                    nxt[r, c] = True
        if not nxt.any():
            break
        out |= nxt
        front = nxt
    return out.astype(np.uint8)


@pytest.mark.parametrize("seed, rows", [(0, 0), (1, 3), (2, 40), (3, 7)])
def test_grow_down_equals_a_loop(seed, rows):
    rng = np.random.default_rng(seed)
    mask = (rng.random((24, 19)) < 0.05).astype(np.uint8)
    weak = (rng.random((24, 19)) < 0.55).astype(np.uint8)
    got = grow_down(mask, weak, rows)
    assert got.dtype == np.uint8 and np.array_equal(got, _ref_grow_down(mask, weak, rows))
    assert np.all(got >= mask) and np.all(got <= np.maximum(mask, weak))


def test_grow_down_hand_worked():
    m = np.zeros((8, 7), np.uint8)
    m[1, 3] = 1
    w = np.zeros_like(m)
    w[0, 3] = 1  # above the mask: never grown up
    w[2, 2] = w[3, 2] = w[4, 1] = 1  # a slanting leg: joins, row after row
    w[5, 5] = 1  # weak but not below the grown region
    w[2, 6] = 1  # beside, not below
    want = m.copy()
    want[2, 2] = want[3, 2] = want[4, 1] = 1
    assert np.array_equal(grow_down(m, w, 10), want)
    two = m.copy()
    two[2, 2] = two[3, 2] = 1  # at most 2 rows below the mask
    assert np.array_equal(grow_down(m, w, 2), two)


def test_faint_legs_join_the_body():
    bg = np.full((100, 60), 120, np.uint8)
    img = bg.copy()
    img[10:50, 25:35] = 180  # body: 60 grey levels above the road
    img[50:80, 27:33] = 130  # legs: 10 grey levels, under the threshold 20
    img[90:95, 5:10] = 130  # a faint patch apart from any body
    off = BackgroundModel(bg, open_px=0, close_px=0)
    assert off.foreground(img).sum() == 40 * 10
    on = BackgroundModel(bg, open_px=0, close_px=0, legs_weak=0.4)  # 8 grey levels
    got = on.foreground(img)
    want = np.zeros_like(got)
    want[10:50, 25:35] = 1
    want[50:60, 27:33] = 1  # 0.1 x 100 rows below the body's lowest row at most
    assert np.array_equal(got, want)
    full = BackgroundModel(bg, open_px=0, close_px=0, legs_weak=0.4, legs_rows_fraction=0.5)
    want[50:80, 27:33] = 1  # the whole leg; the faint patch apart stays out
    assert np.array_equal(full.foreground(img), want)
    low = BackgroundModel(bg, open_px=0, close_px=0, legs_weak=0.55)  # 11 > 10: no leg
    assert low.foreground(img).sum() == 40 * 10


@pytest.mark.parametrize("field, value", [("legs_weak", 1.0), ("legs_weak", -0.1),
                                          ("legs_rows_fraction", 1.5),
                                          ("legs_rows_fraction", -0.1)])
def test_legs_options_validated(field, value):
    with pytest.raises(ValueError, match=field):
        BlobOptions(**{field: value})
    with pytest.raises(ValueError, match=field):
        with_changes(CountOptions(), {f"blobs.{field}": value})
    with pytest.raises(ValueError, match=field):
        BackgroundModel(np.zeros((4, 4), np.uint8), **{field: value})


def test_blob_options_give_the_model_its_legs_settings():
    m = BackgroundModel(np.zeros((40, 4), np.uint8),
                        **BlobOptions(legs_weak=0.4, legs_rows_fraction=0.25).model_kwargs())
    assert (m.legs_weak, m.legs_rows) == (0.4, 10)
    assert BackgroundModel(np.zeros((4, 4), np.uint8)).legs_weak == 0.0  # off by default
