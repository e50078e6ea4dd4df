"""Images and blobs levels (rhythmjax/blobs.py) against NumPy float64 references and hand-counted
shapes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.vision.blobs import BackgroundModel, Blob, find_blobs, foreground_fraction, is_crowd


def _ref_step(bg: np.ndarray, img: np.ndarray, alpha: float, beta: float, t: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """Float64 reference of steps 1 and 3 without morphology: mask, new background."""
    d = img.astype(np.float64) - bg
    mask = (np.abs(d) > t).astype(np.uint8)
    rate = np.where(mask == 1, beta, alpha)
    return mask, bg + rate * d


@pytest.mark.parametrize("beta", [0.0, 0.01])
def test_selective_update_matches_float64_reference(beta: float) -> None:
    rng = np.random.default_rng(1)
    h, w, alpha, t = 24, 31, 0.07, 20.0
    first = rng.integers(0, 256, (h, w), dtype=np.uint8)
    model = BackgroundModel(first, alpha=alpha, threshold=t, open_px=0, close_px=0,
                            slow_alpha=beta)
    ref = first.astype(np.float64)
    n_fg = 0
    for _ in range(12):
        img = np.clip(ref + rng.normal(0, 15, (h, w)), 0, 255).astype(np.uint8)
        # keep |D| away from the threshold so float32 rounding cannot flip a pixel
        img[np.abs(np.abs(img - ref) - t) < 1e-3] = 0
        want_mask, ref = _ref_step(ref, img, alpha, beta, t)
        got = model.apply(img)
        assert got.dtype == np.uint8 and got.shape == (h, w)
        np.testing.assert_array_equal(got, want_mask)
        n_fg += int(want_mask.sum())
        # float32 spacing at 255 is 1.5e-5: allow one ulp of relative error per frame
        np.testing.assert_allclose(model.background, ref, rtol=1e-6, atol=1e-5)
    assert 0 < n_fg < 12 * h * w  # both branches of the update were exercised
    assert model.n_frames == 12


def test_foreground_pixels_keep_background_when_beta_zero() -> None:
    first = np.full((10, 12), 50, np.uint8)
    model = BackgroundModel(first, alpha=0.5, threshold=10, open_px=0, close_px=0,
                            slow_alpha=0.0)
    img = first.copy()
    img[2:5, 3:7] = 200  # object
    img[8, :] = 55  # small change below the threshold: absorbed at alpha
    mask = model.apply(img)
    assert mask.sum() == 12 and mask[2:5, 3:7].all()
    bg = model.background
    np.testing.assert_array_equal(bg[2:5, 3:7], 50.0)
    np.testing.assert_allclose(bg[8], 52.5, atol=1e-6)


def test_slow_update_absorbs_lighting_change() -> None:
    first = np.full((20, 20), 100, np.uint8)
    model = BackgroundModel(first, alpha=0.05, threshold=20, open_px=0, close_px=0,
                            slow_alpha=0.1)
    bright = np.full((20, 20), 160, np.uint8)
    fractions = [foreground_fraction(model.apply(bright)) for _ in range(30)]
    assert fractions[0] == 1.0
    # |160 - B_k| = 60 (0.9)^k falls to <= 20 when k >= log(1/3)/log(0.9) = 10.4
    k = math.ceil(math.log(20 / 60) / math.log(0.9))
    assert fractions[k - 1] == 1.0 and fractions[k] == 0.0


def test_morphology_removes_speck_and_fills_gap() -> None:
    first = np.zeros((40, 40), np.uint8)
    model = BackgroundModel(first, threshold=20, open_px=1, close_px=2)
    img = first.copy()
    img[5, 5] = 255  # isolated pixel: removed by the 3x3 opening
    img[10:30, 10:20] = 255
    img[10:30, 14] = 0  # one-px gap in the column: filled by the 5x5 closing
    mask = model.foreground(img)
    assert mask[5, 5] == 0
    assert mask[10:30, 10:20].all()
    assert mask.sum() == 200


@pytest.mark.parametrize(("o", "c"), [(1, 2), (0, 2), (2, 0), (1, 1), (0, 0)])
def test_morphology_equals_open_then_close(o: int, c: int) -> None:
    import cv2

    rng = np.random.default_rng(o + 3 * c)
    first = np.zeros((50, 70), np.uint8)
    img = ((rng.random((50, 70)) < 0.4) * 255).astype(np.uint8)
    img[:, :3] = 255  # regions touching the border
    got = BackgroundModel(first, threshold=20, open_px=o, close_px=c).foreground(img)
    want = (img > 20).astype(np.uint8)
    if o:
        want = cv2.morphologyEx(want, cv2.MORPH_OPEN, np.ones((2 * o + 1,) * 2, np.uint8))
    if c:
        want = cv2.morphologyEx(want, cv2.MORPH_CLOSE, np.ones((2 * c + 1,) * 2, np.uint8))
    np.testing.assert_array_equal(got, want)


def test_find_blobs_rectangles_and_l_shape() -> None:
    m = np.zeros((60, 80), np.uint8)
    m[5:25, 10:16] = 1  # 6 x 20 rectangle
    m[40:50, 30:50] = 1  # L: 20 x 10 bar ...
    m[30:40, 30:35] = 1  # ... plus a 5 x 10 leg above its left end
    m[0:2, 70:72] = 1  # 4 px: below min_area
    blobs, labels = find_blobs(m, min_area=10)
    assert len(blobs) == 2
    r, ell = sorted(blobs, key=lambda b: b.box)
    assert r.box == (10, 5, 16, 25) and r.area == 120 and r.density == 1.0
    assert (r.width, r.height) == (6, 20)
    assert r.centroid == pytest.approx((12.5, 14.5))
    assert r.bottom_center == (12.5, 24.0)
    # contour through boundary pixel centres: 2 (w - 1) + 2 (h - 1), exactly
    assert r.perimeter == pytest.approx(2 * 5 + 2 * 19, abs=1e-9)
    # and within 4 px of the analytic 2 (w + h) of the drawn rectangle
    assert abs(r.perimeter - 2 * (6 + 20)) <= 4
    assert ell.box == (30, 30, 50, 50) and ell.area == 250
    assert ell.density == pytest.approx(250 / 400)
    # L: its box's 2 * 19 + 2 * 19, less the concave corner cut by one diagonal step (2 -> sqrt 2)
    assert ell.perimeter == pytest.approx(2 * 19 + 2 * 19 - 2 + math.sqrt(2), abs=1e-6)
    cu = (200 * 39.5 + 50 * 32.0) / 250
    cv = (200 * 44.5 + 50 * 34.5) / 250
    assert ell.centroid == pytest.approx((cu, cv))
    assert np.count_nonzero(labels == r.label) == 120
    assert np.count_nonzero(labels == ell.label) == 250
    # any non-zero value is foreground (0/255 masks take the crop-components path)
    blobs255, labels255 = find_blobs(m * 255, min_area=10)
    assert blobs255 == blobs
    np.testing.assert_array_equal(labels255, labels)


def test_perimeter_of_disc_near_circumference() -> None:
    r = 15
    yy, xx = np.mgrid[0:50, 0:50]
    m = ((xx - 25) ** 2 + (yy - 25) ** 2 <= r * r).astype(np.uint8)
    (b,) = find_blobs(m)[0]
    # an 8-connected chain with unit and sqrt(2) steps overestimates a circle's length by about
    # 5 % (steps follow the pixel grid, not the arc): within 8 % of 2 pi r, and above it
    assert b.perimeter == pytest.approx(2 * math.pi * r, rel=0.08)
    assert b.perimeter > 2 * math.pi * (r - 0.5)
    assert b.area == int(m.sum())
    assert b.density == pytest.approx(b.area / (31 * 31))


def test_find_blobs_bool_mask_hole_and_diagonal() -> None:
    m = np.zeros((30, 30), bool)
    m[5:15, 5:15] = True
    m[8:12, 8:12] = False  # a hole: the outer contour ignores it
    m[20, 20] = m[21, 21] = True  # 8-connected diagonal pair
    blobs, _ = find_blobs(m, min_area=2)
    assert [b.area for b in blobs] == [84, 2]
    assert blobs[0].perimeter == pytest.approx(36.0)
    assert blobs[1].box == (20, 20, 22, 22)


@pytest.mark.parametrize("max_crops", [10_000, 0])
def test_empty_mask_and_many_regions(max_crops: int, monkeypatch: pytest.MonkeyPatch) -> None:
    blobs, labels = find_blobs(np.zeros((16, 16), np.uint8), max_crops=max_crops)
    assert blobs == [] and not labels.any() and labels.shape == (16, 16)
    m = np.zeros((60, 60), np.uint8)
    m[::2, ::2] = 1  # 900 isolated pixels
    m[0:3, 0:3] = 1  # one 9-px region (absorbs 4 of them)
    blobs, labels = find_blobs(m, min_area=2, max_crops=max_crops)
    assert labels.dtype == np.uint16 and len(blobs) == 1 and blobs[0].area == 9
    assert np.count_nonzero(labels) == 9
    # more blobs than uint16 labels can hold (the limit lowered: 65536 blobs are slow in tests)
    monkeypatch.setattr("rhythmjax.vision.blobs.MAX_U16_LABELS", 500)
    blobs, labels = find_blobs(m, min_area=1, max_crops=max_crops)
    assert labels.dtype == np.int32 and len(blobs) == 900 - 3 == labels.max()
    assert [b.label for b in blobs] == list(range(1, 898))


def _random_mask(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    m = (rng.random((h // 4, w // 4)) < 0.35).astype(np.uint8)
    m = np.kron(m, np.ones((4, 4), np.uint8))  # blocks, then ragged edges and specks
    m ^= (rng.random((h, w)) < 0.08).astype(np.uint8)
    m[h // 2 - 10:h // 2 + 10, w // 2 - 10:w // 2 + 10] = 1  # a ring ...
    m[h // 2 - 7:h // 2 + 7, w // 2 - 7:w // 2 + 7] = 0
    m[h // 2 - 3:h // 2 + 3, w // 2 - 3:w // 2 + 3] = 1  # ... with a blob in its hole
    return m


@pytest.mark.parametrize("max_crops", [10_000, 0])  # the per-box path, the full-frame path
@pytest.mark.parametrize("seed", range(3))
def test_find_blobs_matches_full_frame_connected_components(seed: int, max_crops: int) -> None:
    import cv2

    rng = np.random.default_rng(seed)
    m = _random_mask(rng, 96, 128)
    min_area = int(rng.integers(1, 12))
    blobs, labels = find_blobs(m, min_area=min_area, max_crops=max_crops)
    n, ref, st, ce = cv2.connectedComponentsWithStats(m, connectivity=8, ltype=cv2.CV_32S)
    keep = [k for k in range(1, n) if st[k, cv2.CC_STAT_AREA] >= min_area]
    assert len(blobs) == len(keep) > 5
    keep.sort(key=lambda k: (st[k, 1], st[k, 0], st[k, 4], st[k, 0] + st[k, 2],
                             st[k, 1] + st[k, 3]))
    for lab, (b, k) in enumerate(zip(blobs, keep), start=1):  # ordered by box, then area
        x, y, w, h, a = st[k]
        assert b.box == (x, y, x + w, y + h) and b.area == a and b.label == lab
        assert b.centroid == pytest.approx(tuple(ce[k]), abs=1e-9)
        np.testing.assert_array_equal(labels == b.label, ref == k)
        contours, _ = cv2.findContours((ref == k).astype(np.uint8), cv2.RETR_EXTERNAL,
                                       cv2.CHAIN_APPROX_NONE)
        assert b.perimeter == pytest.approx(cv2.arcLength(contours[0], True), rel=1e-6)
    assert np.count_nonzero(labels) == sum(b.area for b in blobs)


def test_is_crowd() -> None:
    small = Blob(box=(0, 0, 10, 10), area=100, perimeter=36.0, centroid=(4.5, 4.5),
                 density=1.0, label=1)
    big = Blob(box=(0, 0, 80, 40), area=1600, perimeter=236.0, centroid=(40.0, 20.0),
               density=0.5, label=2)
    assert not is_crowd([small], (60, 80))
    assert is_crowd([small, big], (60, 80), fraction=0.5)
    assert not is_crowd([small, big], (60, 80), fraction=0.7)
    assert not is_crowd([], (60, 80))


@pytest.mark.parametrize("bad", [np.zeros((4, 4, 3), np.uint8), np.zeros(5, np.uint8),
                                 np.zeros((4, 4), np.float32), np.zeros((4, 4), np.int32)])
def test_bad_input(bad: np.ndarray) -> None:
    with pytest.raises(ValueError, match="2-D|dtype"):
        BackgroundModel(bad)
    with pytest.raises(ValueError, match="2-D|dtype"):
        find_blobs(bad)
    model = BackgroundModel(np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError, match="2-D|dtype"):
        model.apply(bad)


def test_bad_options_and_shape() -> None:
    first = np.zeros((4, 4), np.uint8)
    with pytest.raises(ValueError, match="alpha"):
        BackgroundModel(first, alpha=1.5)
    with pytest.raises(ValueError, match="slow_alpha"):
        BackgroundModel(first, alpha=0.01, slow_alpha=-0.02)
    with pytest.raises(ValueError, match="open_px"):
        BackgroundModel(first, open_px=-1)
    with pytest.raises(ValueError, match="differs"):
        BackgroundModel(first).apply(np.zeros((5, 4), np.uint8))
    with pytest.raises(ValueError, match="min_area"):
        find_blobs(first, min_area=0)


def test_moving_rectangle_end_to_end_and_crowd() -> None:
    rng = np.random.default_rng(3)
    bg = rng.integers(90, 110, (60, 80)).astype(np.uint8)  # texture below the threshold
    model = BackgroundModel(bg)  # defaults: alpha 0.05, threshold 20, open 1, close 2
    for k in range(4):
        img = bg.copy()
        img[20:50, 10 + 5 * k:22 + 5 * k] = 200  # a 12 x 30 walker moving 5 px/frame
        blobs, _ = find_blobs(model.apply(img))
        assert len(blobs) == 1
        assert blobs[0].box == (10 + 5 * k, 20, 22 + 5 * k, 50) and blobs[0].area == 360
        assert not is_crowd(blobs, img.shape)
    # the lights go up: one blob over the whole frame, flagged, no crash
    blobs, _ = find_blobs(model.apply(np.full((60, 80), 250, np.uint8)))
    assert len(blobs) == 1 and blobs[0].area == 60 * 80 and is_crowd(blobs, (60, 80))


def test_component_and_meeting_match_plain_references() -> None:
    """`_component` (a flood fill) is the 8-connected component `connectedComponentsWithStats`
    labels at the seed, also with mixed non-zero values; `meeting` is the float test of the
    pedestrians level written out per blob (intersection > frac x box area or > half the
    blob's box area)."""
    import cv2

    from rhythmjax.vision.blobs import _component, box_table, meeting

    rng = np.random.default_rng(8)
    for _ in range(60):
        crop = ((rng.random((30, 40)) < 0.45) * rng.choice([1, 3, 255], (30, 40))).astype(np.uint8)
        _, cl, st, _ = cv2.connectedComponentsWithStats(crop, connectivity=8)
        ys, xs = np.nonzero(crop)
        k = int(rng.integers(len(ys)))
        own, n = _component(crop, int(xs[k]), int(ys[k]))
        lab = cl[ys[k], xs[k]]
        np.testing.assert_array_equal(own, cl == lab)
        assert n == st[lab, cv2.CC_STAT_AREA]
    area = lambda a: float(max(0.0, a[2] - a[0]) * max(0.0, a[3] - a[1]))  # noqa: E731
    for _ in range(200):
        x, y = rng.integers(0, 80, (2, 8))
        blobs = [Blob(box=(int(a), int(b), int(a + c), int(b + d)), area=1, perimeter=0.0,
                      centroid=(0.0, 0.0), density=1.0, label=1)
                 for a, b, c, d in zip(x, y, *rng.integers(0, 30, (2, 8)))]
        u, v, w, h = rng.uniform(0, 100), rng.uniform(0, 100), *rng.uniform(0, 40, 2)
        box, frac = (u - w / 2, v - h, u + w / 2, v), float(rng.choice([0.1, 0.2]))
        want = set()
        for j, b in enumerate(blobs):
            ov = float(max(0.0, min(box[2], b.box[2]) - max(box[0], b.box[0]))
                       * max(0.0, min(box[3], b.box[3]) - max(box[1], b.box[1])))
            if ov > frac * area(box) or ov > 0.5 * area(b.box):
                want.add(j)
        assert meeting(box, box_table(blobs), frac) == want
