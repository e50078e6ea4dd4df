"""The camera model (3), its Jacobian and its inverse on the ground plane (STYLE R8 layers 1, 2, 4).

Default camera: f = 0.008 m, h = 1 m, theta = 15 deg, a = b = 1e5 px/m (a f = b f = 800 px),
Uc = Vc = 256 px.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model.camera import (
    depth,
    ground_from_image,
    ground_width,
    horizon_v,
    image_width,
    in_front,
    measure,
    measure_jacobian,
    project,
)
from rhythmjax.model.params import Camera

from .helpers import CamRef, horizon_ref, jac_fd, measure_ref, project_paper_ref, project_ref


TOL = {  # measured (CPU, jax 0.10.2) in brackets
    "hand_px": 1e-4,  # hand-worked points (given to 1e-6 px), float64 run [3.8e-7]
    "hand_px_float32": 1e-4,  # the same points in float32 [4.1e-5]
    "ref_px": {"float32": 2e-4, "float64": 1e-9},  # grid against project_ref [8.2e-5, 0]
    "roundtrip_px": 1e-3,  # image -> ground -> image, float32 [5.1e-5]
    "roundtrip_m": 1e-5,  # ground -> image -> ground, relative to y, float32 [4.5e-7]
    "jac_rtol": 1e-4,  # against float64 central differences, of max|H| [1.6e-7]
    "width_rel": 1e-5,  # ground_width(image_width(w)) / w - 1 [4.8e-7]
    "horizon_px": 1e-4,  # horizon_v against the limit of (3) [2.1e-5]
}
CAM = CamRef()
S15, C15 = math.sin(math.radians(15.0)), math.cos(math.radians(15.0))

# Hand-worked from PAPERS.md's expanded (3), s = sin 15 deg = 0.2588190451, c = cos 15 deg =
# 0.9659258263, a f = b f = 0.008 * 1e5 = 800 px; D = f + y c + h s.
#  (x, y) = (0, 10): D = 0.008 + 9.659258263 + 0.258819045 = 9.926077308
#                    u = 256 + 800 * 0 / D = 256
#                    y s - h c = 2.588190451 - 0.965925826 = 1.622264625
#                    v = 256 - 800 * 1.622264625 / 9.926077308 = 256 - 130.747692 = 125.252308
#  (x, y) = (1, 5):  D = 0.008 + 4.829629131 + 0.258819045 = 5.096448177
#                    u = 256 + 800 / 5.096448177 = 256 + 156.972066 = 412.972066
#                    y s - h c = 1.294095226 - 0.965925826 = 0.328169399
#                    v = 256 - 800 * 0.328169399 / 5.096448177 = 256 - 51.513429 = 204.486571
#  (x, y) = (-2, 20): D = 0.008 + 19.318516526 + 0.258819045 = 19.585335571
#                    u = 256 - 1600 / 19.585335571 = 256 - 81.693775 = 174.306225
#                    y s - h c = 5.176380902 - 0.965925826 = 4.210455076
#                    v = 256 - 800 * 4.210455076 / 19.585335571 = 256 - 171.983985 = 84.016015
HAND = [((0.0, 10.0), (256.0, 125.252308)), ((1.0, 5.0), (412.972066, 204.486571)),
        ((-2.0, 20.0), (174.306225, 84.016015))]
# horizon: v -> Vc - b f tan(theta) = 256 - 800 * 0.2679491924 = 41.640646 px
HORIZON = 41.640646

X_GRID, Y_GRID = (a.ravel() for a in np.meshgrid(np.linspace(-2, 2, 9), np.linspace(3, 20, 18)))


def f32(a):
    return jnp.asarray(a, jnp.float32)


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_hand_worked_points(dtype):
    with jax.enable_x64(dtype == "float64"):
        camera = Camera()
        assert camera.h.dtype == jnp.dtype(dtype)
        for (x, y), (u, v) in HAND:
            got = project(camera, jnp.asarray(x, dtype), jnp.asarray(y, dtype))
            tol = TOL["hand_px"] if dtype == "float64" else TOL["hand_px_float32"]
            assert float(got[0]) == pytest.approx(u, abs=tol)
            assert float(got[1]) == pytest.approx(v, abs=tol)
            assert project_ref(*CAM.args(), x, y) == pytest.approx((u, v), abs=1e-6)


def test_expanded_form_equals_the_paper_form():
    u1, v1 = project_ref(*CAM.args(), X_GRID, Y_GRID)
    u2, v2 = project_paper_ref(*CAM.args(), X_GRID, Y_GRID)
    np.testing.assert_allclose(u1, u2, rtol=0, atol=1e-10)
    np.testing.assert_allclose(v1, v2, rtol=0, atol=1e-10)
    other = CamRef(f=0.012, h=2.5, theta=math.radians(31.0), a=7e4, b=9e4, uc=300.0, vc=200.0)
    np.testing.assert_allclose(project_ref(*other.args(), X_GRID, Y_GRID),
                               project_paper_ref(*other.args(), X_GRID, Y_GRID), atol=1e-10)


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_grid_agrees_with_reference(dtype):
    with jax.enable_x64(dtype == "float64"):
        u, v = project(Camera(), jnp.asarray(X_GRID, dtype), jnp.asarray(Y_GRID, dtype))
        assert u.dtype == jnp.dtype(dtype)
    ur, vr = project_ref(*CAM.args(), X_GRID, Y_GRID)
    assert np.abs(np.asarray(u, np.float64) - ur).max() <= TOL["ref_px"][dtype]
    assert np.abs(np.asarray(v, np.float64) - vr).max() <= TOL["ref_px"][dtype]
    d = np.asarray(depth(Camera(), f32(Y_GRID)))
    np.testing.assert_allclose(d, 0.008 + Y_GRID * C15 + S15, rtol=1e-6)


def test_round_trip_image_ground_image_float32():
    cam = Camera()
    ur, vr = project_ref(*CAM.args(), X_GRID, Y_GRID)
    x, y, ok = ground_from_image(cam, f32(ur), f32(vr))
    assert bool(ok.all())
    u2, v2 = project(cam, x, y)
    assert np.abs(np.asarray(u2, np.float64) - ur).max() <= TOL["roundtrip_px"]
    assert np.abs(np.asarray(v2, np.float64) - vr).max() <= TOL["roundtrip_px"]


def test_round_trip_ground_image_ground_float32():
    cam = Camera()
    u, v = project(cam, f32(X_GRID), f32(Y_GRID))
    x, y, ok = ground_from_image(cam, u, v)
    assert bool(ok.all())
    assert np.abs(np.asarray(x, np.float64) - X_GRID).max() <= TOL["roundtrip_m"] * 20
    assert (np.abs(np.asarray(y, np.float64) - Y_GRID) / Y_GRID).max() <= TOL["roundtrip_m"]


def test_jacobian_against_central_differences():
    cam = Camera()
    states = np.stack([X_GRID, np.full_like(X_GRID, 0.7), Y_GRID, np.full_like(X_GRID, -1.1)], -1)
    H_all = np.asarray(jax.jit(jax.vmap(measure_jacobian, (None, 0)))(cam, f32(states)),
                       np.float64)
    z_all = np.asarray(jax.jit(jax.vmap(measure, (None, 0)))(cam, f32(states)), np.float64)
    worst = 0.0
    for state, H, z in zip(states, H_all, z_all, strict=True):
        H_fd = jac_fd(lambda s: measure_ref(CAM, s), state, 1e-4)
        assert np.abs(z - measure_ref(CAM, state)).max() <= TOL["ref_px"]["float32"]
        assert np.all(H[:, [1, 3]] == 0.0) and np.all(H_fd[:, [1, 3]] == 0.0)  # velocities
        worst = max(worst, np.abs(H - H_fd).max() / np.abs(H_fd).max())
        # the one entry known in closed form: du/dx = a f / D
        assert H[0, 0] == pytest.approx(800.0 / (0.008 + state[2] * C15 + S15), rel=1e-6)
    assert worst <= TOL["jac_rtol"]


def test_behind_the_camera_and_above_the_horizon_are_flagged_and_finite():
    cam = Camera()
    y_behind = jnp.asarray([-5.0, -(0.008 + S15) / C15, -0.2762], jnp.float32)  # D < 0, = 0, ~0
    assert not bool(in_front(cam, y_behind).any())
    assert bool(in_front(cam, f32([0.0, 3.0, 1e4])).all())
    for a in project(cam, f32([1.0, 1.0, 1.0]), y_behind):
        assert bool(jnp.isfinite(a).all())
    for yb in y_behind:
        H = measure_jacobian(cam, jnp.stack([f32(1.0), f32(0.0), yb, f32(0.0)]))
        assert bool(jnp.isfinite(H).all())
    assert bool(jnp.isfinite(image_width(cam, f32(0.5), y_behind)).all())
    # above, on, and just below the horizon; and non-finite input
    u = f32([256.0, 256.0, 100.0, 256.0, np.nan, 256.0, np.inf])
    v = f32([10.0, HORIZON, 30.0, HORIZON + 0.5, 200.0, np.nan, 200.0])
    x, y, ok = ground_from_image(cam, u, v)
    np.testing.assert_array_equal(np.asarray(ok), [False, False, False, True, False, False, False])
    assert bool(jnp.isfinite(x).all() & jnp.isfinite(y).all())
    bad = ~np.asarray(ok)
    assert np.all(np.asarray(x)[bad] == 0) and np.all(np.asarray(y)[bad] == 0)
    assert float(y[3]) > 500.0  # half a pixel under the horizon is far away
    wid, ok_w = ground_width(cam, f32([40.0] * 7), u, v)
    np.testing.assert_array_equal(np.asarray(ok_w), np.asarray(ok))
    assert bool(jnp.isfinite(wid).all())


def test_image_width_and_ground_width_are_inverse():
    cam = Camera()
    for w in (0.3, 0.5, 1.2):
        w_px = image_width(cam, f32(w), f32(Y_GRID))
        D = 0.008 + Y_GRID * C15 + S15
        np.testing.assert_allclose(np.asarray(w_px), 800.0 * w / D, rtol=1e-6)  # a f w / D
        u, v = project(cam, f32(X_GRID), f32(Y_GRID))
        back, ok = ground_width(cam, w_px, u, v)
        assert bool(ok.all())
        assert np.abs(np.asarray(back, np.float64) / w - 1).max() <= TOL["width_rel"]


def test_horizon_is_the_limit_of_the_projection():
    assert horizon_ref(CAM) == pytest.approx(HORIZON, abs=1e-6)
    assert project_ref(*CAM.args(), 0.0, 1e9)[1] == pytest.approx(HORIZON, abs=1e-6)
    assert float(horizon_v(Camera())) == pytest.approx(HORIZON, abs=TOL["horizon_px"])
    v_far = np.asarray(project(Camera(), f32([0.0] * 4), f32([1e2, 1e3, 1e4, 1e5]))[1])
    assert np.all(np.diff(v_far) < 0) and np.all(v_far > HORIZON - TOL["horizon_px"])
    assert v_far[-1] - HORIZON < 0.01
    other = Camera(h=2.0, theta=math.radians(30.0), b=5e4)
    lim = 256.0 - 5e4 * 0.008 * math.tan(math.radians(30.0))
    assert float(horizon_v(other)) == pytest.approx(lim, abs=TOL["horizon_px"])


# ----------------------------------------------------------------------------------------------
# Roll (extension): the image of (3) rotated by +roll about (Uc, Vc)

ROLLED = dict(f=0.008, h=3.0, theta=math.radians(22.0), a=1.1e5, b=1.12e5, uc=240.0, vc=190.0)


def _rolled_ref(roll, x, y, cam=ROLLED):
    """NumPy float64: project_ref, then rotate (u - Uc, v - Vc) by +roll (v down)."""
    u0, v0 = project_ref(*(cam[k] for k in ("f", "h", "theta", "a", "b", "uc", "vc")), x, y)
    du, dv = u0 - cam["uc"], v0 - cam["vc"]
    c, s = math.cos(roll), math.sin(roll)
    return cam["uc"] + c * du - s * dv, cam["vc"] + s * du + c * dv


@pytest.mark.parametrize("roll_deg", [-12.0, -3.0, 0.5, 7.0])
def test_rolled_projection_against_numpy_and_its_inverse(roll_deg):
    roll = math.radians(roll_deg)
    with jax.enable_x64(True):
        cam = Camera(**ROLLED, roll=roll)
        u, v = project(cam, jnp.asarray(X_GRID), jnp.asarray(Y_GRID))
        ur, vr = _rolled_ref(roll, X_GRID, Y_GRID)
        assert np.abs(np.asarray(u) - ur).max() < 1e-9 and np.abs(np.asarray(v) - vr).max() < 1e-9
        x, y, ok = ground_from_image(cam, jnp.asarray(ur), jnp.asarray(vr))
        assert bool(ok.all())
        assert np.abs(np.asarray(x) - X_GRID).max() < 1e-9
        assert np.abs(np.asarray(y) - Y_GRID).max() < 1e-9
        # the horizon: far points along any lateral offset lie on the line of slope tan(roll)
        # through (Uc, horizon_v)
        xf = np.array([-3e7, 0.0, 3e7])
        uf, vf = _rolled_ref(roll, xf, np.full(3, 1e9))
        line = float(horizon_v(cam)) + (uf - ROLLED["uc"]) * math.tan(roll)
        assert np.abs(vf - line).max() < 1e-3
        # a lateral ground segment of w m: its extent along the rows is image_width
        w = 0.5
        ua, _ = _rolled_ref(roll, X_GRID - w / 2, Y_GRID)
        ub, _ = _rolled_ref(roll, X_GRID + w / 2, Y_GRID)
        wpx = image_width(cam, jnp.asarray(w), jnp.asarray(Y_GRID))
        np.testing.assert_allclose(np.asarray(wpx), ub - ua, rtol=1e-12)
        back, ok = ground_width(cam, jnp.asarray(ub - ua), jnp.asarray(ur), jnp.asarray(vr))
        np.testing.assert_allclose(np.asarray(back), w, rtol=1e-12)


def test_rolled_jacobian_against_central_differences():
    roll = math.radians(-6.0)
    cam = Camera(**ROLLED, roll=roll)
    states = np.stack([X_GRID, np.full_like(X_GRID, 0.7), Y_GRID, np.full_like(X_GRID, -1.1)], -1)
    H_all = np.asarray(jax.vmap(measure_jacobian, (None, 0))(cam, f32(states)), np.float64)
    ref = lambda s: np.array(_rolled_ref(roll, s[0], s[2]))  # noqa: E731
    worst = max(np.abs(H - jac_fd(ref, s, 1e-4)).max() / np.abs(H).max()
                for s, H in zip(states, H_all, strict=True))
    assert worst <= TOL["jac_rtol"]
    # and the Jacobian of the residual in roll itself (what the fit uses), in float64
    with jax.enable_x64(True):
        g = jax.jacfwd(lambda r: jnp.stack(project(Camera(**ROLLED, roll=r), jnp.asarray(1.3),
                                                   jnp.asarray(8.0))))(jnp.float64(roll))
    fd = (np.array(_rolled_ref(roll + 1e-6, 1.3, 8.0)) - np.array(_rolled_ref(roll - 1e-6, 1.3,
                                                                               8.0))) / 2e-6
    np.testing.assert_allclose(np.asarray(g), fd, rtol=1e-7, atol=1e-7)


def test_roll_zero_is_bit_identical_to_the_paper_formulas():
    # the pre-roll expressions of (3), evaluated op for op; roll = 0 must not change one bit
    cam = Camera(**ROLLED)
    x, y = f32(X_GRID), f32(Y_GRID)
    d = cam.f + y * jnp.cos(cam.theta) + cam.h * jnp.sin(cam.theta)
    s, c = jnp.sin(cam.theta), jnp.cos(cam.theta)
    u0 = cam.uc + cam.a * cam.f * x / d
    v0 = cam.vc - cam.b * cam.f * (y * s - cam.h * c) / d
    u, v = project(cam, x, y)
    np.testing.assert_array_equal(np.asarray(u), np.asarray(u0))
    np.testing.assert_array_equal(np.asarray(v), np.asarray(v0))
    np.testing.assert_array_equal(np.asarray(image_width(cam, f32(0.5), y)),
                                  np.asarray(cam.a * cam.f * 0.5 / d))
    bf = cam.b * cam.f
    dv = cam.vc - v0
    y0 = (dv * (cam.f + cam.h * s) + bf * cam.h * c) / (bf * s - dv * c)
    d0 = cam.f + y0 * c + cam.h * s
    gx, gy, ok = ground_from_image(cam, u0, v0)
    assert bool(ok.all())
    np.testing.assert_array_equal(np.asarray(gy), np.asarray(y0))
    np.testing.assert_array_equal(np.asarray(gx), np.asarray((u0 - cam.uc) * d0 / (cam.a * cam.f)))
    assert float(horizon_v(cam)) == float(cam.vc - bf * jnp.tan(cam.theta))


def test_roll_zero_jitted_projection_and_jacobian_are_bit_identical_to_the_paper_formulas():
    # under jit XLA may fuse differently shaped expressions differently: the EKF's h(X) and H
    # (jitted) must keep the bits of the pre-roll expressions at roll 0
    cam = Camera(**ROLLED)

    def paper(camera, state):
        x, y = state[0], state[2]
        s, c = jnp.sin(camera.theta), jnp.cos(camera.theta)
        d = camera.f + y * c + camera.h * s
        d = jnp.where(d > 1e-3, d, 1.0)
        return jnp.stack([camera.uc + camera.a * camera.f * x / d,
                          camera.vc - camera.b * camera.f * (y * s - camera.h * c) / d])

    states = f32(np.stack([X_GRID, np.full_like(X_GRID, 0.7), Y_GRID,
                           np.full_like(X_GRID, -1.1)], -1))
    for ours, ref in ((measure, paper), (measure_jacobian, jax.jacfwd(paper, argnums=1))):
        got = jax.jit(jax.vmap(ours, (None, 0)))(cam, states)
        want = jax.jit(jax.vmap(ref, (None, 0)))(cam, states)
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
