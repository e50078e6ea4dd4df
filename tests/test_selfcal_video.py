"""`rhythmjax-fit selfcal VIDEO` (`fit.selfcal_video`): track a video, fit, track again, fit.

Reference: a clip the project renders itself (`rhythmjax.sim.scene.random_spec` seed 0: 10
walkers, no bicycle or dog, 300 frames at 15 fps, 512x512), seen by Table 1's camera (h 1 m,
tilt 15 deg, a f 800 px), which is also the rough start camera the command builds from the
video's image size and frame rate. Tolerances: h within 15 % and the tilt within 3 deg of that
camera (measured when written, with `--outliers`: h 0.94 m, tilt 14.5 deg, a f 812 px after two
rounds; seven walkers with a clear gait peak, so the fit is loose: SEs 5 %, 1.5 deg). Without
`--outliers` the first round gives h 1.10 m, tilt 13.6 deg, a f 908 px and the second, tracked
with that camera, collapses (tilt 63.5 +- 2.9 deg), which the rounds' agreement check refuses:
the end-to-end test uses `--outliers`, the check is tested on its own."""

from __future__ import annotations

import json

import cv2
import pytest

from fit.cli import main as fit_main
from fit.selfcal_video import ROUNDS_AGREE_SE, is_video, rounds_disagree
from rhythmjax.io import read_tracks
from rhythmjax.sim import scene as synth


@pytest.fixture(scope="module")
def walkers_avi(tmp_path_factory):
    """The module doc's clip, written as grey MJPG."""
    spec = synth.random_spec(0, n_walkers=10, n_bicycles=0, n_dogs=0, n_frames=300)
    frames = synth.render_scene(0, spec).frames
    path = str(tmp_path_factory.mktemp("clip") / "walkers.avi")
    w = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (512, 512), False)
    for f in frames:
        w.write(f)
    w.release()
    return path


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


def test_inputs_are_videos_by_their_extension():
    assert all(is_video(f"a{s}") for s in (".avi", ".MP4", ".mov", ".mkv", ".m4v", ".mpg",
                                            ".WebM"))
    assert not any(is_video(f"a{s}") for s in (".csv", ".parquet", ".avi.csv", ""))


def test_rounds_that_disagree_beyond_their_errors_are_refused():
    """By hand: SEs 0.3 m, 1 deg, 40 px in each round, so the combined SE is sqrt(2) of each."""
    from types import SimpleNamespace as NS

    se = {"h": 0.3, "theta": 1.0, "af": 40.0}
    one = NS(values={"h": 6.0, "theta": 14.0, "af": 800.0}, se=se)
    near = NS(values={"h": 6.0 + 0.3 * 2**0.5 * (ROUNDS_AGREE_SE - 0.1), "theta": 16.0,
                      "af": 760.0}, se=se)
    assert rounds_disagree(one, near) is None
    far = NS(values={"h": 6.0, "theta": 14.0 + 2**0.5 * (ROUNDS_AGREE_SE + 0.1), "af": 800.0},
             se=se)
    why = rounds_disagree(one, far)
    assert why is not None and "theta 14 -> 18.4 deg" in why and "h 6" not in why, why
    exact = NS(values=one.values, se={})  # no SEs: only equal values agree
    assert rounds_disagree(exact, exact) is None
    assert "af 800 -> 801 px" in rounds_disagree(exact, NS(values={**one.values, "af": 801.0},
                                                             se={}))


def test_a_video_is_tracked_fitted_and_tracked_again(walkers_avi, tmp_path, capsys):
    out, tracks = tmp_path / "cam.json", tmp_path / "last.parquet"
    rc = fit_main(["selfcal", walkers_avi, "-o", str(out), "--tracks-out", str(tracks),
                   "--json", "--outliers"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    s = json.loads(captured.out)
    assert s["written"] == str(out) and s["tracks_out"] == str(tracks)
    assert [r["round"] for r in s["rounds"]] == [1, 2]
    first, second = s["rounds"]
    assert first["tracking_camera"]["h"] == pytest.approx(1.0)  # Table 1's, the rough start
    assert second["tracking_camera"]["h"] == pytest.approx(first["values"]["h"])
    assert s["values"] == pytest.approx(second["values"])
    assert "round 1 of 2" in captured.err and "round 2 of 2" in captured.err
    cam = json.loads(out.read_text())["camera"]
    assert (cam["image_width_px"], cam["image_height_px"], cam["fps"]) == (512, 512, 15.0)
    assert cam["h_m"] == pytest.approx(1.0, rel=0.15)
    assert cam["theta_deg"] == pytest.approx(15.0, abs=3.0)
    tr = read_tracks(tracks)
    assert len(tr.ids) == second["n_tracks_written"] and tr.v_top is not None


@pytest.mark.parametrize("name, content, message", [
    ("missing.mp4", None, "no such file"),
    ("garbage.avi", b"not a video", "not a readable video"),
])
def test_a_bad_video_exits_2_naming_the_file(tmp_path, capsys, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    out = tmp_path / "cam.json"
    assert fit_main(["selfcal", str(path), "-o", str(out)]) == 2
    err = _one_line(capsys)
    assert str(path) in err and message in err, err
    assert not out.exists()


def test_video_only_options_are_refused_on_the_wrong_input(walkers_avi, tmp_path, capsys):
    out = tmp_path / "cam.json"
    assert fit_main(["selfcal", walkers_avi, "-o", str(out), "--image-size", "640x480"]) == 2
    assert "--image-size" in _one_line(capsys)
    t = tmp_path / "t.csv"
    t.write_text("track_id,frame,t,u,v,width_px,intensity\n1,0,0,1,1,1,1\n")
    assert fit_main(["selfcal", str(t), "-o", str(out), "--tracks-out",
                     str(tmp_path / "x.csv")]) == 2
    assert "--tracks-out" in _one_line(capsys)
    assert not out.exists()
