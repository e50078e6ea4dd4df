"""Detection (Sec. 2) and the window-B rhythm signal (Sec. 4.1) on synthetic frames, against NumPy
references written again here."""

from __future__ import annotations

import math
import os

import cv2
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model.camera import project
from rhythmjax.model.params import Camera, WidthModel
from rhythmjax.vision.detect import (
    Detection,
    block_any,
    box_overlap,
    detect_in_window,
    find_objects,
    frame_difference,
    is_duplicate,
    is_global_change,
    motion_from_diff,
    motion_image,
    shared_detections,
    walker_width_px,
    window_b_intensity,
    window_b_rect,
)


S = 256
CASIA = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "real", "casia_b_090",
                     "001-nm-01-090.avi")


def _background(textured: bool, seed: int = 0) -> np.ndarray:
    if not textured:
        return np.full((S, S), 150, np.uint8)
    rng = np.random.default_rng(seed)
    noise = rng.normal(0, 1, (S // 8, S // 8))
    tex = cv2.resize(noise, (S, S), interpolation=cv2.INTER_CUBIC)
    return np.clip(150 + 25 * tex, 90, 210).astype(np.uint8)


def _walker(img: np.ndarray, x: int, bottom: int, k: int, width: int = 24,
            height: int = 70) -> tuple[float, int]:
    """Draw a dark body (columns x .. x+width-1) on two swinging legs whose feet stay inside the
    body's columns; the lowest drawn row is `bottom`. Returns the drawn bottom centre (u, v)."""
    hip = bottom - 30
    cv2.rectangle(img, (x, bottom - height + 1), (x + width - 1, hip), 40, -1)
    swing = int(round(5 * math.sin(0.9 * k)))
    for hx, s in ((x + 3, swing), (x + width - 10, -swing)):
        foot = min(max(hx + s, x), x + width - 7)
        leg = np.array([[hx, hip], [hx + 6, hip], [foot + 6, bottom], [foot, bottom]], np.int32)
        cv2.fillPoly(img, [leg], 55)
    return x + (width - 1) / 2, bottom


def _scene(n: int, textured: bool, dx: int = 2, x0: int = 60, bottom: int = 200,
           noise: float = 2.0, seed: int = 0):
    rng = np.random.default_rng(seed)
    bg = _background(textured, seed)
    frames, truth = [], []
    for k in range(n):
        f = bg.copy()
        truth.append(_walker(f, x0 + dx * k, bottom, k))
        f = np.clip(f + rng.normal(0, noise, f.shape), 0, 255).astype(np.uint8)
        frames.append(f)
    return frames, truth


def _motion_ref(prev: np.ndarray, cur: np.ndarray, t: float, te: float) -> np.ndarray:
    """[D > t] + [min(|Sobel_x D|, 255) > te], Sobel by hand on a reflect-101 padded D."""
    d = np.abs(cur.astype(np.int32) - prev.astype(np.int32))
    p = np.pad(d, 1, mode="reflect")  # numpy 'reflect' == OpenCV BORDER_REFLECT_101
    kx = np.array([[-1, 0, 1], [-2, 0, 2], [-1, 0, 1]])
    sx = sum(kx[i, j] * p[i:i + d.shape[0], j:j + d.shape[1]] for i in range(3) for j in range(3))
    return (d > t).astype(np.uint8) + (np.minimum(np.abs(sx), 255) > te).astype(np.uint8)


@pytest.mark.parametrize("textured", [False, True])
def test_motion_image_matches_numpy_reference_exactly(textured):
    frames, _ = _scene(3, textured)
    for t, te in ((20, None), (12.5, 30), (0, 0)):
        m, d = motion_image(frames[1], frames[2], diff_threshold=t, edge_threshold=te)
        ref = _motion_ref(frames[1], frames[2], t, 4 * t if te is None else te)
        assert m.dtype == np.uint8 and np.array_equal(m, ref)
        assert np.array_equal(d, np.abs(frames[2].astype(int) - frames[1].astype(int)))
    with pytest.raises(ValueError):
        motion_from_diff(d, diff_threshold=70)  # default edge threshold 280 > 255
    with pytest.raises(ValueError):
        frame_difference(frames[0], frames[0][:-1])


@pytest.mark.parametrize("textured", [False, True])
def test_foot_point_and_width_in_window(textured):
    frames, truth = _scene(20, textured, dx=2)
    for k in range(1, 20):
        m, _ = motion_image(frames[k - 1], frames[k], diff_threshold=20)
        u, v = truth[k]
        pred = (u + 7, v - 10)  # a prediction a few px off
        det = detect_in_window(m, pred, (80, 120))
        assert det is not None
        # wid_IMG spans both positions: the drawn width plus |dx| (2 px), u lags dx/2; the Sobel
        # halo (1 px a side) is removed
        assert abs(det.u - u) <= 2 and abs(det.v - v) <= 2, (k, det, truth[k])
        assert abs(det.width - 24) <= 3, (k, det)
        x0, y0, w, h = det.box
        assert x0 <= det.u <= x0 + w and det.v == y0 + h - 1 and det.area > 0


def test_projection_slicing_on_a_block():
    m = np.zeros((100, 100), np.uint8)
    m[30:61, 40:51] = 1  # rows 30..60, columns 40..50
    m[55:61, 42:49] = 2  # 'edges' add on top
    det = detect_in_window(m, (45, 60), 60, halo=0)
    assert (det.u, det.v, det.width, det.box) == (45.0, 60.0, 11.0, (40, 30, 11, 31))
    assert detect_in_window(m, (45, 60), 60).width == 9.0  # less the 1 px halo each side
    assert det.area == 31 * 11
    m[90:, :] = 0
    assert detect_in_window(m, (10, 95), 10) is None  # empty window
    assert detect_in_window(m, (500, 500), 20) is None  # outside the image
    assert detect_in_window(m, (math.nan, 10), 20) is None
    assert detect_in_window(m, np.array([45.0, 60.0]), np.int64(60), halo=0) == det


def test_find_objects_two_separated_and_exclusion():
    a, _ = _scene(2, True, x0=40, seed=1)
    b = [f.copy() for f in a]
    for k, f in enumerate(b):  # a second, smaller walker further right and higher
        _walker(f, 170 + 3 * k, 150, k, width=16, height=50)
    m, _ = motion_image(b[0], b[1], diff_threshold=20)
    objs = find_objects(m, min_area=30)
    assert len(objs) == 2
    objs.sort(key=lambda o: o.u)
    assert abs(objs[0].u - (41 + 23 / 2)) <= 2 and abs(objs[0].v - 200) <= 2
    assert abs(objs[1].u - (173 + 15 / 2)) <= 2.5 and abs(objs[1].v - 150) <= 2
    assert objs[0].area > objs[1].area
    left = find_objects(m, min_area=30, exclude_boxes=[objs[0].box])
    assert len(left) == 1 and left[0] == objs[1]
    assert find_objects(m, min_area=10**6) == []
    assert len(find_objects(m, min_area=30, max_objects=1)) == 1


def test_window_b_intensity_is_a_numpy_sum():
    rng = np.random.default_rng(3)
    d = rng.integers(0, 256, (240, 320), dtype=np.uint8)
    # W = 37.4: 37 columns from floor(100.3 - 18.5 + 0.5) = 82, round(7.48) = 7 rows ending at
    # row round(200.6) = 201 (the foot row is inside B)
    assert window_b_rect(d.shape, 100.3, 200.6, 37.4) == (82, 195, 119, 202)
    assert window_b_intensity(d, 100.3, 200.6, 37.4) == float(d[195:202, 82:119].sum())
    assert window_b_intensity(d, 100.3, 200.6, 37.4, mean=True) == pytest.approx(
        d[195:202, 82:119].mean())
    # clipped at the borders: x0 = floor(5 - 20 + 0.5) = -15 -> 0, rows 232..239 -> 232..239
    assert window_b_intensity(d, 5, 239, 40) == float(d[232:240, 0:25].sum())
    assert window_b_intensity(d, 5, 239, 40, mean=True) == pytest.approx(d[232:240, 0:25].mean())
    assert window_b_intensity(d, 1000, 1000, 40) == 0.0
    assert math.isnan(window_b_intensity(d, math.nan, 10, 40))
    assert math.isnan(window_b_intensity(d, 10, 10, 0))
    # the walker's legs make B's intensity move with the gait
    frames, truth = _scene(16, True)
    sig = []
    for k in range(1, 16):
        m, dd = motion_image(frames[k - 1], frames[k], diff_threshold=20)
        det = detect_in_window(m, truth[k], 100)
        sig.append(window_b_intensity(dd, det.u, det.v, 26))
    assert np.std(sig) > 0.05 * np.mean(sig) > 0


def test_walker_width_from_camera():
    cam, wm = Camera(), WidthModel()
    for y in (3.0, 10.0, 20.0):
        u, v = (float(c) for c in project(cam, jnp.float32(0.4), jnp.float32(y)))
        f, h, th, af = 0.008, 1.0, math.radians(15), 0.008 * 1e5
        want = af * 0.5 / (f + y * math.cos(th) + h * math.sin(th))
        assert walker_width_px(cam, wm, u, v) == pytest.approx(want, rel=1e-4)
    assert math.isnan(walker_width_px(cam, wm, 256, 0))  # above the horizon (v ~ 41.6 px)
    ws = walker_width_px(cam, wm, np.array([256.0, 256.0]), np.array([0.0, 300.0]))
    assert ws.shape == (2,) and math.isnan(ws[0])
    assert ws[1] == pytest.approx(walker_width_px(cam, wm, 256, 300.0), rel=1e-6)


def test_global_change_and_duplicates():
    frames, _ = _scene(3, True)
    d = frame_difference(frames[1], frames[2])
    assert not is_global_change(d, 20) and not is_duplicate(d)
    bright = cv2.add(frames[2], 60)  # sudden illumination change
    assert is_global_change(frame_difference(frames[1], bright), 20)
    garbage = np.random.default_rng(0).integers(0, 256, frames[0].shape, dtype=np.uint8)
    assert is_global_change(frame_difference(frames[1], garbage), 20)
    assert not is_global_change(frame_difference(frames[1], garbage), 20, fraction=0.95)
    assert is_duplicate(frame_difference(frames[1], frames[1].copy()))


@pytest.mark.data
def test_casia_smoke():
    if not os.path.isfile(CASIA):
        pytest.skip("CASIA-B clip not present")
    from rhythmjax.vision.video import open_video

    src = open_video(CASIA)
    assert src.fps == 25.0 and (src.width, src.height) == (320, 240)
    prev, found = None, []
    for _, _, f in src:
        if prev is not None:
            m, _ = motion_image(prev, f, diff_threshold=15)
            objs = find_objects(m, min_area=100)
            found.append(bool(objs) and objs[0].width > 10)
        prev = f
    n = len(found)
    assert n == src.n_frames_read - 1 >= 50
    # the background is empty until the walker enters; from then on it is found in most frames
    first = found.index(True)
    assert 10 < first < n // 2
    assert np.mean(found[first:]) >= 0.9, (first, found)


def test_box_overlap_and_shared_detections_hand_worked():
    """(x0, y0, w, h) boxes: [0, 10) x [0, 10) and [6, 16) x [5, 25) share a 4 x 5 px patch;
    two detections are one blob when that covers half of the smaller box."""
    assert box_overlap((0, 0, 10, 10), (6, 5, 10, 20)) == 20
    assert box_overlap((0, 0, 10, 10), (10, 0, 5, 5)) == 0  # touching, half-open
    assert box_overlap((0, 0, 10, 10), (2, 3, 4, 4)) == 16  # contained
    det = lambda box: Detection(u=0.0, v=0.0, width=1.0, box=box, area=1)  # noqa: E731
    dets = {0: det((0, 0, 10, 10)), 1: det((2, 3, 4, 4)), 2: det((6, 5, 10, 20)),
            3: det((40, 40, 5, 5))}
    # 0-1: 16 >= 0.5 * 16; 0-2: 20 < 0.5 * 100; 1-2: 0; 3 alone
    assert shared_detections(dets, 0.5) == {0, 1}
    assert shared_detections(dets, 0.2) == {0, 1, 2}  # 20 >= 0.2 * 100
    assert shared_detections({0: dets[0]}) == set()


def test_body_parts_apart_are_joined_within_body_px():
    """A far walker's motion: two torso outlines apart (its uniform inside does not change), a
    leg under the left one; the prediction (core) is off to the right by half a body, so the
    left part has a single column inside it. Without `body_px` only the right outline is
    measured (narrow, foot point on the wrong part); with it the parts touching the core within
    body_px columns are joined (the whole body, foot at the leg), and neither a part outside
    the core (above it) nor one that would widen them beyond body_px is."""
    m = np.zeros((200, 200), np.uint8)
    m[40:100, 60:63] = 1  # left torso outline, columns 60..62
    m[100:130, 58:61] = 2  # a leg under it, foot row 129 (one region with the outline)
    m[40:100, 88:91] = 1  # right torso outline, columns 88..90 (apart by 25 px > dilation)
    m[10:20, 70:73] = 1  # above the core: not the body's
    m[60:128, 140:150] = 1  # a neighbour further right, outside the core
    core = (62, 30, 40, 102)  # predicted body box: columns 62..101, rows 30..131
    kw = dict(halo=0, core=core)
    alone = detect_in_window(m, (100, 90), (120, 180), **kw)
    assert alone.box[0] == 88 and alone.width == 3 and alone.v == 99  # the right outline only
    joined = detect_in_window(m, (100, 90), (120, 180), body_px=40, **kw)
    assert joined.box == (58, 40, 33, 90) and joined.v == 129 and joined.u == 58 + 32 / 2
    assert detect_in_window(m, (100, 90), (120, 180), body_px=20, **kw) == alone  # too wide


@pytest.mark.parametrize("s", [2, 4, 5, 8])
def test_block_any_matches_a_numpy_loop(s):
    """`block_any` against a plain loop over the s x s blocks (partial ones at the right and
    bottom edges included), on sparse random masks with values 0-2 and sizes not divisible by s;
    exact."""
    rng = np.random.default_rng(s)
    for H, W in ((37, 53), (64, 64), (5, 3)):
        mask = (rng.random((H, W)) < 0.03).astype(np.uint8) * rng.integers(1, 3, (H, W)).astype(
            np.uint8)
        Hs, Ws = -(-H // s), -(-W // s)
        ref = np.zeros((Hs, Ws), np.uint8)
        for i in range(Hs):
            for j in range(Ws):
                ref[i, j] = mask[i * s:(i + 1) * s, j * s:(j + 1) * s].any()
        np.testing.assert_array_equal(block_any(mask, s), ref)


def test_motion_image_changed_counts_the_thresholded_difference():
    """M and D equal `motion_image`'s and n equals a NumPy count of D > threshold, exactly, on
    random frames (including thresholds at the grey levels present)."""
    from rhythmjax.vision.detect import motion_image_changed

    rng = np.random.default_rng(5)
    for thr in (0, 7, 15, 60):
        a, b = (rng.integers(0, 256, (37, 53), dtype=np.uint8) for _ in range(2))
        m, d, n = motion_image_changed(a, b, diff_threshold=thr)
        m0, d0 = motion_image(a, b, diff_threshold=thr)
        np.testing.assert_array_equal(m, m0)
        np.testing.assert_array_equal(d, d0)
        assert n == int(np.sum(np.abs(a.astype(int) - b.astype(int)) > thr))
        for f in (0.3, 0.5, 0.9):
            assert is_global_change(d, thr, f, changed=n) == is_global_change(d, thr, f)


def test_motion_outside_counts_motion_pixels_outside_the_boxes():
    """Against a NumPy mask loop: boxes overlapping each other, the border and the frame's
    outside (negative corners, past the edge), and none."""
    from rhythmjax.vision.detect import motion_outside

    rng = np.random.default_rng(6)
    m = (rng.random((40, 60)) < 0.3).astype(np.uint8) * rng.integers(1, 3, (40, 60)).astype(
        np.uint8)
    boxes = [(-5, -3, 12, 10), (8, 4, 20, 15), (20, 10, 10, 40), (55, 35, 30, 30), (0, 0, 0, 5)]
    for k in range(len(boxes) + 1):
        keep = np.ones(m.shape, bool)
        for x, y, w, h in boxes[:k]:
            for yy in range(max(y, 0), min(y + h, 40)):
                for xx in range(max(x, 0), min(x + w, 60)):
                    keep[yy, xx] = False
        assert motion_outside(m, boxes[:k]) == int(np.sum((m > 0) & keep))
    for margin in (1, 3):  # the boxes grown by `margin` on each side
        keep = np.ones(m.shape, bool)
        for x, y, w, h in boxes:
            for yy in range(max(y - margin, 0), min(y + h + margin, 40)):
                for xx in range(max(x - margin, 0), min(x + w + margin, 60)):
                    keep[yy, xx] = False
        assert motion_outside(m, boxes, margin) == int(np.sum((m > 0) & keep))


def test_foot_column_of_the_body_core_beside_a_trailing_suitcase():
    """Rule 32b, hand-worked: a walker's motion (columns 40..50, rows 30..90: 61 px per column)
    pulling a suitcase (columns 52..69, rows 75..90: 16 px per column, 0.26 of the walker's).
    The slice at 0.1 takes both (extent 40..69: u_p 54.5, wid_IMG 30); where that extent is
    wider than the predicted body box, u_p is the centre of the columns reaching 0.3 of the
    maximum (the walker's, 40..50: 45.0) and the box spans those columns; the foot row, the
    rows and the width stay the slice's. A body box at least as wide as the extent, no body
    box, or no column fraction: 54.5."""
    m = np.zeros((120, 120), np.uint8)
    m[30:91, 40:51] = 1
    m[75:91, 52:70] = 1
    centre, size = (55, 60), (80, 100)
    kw = dict(fraction=0.1, halo=0, dilate_px=3)
    paper = detect_in_window(m, centre, size, core=(35, 20, 24, 72), column_fraction=None, **kw)
    assert (paper.u, paper.v, paper.width, paper.box) == (54.5, 90.0, 30.0, (40, 30, 30, 61))
    core = detect_in_window(m, centre, size, core=(35, 20, 24, 72), column_fraction=0.3, **kw)
    assert core.u == 45.0 and (core.v, core.width, core.box) == (90.0, 30.0, (40, 30, 11, 61))
    assert core.u_extent == 54.5 and math.isnan(paper.u_extent) and paper.window_u(True) == 54.5
    assert detect_in_window(m, centre, size, core=(30, 20, 30, 72), column_fraction=0.3,
                            **kw).u == 54.5  # the extent (30 px) is not wider than the box
    assert detect_in_window(m, centre, size, column_fraction=0.3, **kw).u == 54.5  # no box
    # 0.3 of the maximum and no more: at 0.25 the suitcase's columns (0.26) are the core's too
    assert detect_in_window(m, centre, size, core=(35, 20, 24, 72), column_fraction=0.25,
                            **kw).u == 54.5


def test_foot_column_of_the_upper_body_beside_a_trailing_suitcase():
    """Rule 33, hand-worked on rule 32b's walker and suitcase: the sliced rows are 30..90 (61),
    their top half (int(0.5 * 61) = 30 rows, 30..59) holds the walker's columns only (40..50),
    so u_p is 45.0 and the box spans them; foot row, rows and width stay the slice's. With the
    top 0.8 (48 rows, 30..77) the suitcase's 3 rows per column are below the slice (3/48 < 0.1):
    45.0; with the top 0.9 (54 rows, 30..83) its 9 are above it (9/54): u_p 54.5 again. Not wider
    than the body box, or no body box: the paper's 54.5."""
    m = np.zeros((120, 120), np.uint8)
    m[30:91, 40:51] = 1
    m[75:91, 52:70] = 1
    centre, size = (55, 60), (80, 100)
    kw = dict(fraction=0.1, halo=0, dilate_px=3)
    upper = detect_in_window(m, centre, size, core=(35, 20, 24, 72), column_rows=0.5, **kw)
    assert upper.u == 45.0 and (upper.v, upper.width, upper.box) == (90.0, 30.0, (40, 30, 11, 61))
    # rule 54: the paper's column kept for window B (the extent 40..69), u itself otherwise
    assert (upper.u_extent, upper.window_u(True), upper.window_u(False)) == (54.5, 54.5, 45.0)
    kept = detect_in_window(m, centre, size, core=(35, 20, 24, 72), column_rows=0.5,
                            column_box=False, **kw)  # rule 54: only u_p moves, the box stays
    assert (kept.u, kept.u_extent, kept.box) == (45.0, 54.5, (40, 30, 30, 61))
    # rule 54b: every detection with a body box, the one as wide as the box too
    assert detect_in_window(m, centre, size, core=(30, 20, 30, 72), column_rows=0.5,
                            column_wide_px=0, **kw).u == 45.0
    assert detect_in_window(m, centre, size, core=(35, 20, 24, 72), column_rows=0.8,
                            **kw).u == 45.0
    assert detect_in_window(m, centre, size, core=(35, 20, 24, 72), column_rows=0.9,
                            **kw).u == 54.5
    assert detect_in_window(m, centre, size, core=(30, 20, 30, 72), column_rows=0.5,
                            **kw).u == 54.5
    plain = detect_in_window(m, centre, size, column_rows=0.5, **kw)  # no body box: untouched
    assert plain.u == 54.5 and math.isnan(plain.u_extent) and plain.window_u(True) == 54.5


def test_upper_body_column_ignores_the_legs_swing():
    """Rule 33 against rule 32b on a walker mid-stride: torso columns 40..50 over rows 30..65,
    below them a stance leg with little motion (columns 34..41, every other row of 66..90: 13 px
    per column) and a swinging leg with much (columns 49..58, every row of 66..90: 25 px). The
    slice at 0.1 spans 34..58 (u_p 46.0); the upper half's columns (rows 30..59) are the
    torso's, 40..50 (45.0); the core fraction 0.3 (of 61 px) keeps the swinging leg's columns
    and not the stance leg's: 40..58 (49.0), pulled by the legs."""
    m = np.zeros((120, 120), np.uint8)
    m[30:66, 40:51] = 1
    m[66:91:2, 34:42] = 1
    m[66:91, 49:59] = 1
    centre, size = (45, 60), (80, 100)
    kw = dict(fraction=0.1, halo=0, dilate_px=3, core=(39, 20, 12, 72))
    assert detect_in_window(m, centre, size, **kw).u == 46.0
    assert detect_in_window(m, centre, size, column_rows=0.5, **kw).u == 45.0
    assert detect_in_window(m, centre, size, column_fraction=0.3, **kw).u == 49.0
