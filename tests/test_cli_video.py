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
    for name in ("tracks.parquet", "verdicts.csv", "truth.csv", "spectra.png"):
        assert (out / name).stat().st_size > 0, name
    assert not any(p.name.startswith(".") or ".tmp" in p.name for p in out.iterdir())


def test_run_tracks_the_walker_of_a_video(walker_avi, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", walker_avi, "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n_frames"] == 70 and summary["n_tracks"] >= 1
    assert (out / "overlay.mp4").stat().st_size > 0 and (out / "verdicts.csv").exists()


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
    assert main(["run", walker_avi, "-o", str(tmp_path / "a"), "--fps", "0"]) == 2
    assert "fps" in _one_line(capsys)
    cfg = tmp_path / "up.json"  # looking up: the 3-20 m range projects above the image
    cfg.write_text(json.dumps({"camera": {"vc_px": -2000}}))
    assert main(["run", walker_avi, "-o", str(tmp_path / "b"), "--config", str(cfg)]) == 2
    assert "detection range" in _one_line(capsys)
    assert not (tmp_path / "b" / "verdicts.csv").exists()


def test_unwritable_output_exits_2(walker_avi, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["run", walker_avi, "-o", str(blocker / "sub")]) == 2
    assert "sub" in _one_line(capsys)
    assert main(["track", walker_avi, "-o", str(blocker / "t.csv")]) == 2
    assert "t.csv" in _one_line(capsys)
