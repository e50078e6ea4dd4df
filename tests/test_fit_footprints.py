"""Footprints files: `rhythmjax.io.read_footprints` and `rhythmjax-fit footprints`
(`fit.footprints`), on hand-made files, synthetic cameras and the real PETS / ETH data."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fit.cli import main
from fit.footprints import (
    grid_points,
    image_to_ground,
    match_by_geometry,
    read_boxes,
    through_homography,
)
from fit.random_cameras import pinhole
from rhythmjax.evaluation import datasets as D
from rhythmjax.io import BadInput, read_config, read_footprints, read_table, write_table
from rhythmjax.model.camera_np import ground_of_pixels, project_3d
from rhythmjax.model.params import Camera


CAM = Camera(h=4.0, theta=math.radians(18.0), a=700 / 0.008, b=700 / 0.008, uc=320.0,
             vc=240.0, roll=math.radians(2.0), image_width=640, image_height=480)


def _err(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


# -- read_footprints ----------------------------------------------------------------------------
def test_read_footprints_needs_only_u_v_x_y(tmp_path):
    (tmp_path / "a.csv").write_text("x,u,y,v,note\n1.5,10,6,20,hi\n-2,30,,40,\n")
    fp = read_footprints(tmp_path / "a.csv")
    np.testing.assert_array_equal(fp.u, [10, 30])
    np.testing.assert_array_equal(fp.x, [1.5, -2])
    assert np.isnan(fp.y[1]) and fp.track_id is None and fp.frame is None
    assert fp.line.tolist() == [2, 3] and fp.unit == "line"
    write_table(tmp_path / "b.parquet", {"u": [1.0, 2.0], "v": [3.0, 4.0], "x": [0.0, 1.0],
                                         "y": [5.0, 6.0], "track_id": ["a", "b"],
                                         "frame": [7, 8]},
                ("u", "v", "x", "y", "track_id", "frame"))
    fp = read_footprints(tmp_path / "b.parquet")
    assert fp.track_id.tolist() == ["a", "b"] and fp.frame.tolist() == [7, 8]


@pytest.mark.parametrize("text, what", [
    ("u,v,x\n1,2,3\n", "footprints need columns 'x' and 'y'"),
    ("x,y,u\n1,2,3\n", "footprints need columns 'u' and 'v'"),
    ("u,v,x,y\n1,2,3,4\n1,2,inf,4\n", "a.csv line 3, column 'x': inf is not a usable value"),
    ("u,v,x,y\n1,2,3,oops\n", "a.csv line 2, column 'y': 'oops' is not a number"),
    ("u,v,x,y,frame\n1,2,3,4,1.5\n", "column 'frame': '1.5' is not an integer"),
])
def test_read_footprints_errors_name_file_line_column(tmp_path, text, what):
    (tmp_path / "a.csv").write_text(text)
    with pytest.raises(BadInput) as e:
        read_footprints(tmp_path / "a.csv")
    assert what in str(e.value) and "a.csv" in str(e.value)


# -- readers ------------------------------------------------------------------------------------
def test_mot_and_cvml_foot_points_hand_worked(tmp_path):
    # MOT: left 100, top 50, 20 x 60 -> foot (110, 110); x 0.5 -> (55, 55); world x, y kept
    (tmp_path / "gt.txt").write_text("1,7,100,50,20,60,1,3.5,8.25,0\n2,7,104,50,20,60,1,-1,-1,-1\n")
    b = read_boxes(tmp_path / "gt.txt", scale=0.5)
    np.testing.assert_allclose(b["foot_u"], [55.0, 57.0])
    np.testing.assert_allclose(b["foot_v"], [55.0, 55.0])
    np.testing.assert_array_equal(b["x"][:1], [3.5])
    assert np.isnan(b["x"][1]) and b["frame"].tolist() == [1, 2] and b["id"].tolist() == [7, 7]
    # CVML (PETS): centre (xc, yc), height h -> foot (xc, yc + h / 2)
    (tmp_path / "a.xml").write_text(
        '<dataset><frame number="0"><objectlist><object id="9"><box h="80" w="30" xc="500" '
        'yc="200"/></object></objectlist></frame></dataset>')
    b = read_boxes(tmp_path / "a.xml", scale=0.625)
    np.testing.assert_allclose([b["foot_u"][0], b["foot_v"][0]], [312.5, 150.0])


def test_homography_conventions_match_the_inverse_of_3(tmp_path):
    # H from the camera's pin-hole (ground -> image G = K [r1 r2 t], inverted): every grid
    # point maps to the ground point that camera_np.ground_of_pixels (the inverse of (3))
    # gives, to 1e-9 m, in both conventions ([u, v, 1] and ETH's [row, col, 1])
    K, rvec, t = pinhole(CAM)
    R = __import__("cv2").Rodrigues(rvec)[0]
    G = K @ np.column_stack([R[:, 0], R[:, 1], t])
    H_uv = np.linalg.inv(G)
    H_rc = H_uv @ np.array([[0, 1.0, 0], [1, 0, 0], [0, 0, 1]])
    u, v = grid_points(H_rc, (640, 480), 12, "rowcol")
    assert u.size > 50
    gx, gy, ok = ground_of_pixels(CAM, u, v)
    assert ok.all()
    for H, order in ((H_uv, "uv"), (H_rc, "rowcol")):
        x, y, _ = image_to_ground(H, u, v, order)
        np.testing.assert_allclose(x, gx, atol=1e-9 * np.abs(gy).max())
        np.testing.assert_allclose(y, gy, atol=1e-9 * np.abs(gy).max())
    # the grid keeps the ground side of the horizon only, within the depth ratio
    row_hz = CAM.vc - 700 * math.tan(CAM.theta)  # roughly (roll 2 deg)
    assert v.min() > row_hz
    made = through_homography({"u": np.r_[u, 320.0], "v": np.r_[v, row_hz - 100]}, H_rc,
                              "rowcol", source="pts")
    assert len(made) == u.size and "1 image point(s) dropped" in made.notes[0]


def _scene(rng, n_frames=30, n_people=6, extra=1):
    """People walking in front of CAM: world positions (chunk ids, not people) and MOT boxes
    (1-based frames, boxes at twice the image size, an extra box without a position)."""
    pos, boxes, truth = [], [], []
    start = rng.uniform([-4, 6], [4, 20], (n_people + extra, 2))
    vel = rng.uniform(-0.7, 0.7, (n_people + extra, 2))
    for f in range(n_frames):
        for p in range(n_people + extra):
            x, y = start[p] + vel[p] * f * 0.2
            fu, fv = project_3d(CAM, x, y, 0.0)
            fu, fv = fu + rng.normal(0, 1.0), fv + rng.normal(0, 1.0)
            boxes.append((f + 1, p + 1, 2 * (fu - 10), 2 * (fv - 70), 40.0, 140.0))
            if p < n_people:
                pos.append((f, 100 + 10 * p + f // 10, round(x, 3), round(y, 3)))
                truth.append((f + 1, p + 1))
    return pos, boxes, truth


def test_geometry_matching_recovers_every_pair(tmp_path, capsys):
    rng = np.random.default_rng(1)
    pos, boxes, truth = _scene(rng)
    (tmp_path / "pos.txt").write_text("".join(f"{f} {i} {x} {y}\n" for f, i, x, y in pos))
    (tmp_path / "gt.txt").write_text("".join(",".join(map(str, b)) + ",1,-1,-1,-1\n"
                                             for b in boxes))
    out = tmp_path / "fp.csv"
    rc = main(["footprints", "--boxes", str(tmp_path / "gt.txt"), "--positions",
               str(tmp_path / "pos.txt"), "--box-scale", "0.5", "--frame-offset", "-1", "-o",
               str(out), "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0 and rep["match"] == "geometry" and rep["n"] == len(truth)
    t = read_table(out)
    assert sorted(zip(t["frame"].tolist(), t["track_id"].astype(int).tolist())) == sorted(truth)
    # each footprint's world point projects (through CAM) onto its foot point within the noise
    pu, pv = project_3d(CAM, t["x"], t["y"], 0.0)
    assert np.max(np.hypot(pu - t["u"], pv - t["v"])) < 5.0
    assert rep["homography_rms_px"] < 1.3  # 1 px noise, positions rounded to 1 mm


def test_id_matching_and_world_columns_of_mot(tmp_path, capsys):
    (tmp_path / "gt.txt").write_text("1,3,10,20,4,10,1,1.0,5.0,0\n1,4,30,20,4,10,1,2.0,6.0,0\n"
                                     "2,3,11,21,4,10,1,1.1,5.1,0\n2,4,31,22,4,10,1,2.1,6.2,0\n"
                                     "3,3,12,22,4,10,1,1.2,5.2,0\n")
    rc = main(["footprints", "--boxes", str(tmp_path / "gt.txt"), "-o", str(tmp_path / "a.csv")])
    assert rc == 0 and "5 footprints" in capsys.readouterr().out
    t = read_table(tmp_path / "a.csv")
    np.testing.assert_allclose(t["u"], [12, 13, 14, 32, 33])  # sorted by (track_id, frame)
    np.testing.assert_allclose(t["y"], [5.0, 5.1, 5.2, 6.0, 6.2])
    (tmp_path / "pos.txt").write_text("1 3 100 500\n2 3 110 510\n3 3 120 520\n1 4 200 600\n")
    rc = main(["footprints", "--boxes", str(tmp_path / "gt.txt"), "--positions",
               str(tmp_path / "pos.txt"), "--units", "cm", "-o", str(tmp_path / "b.csv")])
    assert rc == 0 and "matched by id" in capsys.readouterr().out
    t = read_table(tmp_path / "b.csv")
    np.testing.assert_allclose(t["x"], [1.0, 1.1, 1.2, 2.0])


@pytest.mark.parametrize("files, args, what", [
    ({"pos.txt": "0 1 2.0 3.0\n0 2 x 3\n"}, ["--boxes", "gt.txt", "--positions", "pos.txt"],
     "pos.txt line 2, column 'x': 'x' is not a number"),
    ({"pos.txt": "0 1 2.0\n"}, ["--boxes", "gt.txt", "--positions", "pos.txt"],
     "pos.txt line 1: expected 4 fields"),
    ({"H.txt": "1 2 3\n2 4 6\n0 0 1\n"}, ["--points", "gt.txt", "--homography", "H.txt"],
     "H.txt: the homography is singular"),
    ({"H.txt": "1 0 0\n0 1 0\n"}, ["--points", "gt.txt", "--homography", "H.txt"],
     "H.txt: expected a 3x3 matrix"),
    ({}, ["--points", "gt.txt"], "--points needs --homography"),
    ({"bad.txt": "1,1,0,0,1\n"}, ["--boxes", "bad.txt", "--positions", "gt.txt"],
     "bad.txt line 1: expected 6 to 10"),
    ({"a.xml": "<dataset><frame number='0'><objectlist><object id='1'><box h='3' w='2' "
               "xc='1'/></object></objectlist></frame></dataset>"},
     ["--boxes", "a.xml", "--positions", "gt.txt"], "box attribute 'yc' missing"),
    ({"a.xml": "<dataset><frame>"}, ["--boxes", "a.xml", "--positions", "gt.txt"],
     "a.xml line 1: not valid XML"),
    ({}, ["--boxes", "gt.txt"], "carry no world position"),
])
def test_footprints_bad_input_exit_2(tmp_path, capsys, monkeypatch, files, args, what):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "gt.txt").write_text("1,1,10,20,4,10,1,-1,-1,-1\n")
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    rc = main(["footprints", *args, "-o", "out.csv"])
    err = _err(capsys)
    assert rc == 2 and what in err, err
    assert not (tmp_path / "out.csv").exists()


def test_grid_homography_to_camera_end_to_end(tmp_path, capsys):
    # H of CAM in a world frame rotated by 40 deg and shifted by (3, -7) m: the grid footprints
    # give back CAM exactly (it is a camera of (3), principal point at the centre, a = b):
    # RMS under 1e-3 px, h, theta and roll to 1e-3
    K, rvec, t = pinhole(CAM)
    R = __import__("cv2").Rodrigues(rvec)[0]
    H = np.linalg.inv(K @ np.column_stack([R[:, 0], R[:, 1], t]))  # image [u, v, 1] -> ground
    c, s = math.cos(math.radians(40)), math.sin(math.radians(40))
    W = np.array([[c, -s, 3.0], [s, c, -7.0], [0, 0, 1]])  # ground -> world
    np.savetxt(tmp_path / "H.txt", W @ H)
    rc = main(["footprints", "--grid", "15", "--image-size", "640x480", "--homography",
               str(tmp_path / "H.txt"), "--homography-convention", "image-uv", "-o",
               str(tmp_path / "g.csv")])
    assert rc == 0, capsys.readouterr()
    capsys.readouterr()
    rc = main(["camera", str(tmp_path / "g.csv"), "--world", "--image-size", "640x480",
               "--image-center", "-o", str(tmp_path / "c.json"), "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0 and rep["rms_px"] < 1e-3
    got = read_config(tmp_path / "c.json").camera
    assert abs(float(got.h) - 4.0) < 1e-3
    assert abs(math.degrees(float(got.theta)) - 18.0) < 1e-3
    assert abs(math.degrees(float(got.roll)) - 2.0) < 1e-3


def test_geometry_match_without_common_frames_is_refused():
    b = {"frame": np.arange(5), "id": np.ones(5, int), "foot_u": np.ones(5), "foot_v": np.ones(5)}
    p = {"frame": np.arange(5) + 100, "x": np.ones(5), "y": np.ones(5)}
    with pytest.raises(ValueError, match="--frame-offset"):
        match_by_geometry(b, p)


# -- real data ------------------------------------------------------------------------------
@pytest.mark.data
def test_pets_footprints_and_camera_from_the_command_line(tmp_path, capsys):
    """PETS: CVML boxes (x 0.625) + TrajNet positions, matched by geometry: the pairs that the
    Tsai calibration matches (`fit.real_footprints.pets_pairs`), and a camera whose RMS is the
    least-squares homography's (2.17 px) within 0.01 px, near Tsai's h and tilt."""
    root = D.pets_root()
    if root is None:
        pytest.skip("PETS 2009 data absent")
    from fit.real_footprints import pets_pairs

    rc = main(["footprints", "--boxes", str(root / "annotations" / "PETS2009-S2L1.xml"),
               "--box-scale", "0.625", "--positions",
               str(root / "world" / "PETS09-S2L1_trajnet.txt"), "-o", str(tmp_path / "fp.csv"),
               "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0 and rep["match"] == "geometry" and rep["n"] >= 2130
    u, v, X, Y, _ = pets_pairs("trajnet")
    t = read_table(tmp_path / "fp.csv")
    mine = {(round(a, 3), round(b, 3), round(c, 2), round(d, 2)) for a, b, c, d in
            zip(t["u"], t["v"], t["x"], t["y"])}
    tsai = {(round(a, 3), round(b, 3), round(c, 2), round(d, 2)) for a, b, c, d in
            zip(u, v, X, Y)}
    assert len(mine & tsai) >= 2130, (len(mine), len(tsai), len(mine & tsai))
    (tmp_path / "c0.json").write_text('{"camera": {"fps": 7}}')
    rc = main(["camera", str(tmp_path / "fp.csv"), "--world", "--image-size", "480x360",
               "--image-center", "-c", str(tmp_path / "c0.json"), "-o",
               str(tmp_path / "pets.json"), "--json"])
    fit = json.loads(capsys.readouterr().out)
    assert rc == 0 and fit["rms_px"] < rep["homography_rms_px"] + 0.01
    cam = read_config(tmp_path / "pets.json").camera
    tsai_cam = D.pets_tsai()
    assert abs(float(cam.h) - tsai_cam.h_m) < 0.15
    assert abs(float(cam.theta) - tsai_cam.theta_rad) < math.radians(0.6)


@pytest.mark.data
def test_eth_homography_footprints_to_camera(tmp_path, capsys):
    """ETH: footprints of a 20 x 20 grid through H.txt; seq_eth gives a camera of (3) (principal
    point at the image centre, roll fitted) within 1.1 px RMS of H on the grid, and the obsmat
    points reprojected within 0.8 px RMS of H's own mapping; seq_hotel (a camera looking
    straight down whose H no centred pin-hole represents) is refused as ill-determined (exit 1)."""
    if D.eth_root() is None:
        pytest.skip("ETH data absent")
    from fit.camera import fit_camera

    for name, size, expect in (("seq_eth", "640x480", 0), ("seq_hotel", "720x576", 1)):
        H = D.eth_root() / name / "H.txt"
        rc = main(["footprints", "--grid", "20", "--image-size", size, "--homography", str(H),
                   "-o", str(tmp_path / f"{name}.csv")])
        assert rc == 0
        capsys.readouterr()
        rc = main(["camera", str(tmp_path / f"{name}.csv"), "--world", "--image-size", size,
                   "--image-center", "-o", str(tmp_path / f"{name}.json"), "--json"])
        rep = json.loads(capsys.readouterr().out)
        assert rc == expect, rep["reasons"]
        if name == "seq_eth":
            assert rep["rms_px"] < 1.1
            t = read_table(tmp_path / f"{name}.csv")
            cam0 = read_config(tmp_path / f"{name}.json").camera
            r = fit_camera(t["u"], t["v"], t["x"], t["y"], cam0, fit=("af", "h", "theta", "roll"),
                           world=True)
            s = D.eth_sequence(name)
            ou, ov = s.image_points()
            pu, pv = project_3d(r.camera, *r.to_ground(s.obs["x"], s.obs["y"]), 0.0)
            assert np.sqrt(np.mean(np.r_[pu - ou, pv - ov] ** 2)) < 0.8
