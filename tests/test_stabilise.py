"""vision.stabilise against an analytic reference: a textured scene evaluated at shifted
coordinates (no resampling of a rendered image, so the reference shift is exact)."""

from __future__ import annotations

import numpy as np
import pytest

from rhythmjax.vision import detect, stabilise


def _scene(du: float, dv: float, size: int = 256, seed: int = 3) -> np.ndarray:
    """Grey image (uint8) of smooth blobs and bars whose content sits (du, dv) px from du = dv = 0:
    each pixel (u, v) takes the analytic intensity at (u - du, v - dv)."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:size, 0:size].astype(np.float64)
    u, v = u - du, v - dv
    img = np.full(u.shape, 110.0)
    for cu, cv, s, a in zip(rng.uniform(0, size, 60), rng.uniform(0, size, 60),
                            rng.uniform(3, 9, 60), rng.uniform(-60, 60, 60)):
        img += a * np.exp(-((u - cu) ** 2 + (v - cv) ** 2) / (2 * s * s))
    img += 25 * np.tanh(np.sin(u / 7.0) * 3) + 15 * np.tanh(np.cos(v / 11.0) * 3)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("du,dv", [(1.5, -2.0), (-0.7, 1.2), (2.0, 0.5), (-1.25, -1.75)])
def test_known_shift_recovered_to_a_tenth_of_a_pixel(du, dv):
    prev, cur = _scene(0.0, 0.0), _scene(du, dv)
    _, (eu, ev) = stabilise.align_previous(prev, cur)
    assert abs(eu - du) < 0.1 and abs(ev - dv) < 0.1


def test_shaken_static_scene_gives_near_zero_difference():
    prev, cur = _scene(0.0, 0.0), _scene(1.5, -1.0)
    thr = 15.0
    before = detect.frame_difference(prev, cur)
    aligned, _ = stabilise.align_previous(prev, cur)
    after = detect.frame_difference(aligned, cur)
    inner = (slice(4, -4), slice(4, -4))
    assert (before[inner] > thr).mean() > 0.02  # the shake lights up the edges
    assert (after[inner] > thr).mean() < 0.001
    assert after[inner].mean() < 0.2 * before[inner].mean()


def test_moving_object_does_not_pull_the_shift():
    prev, cur = _scene(0.0, 0.0), _scene(1.0, 0.5)
    cur = cur.copy()
    cur[100:180, 60:100] = 30  # an object covering part of one tile, absent from prev
    _, (eu, ev) = stabilise.align_previous(prev, cur)
    assert abs(eu - 1.0) < 0.1 and abs(ev - 0.5) < 0.1


def test_fixed_camera_leaves_the_previous_frame_untouched():
    prev = _scene(0.0, 0.0)
    rng = np.random.default_rng(0)
    noisy = np.clip(prev + rng.normal(0, 2, prev.shape), 0, 255).astype(np.uint8)
    aligned, shift = stabilise.align_previous(prev, noisy)
    assert aligned is prev and shift == (0.0, 0.0)


def test_bad_input_raises():
    with pytest.raises(ValueError):
        stabilise.estimate_shift(np.zeros((32, 32), np.uint8), np.zeros((32, 16), np.uint8))
    with pytest.raises(ValueError):
        stabilise.estimate_shift(np.zeros((32, 32), np.uint8), np.zeros((32, 32), np.uint8),
                                 tiles=8)



def test_shaken_rendered_street_has_no_motion_after_stabilisation():
    """The renderer's empty street (ground texture, sensor noise) shaken by 1 px (std) per frame:
    the motion image M (what the tracker detects in) lights up along the texture without
    stabilisation and much less with it; unshaken, stabilisation changes nothing."""
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import SceneSpec, render_scene

    cam = config_from_dict(SYNTHETIC_CONFIG).camera

    def moving(jitter: float, on: bool) -> float:
        frames = render_scene(11, SceneSpec(n_frames=12, camera=cam, jitter_px=jitter)).frames
        out = []
        for prev, cur in zip(frames[:-1], frames[1:]):
            if on:
                prev = stabilise.align_previous(prev, cur)[0]
            m, _, _ = detect.motion_image_changed(prev, cur, diff_threshold=15.0)
            out.append(np.count_nonzero(m[4:-4, 4:-4]) / m[4:-4, 4:-4].size)
        return float(np.mean(out))

    assert moving(0.0, False) == moving(0.0, True) == 0.0  # measured: 0
    shaken = moving(1.0, False)  # measured: 0.47 % of the pixels
    assert shaken > 0.002
    assert moving(1.0, True) < 0.25 * shaken  # measured: 0.07 %


def test_alignment_never_raises_the_difference():
    """A large object sliding across most of the frame on a still background: whatever shift the
    tiles report, the frame returned never differs more from cur than prev does."""
    prev = _scene(0.0, 0.0)
    cur = prev.copy()
    band = _scene(3.0, 0.0, seed=9)
    cur[20:236, 20:236] = band[20:236, 20:236]
    prev = prev.copy()
    prev[20:236, 20:236] = _scene(0.0, 0.0, seed=9)[20:236, 20:236]
    aligned, (du, dv) = stabilise.align_previous(prev, cur)
    D0 = detect.frame_difference(prev, cur).astype(float).sum()
    D1 = detect.frame_difference(aligned, cur).astype(float).sum()
    assert D1 <= D0


@pytest.mark.parametrize("du,dv", [(0.5, -0.3), (-1.0, 1.5), (2.0, 0.5), (-1.25, -1.75)])
def test_screen_reads_a_known_shift_to_fifteen_percent(du, dv):
    """The cheap screen (one Lucas-Kanade step per tile on frames shrunk 4x) against the exact
    shift of the analytic scene: within 15 % of the shift's size plus 0.05 px on each axis (a
    first-order step; the estimate proper is the test above)."""
    prev, cur = _scene(0.0, 0.0), _scene(du, dv)
    eu, ev = stabilise.screen_shift(stabilise.shrink(prev), stabilise.shrink(cur))
    tol = 0.15 * np.hypot(du, dv) + 0.05
    assert abs(eu - du) < tol and abs(ev - dv) < tol


def test_stabiliser_screens_out_a_fixed_camera_and_aligns_a_shaken_one():
    """Over a stream: still frames give back `prev` itself (bit-identical differences, no
    estimate run); a 1.5 px shake is aligned as `align_previous` aligns it."""
    st = stabilise.Stabiliser()
    a, b = _scene(0.0, 0.0), _scene(0.0, 0.0, seed=3)
    assert st.align(a, b) is a
    c = _scene(1.5, -1.0)
    out = st.align(b, c)
    assert out is not b
    np.testing.assert_array_equal(out, stabilise.align_previous(b, c)[0])
