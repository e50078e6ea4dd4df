"""`rhythmjax count` and its files: MOT round trip, the verb on tiny generated videos (crossing
walkers, no motion, a dense-crowd frame), exit codes and the JSON summary."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from rhythmjax.cli import main
from rhythmjax.count import CountOptions, count_frames
from rhythmjax.io import BadInput, read_table
from rhythmjax.mot import MOT_COLUMNS, read_mot, write_mot
from rhythmjax.params import config_from_dict
from rhythmjax.synth import SceneSpec, render_scene, walker

from .test_pedestrians import SMALL


CFG = config_from_dict(SMALL)


def test_mot_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    n = 40
    cols = {"frame": rng.integers(1, 20, n), "id": rng.integers(1, 6, n),
            "bb_left": rng.uniform(-20, 200, n), "bb_top": rng.uniform(-5, 100, n),
            "bb_width": rng.uniform(1, 40, n), "bb_height": rng.uniform(1, 90, n),
            "conf": rng.choice([0.5, 1.0], n), "x": rng.uniform(-5, 5, n),
            "y": rng.uniform(3, 15, n), "z": np.zeros(n)}
    p = tmp_path / "mot.txt"
    write_mot(p, cols)
    back = read_mot(p)
    order = np.lexsort((cols["id"], cols["frame"]))
    for c in MOT_COLUMNS:
        np.testing.assert_allclose(back[c], np.asarray(cols[c])[order], rtol=0, atol=5e-7)
    assert back["frame"].dtype == np.int64 and back["id"].dtype == np.int64
    first = p.read_text().splitlines()[0].split(",")
    assert len(first) == 10 and first[0].isdigit()  # no header
    # 6-column files (MOT ground truth without world position) take the defaults
    (tmp_path / "six.txt").write_text("3,2,10,20,5,8\n\n")
    six = read_mot(tmp_path / "six.txt")
    assert six["conf"][0] == 1.0 and six["x"][0] == six["y"][0] == six["z"][0] == -1.0


@pytest.mark.parametrize("text,where", [
    ("1,1,0,0,5,5,1,-1,-1,-1\n1,2,0,0,5\n", "line 2"),
    ("1,1,0,0,5,5\n0,1,0,0,5,5\n", "line 2"),
    ("1,1,a,0,5,5\n", "line 1"),
    ("1,1.5,0,0,5,5\n", "line 1"),
    ("1,1,0,0,-5,5\n", "line 1"),
])
def test_read_mot_names_file_and_line(tmp_path, text, where):
    p = tmp_path / "bad.txt"
    p.write_text(text)
    with pytest.raises(BadInput) as e:
        read_mot(p)
    assert str(p) in str(e.value) and where in str(e.value)
    with pytest.raises(BadInput, match="no such file"):
        read_mot(tmp_path / "missing.txt")


def _crossing_frames(n=72):
    a = walker(-4.0, 7.0, 0.0, start_frame=3, phase=0.1)
    b = walker(4.0, 7.6, math.pi, start_frame=3, phase=0.6, grey_torso=150, grey_legs=70)
    return render_scene(1, SceneSpec(n_frames=n, actors=(a, b), camera=CFG.camera)).frames


@pytest.fixture(scope="module")
def videos(tmp_path_factory):
    """Frame folders at 15 fps: crossing walkers, a still scene, and a still scene with a
    burst of frames where a block covers 80 % of the image (a dense crowd)."""
    root = tmp_path_factory.mktemp("count")
    cross = _crossing_frames()
    still = np.repeat(cross[:1], 30, axis=0)
    crowd = still.copy()
    crowd[10:14, 10:180, 5:250] = 230
    out = {}
    for name, frames in (("cross", cross), ("still", still), ("crowd", crowd)):
        d = root / name
        d.mkdir()
        for k, f in enumerate(frames):
            assert cv2.imwrite(str(d / f"f{k:03d}.png"), f)
        out[name] = d
    cfg = root / "small.json"
    cfg.write_text(json.dumps(SMALL))
    out["config"] = cfg
    return out


@pytest.fixture(scope="module")
def crossing_run(videos, tmp_path_factory):
    out = tmp_path_factory.mktemp("cross_out")
    rc = main(["count", str(videos["cross"]), "-c", str(videos["config"]), "-o", str(out),
               "--fps", "15", "--quiet", "--overlay", str(out / "overlay.mp4")])
    return rc, out


def test_count_cli_writes_consistent_files(crossing_run):
    rc, out = crossing_run
    assert rc == 0
    mot = read_mot(out / "mot.txt")
    tracks = read_table(out / "tracks.parquet", required=["track_id", "frame", "t", "u", "v",
                                                            "width_px", "intensity"])
    verdicts = read_table(out / "verdicts.csv", required=["track_id", "verdict", "reason"])
    counts = json.loads((out / "counts.json").read_text())
    ids = sorted(set(mot["id"].tolist()))
    assert ids == [1, 2]  # two walkers crossing, two tracks
    assert sorted(set(np.asarray(tracks["track_id"]).astype(int).tolist())) == ids
    assert sorted(np.asarray(verdicts["track_id"]).astype(int).tolist()) == ids
    c = counts["counts"]
    assert c["tracks"] == 2
    assert c["walkers"] + c["non_pedestrians"] + c["unclassified"] == 2
    assert c["walkers"] == int(np.sum(np.asarray(verdicts["verdict"]) == "pedestrian"))
    # MOT frames are 1-based video frames; the tracks file keeps the 0-based index
    assert mot["frame"].min() == np.asarray(tracks["frame"]).min() + 1
    assert np.all(mot["z"] == 0.0) and np.all((mot["y"] > 3.0) & (mot["y"] < 15.0))
    assert (out / "overlay.mp4").stat().st_size > 0


def test_classify_rejudges_the_written_tracks(crossing_run, videos, tmp_path, capsys):
    _, out = crossing_run
    rc = main(["classify", str(out / "tracks.parquet"), "-c", str(videos["config"]), "--json",
               "-o", str(tmp_path / "v.csv")])
    assert rc == 0
    again = read_table(tmp_path / "v.csv", required=["track_id", "verdict"])
    first = read_table(out / "verdicts.csv", required=["track_id", "verdict"])
    assert list(np.asarray(again["verdict"])) == list(np.asarray(first["verdict"]))


def test_no_motion_gives_zero_tracks(videos, tmp_path, capsys):
    capsys.readouterr()
    rc = main(["count", str(videos["still"]), "-c", str(videos["config"]), "-o",
               str(tmp_path), "--fps", "15", "--json"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["counts"] == {"tracks": 0, "walkers": 0, "non_pedestrians": 0,
                                 "unclassified": 0}
    assert summary["n_frames"] == 30 and summary["crowd_frames"] == 0
    assert (tmp_path / "mot.txt").read_text() == ""
    assert read_mot(tmp_path / "mot.txt")["frame"].shape == (0,)


def test_dense_crowd_frames_degrade_without_crash(videos, tmp_path, capsys):
    capsys.readouterr()
    rc = main(["count", str(videos["crowd"]), "-c", str(videos["config"]), "-o",
               str(tmp_path), "--fps", "15", "--json"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["crowd_frames"] >= 3
    assert any("dense crowd" in n for n in summary["notes"])
    assert summary["counts"]["tracks"] == 0


def test_bad_inputs_exit_2(videos, tmp_path, capsys):
    assert main(["count", str(tmp_path / "nope.mp4"), "-o", str(tmp_path / "o"),
                 "--quiet"]) == 2
    assert "nope.mp4" in capsys.readouterr().err
    bad_cfg = tmp_path / "bad.json"
    bad_cfg.write_text('{"camera": {"h_m": -1}}')
    assert main(["count", str(videos["still"]), "-c", str(bad_cfg), "-o", str(tmp_path / "o"),
                 "--fps", "15", "--quiet"]) == 2
    assert "camera.h_m" in capsys.readouterr().err
    assert main(["count", str(videos["still"]), "-c", str(videos["config"]), "-o",
                 str(tmp_path / "o"), "--fps", "15", "--min-frames", "0", "--quiet"]) == 2


def test_help_explains(capsys):
    with pytest.raises(SystemExit):
        main(["count", "--help"])
    text = capsys.readouterr().out
    for word in ("mot.txt", "tracks.parquet", "counts.json", "--dynamics", "walkers",
                 "dense crowd"):
        assert word in text


def test_missing_frames_predict_only():
    frames = _crossing_frames(40)
    items = [(k, k / 15.0, None if k in (20, 21) else f) for k, f in enumerate(frames)]
    res = count_frames(CFG, iter(items), options=CountOptions(classify=False,
                                                              online_verdicts=False))
    assert res.summary["missing_frames"] == 2
    assert res.counts["tracks"] == 2
    at = np.isin(res.mot["frame"], [21, 22])
    assert at.sum() == 4 and np.all(res.mot["conf"][at] == 0.5)  # 2 tracks x 2 frames
