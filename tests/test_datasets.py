"""evaluation.datasets against the figures in each folder's SOURCE.md (skipped without the data)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.evaluation import datasets as D
from rhythmjax.io.tables import BadInput
from rhythmjax.model.camera import ground_from_image, project


pytestmark = pytest.mark.data
need_pets = pytest.mark.skipif(D.pets_root() is None, reason="PETS 2009 data absent")
need_eth = pytest.mark.skipif(D.eth_root() is None, reason="ETH data absent")
need_ucsd = pytest.mark.skipif(D.ucsd_root() is None, reason="UCSD Ped2 data absent")


@pytest.fixture(scope="module")
def pets():
    if D.pets_root() is None:
        pytest.skip("PETS 2009 data absent")
    return D.pets_tsai(), D.pets_boxes(), D.pets_world()


@need_pets
def test_pets_boxes_match_source_and_a_hand_parsed_box(pets):
    _, b, _ = pets
    assert b["frame"].size == 4650 and np.unique(b["id"]).size == 19
    assert (b["frame"].min(), b["frame"].max()) == (0, 794)
    # SOURCE: heights 52.5 .. 153.5 px at 768x576 (rounded to 0.1 px there)
    assert b["bb_height"].min() == pytest.approx(52.5 * 0.625, abs=0.1)
    assert b["bb_height"].max() == pytest.approx(153.5 * 0.625, abs=0.1)
    # frame 0, id 9 in the XML: h=75.17 w=31.03 xc=514.7109 yc=195.2731 (768x576)
    i = np.flatnonzero((b["frame"] == 0) & (b["id"] == 9))[0]
    assert b["foot_u"][i] == pytest.approx(514.7109 * 0.625, abs=1e-9)
    assert b["foot_v"][i] == pytest.approx((195.2731 + 75.17 / 2) * 0.625, abs=1e-9)
    assert b["bb_left"][i] == pytest.approx((514.7109 - 31.03 / 2) * 0.625, abs=1e-9)
    np.testing.assert_allclose(b["bb_top"] + b["bb_height"], b["foot_v"], atol=1e-9)
    c = D.pets_boxes(cropped=True)
    assert c["frame"].size == 3955 and np.unique(c["id"]).size == 23
    w = D.pets_world()
    assert w["frame"].size == 2140 and np.unique(w["id"]).size == 107
    assert D.pets_video().is_file()


@need_pets
def test_tsai_pose_reproduces_source(pets):
    t, _, _ = pets
    assert t.h_m == pytest.approx(7.066, abs=6e-4)
    assert math.degrees(t.theta_rad) == pytest.approx(16.48, abs=6e-3)
    # SOURCE's roll -2.96 deg is the elevation of the camera x axis, asin(R[0, 2]); ours is the
    # rotation about the optical axis, asin(R[0, 2] / cos(theta)) = -3.09 deg
    assert math.degrees(math.asin(t.R[0, 2])) == pytest.approx(-2.96, abs=6e-3)
    assert math.sin(t.roll_rad) * math.cos(t.theta_rad) == pytest.approx(t.R[0, 2], abs=1e-12)
    fu, fv = t.focal_px(1.0)
    assert (fu, fv) == pytest.approx((1185.0, 1194.6), abs=0.06)
    assert t.focal_px() == pytest.approx((740.6, 746.6), abs=0.06)
    np.testing.assert_allclose(t.R @ t.R.T, np.eye(3), atol=1e-12)


@need_pets
def test_tsai_round_trip_and_trajnet_lands_on_the_feet(pets):
    t, b, w = pets
    u, v = t.world_to_image(w["x"], w["y"])
    gx, gy = t.ground_of_image(u, v)
    assert np.abs(gx - w["x"]).max() < 1e-9 and np.abs(gy - w["y"]).max() < 1e-9
    # distortion: the undistort of the Newton-distorted point is exact to 1e-9 px
    d = []
    for k in np.unique(w["frame"]):
        m, mb = w["frame"] == k, b["frame"] == k
        du = u[m][:, None] - b["foot_u"][mb][None, :]
        dv = v[m][:, None] - b["foot_v"][mb][None, :]
        d.append(np.hypot(du, dv).min(axis=1))
    d = np.concatenate(d)
    # measured: median 2.59 px, 90 % 4.76 px over 2140 points (boxes are hand-placed, smoothed)
    assert np.median(d) < 3.5 and np.percentile(d, 90) < 6.0


@need_pets
def test_pets_camera_is_the_tsai_camera_without_distortion(pets):
    t, _, w = pets
    cam = D.pets_camera()
    assert (cam.image_width, cam.image_height, cam.fps) == (480, 360, 7.0)
    gx, gy = D.pets_ground(w["x"], w["y"])
    with jax.enable_x64(True):
        pu, pv = (np.asarray(a) for a in project(cam, jnp.asarray(gx), jnp.asarray(gy)))
        bx, by, ok = ground_from_image(cam, jnp.asarray(pu), jnp.asarray(pv))
    assert bool(np.all(ok))
    assert np.abs(np.asarray(bx) - gx).max() < 1e-3 and np.abs(np.asarray(by) - gy).max() < 1e-3
    t0 = D.TsaiCamera(**{**t.__dict__, "kappa1": 0.0})
    u0, v0 = t0.world_to_image(w["x"], w["y"])
    e0 = np.hypot(pu - u0, pv - v0)
    # left: f in the depth of (3) and sx applied before the roll; measured median 0.057, max 0.156
    assert np.median(e0) < 0.1 and e0.max() < 0.25
    u, v = t.world_to_image(w["x"], w["y"])
    e = np.hypot(pu - u, pv - v)  # the lens distortion (3) cannot represent: 0.53 / 8.5 px
    assert 0.2 < np.median(e) < 1.0 and e.max() < 12.0


@need_eth
@pytest.mark.parametrize("name, n, tracks, rows, cols", [
    ("seq_eth", 8908, 360, (16, 465), (133, 479)), ("seq_hotel", 6544, 390, (107, 518), (2, 720))])
def test_eth_image_points_are_the_clicked_pixels(name, n, tracks, rows, cols):
    s = D.eth_sequence(name)
    assert s.obs["x"].size == n and np.unique(s.obs["id"]).size == tracks
    assert s.fps == 2.5 and s.video is None and s.reference.is_file()
    u, v = s.image_points()
    assert np.abs(u - np.round(u)).max() < 1e-4 and np.abs(v - np.round(v)).max() < 1e-4
    assert (round(v.min()), round(v.max())) == rows and (round(u.min()), round(u.max())) == cols
    x, y = s.world_of_image(u, v)
    assert np.abs(x - s.obs["x"]).max() < 1e-9 and np.abs(y - s.obs["y"]).max() < 1e-9
    # velocities = central differences of positions at dt = 0.4 s (SOURCE: median error 0.000)
    o = np.lexsort((s.obs["frame"], s.obs["id"]))
    ids, xs, vx = s.obs["id"][o], s.obs["x"][o], s.obs["vx"][o]
    i = np.flatnonzero(ids[2:] == ids[:-2])
    cd = (xs[i + 2] - xs[i]) / 0.8
    assert np.median(np.abs(cd - vx[i + 1])) < 5e-3


@need_ucsd
def test_ucsd_clips_and_boxes():
    counts = {"Test002": 86, "Test004": 150, "Test006": 159, "Test010": 150}
    for clip in D.UCSD_CLIPS:
        folder, bx = D.ucsd_clip(clip)
        assert np.unique(bx["frame"]).size == counts[clip]
        assert (folder / "000.jpg").is_file()
        assert bx["frame"].max() < len(list(folder.glob("*.jpg")))
    _, b2 = D.ucsd_clip("Test002")
    assert (b2["frame"].min(), b2["frame"].max()) == (94, 179)
    with pytest.raises(ValueError, match="unknown UCSD clip"):
        D.ucsd_clip("Test001")


def test_bad_files_name_the_file(tmp_path):
    (tmp_path / "annotations").mkdir()
    (tmp_path / "annotations" / "PETS2009-S2L1.xml").write_text("<dataset><frame number='0'>")
    with pytest.raises(BadInput, match="PETS2009-S2L1.xml"):
        D.pets_boxes(tmp_path)
    (tmp_path / "seq_eth").mkdir()
    (tmp_path / "seq_eth" / "H.txt").write_text("1 0 0\n0 1 0\n0 0 x\n")
    with pytest.raises(BadInput, match=r"H\.txt.*line 3"):
        D.eth_sequence("seq_eth", tmp_path)
    with pytest.raises(FileNotFoundError):
        D.pets_tsai(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="unknown ETH"):
        D.eth_sequence("seq_zara", tmp_path)


def test_default_data_root_is_beside_the_checkout(monkeypatch):
    """Without RHYTHMJAX_DATA the loaders look in ../shared/data/real beside the checkout (a
    module moved one folder deeper once pointed inside the checkout, and every real-data test
    skipped without a word)."""
    import importlib
    from pathlib import Path

    monkeypatch.delenv("RHYTHMJAX_DATA", raising=False)
    fresh = importlib.reload(D)
    try:
        want = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
        assert fresh.DATA_ROOT == want
    finally:
        monkeypatch.undo()
        importlib.reload(D)


def test_data_root_after_a_plain_install(monkeypatch, tmp_path):
    """After `pip install .` the module lies in the environment, not beside the data: the root is
    then $RHYTHMJAX_DATA, else shared/data/real in the working directory or its parent."""
    monkeypatch.setattr(D, "__file__", str(tmp_path / "venv" / "lib" / "py" / "site" / "x.py"))
    monkeypatch.delenv("RHYTHMJAX_DATA", raising=False)
    checkout = tmp_path / "work" / "main"
    checkout.mkdir(parents=True)
    data = tmp_path / "work" / "shared" / "data" / "real"
    data.mkdir(parents=True)
    monkeypatch.chdir(checkout)
    assert D.default_data_root() == data  # the checkout's parent
    monkeypatch.chdir(tmp_path / "work")
    assert D.default_data_root() == data  # the working directory
    monkeypatch.setenv("RHYTHMJAX_DATA", str(tmp_path / "elsewhere"))
    assert D.default_data_root() == tmp_path / "elsewhere"
    with pytest.raises(FileNotFoundError, match="RHYTHMJAX_DATA"):
        D.pets_tsai(tmp_path / "none")
