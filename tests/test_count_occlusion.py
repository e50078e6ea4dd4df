"""`count.occlusion` (`placement.depth_order`): the placement order and the hidden-feet test on
hand-worked cases, and one hand-made merged blob placed by `PedestrianLevel._place`: an older
far walker whose blob a nearer walker's joins from below takes the nearer one's feet in the
default order, its own with the depth order, and is measured across only when the nearer
walker stands right under its feet; with `placement.shared_row_gate` it takes no measurement
there (and, with `shared_row_unsampled`, no rhythm sample); `row_gated` by hand."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from rhythmjax.count import CountOptions
from rhythmjax.count.occlusion import HIDDEN_ROWS, feet_hidden, placement_order
from rhythmjax.count.options import VerdictOptions, with_changes
from rhythmjax.model.params import config_from_dict


# a small camera (as tests/test_pedestrians.py): 256x192, 3 m high, 25 deg down, a f = b f =
# 200 px/m
CFG = config_from_dict({
    "camera": {"f_m": 0.008, "h_m": 3.0, "theta_deg": 25.0, "a_px_per_m": 25000.0,
               "b_px_per_m": 25000.0, "uc_px": 128.0, "vc_px": 96.0, "fps": 15.0,
               "image_width_px": 256, "image_height_px": 192},
    "thresholds": {"range_min_m": 3.0, "range_max_m": 15.0}})


def _ped(name, hits, born, v):
    return SimpleNamespace(name=name, hits=hits, born=born, next_uv=(50.0, v))


def test_order_by_age_or_by_depth():
    peds = [_ped("young near", 3, 9, 150.0), _ped("old far", 20, 0, 90.0),
            _ped("old near", 20, 1, 150.0), _ped("lost", 30, 0, float("nan")),
            _ped("young mid", 3, 5, 120.0)]
    names = lambda order: [q.name for q in order]
    assert names(placement_order(peds, False)) == [
        "lost", "old far", "old near", "young mid", "young near"]
    # nearest (largest foot row) first; equal rows older first; no prediction last
    assert names(placement_order(peds, True)) == [
        "old near", "young near", "young mid", "old far", "lost"]


def test_feet_hidden_reads_the_rows_under_the_middle_half():
    claimed = np.zeros((40, 60), bool)
    assert not feet_hidden(None, 30.0, 20.0, 16.0)
    assert not feet_hidden(claimed, 30.0, 20.0, 16.0)
    claimed[21, 26] = True  # the row below, column u - w/4 = 26: hidden
    assert feet_hidden(claimed, 30.0, 20.0, 16.0)
    claimed[:] = False
    claimed[20 + HIDDEN_ROWS, 34] = True  # the last row searched, column u + w/4 = 34
    assert HIDDEN_ROWS == 2 and feet_hidden(claimed, 30.0, 20.0, 16.0)
    claimed[:] = False
    claimed[23, 30] = True  # three rows down: not under the feet
    claimed[21, 25] = claimed[21, 35] = True  # beside the middle half
    claimed[20, 30] = True  # the foot row itself
    assert not feet_hidden(claimed, 30.0, 20.0, 16.0)
    claimed[:] = False
    claimed[39, 30] = True  # a foot row on the image's last row: nothing below it
    assert not feet_hidden(claimed, 30.0, 39.0, 16.0)


def _merged(level, du_w: float):
    """One blob (label 1): a far walker's patch standing on (100, 100) and a nearer walker's
    standing on (100 + du_w x the far W, 100 + a quarter of the far H), both full rectangles;
    the far pedestrian older. Returns (far, near, blobs, labels, far W, far H, near row)."""
    from rhythmjax.count.pedestrian_level import Pedestrian
    from rhythmjax.vision.blobs import Blob

    wf, hf = (float(q) for q in level.shape.size(100.0, 100.0))
    vn = 100.0 + round(0.25 * hf)
    un = 100.0 + du_w * wf
    wn, hn = (float(q) for q in level.shape.size(un, vn))
    lab = np.zeros((192, 256), np.int32)
    lab[round(101 - hf):101, round(100 - wf / 2):round(100 + wf / 2)] = 1
    lab[round(vn + 1 - hn):round(vn) + 1, round(un - wn / 2):round(un + wn / 2)] = 1
    ys, xs = np.nonzero(lab)
    blob = Blob((int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1),
                int(ys.size), 0.0, (float(xs.mean()), float(ys.mean())), 0.5, 1)
    far, near = Pedestrian(slot=0, born=0), Pedestrian(slot=1, born=5)
    far.hits, far.track_id, far.next_uv = 30, 1, (100.0, 101.5)  # predicted 1.5 rows low
    near.hits, near.track_id, near.next_uv = 10, 2, (un, vn)
    level.peds = [far, near]
    return far, near, [blob], lab, wf, hf, vn


@pytest.mark.parametrize("depth_order", [False, True])
def test_a_nearer_walker_joining_below_no_longer_lends_its_feet(depth_order):
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"placement.depth_order": depth_order})
    level = PedestrianLevel(CFG, opt)
    # the near walker one far W to the right: its patch covers the far patch's right edge
    # only (not under the far walker's middle half), the merged blob wide enough to place both
    far, near, blobs, lab, wf, hf, vn = _merged(level, 1.0)
    assert vn - 100.0 < 0.35 * hf  # inside the band the far placement searches below
    level._place({id(far): {0}, id(near): {0}}, blobs, lab)
    assert near.z == pytest.approx((near.next_uv[0], vn), abs=1.0)
    if depth_order:
        assert far.z[1] == 100.0 and abs(far.z[0] - 100.0) <= 0.3 * wf
        assert level.gated == {}
    else:  # the older far walker placed first takes the nearer one's feet
        assert far.z[1] == vn


def test_feet_right_above_a_nearer_walker_are_measured_across_only():
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"placement.depth_order": True})
    level = PedestrianLevel(CFG, opt)
    # the near walker 0.7 far W to the right: its patch (wider than the far one) reaches under
    # the far walker's middle half, whose lowest unclaimed pixels are its own feet at row 100
    far, near, blobs, lab, wf, hf, vn = _merged(level, 0.7)
    level._place({id(far): {0}, id(near): {0}}, blobs, lab)
    assert near.z == pytest.approx((near.next_uv[0], vn), abs=1.0)
    assert far.z[1] == far.next_uv[1] == 101.5  # the predicted row: not measured
    assert abs(far.z[0] - 100.0) <= 0.3 * wf
    assert level.gated == {"hidden": 1}


def test_is_wide_and_the_row_tolerance():
    from rhythmjax.count.occlusion import foot_row_tolerance, is_wide

    box = (10, 0, 70, 40)  # 60 px wide
    assert is_wide(box, 19.0, 3.0) and not is_wide(box, 20.0, 3.0)  # 60 > 57; 60 = 60 is not
    assert not is_wide(box, 19.0, 0.0) and not is_wide(box, float("nan"), 3.0)
    # k_sigma2 (Table 1: 3) x the foot row's noise std: 2 px by default, 4 px here
    assert foot_row_tolerance(CFG) == 6.0
    noisy = config_from_dict({"noise": {"r_std_px": [4.0, 4.0]}})
    assert foot_row_tolerance(noisy) == 12.0


def alone_on(level, extra, **fields):
    """One pedestrian (predicted at (100, 101.5), older than any; `fields` set on it) alone on
    one blob (label 1): its own patch standing on (100, 100) plus the rectangles `extra` (x0,
    y0, x1, y1)."""
    from rhythmjax.count.pedestrian_level import Pedestrian
    from rhythmjax.vision.blobs import Blob

    wf, hf = (float(q) for q in level.shape.size(100.0, 100.0))
    lab = np.zeros((192, 256), np.int32)
    lab[round(101 - hf):101, round(100 - wf / 2):round(100 + wf / 2)] = 1
    for x0, y0, x1, y1 in extra(wf):
        lab[y0:y1, x0:x1] = 1
    ys, xs = np.nonzero(lab)
    blob = Blob((int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1),
                int(ys.size), 0.0, (float(xs.mean()), float(ys.mean())), 0.5, 1)
    p = Pedestrian(slot=0, born=0)
    p.hits, p.track_id, p.next_uv = 30, 1, (100.0, 101.5)
    for name, value in fields.items():
        setattr(p, name, value)
    level.peds = [p]
    level._place({id(p): {0}}, [blob], lab)
    return p, wf


@pytest.mark.parametrize("wide_widths", [0.0, 3.0])
def test_a_walker_on_a_wide_blob_keeps_its_row(wide_widths):
    """A wider object in front (100 px, ~6.8 W, bottom row 112: 10.5 px below the predicted
    row, over the 6 px tolerance) merged into the walker's blob: in the default placement the
    walker's foot row drops to that object's bottom; with `placement.wide_widths` 3 it is
    measured across only, at its predicted row."""
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"placement.wide_widths": wide_widths})
    level = PedestrianLevel(CFG, opt)
    p, wf = alone_on(level, lambda wf: [(60, 85, 160, 113)])
    assert 100 / wf > 3.0
    assert abs(p.z[0] - 100.0) <= 0.3 * wf
    if wide_widths:
        assert p.z[1] == 101.5 and level.gated == {"wide": 1}
    else:
        assert p.z[1] == 112.0 and level.gated == {}


def test_a_walker_in_a_wide_group_still_measures_its_feet():
    """Three walkers side by side (their rectangles 1.1 W apart: a box 3.2 W wide) on one blob:
    the middle one is alone on a wide blob, its feet 1.5 px from the prediction: measured."""
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"placement.wide_widths": 3.0})
    level = PedestrianLevel(CFG, opt)

    def sides(wf):
        h = round(float(level.shape.size(100.0, 100.0)[1]))
        return [(round(100 + s * 1.1 * wf - wf / 2), 101 - h, round(100 + s * 1.1 * wf + wf / 2),
                 101) for s in (-1, 1)]

    p, wf = alone_on(level, sides)
    assert p.z[1] == 100.0 and abs(p.z[0] - 100.0) <= 1.0
    assert level.gated == {}


@pytest.mark.parametrize("key", ["placement.wide_widths", "life.max_dv_w"])
@pytest.mark.parametrize("value", [-1.0, float("nan"), float("inf")])
def test_a_negative_or_nan_limit_is_refused(key, value):
    with pytest.raises(ValueError, match=key.replace(".", r"\.")):
        with_changes(CountOptions(), {key: value})
    group, name = key.split(".")
    assert getattr(getattr(with_changes(CountOptions(), {key: 3.0}), group), name) == 3.0


@pytest.mark.parametrize("gate", [False, True])
def test_a_shared_placement_whose_row_is_off_predicts_with_the_gate(gate):
    """`placement.shared_row_gate`: the merged blob above (the older far walker placed first
    takes the nearer one's feet, a quarter far H = about 9 px below its predicted row, over the
    6 px tolerance): without the gate it measures that row, with it it takes no measurement
    (gated "shared-row"); the nearer walker, on its own feet, is measured either way."""
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"placement.shared_row_gate": gate})
    level = PedestrianLevel(CFG, opt)
    far, near, blobs, lab, wf, hf, vn = _merged(level, 1.0)
    assert vn - far.next_uv[1] > level.row_tolerance
    level._place({id(far): {0}, id(near): {0}}, blobs, lab)
    assert near.z == pytest.approx((near.next_uv[0], vn), abs=1.0)
    if gate:
        assert all(np.isnan(far.z)) and level.gated == {"shared-row": 1}
    else:
        assert far.z[1] == vn and level.gated == {}


def test_row_gated_by_hand():
    """`row_gated` on a stub level: the first rule that applies wins; within the tolerance (6 px
    here) nothing changes; alone (not shared) the shared-row gate does not apply."""
    from rhythmjax.count.occlusion import row_gated

    def level(**changes):
        opt = with_changes(CountOptions(), changes)
        return SimpleNamespace(opt=opt, row_tolerance=6.0, gated={})

    p = SimpleNamespace(next_uv=(50.0, 100.0), rewound=False)
    near, off = SimpleNamespace(u=52.0, v=105.0, w=20.0), SimpleNamespace(u=52.0, v=107.0, w=20.0)
    on = level(**{"placement.shared_row_gate": True})
    assert row_gated(on, p, near, (52.0, 105.0), shared=True, wide=False, claimed=None) == \
        (52.0, 105.0)
    assert row_gated(on, p, off, (52.0, 107.0), shared=True, wide=False, claimed=None) is None
    assert on.gated == {"shared-row": 1}
    assert row_gated(on, p, off, (52.0, 107.0), shared=False, wide=False, claimed=None) == \
        (52.0, 107.0)
    assert row_gated(on, p, off, (52.0, 107.0), shared=True, wide=True, claimed=None) == \
        (52.0, 100.0) and on.gated == {"shared-row": 1, "wide": 1}  # wide first: across only
    default = level()
    assert row_gated(default, p, off, (52.0, 107.0), shared=True, wide=False,
                     claimed=None) == (52.0, 107.0) and default.gated == {}
    p.rewound = True
    predict = level(**{"life.rewind_predict": True})
    assert row_gated(predict, p, off, (52.0, 107.0), shared=False, wide=False,
                     claimed=None) is None and predict.gated == {"rewound": 1}


@pytest.mark.parametrize("unsampled", [False, True])
def test_a_refused_shared_row_samples_no_intensity_with_the_option(unsampled):
    """`placement.shared_row_unsampled`: a row whose shared placement the gate refused
    (`Pedestrian.unseen`) keeps a predicted row in the tracks; its I(k) is NaN with the option,
    window B's sum at the estimate without it (a frame difference of ones: W x W/5 pixels)."""
    from rhythmjax.count.pedestrian_level import PedestrianLevel
    from rhythmjax.model.camera_np import project_3d

    from .test_count_coast import DT, unmeasured_step

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"placement.shared_row_gate": True,
                        "placement.shared_row_unsampled": unsampled})
    level = PedestrianLevel(CFG, opt)
    level.image_shape = (192, 256)
    p = level.new_pedestrian(0)
    p.track_id = p.hits = 1
    level.peds.append(p)
    uv = project_3d(CFG.camera, 0.0, 8.0, 0.0)
    D = np.ones((192, 256), np.float32)
    for unseen in (False, True):
        p.z, p.unseen = (math.nan, math.nan), unseen
        level._after(p, unmeasured_step(level.filter.slots, uv), 0, 0.0, DT, [], D)
    seen_row, unseen_row = p.rows
    assert seen_row.intensity > 0 and np.isfinite(seen_row.intensity)
    if unsampled:
        assert np.isnan(unseen_row.intensity)
    else:
        assert unseen_row.intensity == seen_row.intensity


@pytest.mark.parametrize("column", ["measured", "estimate"])
def test_window_b_column_on_a_measured_frame(column):
    """`placement.window_column`: on a measured frame window B is centred on the placed column
    ("measured") or on the filter's column estimate ("estimate"), its bottom row the measured
    foot row either way. On a frame difference equal to the column index, I(k) is Hb rows x
    the sum of Wb consecutive column indices from x0, worked by hand from (u, v, W)."""
    from rhythmjax.count.pedestrian_level import PedestrianLevel
    from rhythmjax.model.camera_np import project_3d

    from .test_count_coast import DT, unmeasured_step

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"placement.window_column": column})
    level = PedestrianLevel(CFG, opt)
    level.image_shape = (192, 256)
    p = level.new_pedestrian(0)
    p.track_id = p.hits = 1
    level.peds.append(p)
    eu, ev = (float(q) for q in project_3d(CFG.camera, 0.0, 8.0, 0.0))
    out = unmeasured_step(level.filter.slots, (eu, ev))
    out.used[0] = 1.0  # the filter took the measurement
    zu, zv = eu + 7.3, ev + 0.4  # placed 7.3 px across and 0.4 px below the estimate
    p.z = (zu, zv)
    D = np.tile(np.arange(256, dtype=np.float32), (192, 1))  # D[y, x] = x
    level._after(p, out, 0, 0.0, DT, [], D)
    u = zu if column == "measured" else eu
    W = float(level.shape.size(u, zv)[0])
    wb, hb = math.floor(W + 0.5), math.floor(W / 5 + 0.5)
    x0 = math.floor(u - wb / 2 + 0.5)
    want = hb * wb * (x0 + (wb - 1) / 2)  # the column indices x0 .. x0 + wb - 1, hb rows
    row = p.rows[-1]
    assert (row.u, row.v) == (zu, zv)  # the tracks keep the measured foot point
    assert row.intensity == pytest.approx(want, rel=1e-6)
    other = zu if column == "estimate" else eu  # the other column gives another sum
    assert abs(row.intensity - hb * wb * (math.floor(other - wb / 2 + 0.5) + (wb - 1) / 2)) > 1


def test_window_column_refuses_an_unknown_value():
    assert CountOptions().placement.window_column == "measured"
    with pytest.raises(ValueError, match="placement.window_column"):
        with_changes(CountOptions(), {"placement.window_column": "legs"})
