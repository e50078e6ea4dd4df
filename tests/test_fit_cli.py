"""`rhythmjax-fit` in-process on files written by rhythmjax.sim.tracks (issue 5)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fit.cli import main
from rhythmjax.io import read_config, write_config, write_table
from rhythmjax.model.params import Camera, Config
from rhythmjax.sim.tracks import make_tracks


COLS = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y")
CAM = Camera(h=3.0, theta=math.radians(20.0), uc=256.0, vc=256.0)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("fitcli")
    cols, _ = make_tracks(n_walkers=12, n_bicycles=0, n_dogs=0, n_cars=0, seed=3, camera=CAM,
                          r_std_px=1.0)
    write_table(d / "fp.csv", cols, COLS)
    write_table(d / "noxy.csv", cols, COLS[:-2])
    few = {k: v[:3] for k, v in cols.items()}
    write_table(d / "few.csv", few, COLS)
    nan = dict(cols)
    nan["u"] = np.full(len(cols["u"]), np.nan)
    write_table(d / "nan.csv", nan, COLS)
    write_config(d / "c.json", Config())
    return d


def test_camera_fit_writes_config(files, capsys):
    out = files / "c2.json"
    rc = main(["camera", str(files / "fp.csv"), "--config", str(files / "c.json"), "-o",
               str(out), "--json"])
    assert rc == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["result"] == "successful" and rep["num_steps"] > 0
    assert set(rep["se"]) == {"af", "bf", "h", "theta"}
    cam = read_config(out).camera
    # 1 px noise, about 1000 footprints from the default-start config: h within 5 cm, theta
    # within 0.5 deg of the generating camera, and inside 4 reported SE
    assert abs(float(cam.h) - 3.0) < 0.05 and abs(float(cam.h) - 3.0) < 4 * rep["se"]["h"] + 1e-3
    assert abs(math.degrees(float(cam.theta)) - 20.0) < 0.5
    assert abs(rep["rms_px"] - 1.0) < 0.1


def test_camera_text_output_and_center(files, capsys):
    out = files / "c3.json"
    rc = main(["camera", str(files / "fp.csv"), "-o", str(out), "--fit-center", "--loss",
               "huber", "--image-size", "512x512"])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "uc" in text and "+-" in text and "successful" in text and "wrote" in text
    # no config: the principal point and the roll are fitted, and the camera screen follows
    assert "principal point not in the config: fitted" in text and "roll not in the config" in text
    assert "determined by the data:" in text and "horizon" in text and "detection range" in text
    assert abs(float(read_config(out).camera.h) - 3.0) < 0.1


@pytest.mark.parametrize("name, what", [("noxy.csv", "'x' and 'y'"),
                                        ("few.csv", "footprints for 6 parameters"),
                                        ("nan.csv", "no footprint with finite")])
def test_camera_bad_input_exit_2(files, capsys, name, what):
    out = files / "never.json"
    rc = main(["camera", str(files / name), "-o", str(out), "--image-size", "512x512"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert name in err and what in err
    assert not out.exists()


def test_solver_failure_exit_1_keeps_config(files, capsys):
    out = files / "keep.json"
    out.write_text("previous\n")
    rc = main(["camera", str(files / "fp.csv"), "-o", str(out), "--max-steps", "1",
               "--image-size", "512x512"])
    cap = capsys.readouterr()
    assert rc == 1
    assert "steps" in cap.out and "not written" in cap.err
    assert out.read_text() == "previous\n"


def test_noise_fit(files, capsys):
    # 40 tracks x 60 steps of the model (1)-(3) with q (0.3, 0.5) m/s/sqrt(s), r (1.5, 2.5) px,
    # written as a tracks file; from Table 1's start the fit lands within 25 % of each value.
    from fit.noise import simulate
    from rhythmjax.model.params import Noise

    true = Noise(q_std=(0.3, 0.5), r_std=(1.5, 2.5), init_speed_std=1.0)
    z, _, _, _ = simulate(CAM, true, np.random.default_rng(4), 40, 60)
    B, T = z.shape[:2]
    cols = {"track_id": np.repeat([f"w{i:02d}" for i in range(B)], T),
            "frame": np.tile(np.arange(T), B).astype(np.int64),
            "t": np.tile(np.arange(T) / CAM.fps, B), "u": z[..., 0].ravel(),
            "v": z[..., 1].ravel(), "width_px": np.full(B * T, 20.0),
            "intensity": np.full(B * T, 100.0)}
    write_table(files / "sim.csv", cols, COLS[:7])
    write_config(files / "cam.json", Config(camera=CAM, noise=Noise(init_speed_std=1.0)))
    out = files / "n2.json"
    rc = main(["noise", str(files / "sim.csv"), "--config", str(files / "cam.json"), "-o",
               str(out), "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0, rep
    assert rep["gain"] > 0 and rep["result"] == "successful" and rep["num_steps"] > 0
    noise = read_config(out).noise
    np.testing.assert_allclose(np.asarray(noise.q_std()), [0.3, 0.5], rtol=0.25)
    np.testing.assert_allclose(np.asarray(noise.r_std()), [1.5, 2.5], rtol=0.25)
    assert read_config(out).camera.h == pytest.approx(3.0)


def test_noise_bad_input_exit_2(files, capsys):
    rc = main(["noise", str(files / "nan.csv"), "-o", str(files / "never2.json")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "nan.csv" in err and "too few" in err


def test_walking_bad_input_exit_2(files, capsys):
    # fp.csv holds walkers only: one class; sim-like file without a 'label' column
    out = files / "never3.json"
    rc = main(["walking", str(files / "fp.csv"), "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert "fp.csv" in err and "one class only (pedestrian)" in err and not out.exists()
    cols, _ = make_tracks(n_walkers=2, n_bicycles=1, n_dogs=0, n_cars=0, seed=3, camera=CAM)
    write_table(files / "nolabel.csv", cols, COLS[:7])
    rc = main(["walking", str(files / "nolabel.csv"), "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "nolabel.csv" in err and "no 'label' column" in err and not out.exists()


def test_camera_fit_roll_and_world_frame(tmp_path, capsys):
    """Footprints from a rolled camera (3 deg), given in a world frame rotated by 30 deg and
    shifted by (5, -2) m: --fit-roll --world recovers h, theta and roll (1 px noise, ~1000
    points: h within 5 cm, theta and roll within 0.3 deg) and writes roll_deg."""
    cam = Camera(h=3.0, theta=math.radians(20.0), roll=math.radians(3.0))
    cols, _ = make_tracks(n_walkers=12, n_bicycles=0, n_dogs=0, n_cars=0, seed=4, camera=cam,
                          r_std_px=1.0)
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    x, y = np.asarray(cols["x"]), np.asarray(cols["y"])
    cols = dict(cols, x=c * x - s * y + 5.0, y=s * x + c * y - 2.0)
    write_table(tmp_path / "fp.csv", cols, COLS)
    out = tmp_path / "roll.json"
    rc = main(["camera", str(tmp_path / "fp.csv"), "-o", str(out), "--fit-roll", "--world",
               "--json", "--image-size", "512x512", "--image-center"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0 and {"roll", "tx", "ty", "yaw"} <= set(rep["se"])
    got = read_config(out).camera
    assert abs(float(got.h) - 3.0) < 0.05
    assert abs(math.degrees(float(got.theta)) - 20.0) < 0.3
    assert abs(math.degrees(float(got.roll)) - 3.0) < 0.3
    assert json.loads(out.read_text())["camera"]["roll_deg"] == pytest.approx(3.0, abs=0.3)


# -- issue 15: the camera verb for real users -------------------------------------------------
def _only_uvxy(files, name="uvxy.csv", scale=1.0, shift_y=0.0):
    """fp.csv reduced to the columns u, v, x, y (x, y times `scale`, y shifted)."""
    from rhythmjax.io import read_table

    t = read_table(files / "fp.csv")
    write_table(files / name, {"u": t["u"], "v": t["v"], "x": t["x"] * scale,
                               "y": (t["y"] + shift_y) * scale}, ("u", "v", "x", "y"))
    return files / name


def test_camera_from_u_v_x_y_only_with_image_size_config(files, capsys):
    # columns u, v, x, y alone; a config giving only the image size and fps: the principal point
    # and the roll are fitted (said so), b/a held at 1, and the screen follows; the config keeps
    # the fps, derives N and the detection range from the fitted camera
    from rhythmjax.model.view import visible_range

    (files / "size.json").write_text('{"camera": {"image_width_px": 512, "image_height_px": '
                                     '512, "fps": 10}}')
    out = files / "sized.json"
    rc = main(["camera", str(_only_uvxy(files)), "-c", str(files / "size.json"), "-o", str(out),
               "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0, rep
    assert rep["principal_point"] == "fitted" and set(rep["se"]) == {"af", "h", "theta", "uc",
                                                                      "vc", "roll"}
    assert "principal point not in the config: fitted" in rep["notes"]
    assert "b/a at the config's 1" in rep["held"]["bf"]
    assert set(rep["determination"]) == set(rep["se"])
    assert rep["determination"]["h"] == "determined" and rep["determination"]["af"] == "determined"
    assert rep["camera_report"]["image_size_px"] == [512, 512]
    got = read_config(out)
    assert abs(float(got.camera.h) - 3.0) < 0.05 and abs(float(got.camera.uc) - 256.0) < 3.0
    assert got.camera.fps == 10.0 and got.thresholds.n == round(64 / 15 * 10)
    near, far = visible_range(got.camera)
    assert float(got.thresholds.range_min) == pytest.approx(near, rel=1e-5)
    assert float(got.thresholds.range_max) == pytest.approx(far, rel=1e-5)


def test_camera_refuses_without_image_size_or_with_world(files, capsys):
    fp = str(_only_uvxy(files))
    rc = main(["camera", fp, "-o", str(files / "no.json")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "--image-size WxH" in err and fp in err
    rc = main(["camera", fp, "-o", str(files / "no.json"), "--world", "--image-size", "512x512"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "--image-center" in err and "uc_px" in err
    assert not (files / "no.json").exists()


def test_y_not_positive_suggests_world(files, capsys):
    fp = _only_uvxy(files, "shifted.csv", shift_y=-8.0)
    rc = main(["camera", str(fp), "-o", str(files / "no.json"), "--image-size", "512x512"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert "shifted.csv line " in err and "column 'y'" in err and "add --world" in err


@pytest.mark.parametrize("unit, factor, word", [("cm", 100.0, "centimetres"),
                                                ("mm", 1000.0, "millimetres")])
def test_units_warning_and_units_flag(files, capsys, unit, factor, word):
    fp = _only_uvxy(files, f"in_{unit}.csv", scale=factor)
    args = ["camera", str(fp), "-c", str(files / "c.json")]
    rc = main(args + ["-o", str(files / f"{unit}_raw.json")])
    cap = capsys.readouterr()
    warn = [ln for ln in cap.err.splitlines() if "warning" in ln]
    assert len(warn) == 1 and word in warn[0] and f"--units {unit}" in warn[0]
    # h 300 m is written (with the warning); h 3 km is beyond the fit's domain (exit 1)
    assert rc == (0 if unit == "cm" else 1)
    rc = main(args + ["-o", str(files / f"{unit}.json"), "--units", unit])
    cap = capsys.readouterr()
    assert rc == 0 and "warning" not in cap.err
    assert abs(float(read_config(files / f"{unit}.json").camera.h) - 3.0) < 0.05


def test_random_cameras_from_the_command_line(tmp_path, capsys):
    # 2 random cameras of the acceptance generator; the CLI with a config giving only the image
    # size and fps; held-out RMS (px per coordinate) within 10 % of the 1 px noise and of the
    # true camera's on the same points (`python -m fit.random_cameras` runs 20)
    from fit.random_cameras import footprints, only_size, random_camera, rms
    from rhythmjax.model.camera_np import project_3d

    rng = np.random.default_rng(21)
    for k in range(2):
        cam = random_camera(rng)
        fp = footprints(cam, rng)
        test = fp.walker % 2 == 1
        write_table(tmp_path / "fp.csv", {"u": fp.u[~test], "v": fp.v[~test], "x": fp.x[~test],
                                          "y": fp.y[~test]}, ("u", "v", "x", "y"))
        size = (int(cam.image_width), int(cam.image_height))
        (tmp_path / "c.json").write_text(json.dumps(only_size(size, 25.0)))
        rc = main(["camera", str(tmp_path / "fp.csv"), "-c", str(tmp_path / "c.json"), "-o",
                   str(tmp_path / f"c{k}.json")])
        assert rc == 0, capsys.readouterr()
        got = read_config(tmp_path / f"c{k}.json").camera
        pu, pv = project_3d(got, fp.x[test], fp.y[test], 0.0)
        tu, tv = project_3d(cam, fp.x[test], fp.y[test], 0.0)
        fit_rms, true_rms = rms(pu - fp.u[test], pv - fp.v[test]), rms(tu - fp.u[test],
                                                                       tv - fp.v[test])
        assert fit_rms < 1.1 and fit_rms < 1.1 * true_rms, (fit_rms, true_rms)
