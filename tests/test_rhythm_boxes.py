"""The rhythm signal at given boxes (`track.boxes`) and the `rhythm` verb: I(k) against an
independent float64 loop, MOT boxes to foot points, a rendered walker and dog judged from their
truth boxes, and bad input (one line naming the file, exit 2, nothing written)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.io import BadInput, Tracks, read_table, to_batch
from rhythmjax.io.mot import read_mot_numbered
from rhythmjax.model.batch import classify_tracks
from rhythmjax.model.params import Config
from rhythmjax.sim import scene as synth
from rhythmjax.track.boxes import box_intensities, foot_points, tracks_from_mot, window_widths

from .helpers import write_clip_and_truth_boxes


def _loop_intensity(prev, cur, u, v, W):
    """Window B by its definition, in plain float64 loops: round(W) columns centred on u
    (first column floor(u - round(W)/2 + 0.5)), round(W/5) rows whose last is round(v), round
    = floor(x + 0.5), clipped to the image; the sum of |cur - prev|."""
    H, Wd = cur.shape
    wb, hb = max(1, math.floor(W + 0.5)), max(1, math.floor(W / 5 + 0.5))
    c0, r1 = math.floor(u - wb / 2 + 0.5), math.floor(v + 0.5)
    s = 0.0
    for r in range(r1 - hb + 1, r1 + 1):
        for c in range(c0, c0 + wb):
            if 0 <= r < H and 0 <= c < Wd:
                s += abs(float(cur[r, c]) - float(prev[r, c]))
    return s


def test_intensity_matches_a_float64_loop_on_drawn_frames():
    rng = np.random.default_rng(3)
    # grey 100 plus 0-11: every pixel changes, by less than the motion threshold (no glitch)
    frames = [(100 + rng.integers(0, 12, (48, 64))).astype(np.uint8) for _ in range(4)]
    frames.append(frames[-1].copy())  # frame 4 duplicates frame 3: no sample
    frames.append(None)  # frame 5 does not decode
    frames.append((100 + rng.integers(0, 12, (48, 64))).astype(np.uint8))  # 6: predecessor None
    # rows: (frame, u, v, W); clipped at the left, bottom and right edges; fractional positions
    rows = [(0, 20.0, 30.0, 10.0), (1, 20.0, 30.0, 10.0), (1, 0.7, 47.0, 12.6),
            (2, 61.4, 10.49, 7.5), (2, 33.5, 20.5, 15.4), (3, 5.0, 5.0, 4.0),
            (3, 40.0, 44.0, float("nan")), (4, 20.0, 30.0, 10.0), (5, 20.0, 30.0, 10.0),
            (6, 20.0, 30.0, 10.0), (3, 64.2, 20.0, 10.0)]
    f, u, v, W = (np.asarray(c) for c in zip(*rows))
    stream = ((i, i / 15.0, g) for i, g in enumerate(frames))
    sig = box_intensities(stream, f, u, v, W)
    for k, (fr, uu, vv, ww) in enumerate(rows):
        if fr in (0, 4, 5, 6) or not math.isfinite(ww) or uu >= 63.5:
            assert math.isnan(sig.intensity[k]), k  # first, duplicate, bad, outside the image
        else:
            ref = _loop_intensity(frames[fr - 1], frames[fr], uu, vv, ww)
            assert ref > 0 and sig.intensity[k] == ref, k  # integer sums: exact
    assert sig.glitch == [4] and sig.bad == [5] and sig.n_frames == 7


def test_foot_points_of_a_drawn_box_and_scaled_boxes():
    img = np.zeros((60, 40), np.uint8)
    img[20:50, 10:16] = 255  # columns 10..15, rows 20..49
    ys, xs = np.nonzero(img)
    u, v = foot_points(10, 20, 6, 30)
    assert u == pytest.approx((xs.min() + xs.max()) / 2, abs=1e-12) and v == ys.max()
    u2, v2 = foot_points(5, 10, 3, 15, scale=2.0)
    assert (u2, v2) == (u, v)


def test_mot_boxes_one_based_scaled_and_sorted(tmp_path):
    p = tmp_path / "gt.txt"
    p.write_text("2,7,10,20,6,30,1,-1,-1,-1\n\n1,7,10,20,6,30,1,-1,-1,-1\n1,3,0,0,4,10,0.9\n")
    mot = read_mot_numbered(p)
    assert mot["line"].tolist() == [1, 3, 4]
    tr = tracks_from_mot(mot, str(p), fps=10.0, scale=0.5)
    assert tr.track_id.tolist() == ["3", "7", "7"] and tr.frame.tolist() == [0, 0, 1]
    assert tr.t.tolist() == [0.0, 0.0, 0.1] and tr.line.tolist() == [4, 3, 1]
    np.testing.assert_allclose(tr.u, [1 - 0.5, 6.5 - 0.5, 6.5 - 0.5])
    np.testing.assert_allclose(tr.v, [5 - 1, 25 - 1, 25 - 1])
    np.testing.assert_allclose(tr.width_px, [2, 3, 3])
    assert tracks_from_mot(mot, str(p), fps=10.0, frame_base=0).frame.tolist() == [1, 1, 2]
    p.write_text("1,7,10,20,6,30\n1,7,11,20,6,30\n")
    with pytest.raises(BadInput, match=r"gt.txt line 2: a second box for id 7 in frame 1"):
        tracks_from_mot(read_mot_numbered(p), str(p), fps=10.0)


# ----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def scene():
    """110 frames at 15 fps (the default camera): a walker crossing at 13 m (2.0 Hz, 0.6 m) and
    a trotting dog at 8 m the other way."""
    acts = (synth.walker(-4.0, 13.0, 0.0, pace_hz=2.0, step_length_m=0.6),
            synth.dog(2.5, 8.0, math.pi, pace_hz=4.0, step_length_m=0.2))
    return synth.render_scene(3, synth.SceneSpec(n_frames=110, actors=acts,
                                                 camera=Config().camera))


def test_walker_and_dog_judged_from_their_truth_boxes(scene):
    cfg = Config()
    c = synth.scene_to_tracks_truth(scene)
    W = window_widths(cfg, c["u"], c["v"])
    sig = box_intensities(((i, i / scene.fps, g) for i, g in enumerate(scene.frames)),
                          c["frame"], c["u"], c["v"], W)
    assert np.isfinite(sig.intensity).sum() >= len(c["frame"]) - 2  # all but the first frames
    tr = Tracks(path="truth", track_id=c["track_id"].astype(object), frame=c["frame"], t=c["t"],
                u=c["u"], v=c["v"], width_px=c["width_px"], intensity=sig.intensity,
                line=np.arange(len(c["t"])) + 2, fps=scene.fps)
    v = classify_tracks(cfg, to_batch(tr, max_gap_frames=15, min_len=64), progress=False)
    got = dict(zip(v["track_id"], v["verdict"]))
    assert got["ped000"] == "pedestrian" and got["dog001"] != "pedestrian"
    assert v["pace_hz"][list(v["track_id"]).index("ped000")] == pytest.approx(2.0, abs=0.1)


@pytest.fixture(scope="module")
def clip(scene, tmp_path_factory):
    """The scene as an MJPG clip and its truth as MOT boxes (1-based frames; boxes 3 W tall
    ending at the true foot row)."""
    return write_clip_and_truth_boxes(scene, tmp_path_factory.mktemp("rhythm"))


def test_rhythm_verb_on_mot_boxes(clip, tmp_path, capsys):
    video, gt = clip
    out = tmp_path / "out"
    assert main(["rhythm", video, "--boxes", str(gt), "-o", str(out), "--json",
                 "--no-camera-check"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n_tracks"] == 2 and summary["frames_read"] > 64  # to the last box
    v = read_table(out / "verdicts.csv", ["track_id", "verdict"])
    got = dict(zip(v["track_id"].astype(str), v["verdict"]))
    assert got["1"] == "pedestrian" and got["2"] != "pedestrian"
    t = read_table(out / "tracks.parquet", ["frame", "intensity"])
    assert t["frame"].min() == 0 and np.isfinite(t["intensity"]).sum() >= len(t["frame"]) - 2


def _bad(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    for w in words:
        assert w in err, err


def test_bad_boxes_and_video_exit_2_and_write_nothing(clip, tmp_path, capsys):
    video, _ = clip
    out = tmp_path / "out"
    bad = tmp_path / "bad.txt"
    bad.write_text("1,1,10,20,6,30\n2,1,10,x,6,30\n")
    _bad(capsys, ["rhythm", video, "--boxes", str(bad), "-o", str(out), "--no-camera-check"],
         "bad.txt line 2", "bb_top")
    bad.write_text("1,1,10,20,6,30\n2,1,600,20,6,30\n")
    _bad(capsys, ["rhythm", video, "--boxes", str(bad), "-o", str(out), "--no-camera-check"],
         "bad.txt line 2", "outside the 512x512 image")
    bad.write_text("1,1,10,20,6,30\n500,1,10,20,6,30\n")
    _bad(capsys, ["rhythm", video, "--boxes", str(bad), "-o", str(out), "--no-camera-check"],
         "bad.txt line 2", "past the video's last")
    novideo = tmp_path / "none.avi"
    novideo.write_bytes(b"not a video")
    _bad(capsys, ["rhythm", str(novideo), "--boxes", str(bad), "-o", str(out)], "none.avi")
    _bad(capsys, ["rhythm", video, "--boxes", str(bad), "-o", str(out), "--box-scale", "0"],
         "--box-scale")
    assert not out.exists()
