"""`rhythmjax camera` end to end, one test per source, into a config `read_config` accepts; and
its bad inputs: exit 2, one line naming the file (or option) and the field, nothing written."""

from __future__ import annotations

import json
import re

import cv2
import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.evaluation import datasets as D
from rhythmjax.io import read_config
from rhythmjax.model.camera_from import camera_from_krt, camera_from_tsai
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.lens import TsaiCalibration

from .test_camera_from import PETS_LIKE, cv2_pixels, ground_points, random_camera


def run(capsys, *argv):
    code = main(["camera", *map(str, argv)])
    out = capsys.readouterr()
    return code, out.out, out.err


def one_line(err: str) -> str:
    err = err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


def host(cfg_camera):
    c = cfg_camera
    return tuple(float(np.asarray(getattr(c, k))) for k in ("f", "h", "theta", "a", "b", "uc",
                                                             "vc", "roll"))


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """A 10-frame 160x120 MJPG clip at 12 fps."""
    path = str(tmp_path_factory.mktemp("clip") / "clip.avi")
    w = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"MJPG"), 12.0, (160, 120), False)
    for i in range(10):
        w.write(np.full((120, 160), 20 * i, np.uint8))
    w.release()
    return path


def test_focal_length_height_tilt(tmp_path, capsys):
    out = tmp_path / "cam.json"
    code, stdout, err = run(capsys, "--focal-px", 800, "--height", 5, "--tilt", 30,
                            "--image-size", "640x480", "--fps", 25, "-o", out)
    assert code == 0, err
    d = json.loads(out.read_text())
    assert list(d) == ["camera"] and "uc_px" not in d["camera"]
    assert d["camera"]["h_m"] == pytest.approx(5 - 0.008 * 0.5, abs=1e-12)
    cfg = read_config(out)
    assert (cfg.camera.image_width, cfg.camera.image_height, cfg.camera.fps) == (640, 480, 25.0)
    assert cfg.thresholds.n == round(64 / 15 * 25)
    assert "focal length      800.0 px" in stdout and "horizon" in stdout
    assert "nearest camera" not in stdout and "world -> ground" not in stdout
    code, stdout, _ = run(capsys, "--hfov-deg", 90, "--height", 5, "--tilt", 30,
                          "--image-size", "640x480", "--json")
    s = json.loads(stdout)
    assert code == 0 and s["output"] is None
    assert s["report"]["focal_px"][0] == pytest.approx(320.0)


def test_video_gives_size_and_fps_and_fps_wins(clip, tmp_path, capsys):
    out = tmp_path / "cam.json"
    code, _, err = run(capsys, "--hfov-deg", 60, "--height", 3, "--tilt", 15, "--video", clip,
                       "-o", out)
    assert code == 0, err
    c = json.loads(out.read_text())["camera"]
    assert (c["image_width_px"], c["image_height_px"], c["fps"]) == (160, 120, 12.0)
    code, _, err = run(capsys, "--hfov-deg", 60, "--height", 3, "--tilt", 15, "--video", clip,
                       "--fps", 7, "-o", out)
    assert code == 0 and "--fps 7 overrides the video's 12 fps" in err
    assert json.loads(out.read_text())["camera"]["fps"] == 7.0


def write_tsai(path, c: dict):
    path.write_text(
        f'<?xml version="1.0"?>\n<Camera name="v">\n'
        f'<Geometry width="{c["width"]}" height="{c["height"]}" dpx="{c["dpx"]}" dy="{c["dy"]}"/>'
        f'\n<Intrinsic focal="{c["focal"]}" kappa1="{c["kappa1"]}" cx="{c["cx"]}" cy="{c["cy"]}" '
        f'sx="{c["sx"]}"/>\n<Extrinsic tx="{c["T"][0]}" ty="{c["T"][1]}" tz="{c["T"][2]}" '
        f'rx="{c["Rxyz"][0]}" ry="{c["Rxyz"][1]}" rz="{c["Rxyz"][2]}"/>\n</Camera>\n')


def test_tsai_xml(tmp_path, capsys):
    xml, out = tmp_path / "cal.xml", tmp_path / "cam.json"
    write_tsai(xml, PETS_LIKE)
    code, stdout, err = run(capsys, "--tsai", xml, "--image-size", "480x360", "--fps", 7,
                            "-o", out)
    assert code == 0, err
    ref = camera_from_tsai(TsaiCalibration(**PETS_LIKE), image_size=(480, 360), fps=7.0)
    d = json.loads(out.read_text())["camera"]
    for k, v in ref.section.items():
        assert d[k] == pytest.approx(v, rel=1e-12), k
    assert "nearest camera of (3): max" in stdout and "lens distortion" in stdout
    assert "world -> ground" in stdout and "scaled by 0.625" in err
    read_config(out)


@pytest.mark.skipif(D.pets_root() is None, reason="PETS 2009 data absent")
def test_pets_from_its_xml_and_video_is_datasets_pets_camera(tmp_path, capsys):
    out = tmp_path / "pets.json"
    r = D.pets_root()
    code, _, err = run(capsys, "--tsai", r / "calibration" / "View_001.xml", "--video",
                       D.pets_video(), "--fps", 7, "-o", out)
    assert code == 0, err
    assert host(read_config(out).camera) == host(D.pets_camera())


def opencv_files(tmp_path, K, R, t, size, dist):
    """The same calibration as cv2.FileStorage writes it (YAML, JSON, XML) and as plain JSON."""
    rvec = cv2.Rodrigues(R)[0]
    paths = []
    for ext in ("yml", "json"):
        p = tmp_path / f"cal.{ext}"
        fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
        fs.write("camera_matrix", K)
        fs.write("distortion_coefficients", np.asarray(dist, np.float64).reshape(1, -1))
        fs.write("rvec", rvec)
        fs.write("tvec", t.reshape(3, 1))
        fs.write("image_width", size[0])
        fs.write("image_height", size[1])
        fs.release()
        paths.append(p)
    p = tmp_path / "cal.xml"  # other spellings, 1-D arrays (FileStorage's nd-matrix)
    fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
    fs.write("cameraMatrix", K)
    fs.write("distCoeffs", np.asarray(dist, np.float64))
    fs.write("R", R)
    fs.write("T", t.ravel())
    fs.write("imageSize", np.asarray(size, np.float64))
    fs.release()
    paths.append(p)
    p = tmp_path / "plain.json"
    p.write_text(json.dumps({"K": K.tolist(), "R": R.tolist(), "t": t.tolist(),
                             "dist": list(dist), "image_size": list(size)}))
    return paths + [p]


def test_opencv_files_agree_and_reproduce_cv2(tmp_path, capsys):
    rng = np.random.default_rng(11)
    K, R, t, size, _ = random_camera(rng)
    dist = [0.0] * 5
    ref = camera_from_krt(K, t, R=R, image_size=size)
    X = ground_points(K, R, t, size)
    u0, v0 = cv2_pixels(X, K, R, t)
    for p in opencv_files(tmp_path, K, R, t, size, dist):
        out = tmp_path / f"{p.name}.cam.json"
        code, stdout, err = run(capsys, "--opencv", p, "-o", out)
        assert code == 0, err
        assert "read " in err and "world -> ground" in stdout
        d = json.loads(out.read_text())["camera"]
        for k, v in ref.section.items():
            assert d[k] == pytest.approx(v, rel=1e-9, abs=1e-9), (p.name, k)
        gx, gy = ref.transform.apply(X[:, 0], X[:, 1])
        u, v = project_3d(host(read_config(out).camera), gx, gy, 0 * gx)
        assert np.hypot(u - u0, v - v0).max() < 0.01
    # the world in millimetres
    mm = tmp_path / "mm.json"
    mm.write_text(json.dumps({"K": K.tolist(), "R": R.tolist(), "t": (1000 * t).tolist()}))
    code, _, err = run(capsys, "--opencv", mm, "--world-unit", "mm", "--image-size",
                       f"{size[0]}x{size[1]}", "-o", tmp_path / "mm.cam.json")
    assert code == 0, err
    d = json.loads((tmp_path / "mm.cam.json").read_text())["camera"]
    assert d["h_m"] == pytest.approx(ref.section["h_m"], rel=1e-12)


def test_homography_and_config_base(tmp_path, capsys):
    rng = np.random.default_rng(12)
    K, R, t, size, _ = random_camera(rng)
    G = K @ np.column_stack([R[:, 0], R[:, 1], t])
    hp, base, out = tmp_path / "H.txt", tmp_path / "base.json", tmp_path / "cam.json"
    hp.write_text("\n".join(" ".join(f"{v:.17g}" for v in row) for row in np.linalg.inv(G)))
    base.write_text(json.dumps({"camera": {"f_m": 0.01, "h_m": 3.0}, "noise": {"r_corr": 0.2},
                                "thresholds": {"n_samples": 48, "p_thr": 0.3}}))
    code, stdout, err = run(capsys, "--homography", hp, "--homography-convention", "image-uv",
                            "--image-size", f"{size[0]}x{size[1]}", "--center", *K[:2, 2],
                            "--config", base, "--window-s", 3, "-o", out)
    assert code == 0, err
    d = json.loads(out.read_text())
    assert d["noise"] == {"r_corr": 0.2}
    assert d["thresholds"] == {"p_thr": 0.3, "window_s": 3.0}
    ref = camera_from_krt(K, t, R=R, image_size=size)
    for k in ("h_m", "theta_deg", "a_px_per_m", "b_px_per_m", "roll_deg", "uc_px", "vc_px"):
        assert d["camera"][k] == pytest.approx(ref.section[k], rel=1e-7, abs=1e-7), k
    assert "f_m" in d["camera"] and d["camera"]["f_m"] == 0.008  # replaced, not merged
    read_config(out)


@pytest.mark.skipif(D.eth_root() is None, reason="ETH data absent")
@pytest.mark.parametrize("name, size, line", [
    ("seq_eth", "640x480", "max 4.85 px, RMS 1.58 px"),
    ("seq_hotel", "720x576", "max 9.78 px, RMS 2.72 px")])
def test_eth_homographies(name, size, line, tmp_path, capsys):
    """seq_hotel's camera looks 82 deg down: its bottom row sees ground behind the camera's foot;
    the derived range starts at view.NEAR_FLOOR_M, so no base config is needed."""
    out = tmp_path / "eth.json"
    code, stdout, err = run(capsys, "--homography", D.eth_root() / name / "H.txt",
                            "--homography-convention", "image-rowcol", "--image-size", size,
                            "--fps", 25, "-o", out)
    assert code == 0, err
    assert f"nearest camera of (3): {line}" in stdout
    assert "detection range   " in stdout and "none" not in stdout.split("detection range")[1][:8]
    read_config(out)


def sky_json(tmp_path):
    K, R, t, size, _ = random_camera(np.random.default_rng(2), tilt_deg=-10.0)
    p = tmp_path / "sky.json"
    p.write_text(json.dumps({"K": K.tolist(), "R": R.tolist(), "t": t.tolist(),
                             "image_size": list(size)}))
    return p


@pytest.mark.parametrize("case", [
    "xml_syntax", "xml_field", "yaml_schema", "yaml_missing", "yaml_syntax", "singular",
    "h_text", "sky", "video", "both", "none", "convention", "points", "tilt_missing"])
def test_bad_input_exit_2_one_line_nothing_written(case, tmp_path, capsys):
    out = tmp_path / "cam.json"
    f = tmp_path / {"xml_syntax": "cal.xml", "xml_field": "cal.xml", "yaml_schema": "cal.yml",
                    "yaml_missing": "cal.yml", "yaml_syntax": "cal.yml", "singular": "H.txt",
                    "h_text": "H.txt", "video": "bad.avi"}.get(case, "x")
    size = ["--image-size", "640x480"]
    if case == "xml_syntax":
        f.write_text("<Camera><Geometry width='768'>\n<Intrinsic/>\n")
        argv, want = ["--tsai", f], r"cal\.xml line 3"
    elif case == "xml_field":
        write_tsai(f, PETS_LIKE)
        f.write_text(f.read_text().replace('focal="5.5549183034" ', ""))
        argv, want = ["--tsai", f], r"cal\.xml: Intrinsic\.focal: missing"
    elif case in ("yaml_schema", "yaml_missing"):
        fs = cv2.FileStorage(str(f), cv2.FILE_STORAGE_WRITE)
        fs.write("camera_matrix", np.eye(2) if case == "yaml_schema" else np.eye(3))
        fs.write("rvec", np.zeros((3, 1)))
        if case == "yaml_schema":
            fs.write("tvec", np.array([[0.0], [0.0], [5.0]]))
        fs.release()
        argv = ["--opencv", f, *size]
        want = (r"cal\.yml: camera_matrix: expected 9 numbers" if case == "yaml_schema" else
                r"cal\.yml: t: missing")
    elif case == "yaml_syntax":
        f.write_text("%YAML:1.0\n---\ncamera_matrix: [1, 2,\n")
        argv, want = ["--opencv", f, *size], r"cal\.yml line \d+: unreadable"
    elif case == "singular":
        f.write_text("1 2 3\n2 4 6\n1 1 1\n")
        argv, want = ["--homography", f, "--homography-convention", "image-uv", *size], (
            r"H\.txt: H: singular")
    elif case == "h_text":
        f.write_text("1 0 0\n0 1 x\n0 0 1\n")
        argv, want = ["--homography", f, "--homography-convention", "image-uv", *size], (
            r"H\.txt line 2: H: non-numeric")
    elif case == "sky":
        argv, want = ["--opencv", sky_json(tmp_path)], r"sky\.json: R: .*above the horizontal"
    elif case == "video":
        f.write_bytes(b"not a video at all" * 10)
        argv, want = ["--focal-px", 800, "--height", 5, "--tilt", 20, "--video", f], (
            r"bad\.avi: not a readable video")
    elif case == "both":
        argv, want = ["--focal-px", 800, "--tsai", f], r"source: give exactly one"
    elif case == "none":
        argv, want = [*size], r"source: give exactly one .*got none"
    elif case == "convention":
        argv, want = ["--homography", f, *size], r"--homography-convention: say what H maps"
    elif case == "points":
        argv, want = ["--points", f], r"--points: .*rhythmjax-fit camera"
    else:
        argv, want = ["--focal-px", 800, "--height", 5, *size], r"--tilt: required"
    code, _, err = run(capsys, *argv, "-o", out)
    assert code == 2
    line = one_line(err)
    assert line.startswith("rhythmjax camera: error: ")
    assert re.search(want, line), line
    assert not out.exists()
