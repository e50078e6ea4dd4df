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
               "huber"])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "uc" in text and "+-" in text and "successful" in text and "wrote" in text
    assert abs(float(read_config(out).camera.h) - 3.0) < 0.1


@pytest.mark.parametrize("name, what", [("noxy.csv", "'x' and 'y'"),
                                        ("few.csv", "footprints for 4 parameters"),
                                        ("nan.csv", "no footprint with finite")])
def test_camera_bad_input_exit_2(files, capsys, name, what):
    out = files / "never.json"
    rc = main(["camera", str(files / name), "-o", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert name in err and what in err
    assert not out.exists()


def test_solver_failure_exit_1_keeps_config(files, capsys):
    out = files / "keep.json"
    out.write_text("previous\n")
    rc = main(["camera", str(files / "fp.csv"), "-o", str(out), "--max-steps", "1"])
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
               "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0 and {"roll", "tx", "ty", "yaw"} <= set(rep["se"])
    got = read_config(out).camera
    assert abs(float(got.h) - 3.0) < 0.05
    assert abs(math.degrees(float(got.theta)) - 20.0) < 0.3
    assert abs(math.degrees(float(got.roll)) - 3.0) < 0.3
    assert json.loads(out.read_text())["camera"]["roll_deg"] == pytest.approx(3.0, abs=0.3)
