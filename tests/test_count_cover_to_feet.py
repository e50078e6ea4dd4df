"""`new.cover_to_feet` (`count.refinement.free_runs`): a tracked pedestrian's cover explains
the blob pixels of its columns down to its foot row plus the row tolerance (k_sigma2 r_v px)
only; lower pixels there (a nearer walker in front of it) make a free run; with
`new.join_gap_widths` a walker's two legs make one, with `new.fill_exposed` its fill is asked of
the rows below the cover. Hand-made masks under a small 1 m camera, the runs worked out by hand
from the cover's columns and rows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.count.options import CountOptions, with_changes
from rhythmjax.count.pedestrian_level import PedestrianLevel
from rhythmjax.count.refinement import free_runs, new_pedestrians
from rhythmjax.model.params import config_from_dict
from rhythmjax.vision.blobs import find_blobs


SMALL = {"camera": {"f_m": 0.008, "h_m": 1.0, "theta_deg": 10.0, "a_px_per_m": 25000.0,
                    "b_px_per_m": 25000.0, "uc_px": 128.0, "vc_px": 96.0, "fps": 15.0,
                    "image_width_px": 256, "image_height_px": 192},
         "thresholds": {"range_min_m": 2.0, "range_max_m": 20.0}}
FOOT = (128.0, 110.0)  # the tracked pedestrian's foot point, px


def level_with_one(on: bool) -> PedestrianLevel:
    """A level tracking one pedestrian measured at FOOT, `new.cover_to_feet` on or off."""
    level = PedestrianLevel(config_from_dict(SMALL),
                            with_changes(CountOptions(), {"new.cover_to_feet": on}))
    p = level.new_pedestrian(0)
    p.z = FOOT
    level.peds.append(p)
    return level


def cover_of(level) -> tuple[int, int, int, int]:
    """The cover's columns c0..c1 (the integer span `free_runs` blocks) and rows (top, foot)."""
    w, h = (float(q) for q in level.shape.size(*FOOT))
    half = 0.5 * level.opt.new.walker_widths * w
    return (math.floor(FOOT[0] - half), math.ceil(FOOT[0] + half), round(FOOT[1] - h),
            int(FOOT[1]))


def runs_of(level, mask):
    blobs, labels = find_blobs(mask.astype(np.uint8), min_area=10)
    return list(free_runs(level, blobs, labels)), blobs, labels


def test_row_tolerance_is_k_sigma2_r_v():
    assert level_with_one(True).row_tolerance == pytest.approx(3 * 2.0)  # Table 1: 3 x 2 px


def legs_mask(below: int, cols: tuple[int, int] = (110, 146)) -> np.ndarray:
    """The tracked pedestrian's blob (its patch rows, the cover's columns less 2 each side)
    and a nearer walker's legs in columns `cols`, down to `below` rows under its feet."""
    c0, c1, top, foot = cover_of(level_with_one(False))
    mask = np.zeros((192, 256), bool)
    mask[top:foot + 1, c0 + 2:c1 - 2] = True
    mask[foot + 1:foot + 1 + below, cols[0]:cols[1]] = True
    return mask


@pytest.mark.parametrize("below", [6, 40])
def test_pixels_below_the_feet_are_free_only_with_the_option_and_beyond_the_tolerance(below):
    """A blob filling the cover's patch rows and, in 36 columns under its middle, `below` rows
    lower: with the option off no free run; on, 6 rows (the tolerance) stay explained, 40 rows
    give one run of exactly those 36 columns, standing on the blob's bottom row, its fill the
    free pixels below foot + 6 (by hand: 36 columns x 34 rows = 1224 px)."""
    lv = level_with_one(False)
    foot = cover_of(lv)[3]
    mask = legs_mask(below)
    assert runs_of(lv, mask)[0] == []
    on = level_with_one(True)
    runs, _, _ = runs_of(on, mask)
    if below <= on.row_tolerance:
        assert runs == []
        return
    (run,) = runs
    assert (run.x0 + run.c0, run.x0 + run.c1) == (110, 146)
    assert run.vb == foot + below
    free = run.crop[:, run.c0:run.c1] & (np.arange(run.crop.shape[0])[:, None] + run.y0
                                         > foot + on.row_tolerance)
    assert int(free.sum()) == 36 * (below - 6) == 1224
    assert int(free.sum()) >= on.opt.new.min_fill * run.w * run.h  # not thin: no refusal
    assert run.refused == ""


def test_the_run_is_as_tall_as_all_its_blob_pixels_and_as_full_as_its_free_ones():
    """The run of the legs 40 rows below the feet counts the covered pixels above in its
    height (its free rows alone, 34, are under min_height 0.5 H at its foot row: it would be
    refused as short); 2 free rows under 42 columns of the cover, in one blob with the body,
    are refused as thin (84 px, under min_fill 0.15 of a patch, though the blob's pixels in
    those columns are not), 2 columns as narrow."""
    on = level_with_one(True)
    foot = cover_of(on)[3]
    (run,) = runs_of(on, legs_mask(40))[0]
    assert 34 < on.opt.new.min_height * run.h and run.refused == ""
    (narrow,) = runs_of(on, legs_mask(40, (127, 129)))[0]
    assert narrow.refused == "narrow"
    mask = legs_mask(0)
    mask[foot + 1:foot + 9, 107:149] = True  # one blob with the body; rows foot + 7, + 8 free
    (thin,) = runs_of(on, mask)[0]
    assert (thin.c1 - thin.c0, thin.refused) == (42, "thin")
    assert thin.crop[:, thin.c0:thin.c1].sum() > on.opt.new.min_fill * thin.w * thin.h  # all


def test_a_nearer_walker_in_front_starts_a_pedestrian_on_its_feet():
    """`new_pedestrians` on the legs 40 rows below the feet: one new pedestrian, its foot point
    the run's centre column and bottom row; none with the option off."""
    for on, n in ((False, 0), (True, 1)):
        lv = level_with_one(on)
        blobs, labels = find_blobs(legs_mask(40).astype(np.uint8), min_area=10)
        new = new_pedestrians(lv, blobs, labels)
        assert len(new) == n
        if n:
            assert new[0].z == (127.5, cover_of(lv)[3] + 40.0)


def test_two_legs_under_a_cover_are_one_run_with_join_gap_widths():
    """Two legs (columns 110-125 and 130-145, a 4 px gap) 40 rows below the tracked one's feet:
    alone, each 16 columns is narrower than 0.6 W (W 44 px at the blob's bottom row 150);
    with `new.join_gap_widths` 0.6 (gap < 26 px) they are one run of 36 columns holding
    2 x 16 x 34 = 1088 free pixels (>= min_fill 0.15 W H): it passes. A gap of 30 px is not
    joined."""
    def legs(on: bool, right: int):
        lv = level_with_one(True)
        if on:
            lv.opt = with_changes(lv.opt, {"new.join_gap_widths": 0.6})
        mask = legs_mask(40, (110, 126)) | legs_mask(40, (right, right + 16))
        return runs_of(lv, mask)[0]

    apart = legs(False, 130)
    assert [(r.c1 - r.c0, r.refused) for r in apart] == [(16, "narrow"), (16, "narrow")]
    (one,) = legs(True, 130)
    assert (one.x0 + one.c0, one.x0 + one.c1, one.refused) == (110, 146, "")
    w_bottom = float(level_with_one(True).shape.size(127.5, 150.0)[0])
    assert 4 < 0.6 * w_bottom < 30
    assert len(legs(True, 156)) == 2  # 30 px apart: two runs


def test_fill_exposed_asks_the_fill_of_the_rows_below_the_cover():
    """Legs 20 rows below the tracked one's feet (36 columns, 14 rows free beyond the 6 px
    tolerance: 504 px) are thin against a whole patch (0.15 w h, over 900 px at their foot row)
    but not with `new.fill_exposed`, which asks 0.15 w x 14 rows (by hand, under 100 px)."""
    on = level_with_one(True)
    (run,) = runs_of(on, legs_mask(20))[0]
    assert run.refused == "thin" and 36 * 14 < on.opt.new.min_fill * run.w * run.h
    exposed = level_with_one(True)
    exposed.opt = with_changes(exposed.opt, {"new.fill_exposed": True})
    (run,) = runs_of(exposed, legs_mask(20))[0]
    assert run.refused == "" and on.opt.new.min_fill * run.w * 14 < 100 < 36 * 14
