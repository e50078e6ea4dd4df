"""model.camera_from / camera_homography / lens: the camera of (3) from intrinsics, K R t,
Tsai and homographies, against OpenCV's projection (cv2.projectPoints), a float64 loop of Tsai's
equations written here, hand-worked geometry and the real calibrations (skipped when absent)."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from rhythmjax.evaluation import datasets as D
from rhythmjax.io import read_config
from rhythmjax.model.camera_from import (
    CameraError,
    GroundTransform,
    camera_from_intrinsics,
    camera_from_krt,
    camera_from_tsai,
    distances_px,
    visible_samples,
)
from rhythmjax.model.camera_homography import camera_from_homography
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.lens import TsaiCalibration, opencv_distortion


SIZES = ((640, 480), (800, 600), (1280, 720), (1920, 1080))


def random_camera(rng, *, aspect=0.0, roll_deg=5.0, tilt_deg=None):
    """K (square pixels unless `aspect`: fy = fx (1 + aspect)), R, t (x_cam = R X + t, world z up,
    metres) and the image size of a random camera: principal point within 40 px of the centre,
    height 1-10 m, tilt 5-40 deg, roll within +-roll_deg, any heading, foot within 50 m of the
    origin (`tilt_deg` fixes the tilt, < 0 looking up). R = Rz(roll) R0, R0 the camera's axes
    right, down, forward in the world."""
    w, h = SIZES[rng.integers(len(SIZES))]
    f = rng.uniform(0.6, 1.6) * w
    K = np.array([[f, 0, w / 2 + rng.uniform(-40, 40)], [0, f * (1 + aspect),
                                                         h / 2 + rng.uniform(-40, 40)], [0, 0, 1]])
    tilt = math.radians(rng.uniform(5, 40) if tilt_deg is None else tilt_deg)
    roll = math.radians(rng.uniform(-roll_deg, roll_deg))
    yaw = rng.uniform(-math.pi, math.pi)
    C = np.array([rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(1, 10)])
    fwd = np.array([math.cos(yaw) * math.cos(tilt), math.sin(yaw) * math.cos(tilt),
                    -math.sin(tilt)])
    right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    R0 = np.stack([right, np.cross(fwd, right), fwd])
    Rz = np.array([[math.cos(roll), -math.sin(roll), 0], [math.sin(roll), math.cos(roll), 0],
                   [0, 0, 1]])
    R = Rz @ R0
    return K, R, -R @ C, (w, h), {"H": C[2], "tilt": tilt, "roll": roll}


def ground_points(K, R, t, size, n=15, far_m=80.0):
    """World ground points (N, 3) seen by an n x n grid of pixels in the image (undistorted
    rays through K, R, t met with z = 0), within far_m of the camera's foot."""
    w, h = size
    uu, vv = np.meshgrid(np.linspace(0, w, n), np.linspace(0, h, n))
    rays = np.stack([uu.ravel(), vv.ravel(), np.ones(n * n)], -1) @ np.linalg.inv(K).T @ R
    C = -R.T @ t
    down = rays[:, 2] < -1e-9
    s = -C[2] / rays[down, 2]
    X = C + s[:, None] * rays[down]
    X = X[np.hypot(X[:, 0] - C[0], X[:, 1] - C[1]) < far_m]
    X[:, 2] = 0.0
    return X


def cv2_pixels(X, K, R, t, dist=None):
    uv, _ = cv2.projectPoints(X, cv2.Rodrigues(R)[0], t, K, dist)
    return uv[:, 0, 0], uv[:, 0, 1]


def through_config(r, tmp_path):
    """The camera of the section as `read_config` gives it (float32 fields), as a float64 tuple."""
    p = tmp_path / "cam.json"
    p.write_text(json.dumps({"camera": r.section}))
    c = read_config(p).camera
    return tuple(float(np.asarray(getattr(c, k))) for k in ("f", "h", "theta", "a", "b", "uc",
                                                             "vc", "roll"))


def test_random_cameras_from_krt_reproduce_opencv(tmp_path):
    """50 random cameras: the config from K, R, t projects ground points (world -> the returned
    transform -> (3)) where cv2.projectPoints does: float64 section within 1e-6 px (measured
    max 3.1e-9), through the JSON config's float32 Camera within 0.01 px (measured 1.2e-4);
    `python tests/test_camera_from.py` prints these figures."""
    rng = np.random.default_rng(20240615)
    worst64 = worst32 = 0.0
    for _ in range(50):
        K, R, t, size, truth = random_camera(rng)
        r = camera_from_krt(K, t, R=R, image_size=size)
        X = ground_points(K, R, t, size)
        assert len(X) > 30
        u0, v0 = cv2_pixels(X, K, R, t)
        u, v = r.project_world(X[:, 0], X[:, 1])
        worst64 = max(worst64, np.hypot(u - u0, v - v0).max())
        gx, gy = r.transform.apply(X[:, 0], X[:, 1])
        u, v = project_3d(through_config(r, tmp_path), gx, gy, 0 * gx)
        worst32 = max(worst32, np.hypot(u - u0, v - v0).max())
        s = r.section
        assert s["theta_deg"] == pytest.approx(math.degrees(truth["tilt"]), abs=1e-9)
        assert s["roll_deg"] == pytest.approx(math.degrees(truth["roll"]), abs=1e-9)
        assert s["h_m"] == pytest.approx(truth["H"] - s["f_m"] * math.sin(truth["tilt"]),
                                         abs=1e-9)
        assert r.residual_max_px < 1e-6 and r.unrepresented == ()
    assert worst64 < 1e-6 and worst32 < 0.01


def test_fx_fy_exact_without_roll_and_stated_with_roll():
    rng = np.random.default_rng(3)
    K, R, t, size, _ = random_camera(rng, aspect=0.03, roll_deg=0.0)
    r = camera_from_krt(K, t, R=R, image_size=size)
    X = ground_points(K, R, t, size)
    u0, v0 = cv2_pixels(X, K, R, t)
    u, v = r.project_world(X[:, 0], X[:, 1])
    assert np.hypot(u - u0, v - v0).max() < 1e-6 and r.residual_max_px < 1e-6
    assert r.section["b_px_per_m"] / r.section["a_px_per_m"] == pytest.approx(1.03, abs=1e-12)
    K, R, t, size, truth = random_camera(rng, aspect=0.03, roll_deg=0.0)
    R = np.array([[math.cos(0.08), -math.sin(0.08), 0], [math.sin(0.08), math.cos(0.08), 0],
                  [0, 0, 1]]) @ R
    r = camera_from_krt(K, t, R=R, image_size=size)
    assert r.unrepresented == ("fx != fy with roll",)
    X = ground_points(K, R, t, size, n=9)
    u0, v0 = cv2_pixels(X, K, R, t)
    u, v = r.project_world(X[:, 0], X[:, 1])
    d = np.hypot(u - u0, v - v0)
    # the stated distance bounds what a coarser grid inside the image measures, and is real
    assert 0.05 < r.residual_max_px < 20 and d.max() <= r.residual_max_px + 1e-9


@pytest.mark.parametrize("n", [4, 5, 8, 12])
def test_opencv_distortion_equals_cv2(n):
    rng = np.random.default_rng(n)
    K, R, t, size, _ = random_camera(rng)
    dist = rng.uniform(-0.05, 0.05, n) * np.r_[1, 0.3, 0.05, 0.05, np.full(n - 4, 0.1)]
    X = ground_points(K, R, t, size)
    u0, v0 = cv2_pixels(X, K, R, t, dist)
    r = camera_from_krt(K, t, R=R, dist=dist, image_size=size)
    from rhythmjax.model.lens import Pinhole

    u, v, _ = Pinhole(K, R, t, opencv_distortion(dist)).project(X)
    assert np.hypot(u - u0, v - v0).max() < 1e-9
    # the stated residual is the distance to cv2's own projection over the same ground points
    samples = visible_samples(r.section, r.transform, size, lambda x, y: (
        *cv2_pixels(np.stack([x, y, 0 * x], -1), K, R, t, dist), np.ones(len(x), bool)),
        lambda u, v: Pinhole(K, R, t, opencv_distortion(dist)).ground_of_pixels(u, v))
    d = distances_px(r.section, r.transform, samples)
    assert r.residual_max_px == pytest.approx(d.max(), rel=1e-9)
    assert r.unrepresented == ("lens distortion",) and r.residual_max_px > 0.01
    with pytest.raises(ValueError, match="distortion coefficients, got 3"):
        opencv_distortion([0.1, 0.0, 0.0])


def test_random_cameras_through_a_homography():
    """The same cameras' ground-to-image homography K [r1 r2 t], in the three conventions and
    with the world's y mirrored: (3) reproduces cv2's pixels within 1e-6 px."""
    rng = np.random.default_rng(77)
    swap = np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, 1]])
    for i in range(12):
        K, R, t, size, _ = random_camera(rng)
        G = K @ np.column_stack([R[:, 0], R[:, 1], t])
        X = ground_points(K, R, t, size)
        u0, v0 = cv2_pixels(X, K, R, t)
        Hs = {"ground-to-image": G * 3.7, "image-uv": np.linalg.inv(G),
              "image-rowcol": np.linalg.inv(G) @ swap * -2.0}
        conv = list(Hs)[i % 3]
        r = camera_from_homography(Hs[conv], conv, image_size=size, principal_point=K[:2, 2])
        u, v = r.project_world(X[:, 0], X[:, 1])
        assert np.hypot(u - u0, v - v0).max() < 1e-6, conv
        assert r.residual_max_px < 1e-6 and not r.transform.mirror
    Gm = G @ np.diag([1.0, -1.0, 1.0])  # the same camera, the world's y mirrored
    r = camera_from_homography(Gm, "ground-to-image", image_size=size, principal_point=K[:2, 2])
    u, v = r.project_world(X[:, 0], -X[:, 1])
    assert r.transform.mirror and np.hypot(u - u0, v - v0).max() < 1e-6


def tsai_loop(c: TsaiCalibration, x, y, z, scale):
    """Tsai's equations one point at a time (float64 Python): x_c = R X + T (R = Rz Ry Rx, mm),
    X_u = f x_c / z_c, r_d from r_d + kappa1 r_d^3 = r_u by bisection, u = cx + sx X_d / dpx."""
    a, b, g = c.Rxyz
    Rx = [[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]]
    Ry = [[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]]
    Rz = [[math.cos(g), -math.sin(g), 0], [math.sin(g), math.cos(g), 0], [0, 0, 1]]
    mul = lambda A, B: [[sum(A[i][k] * B[k][j] for k in range(3)) for j in range(3)]  # noqa
                        for i in range(3)]
    R = mul(mul(Rz, Ry), Rx)
    P = [1000 * x, 1000 * y, 1000 * z]
    pc = [sum(R[i][k] * P[k] for k in range(3)) + c.T[i] for i in range(3)]
    xu, yu = c.focal * pc[0] / pc[2], c.focal * pc[1] / pc[2]
    ru = math.hypot(xu, yu)
    lo, hi = 0.0, ru
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if mid + c.kappa1 * mid**3 < ru else (lo, mid)
    s = lo / ru
    return (c.cx + c.sx * xu * s / c.dpx) * scale, (c.cy + yu * s / c.dy) * scale


PETS_LIKE = dict(focal=5.5549183034, kappa1=5.1113043639e-03, cx=324.22149053, cy=282.56650051,
                 sx=1.0937855397, dpx=5.1273271277e-03, dy=4.65e-03,
                 T=(828.73214225, -3175.4796051, 35469.298547),
                 Rxyz=(2.0405458695, -0.89337703748, -0.43056124791), width=768, height=576)


def test_tsai_model_against_a_loop_and_the_former_numbers():
    c = TsaiCalibration(**PETS_LIKE)
    X = np.array([[0.0, 0.0], [5.0, 3.0], [-4.0, 10.0], [12.0, -2.0]])
    for z, scale in ((0.0, 0.625), (1.7, 1.0)):
        u, v = c.world_to_image(X[:, 0], X[:, 1], z, scale)
        ref = np.array([tsai_loop(c, x, y, z, scale) for x, y in X])
        assert np.abs(u - ref[:, 0]).max() < 1e-9 and np.abs(v - ref[:, 1]).max() < 1e-9
    # numbers of the former rhythmjax.evaluation.datasets.TsaiCamera (commit a7a4f49)
    u, v = c.world_to_image(X[:, 0], X[:, 1], 0.0, 0.625)
    np.testing.assert_allclose(u, [219.91971481304853, 224.5252921447988, 16.29886255942246,
                                   358.7605768284102], atol=1e-9)
    np.testing.assert_allclose(v, [109.85010361954046, 88.62228964865332, 111.55399508228868,
                                   73.89169670786143], atol=1e-9)
    gx, gy = c.ground_of_image(np.array([100.0, 240.0, 400.0]), np.array([300.0, 200.0, 350.0]),
                               0.625)
    np.testing.assert_allclose(gx, [-18.305333426129717, -11.078039086502809,
                                    -17.193353810982224], atol=1e-9)
    np.testing.assert_allclose(gy, [-8.941569556123365, -8.05597636269491, -15.390121047328915],
                               atol=1e-9)
    # without distortion (3) is exact but for a f != b f with roll: measured 0.143 px max
    r0 = camera_from_tsai(TsaiCalibration(**{**PETS_LIKE, "kappa1": 0.0}), image_size=(480, 360))
    assert r0.unrepresented == ("fx != fy with roll",) and 0.05 < r0.residual_max_px < 0.2
    r = camera_from_tsai(c, image_size=(480, 360))
    u, v = r.project_world(X[:, 0], X[:, 1])
    u0, v0 = c.world_to_image(X[:, 0], X[:, 1], 0.0, 0.625)
    assert np.hypot(u - u0, v - v0).max() <= r.residual_max_px
    assert r.section["f_m"] == pytest.approx(5.5549183034e-3) and r.notes == (
        "calibration 768x576 scaled by 0.625 to 480x360",)
    with pytest.raises(CameraError, match="not a scaled copy"):
        camera_from_tsai(c, image_size=(480, 300))


@pytest.mark.skipif(D.pets_root() is None, reason="PETS 2009 data absent")
def test_pets_real_calibration_residual_and_trajnet():
    """PETS View 001 at 480x360: the lens distortion (3) cannot hold is max 10.66 px, RMS 2.84 px
    over the image's ground; on the 2140 TrajNet points median 0.55 px, max 8.66 px."""
    t, w = D.pets_tsai(), D.pets_world()
    r = camera_from_tsai(t, image_size=(480, 360), fps=7.0)
    assert r.residual_max_px == pytest.approx(10.66, abs=0.01)
    assert r.residual_rms_px == pytest.approx(2.84, abs=0.01)
    u, v = r.project_world(w["x"], w["y"])
    u0, v0 = t.world_to_image(w["x"], w["y"])
    e = np.hypot(u - u0, v - v0)
    assert 0.3 < np.median(e) < 0.7 and e.max() < r.residual_max_px
    assert D.pets_camera().h == pytest.approx(r.section["h_m"], rel=1e-6)


@pytest.mark.skipif(D.eth_root() is None, reason="ETH data absent")
@pytest.mark.parametrize("name, grid_max, obs_max, obs_rms", [
    ("seq_eth", 4.85, 2.47, 1.06), ("seq_hotel", 9.78, 5.35, 1.98)])
def test_eth_homographies(name, grid_max, obs_max, obs_rms):
    """ETH's H.txt ([row, col, 1] -> m): (3) with the principal point at the image centre cannot
    match these homographies; the distance is stated (over the image: seq_eth max 4.85 px,
    seq_hotel 9.78 px). obsmat points by (3) vs H^-1: seq_eth max 2.47 px, RMS 1.06 px;
    seq_hotel max 5.35, RMS 1.98 (no square-pixel camera fits it: f is assumed, then refined
    with a f != b f)."""
    s = D.eth_sequence(name)
    r = camera_from_homography(s.H, "image-rowcol", image_size=s.image_size)
    u, v = r.project_world(s.obs["x"], s.obs["y"])
    ue, ve = s.image_points()
    e = np.hypot(u - ue, v - ve)
    assert r.residual_max_px == pytest.approx(grid_max, abs=0.02)
    assert e.max() == pytest.approx(obs_max, abs=0.02)
    assert np.sqrt(np.mean(e**2)) == pytest.approx(obs_rms, abs=0.02)


def test_intrinsics_against_hand_geometry():
    """A square-pixel camera 5 m up, tilted 30 deg, f = 800 px, 640x480: a ground point d m ahead
    is seen at row vc + f tan(atan(5 / d) - 30 deg), and x m to the side at u = uc + f x / z_c."""
    r = camera_from_intrinsics(focal_px=800.0, h_m=5.0, tilt_deg=30.0, image_size=(640, 480))
    assert "uc_px" not in r.section and r.section["h_m"] == pytest.approx(5 - 0.008 * 0.5)
    for d, x in ((4.0, 0.0), (10.0, 1.5), (25.0, -3.0)):
        u, v = r.project_world(x, d - 0.008 * math.cos(math.radians(30)))
        th = math.radians(30)
        zc = d * math.cos(th) + 5 * math.sin(th)
        assert v == pytest.approx(240 + 800 * math.tan(math.atan(5 / d) - th), abs=1e-9)
        assert u == pytest.approx(320 + 800 * x / zc, abs=1e-9)
    r = camera_from_intrinsics(hfov_deg=90.0, h_m=3.0, tilt_deg=10.0, image_size=(640, 480))
    assert r.section["a_px_per_m"] * 0.008 == pytest.approx(320.0)
    with pytest.raises(CameraError, match="tilt_deg"):
        camera_from_intrinsics(focal_px=800.0, h_m=5.0, tilt_deg=-5.0, image_size=(640, 480))


def test_refusals_name_the_field():
    rng = np.random.default_rng(5)
    K, R, t, size, _ = random_camera(rng)
    flip = np.diag([1.0, -1.0, -1.0])
    with pytest.raises(CameraError, match=r"^t: .*below the ground"):
        camera_from_krt(K, t, R=R @ flip, image_size=size)  # world z pointing down
    r = camera_from_krt(K, t, R=R @ flip, image_size=size, z_down=True)
    X = ground_points(K, R, t, size)
    u0, v0 = cv2_pixels(X, K, R, t)
    u, v = r.project_world(X[:, 0], -X[:, 1])  # the same points in the z-down world
    assert np.hypot(u - u0, v - v0).max() < 1e-6
    Ku, up, tu, size_u, _ = random_camera(rng, tilt_deg=-10.0)  # looking up, at the sky
    with pytest.raises(CameraError, match=r"^R: .*10.0 deg above the horizontal"):
        camera_from_krt(Ku, tu, R=up, image_size=size_u)
    G = Ku @ np.column_stack([up[:, 0], up[:, 1], tu])
    with pytest.raises(CameraError, match=r"^H: .*10.0 deg above the horizontal"):
        camera_from_homography(G, "ground-to-image", image_size=size_u,
                               principal_point=Ku[:2, 2])
    with pytest.raises(CameraError, match=r"^H: singular"):
        camera_from_homography(np.ones((3, 3)), "image-uv", image_size=size)
    side = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]]) @ R  # image on its side
    with pytest.raises(CameraError, match=r"^R: .*rolled"):
        camera_from_krt(K, -side @ (-R.T @ t), R=side, image_size=size)
    with pytest.raises(CameraError, match="^R: not a rotation"):
        camera_from_krt(K, t, R=R * 1.01, image_size=size)
    Kfar = K.copy()
    Kfar[1, 2] = 20.0 * size[1]  # principal point far below: every row above the horizon
    with pytest.raises(CameraError, match="sees no ground"):
        camera_from_krt(Kfar, t, R=R, image_size=size)


def test_ground_transform_round_trip():
    tr = GroundTransform(0.7, 3.0, -2.0, 0.007, mirror=True, unit_m=0.001)
    x, y = np.array([1000.0, -2500.0]), np.array([400.0, 9000.0])
    gx, gy = tr.apply(x, y)
    bx, by = tr.inverse(gx, gy)
    assert np.abs(bx - x).max() < 1e-9 and np.abs(by - y).max() < 1e-9
    m = np.asarray(tr.as_dict()["matrix_2x3"])
    np.testing.assert_allclose(m[:, :2] @ np.stack([x, y]) + m[:, 2:], np.stack([gx, gy]))
    # the camera's foot, mirrored, is (0, -back) in the ground frame
    assert tr.apply(3000.0, 2000.0) == pytest.approx((0.0, -0.007), abs=1e-12)


def measured_figures() -> list[str]:
    """The figures docs/camera.md quotes (`python tests/test_camera_from.py`)."""
    import pathlib
    import tempfile

    rng = np.random.default_rng(20240615)
    tmp = pathlib.Path(tempfile.mkdtemp())
    w64 = w32 = wh = 0.0
    for _ in range(50):
        K, R, t, size, _ = random_camera(rng)
        X = ground_points(K, R, t, size)
        u0, v0 = cv2_pixels(X, K, R, t)
        r = camera_from_krt(K, t, R=R, image_size=size)
        u, v = r.project_world(X[:, 0], X[:, 1])
        w64 = max(w64, np.hypot(u - u0, v - v0).max())
        gx, gy = r.transform.apply(X[:, 0], X[:, 1])
        u, v = project_3d(through_config(r, tmp), gx, gy, 0 * gx)
        w32 = max(w32, np.hypot(u - u0, v - v0).max())
        G = K @ np.column_stack([R[:, 0], R[:, 1], t])
        rh = camera_from_homography(G, "ground-to-image", image_size=size,
                                    principal_point=K[:2, 2])
        u, v = rh.project_world(X[:, 0], X[:, 1])
        wh = max(wh, np.hypot(u - u0, v - v0).max())
    out = [f"random cameras (50) vs cv2.projectPoints, max px: K R t -> section {w64:.2g}, "
           f"-> JSON config (float32) {w32:.2g}, homography -> section {wh:.2g}"]
    if D.pets_root() is not None:
        t, w = D.pets_tsai(), D.pets_world()
        r = camera_from_tsai(t, image_size=(480, 360), fps=7.0)
        u, v = r.project_world(w["x"], w["y"])
        u0, v0 = t.world_to_image(w["x"], w["y"])
        e = np.hypot(u - u0, v - v0)
        out.append(f"PETS Tsai: image max {r.residual_max_px:.2f} px, RMS "
                   f"{r.residual_rms_px:.2f} px; {e.size} TrajNet points median "
                   f"{np.median(e):.2f} px, max {e.max():.2f} px")
    if D.eth_root() is not None:
        for name in D.ETH_SEQUENCES:
            s = D.eth_sequence(name)
            r = camera_from_homography(s.H, "image-rowcol", image_size=s.image_size)
            u, v = r.project_world(s.obs["x"], s.obs["y"])
            ue, ve = s.image_points()
            e = np.hypot(u - ue, v - ve)
            out.append(f"ETH {name}: image max {r.residual_max_px:.2f} px, RMS "
                       f"{r.residual_rms_px:.2f} px; {e.size} obsmat points max {e.max():.2f} "
                       f"px, RMS {np.sqrt(np.mean(e**2)):.2f} px")
    return out


if __name__ == "__main__":
    print("\n".join(measured_figures()))
