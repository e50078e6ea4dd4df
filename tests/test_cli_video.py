"""The video verbs (`demo`, `run`, `track`) end to end on small synthetic clips, and their bad
inputs: one line naming the file or key, exit code 2, nothing written."""

from __future__ import annotations

import json
import os

import cv2
import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.model.params import Config
from rhythmjax.sim import scene as synth


@pytest.fixture(scope="module")
def walker_avi(tmp_path_factory):
    """A 70-frame MJPG clip of one walker crossing at 10 m (the paper's camera, 15 fps)."""
    act = synth.walker(-3.0, 10.0, 0.0, pace_hz=2.0, step_length_m=0.7)
    scene = synth.render_scene(5, synth.SceneSpec(n_frames=70, actors=(act,),
                                                  camera=Config().camera))
    path = str(tmp_path_factory.mktemp("clip") / "walker.avi")
    w = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (512, 512), False)
    for f in scene.frames:
        w.write(f)
    w.release()
    return path


def _usage_error(argv, capsys) -> str:
    """The last stderr line of an argument refused by argparse (exit 2, before any work)."""
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return err.strip().splitlines()[-1]


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


def test_demo_writes_its_outputs_and_a_json_summary(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "--frames", "40", "--no-overlay", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n_frames"] == 40 and summary["output"] == str(out)
    assert {o["kind"] for o in summary["objects"]} == {"pedestrian", "bicycle", "dog"}
    for name in ("tracks.parquet", "verdicts.csv", "truth.csv", "spectra.png", "spectra.pdf",
                 "report.html"):
        assert (out / name).stat().st_size > 0, name
    assert not any(p.name.startswith(".") or ".tmp" in p.name for p in out.iterdir())


def test_run_tracks_the_walker_of_a_video(walker_avi, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", walker_avi, "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n_frames"] == 70 and summary["n_tracks"] >= 1
    assert (out / "overlay.mp4").stat().st_size > 0 and (out / "verdicts.csv").exists()
    # a browser-playable overlay instead: the mp4 of the previous set goes, the report links it
    assert main(["run", walker_avi, "-o", str(out), "--overlay-format", "webm", "-q"]) == 0
    assert not (out / "overlay.mp4").exists()
    webm = cv2.VideoCapture(str(out / "overlay.webm"))
    n = 0
    while webm.read()[0]:
        n += 1
    assert n == 70
    page = (out / "report.html").read_text()
    assert 'src="overlay.webm"' in page and "MPEG-4 part 2" not in page


def test_track_writes_the_tracks_file(walker_avi, tmp_path, capsys):
    from rhythmjax.io import read_tracks

    out = tmp_path / "tracks.csv"
    assert main(["track", walker_avi, "-o", str(out), "--quiet"]) == 0
    tr = read_tracks(str(out))
    assert len(np.unique(tr.track_id)) >= 1 and np.isfinite(tr.u).sum() > 30


@pytest.mark.parametrize("verb", ["run", "track"])
def test_missing_and_empty_videos_exit_2_naming_the_file(verb, tmp_path, capsys):
    empty = tmp_path / "empty.mp4"
    empty.write_bytes(b"")
    for path in (str(tmp_path / "nope.mp4"), str(empty)):
        out = tmp_path / ("o" if verb == "run" else "o.csv")
        assert main([verb, path, "-o", str(out)]) == 2
        assert os.path.basename(path) in _one_line(capsys)
        assert not (out / "verdicts.csv").exists() if verb == "run" else not out.exists()


def test_fps_zero_and_a_camera_that_misses_the_image_exit_2(walker_avi, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:  # refused by argparse, before any work
        main(["run", walker_avi, "-o", str(tmp_path / "a"), "--fps", "0"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "argument --fps: 0 frames/s is not a video's frame rate" in err.splitlines()[-1], err
    assert "Traceback" not in err and not (tmp_path / "a").exists()
    cfg = tmp_path / "up.json"  # looking up: the given 3-20 m range projects above the image
    cfg.write_text(json.dumps({"camera": {"vc_px": -2000},
                               "thresholds": {"range_min_m": 3, "range_max_m": 20}}))
    assert main(["run", walker_avi, "-o", str(tmp_path / "b"), "--config", str(cfg)]) == 2
    assert "detection range" in _one_line(capsys)
    assert not (tmp_path / "b" / "verdicts.csv").exists()
    # the horizon below the image: no range can be derived; the line names the key and the fix
    cfg.write_text(json.dumps({"camera": {"vc_px": 2000}}))
    assert main(["run", walker_avi, "-o", str(tmp_path / "c"), "--config", str(cfg)]) == 2
    line = _one_line(capsys)
    assert "up.json" in line and "range_min_m" in line and "rhythmjax camera" in line, line
    assert not (tmp_path / "c").exists() or not (tmp_path / "c" / "verdicts.csv").exists()


def test_unwritable_output_exits_2(walker_avi, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["run", walker_avi, "-o", str(blocker / "sub")]) == 2
    assert "sub" in _one_line(capsys)
    assert main(["track", walker_avi, "-o", str(blocker / "t.csv")]) == 2
    assert "t.csv" in _one_line(capsys)


def test_one_fps_rule_and_the_image_size_follow_the_video(walker_avi, tmp_path, capsys):
    """--fps > the config's camera.fps > the container's (15 here), with a note when they
    disagree; the config's image size, when it differs from the video's, is replaced by it with
    a warning; the tracks' times follow the rate used."""
    import pandas as pd

    cfg = tmp_path / "c.json"
    cfg.write_text(json.dumps({"camera": {"fps": 10}}))
    out = tmp_path / "t.csv"
    assert main(["track", walker_avi, "-o", str(out), "--config", str(cfg), "--json"]) == 0
    err = capsys.readouterr().err
    assert "fps 10 used (the config's camera.fps); the file says 15" in err, err
    t = pd.read_csv(out).groupby("track_id")["t"].apply(lambda s: s.diff().median())
    assert np.allclose(t, 0.1)
    assert main(["track", walker_avi, "-o", str(out), "--config", str(cfg), "--fps", "20",
                 "--json"]) == 0
    err = capsys.readouterr().err
    assert "--fps 20 overrides the config's camera.fps 10" in err, err
    t = pd.read_csv(out).groupby("track_id")["t"].apply(lambda s: s.diff().median())
    assert np.allclose(t, 0.05)
    cfg.write_text(json.dumps({"camera": {"image_width_px": 320, "image_height_px": 240},
                               "thresholds": {"range_min_m": 3, "range_max_m": 20}}))
    assert main(["track", walker_avi, "-o", str(out), "--config", str(cfg), "--json"]) == 0
    err = capsys.readouterr().err
    assert "warning: the config's image size 320x240 is not the video's 512x512" in err, err


def test_max_objects_is_settable(walker_avi, tmp_path, capsys):
    out = tmp_path / "t.csv"
    line = _usage_error(["track", walker_avi, "-o", str(out), "--max-objects", "0"], capsys)
    assert "argument --max-objects: 0 is not a whole number >= 1" in line
    assert main(["track", walker_avi, "-o", str(out), "--max-objects", "2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_tracks"] >= 1


def test_a_camera_wrong_for_the_video_is_said_before_the_run(walker_avi, tmp_path, capsys):
    """The walker crosses 10 m ahead of the paper's camera; a detection range of 3-6 m misses
    it: one warning line naming the fixing command, before the run, which goes on."""
    out = tmp_path / "t.csv"
    assert main(["track", walker_avi, "-o", str(out), "--json"]) == 0
    assert "warning" not in capsys.readouterr().err
    cfg = tmp_path / "near.json"
    cfg.write_text(json.dumps({"thresholds": {"range_min_m": 3.0, "range_max_m": 6.0}}))
    assert main(["track", walker_avi, "-o", str(out), "-c", str(cfg), "--json"]) == 0
    warn = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning")]
    assert len(warn) == 1 and "camera check" in warn[0] and "rhythmjax camera" in warn[0]
    assert "outside the detection range 3.0-6.0 m" in warn[0], warn[0]
    assert main(["track", walker_avi, "-o", str(out), "-c", str(cfg), "--json",
                 "--no-camera-check"]) == 0
    assert "camera check" not in capsys.readouterr().err


def test_all_tracks_too_short_gives_the_window_hint(walker_avi, tmp_path, capsys):
    cfg = tmp_path / "long.json"
    cfg.write_text(json.dumps({"thresholds": {"window_s": 10.0}}))  # 150 samples > 70 frames
    assert main(["run", walker_avi, "-o", str(tmp_path / "o"), "-c", str(cfg), "--no-overlay",
                 "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert any("window_s" in n and "N = 150" in n for n in summary["notes"]), summary["notes"]


def test_walkers_refused_as_too_low_give_the_camera_hint(tmp_path, capsys):
    """A walker crossing at 18 m (its head inside the image of the paper's camera): with the
    size rule at 2 walker heights (3.4 m, taller than anyone) its Pedestrian track is refused
    too-low, and the summary names the camera and the option; at the default (0.5) no such
    note."""
    act = synth.walker(-3.4, 18.0, 0.0, pace_hz=1.9, step_length_m=0.62)
    scene = synth.render_scene(3, synth.SceneSpec(n_frames=120, actors=(act,),
                                                  camera=Config().camera))
    clip = str(tmp_path / "far.avi")
    w = cv2.VideoWriter(clip, cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (512, 512), False)
    for f in scene.frames:
        w.write(f)
    w.release()
    out = tmp_path / "o"
    assert main(["run", clip, "-o", str(out), "--no-overlay", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["verdicts"]["pedestrian"] >= 1
    assert not any("too-low" in n for n in summary.get("notes", []))
    assert main(["run", clip, "-o", str(out), "--no-overlay", "--json",
                 "--set", "size.min_height_heights=2.0"]) == 0
    summary = json.loads(capsys.readouterr().out)
    notes = [n for n in summary["notes"] if "too-low" in n]
    assert summary["verdicts"]["pedestrian"] == 0 and len(notes) == 1, summary
    assert "size.min_height_heights=0" in notes[0] and "camera" in notes[0]


def test_fps_on_the_command_line_applies_before_the_config_is_checked(walker_avi, tmp_path,
                                                                      capsys):
    """A window of 1.07 s is N = 16 at the config's default 15 fps (< AR order 15 + 2) but N =
    32 at --fps 30: the check uses the rate that will run. A frame rate no video has is refused
    naming --fps."""
    cfg = tmp_path / "w.json"
    cfg.write_text(json.dumps({"thresholds": {"window_s": 1.067}}))
    out = tmp_path / "t.csv"
    assert main(["track", walker_avi, "-o", str(out), "-c", str(cfg), "--fps", "30",
                 "--json", "--no-camera-check"]) == 0
    capsys.readouterr()
    for bad in ("1e-6", "1e9"):
        line = _usage_error(["track", walker_avi, "-o", str(out), "--fps", bad], capsys)
        assert line.startswith("rhythmjax track: error: argument --fps:"), line


def test_no_stabilise_gives_the_same_tracks_on_a_fixed_camera(walker_avi, tmp_path, capsys):
    """The fixed camera of `walker_avi`: shake compensation on (the default) or off
    (`--no-stabilise`) writes identical tracks (the screen leaves every frame as it is)."""
    import pyarrow.parquet as pq

    a, b = tmp_path / "on.parquet", tmp_path / "off.parquet"
    assert main(["track", walker_avi, "-o", str(a), "--quiet"]) == 0
    assert main(["track", walker_avi, "-o", str(b), "--quiet", "--no-stabilise"]) == 0
    assert pq.read_table(a).equals(pq.read_table(b))
