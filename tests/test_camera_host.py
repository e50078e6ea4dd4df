"""The host (NumPy float64) camera path against the JAX path and an independent reference,
roll included (issue 14, item 2: equation (3) with roll and its inverse written once).

`camera_np` and `camera` share one set of formulas (`camera.*_with` over an array namespace); these
tests hold the fronts to that: the NumPy float64 front equals the JAX front in float64
(`jax.enable_x64` here only) to 1e-9 px over a grid of cameras with and without roll, both equal
a camera-frame reference written again below (dot products with the camera's axes, then the
image rotation), the Python-float path (`camera_np.SCALAR`) gives the NumPy path's bits, and at
roll = 0 the host path gives the bits of the roll-free formulas it replaced.
"""

from __future__ import annotations

import itertools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.count.patches import ShapeModel, patch_size_3d
from rhythmjax.model import camera as jcam
from rhythmjax.model.camera_np import (
    SCALAR,
    HostCamera,
    camera_tuple,
    depth_3d,
    ground_of_pixels,
    host_terms,
    image_width_of,
    project_3d,
    upright_size,
)
from rhythmjax.model.params import Camera, config_from_dict

from .test_pedestrians import SMALL


TOL_PX = 1e-9  # host against JAX float64 [measured: 0, the same bits], and against the
# camera-frame reference [2.3e-13 px]
TOL_M = 1e-9  # ground points, relative to y (the round trip through the reference) [2.7e-15]

# cameras: (f, h, theta deg, a, b, uc, vc) x roll deg; a != b in one of them
BASES = [(0.008, 1.0, 15.0, 1e5, 1e5, 256.0, 256.0),
         (0.008, 3.0, 25.0, 2.5e4, 2.5e4, 128.0, 96.0),
         (0.012, 2.2, 33.0, 7.1e4, 7.6e4, 301.5, 211.0)]
ROLLS_DEG = (-10.0, -2.5, 0.0, 3.0, 8.0)
CAMERA_GRID = list(itertools.product(range(len(BASES)), ROLLS_DEG))

_gx, _gy, _gz = np.meshgrid(np.linspace(-3, 3, 7), np.linspace(2.5, 30, 12), [0.0, 0.9, 1.7])
X, Y, Z = _gx.ravel(), _gy.ravel(), _gz.ravel()


def _camera(i: int, roll_deg: float) -> Camera:
    f, h, th, a, b, uc, vc = BASES[i]
    return Camera(f=f, h=h, theta=math.radians(th), a=a, b=b, uc=uc, vc=vc,
                  roll=math.radians(roll_deg))


def project_frame_ref(cam: HostCamera, x, y, z):
    """(3) with roll from the camera frame, a float64 loop: the camera at height h looks along
    (0, cos theta, -sin theta); image right is +x, image down (0, -sin theta, -cos theta); the
    point's depth is f + its distance along the optical axis (the paper's denominator), then the
    image offsets are rotated by +roll about (uc, vc)."""
    f, h, th, a, b, uc, vc, roll = cam
    ahead = np.array([0.0, math.cos(th), -math.sin(th)])
    down = np.array([0.0, -math.sin(th), -math.cos(th)])
    u, v = np.empty(len(x)), np.empty(len(x))
    for i, p in enumerate(np.stack([x, y, np.asarray(z) - h], 1)):
        depth = f + float(p @ ahead)
        du, dv = a * f * p[0] / depth, b * f * float(p @ down) / depth
        u[i] = uc + math.cos(roll) * du - math.sin(roll) * dv
        v[i] = vc + math.sin(roll) * du + math.cos(roll) * dv
    return u, v


def test_camera_tuple_carries_the_roll_and_reads_the_older_form():
    cam = _camera(2, 3.0)
    host = camera_tuple(cam)
    assert host.roll == float(np.float32(math.radians(3.0))) and host.a == 7.1e4
    assert camera_tuple(host) is host
    assert camera_tuple(tuple(host)[:7]) == (*tuple(host)[:7], 0.0)  # a 7-tuple: roll 0


@pytest.mark.parametrize("i,roll_deg", CAMERA_GRID)
def test_host_path_equals_the_jax_path_in_float64(i, roll_deg):
    with jax.enable_x64(True):
        cam = _camera(i, roll_deg)
        host = camera_tuple(cam)
        ju, jv = (np.asarray(q) for q in jcam.project_3d(cam, jnp.asarray(X), jnp.asarray(Y),
                                                          jnp.asarray(Z)))
        jd = np.asarray(jcam.depth(cam, jnp.asarray(Y)))
        u, v = project_3d(host, X, Y, Z)
        assert max(np.abs(u - ju).max(), np.abs(v - jv).max()) <= TOL_PX
        np.testing.assert_allclose(depth_3d(host, Y, 0.0), jd, rtol=1e-15, atol=0)
        # the inverse, at the ground points' images and at points above the horizon / NaN
        ug, vg = project_3d(host, X, Y, 0.0)
        uq = np.concatenate([ug, [host.uc, 10.0, np.nan, 50.0]])
        vq = np.concatenate([vg, [-2000.0, -5000.0, 100.0, np.inf]])
        x, y, ok = ground_of_pixels(host, uq, vq)
        jx, jy, jok = (np.asarray(q) for q in jcam.ground_from_image(cam, jnp.asarray(uq),
                                                                     jnp.asarray(vq)))
        np.testing.assert_array_equal(ok, jok)
        assert ok[:len(X)].all() and not ok[len(X):].any()
        assert np.abs(x - jx).max() <= TOL_M * 30 and np.abs(y - jy).max() <= TOL_M * 30
        # widths and the upright box (the pedestrian patch)
        jw = np.asarray(jcam.image_width(cam, jnp.asarray(0.5), jnp.asarray(Y)))
        assert np.abs(image_width_of(host, 0.5, Y) - jw).max() <= TOL_PX
        w, h, oks = upright_size(host, ug, vg, 0.5, 1.7)
        jw2, jh2, joks = (np.asarray(q) for q in jcam.upright_size_with(
            jnp, jcam.terms(cam), jnp.asarray(ug), jnp.asarray(vg), 0.5, 1.7))
        np.testing.assert_array_equal(oks, joks)
        assert np.abs(w - jw2).max() <= TOL_PX and np.abs(h - jh2).max() <= TOL_PX


@pytest.mark.parametrize("i,roll_deg", CAMERA_GRID)
def test_host_path_against_the_camera_frame_reference(i, roll_deg):
    host = camera_tuple(_camera(i, roll_deg))
    ur, vr = project_frame_ref(host, X, Y, Z)
    u, v = project_3d(host, X, Y, Z)
    assert max(np.abs(u - ur).max(), np.abs(v - vr).max()) <= TOL_PX
    # inverse: the reference's ground images map back to the ground points
    ur0, vr0 = project_frame_ref(host, X, Y, np.zeros_like(X))
    x, y, ok = ground_of_pixels(host, ur0, vr0)
    assert ok.all()
    assert np.abs((x - X) / Y).max() <= TOL_M and np.abs((y - Y) / Y).max() <= TOL_M
    # the pedestrian patch: the reference's lateral extent at the feet and the head's row
    w, h, ok = patch_size_3d(host, ur0, vr0, 0.5, 1.7)
    ul, _ = project_frame_ref(host, X - 0.25, Y, np.zeros_like(X))
    uh, _ = project_frame_ref(host, X + 0.25, Y, np.zeros_like(X))
    _, vt = project_frame_ref(host, X, Y, np.full_like(X, 1.7))
    assert ok.all()
    assert np.abs(w - (uh - ul)).max() <= TOL_PX and np.abs(h - (vr0 - vt)).max() <= TOL_PX


def test_roll_zero_host_path_is_bit_identical_to_the_roll_free_formulas():
    """The NumPy expressions the host path replaced (camera_np and count.patches before issue
    14), op for op: at roll 0 not one bit may change."""
    cam = camera_tuple(_camera(2, 0.0))
    f, h, th, a, b, uc, vc, _ = cam
    s, c = math.sin(th), math.cos(th)
    d = f + Y * c + (h - Z) * s
    u, v = project_3d(cam, X, Y, Z)
    np.testing.assert_array_equal(u, uc + a * f * X / d)
    np.testing.assert_array_equal(v, vc - b * f * (Y * s - (h - Z) * c) / d)
    np.testing.assert_array_equal(depth_3d(cam, Y, Z), d)
    uq, vq = np.meshgrid(np.arange(0.0, 600.0, 7.0), np.arange(-50.0, 420.0, 3.0))
    dv = vc - vq
    den = b * f * s - dv * c
    ok = den > 1e-6 * b * f
    y = (dv * (f + h * s) + b * f * h * c) / np.where(ok, den, 1.0)
    dd = f + y * c + h * s
    ok = ok & (dd > 1e-3)
    x = (uq - uc) * np.where(ok, dd, 1.0) / (a * f)
    gx, gy, gok = ground_of_pixels(cam, uq, vq)
    np.testing.assert_array_equal(gok, ok)
    np.testing.assert_array_equal(gx, np.where(ok, x, 0.0))
    np.testing.assert_array_equal(gy, np.where(ok, y, 0.0))
    d_head = f + y * c + (h - 1.7) * s
    ok_h = ok & (d_head > 1e-3)
    nan = np.where(ok_h, 1.0, np.nan)
    v_top = vc - b * f * (y * s - (h - 1.7) * c) / np.where(ok_h, d_head, 1.0)
    w, hh, pok = patch_size_3d(cam, uq, vq, 0.5, 1.7)
    np.testing.assert_array_equal(pok, ok_h)
    np.testing.assert_array_equal(w, a * f * 0.5 / np.where(ok_h, dd, 1.0) * nan)
    np.testing.assert_array_equal(hh, (vq - v_top) * nan)


@pytest.mark.parametrize("roll_deg", [0.0, -4.0, 6.5])
def test_python_float_path_gives_the_numpy_bits(roll_deg):
    cam = camera_tuple(_camera(1, roll_deg))
    k = host_terms(cam)
    uq = np.array([0.0, 40.3, 128.0, 200.7, 255.0, 128.0, np.nan, 30.0, 128.0])
    vq = np.array([191.0, 150.2, 96.0, 60.9, 120.0, -400.0, 100.0, np.inf, 50.0])
    xs, ys, oks = ground_of_pixels(cam, uq, vq)
    ws, hs, okp = upright_size(cam, uq, vq, 0.5, 1.7)
    assert not okp[5:8].any() and okp[:5].all()
    us, vs = project_3d(cam, X, Y, Z)
    for j in range(len(uq)):
        x, y, ok = jcam.ground_with(SCALAR, k, float(uq[j]), float(vq[j]))
        assert (x, y, ok) == (xs[j], ys[j], oks[j])
        assert ground_of_pixels(cam, uq[j], float(vq[j])) == (x, y, ok)  # numbers: SCALAR
        w, h, ok2 = jcam.upright_size_with(SCALAR, k, float(uq[j]), float(vq[j]), 0.5, 1.7)
        np.testing.assert_array_equal([w, h, ok2], [ws[j], hs[j], okp[j]])
        u, v = jcam.project_with(SCALAR, k, float(X[j]), float(Y[j]), float(Z[j]))
        assert (u, v) == (us[j], vs[j]) == project_3d(cam, X[j], Y[j], Z[j])  # numbers: SCALAR
        assert type(u) is float and type(ok) is bool
    assert project_3d(cam, 1, 10, 0) == tuple(float(q[0]) for q in project_3d(
        cam, np.array([1.0]), np.array([10.0]), np.array([0.0])))


@pytest.mark.parametrize("roll_deg", [0.0, 5.0])
def test_shape_model_sizes_with_roll(roll_deg):
    """With roll the patch size depends on the column as well as the row: `foot_sizes` gives
    `size` at each foot point (from the row table only without roll, where the table's bits are
    the same), and `size` on floats gives the array path's values."""
    cfg = config_from_dict({**SMALL, "camera": {**SMALL["camera"], "roll_deg": roll_deg}})
    shape = ShapeModel.from_config(cfg, "3d")
    assert shape.camera.roll == pytest.approx(math.radians(roll_deg), abs=1e-7)
    rows = np.array([30, 60, 96, 150, 191, 191])
    us = np.array([10.0, 128.0, 250.0, 40.5, 128.0, 230.0])
    w, h, fin = shape.foot_sizes(us, rows, 192)
    ws, hs = shape.size(us, rows.astype(float))
    ok = np.isfinite(ws)
    np.testing.assert_array_equal(fin, ok)
    np.testing.assert_array_equal(w, np.where(ok, ws, 0.0))
    np.testing.assert_array_equal(h, np.where(ok, hs, 0.0))
    for j in range(len(us)):
        np.testing.assert_array_equal(shape.size(float(us[j]), float(rows[j])), (ws[j], hs[j]))
    w_l, _ = shape.size(np.array([20.0]), np.array([150.0]))
    w_r, _ = shape.size(np.array([236.0]), np.array([150.0]))
    if roll_deg == 0.0:
        assert w_l[0] == w_r[0]  # one size per row
    else:  # positive roll: the horizon falls to the right, so on one row the right is nearer
        assert w_l[0] > 1.05 * w_r[0]  # the horizon, farther away on the ground, narrower
