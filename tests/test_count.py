"""`rhythmjax count` and its files: MOT round trip, the verb on tiny generated videos (crossing
walkers, no motion, a dense-crowd frame), exit codes and the JSON summary."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.count import CountOptions, count_frames
from rhythmjax.count.options import StitchOptions
from rhythmjax.io import BadInput, read_table
from rhythmjax.io.mot import MOT_COLUMNS, read_mot, write_mot
from rhythmjax.model.params import config_from_dict
from rhythmjax.sim.scene import SceneSpec, render_scene, walker
from rhythmjax.track.rows import TrackRow

from .test_pedestrians import FAST, QUIET, SMALL


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
    verdicts = read_table(out / "verdicts.csv", required=["track_id", "verdict", "reason",
                                                            "too_fast", "counted",
                                                            "track_speed_mps", "width_m",
                                                            "width_ok"])
    counts = json.loads((out / "counts.json").read_text())
    ids = sorted(set(mot["id"].tolist()))
    assert ids == [1, 2]  # two walkers crossing, two tracks
    assert sorted(set(np.asarray(tracks["track_id"]).astype(int).tolist())) == ids
    assert sorted(np.asarray(verdicts["track_id"]).astype(int).tolist()) == ids
    c = counts["counts"]
    assert c["tracks"] == 2
    assert c["pedestrians"] + c["non_pedestrians"] + c["unclassified"] == 2
    assert c["pedestrians"] == int(np.sum(np.asarray(verdicts["verdict"]) == "pedestrian"))
    assert c["walkers"] == 2 - int(np.sum(np.asarray(verdicts["verdict"]) == "non-pedestrian")) \
        - c["too_fast"]
    assert sum(str(x).lower() == "true" for x in verdicts["counted"]) == c["walkers"]
    assert c["walkers_low"] <= c["walkers"] <= c["walkers_high"]
    assert c["walkers_low"] == c["pedestrians"]
    assert c["walkers_high"] == c["pedestrians"] + c["unclassified"]
    # the drawn walkers go 2.05 Hz x 0.72 m = 1.476 m/s: the speed guess within 10 %; a width
    assert np.allclose(np.asarray(verdicts["track_speed_mps"], float), 1.476, rtol=0.1)
    assert np.all(np.isfinite(np.asarray(verdicts["width_m"], float)))
    assert "unclassified" in counts["count_rule"]
    # MOT frames are 1-based video frames; the tracks file keeps the 0-based index
    assert mot["frame"].min() == np.asarray(tracks["frame"]).min() + 1
    assert np.all(mot["z"] == 0.0) and np.all((mot["y"] > 3.0) & (mot["y"] < 15.0))
    assert (out / "overlay.mp4").stat().st_size > 0
    page = (out / "report.html").read_text()  # one table row per verdict, the overlay linked
    body = page.split('id="verdicts"', 1)[1].split("</tbody>", 1)[0]
    assert body.count("<tr>") - 1 == len(ids)  # the header row, then one row per track
    assert 'src="overlay.mp4"' in page and "data:image/jpeg;base64," in page


def test_classify_rejudges_the_written_tracks(crossing_run, videos, tmp_path, capsys):
    """`classify` with count's rules (rule 56 off in count's verdicts: `--no-stride-peak`)
    gives count's verdicts again; with its own default (rule 56 on) a verdict may differ only
    where rule 56 reads the window (reason matched-stride)."""
    _, out = crossing_run
    first = read_table(out / "verdicts.csv", required=["track_id", "verdict"])
    for flags, name in ((["--no-stride-peak"], "v.csv"), ([], "default.csv")):
        rc = main(["classify", str(out / "tracks.parquet"), "-c", str(videos["config"]),
                   "--json", "-o", str(tmp_path / name), *flags])
        assert rc == 0
    again = read_table(tmp_path / "v.csv", required=["track_id", "verdict"])
    assert list(np.asarray(again["verdict"])) == list(np.asarray(first["verdict"]))
    default = read_table(tmp_path / "default.csv", required=["track_id", "verdict", "reason"])
    moved = np.asarray(default["verdict"]) != np.asarray(first["verdict"])
    assert set(np.asarray(default["reason"])[moved]) <= {"matched-stride"}


def test_no_motion_gives_zero_tracks(videos, tmp_path, capsys):
    capsys.readouterr()
    rc = main(["count", str(videos["still"]), "-c", str(videos["config"]), "-o",
               str(tmp_path), "--fps", "15", "--json"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["counts"] == {"tracks": 0, "pedestrians": 0, "non_pedestrians": 0,
                                 "unclassified": 0, "too_fast": 0, "explained": 0,
                                 "unjudged_plausible": 0, "walkers": 0, "walkers_low": 0,
                                 "walkers_high": 0}
    assert "non_pedestrians" in summary["count_rule"]
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
    assert "--min-frames" in capsys.readouterr().err
    blocker = tmp_path / "file"  # an output directory that cannot be created
    blocker.write_text("x")
    assert main(["count", str(videos["still"]), "-c", str(videos["config"]), "-o",
                 str(blocker / "o"), "--fps", "15", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "cannot create the output directory" in err and "\n" not in err


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
    res = count_frames(CFG, iter(items), options=FAST)
    assert res.summary["missing_frames"] == 2
    assert res.counts["tracks"] == 2
    at = np.isin(res.mot["frame"], [21, 22])
    assert at.sum() == 4 and np.all(res.mot["conf"][at] == 0.5)  # 2 tracks x 2 frames


# ----------------------------------------------------------------------------------------------
# the counting rule and stitching


def test_count_rule_removes_non_pedestrians_and_too_fast_unclassified():
    from rhythmjax.count import COUNT_RULE, count_walkers, counted, walker_ids

    v = ["pedestrian", "unclassified", "non-pedestrian", "unclassified", "pedestrian",
         "non-pedestrian", "unclassified"]
    fast = [False, False, True, True, True, False, False]
    c = count_walkers(v)
    # the paper counts every confirmed track (7); the classifier removes the 2 non-pedestrians;
    # the 3 too short to judge still count
    assert c == {"tracks": 7, "pedestrians": 2, "non_pedestrians": 2, "unclassified": 3,
                 "too_fast": 0, "explained": 0, "unjudged_plausible": 3, "walkers": 5,
                 "walkers_low": 2, "walkers_high": 5}
    # ... unless faster than the walking model accepts (only the unclassified one counts as
    # too fast: a judged track keeps its verdict)
    c = count_walkers(v, fast)
    assert c["too_fast"] == 1 and c["walkers"] == 4 and c["unjudged_plausible"] == 2
    # judged pedestrian + unjudged and plausible; the range: judged only .. + every unjudged
    assert c["walkers"] == c["pedestrians"] + c["unjudged_plausible"]
    assert (c["walkers_low"], c["walkers_high"]) == (2, 5)
    verdicts = {"track_id": np.arange(1, 8), "verdict": np.asarray(v, dtype=object),
                "too_fast": np.asarray(fast)}
    assert counted(verdicts).tolist() == [True, True, False, False, True, False, True]
    assert walker_ids(verdicts) == [1, 2, 5, 7]
    del verdicts["too_fast"]
    assert walker_ids(verdicts) == [1, 2, 4, 5, 7]
    assert count_walkers([]) == {"tracks": 0, "pedestrians": 0, "non_pedestrians": 0,
                                 "unclassified": 0, "too_fast": 0, "explained": 0,
                                 "unjudged_plausible": 0, "walkers": 0, "walkers_low": 0,
                                 "walkers_high": 0}
    assert "non_pedestrians" in COUNT_RULE and "too_fast" in COUNT_RULE


def test_too_fast_is_the_walking_models_top_speed():
    from rhythmjax.count import track_speed, walking_top_speed
    from rhythmjax.count.pedestrian_level import Pedestrian

    # (14): pace within 3 sigma of 2.05 +- 0.183 Hz, stride within 3 sigma of 0.72 +- 0.09 m
    assert walking_top_speed(CFG) == pytest.approx((2.05 + 3 * 0.183) * (0.72 + 3 * 0.09),
                                                   rel=1e-5)
    p = Pedestrian(slot=0, born=0)
    # rows: (index, t, u, v, W, I, x, y, state): 1.5 s at (1.2, -1.6) m/s = 2 m/s, measured
    p.rows = [TrackRow(k, k / 15, 100.0, 100.0, 20.0, 1.0, 1.2 * k / 15, 8 - 1.6 * k / 15, 2)
              for k in range(23)]
    p.rows[5] = p.rows[5]._replace(state=3)  # a predicted row is left out
    assert track_speed(p) == pytest.approx(2.0, rel=1e-6)
    p.rows = p.rows[:5]  # under 0.5 s: unknown
    assert math.isnan(track_speed(p))


def _piece(first, last, start, end, size=(20.0, 60.0), ground=None, fps=15.0):
    from rhythmjax.count import Piece

    fl = lambda q: None if q is None else tuple(float(x) for x in q)
    return Piece(first, last, first / fps, last / fps, fl(start), fl(end), fl(size), fl(ground))


# the defaults: 0.9 W across, 0.45 H up/down (growing 50 %/s of gap), 2 W/s velocity, 5 s gap
STITCH = {"max_gap_s": 5.0, "gate_w": 0.9, "gate_h": 0.45, "gate_per_s": 0.5, "max_dv_w": 2.0}


def test_stitch_links_a_track_that_continues_another():
    from rhythmjax.count import stitch_pieces

    # W = 20 px, H = 60 px; a walker going right at 30 px/s, lost at frame 30 (u = 100), back
    # at frame 45 (1 s later, u = 130)
    a = _piece(0, 30, (40, 150, 30, 0), (100, 150, 30, 0))
    b = _piece(45, 90, (131, 151, 28, 1), (220, 150, 30, 0))
    bike = _piece(44, 80, (128, 150, 90, 0), (300, 150, 90, 0))  # right place, too fast
    far = _piece(46, 80, (130, 210, 30, 0), (200, 210, 30, 0))  # 60 px = 1 H lower
    back = _piece(45, 80, (130, 150, -30, 0), (60, 150, -30, 0))  # walking back
    early = _piece(25, 80, (100, 150, 30, 0), (210, 150, 30, 0))  # overlaps a in time
    late = _piece(111, 150, (265, 150, 30, 0), (340, 150, 30, 0))  # 5.4 s later, on its line
    o = StitchOptions()
    assert STITCH == {"max_gap_s": o.max_gap_s, "gate_w": o.gate_w, "gate_h": o.gate_h,
                      "gate_per_s": o.gate_per_s, "max_dv_w": o.max_dv_w}
    assert stitch_pieces([a, b], **STITCH) == [1, -1]
    for other in (bike, far, back, early, late):
        assert stitch_pieces([a, other], **STITCH) == [-1, -1]
    # the best fitting one wins, each piece has one successor and one predecessor
    b2 = _piece(45, 90, (138, 150, 30, 0), (220, 150, 30, 0))  # 8 px off: a worse fit
    assert stitch_pieces([a, b2, b, far], **STITCH) == [2, -1, -1, -1]
    # chains: a -> b -> c (c 8.7 s after a: beyond the 5 s gap, 4.7 s after b, on b's line)
    c = _piece(160, 190, (220 + 30 * 70 / 15, 150, 30, 0), (420, 150, 30, 0))
    assert stitch_pieces([a, b, c], **STITCH) == [1, 2, -1]
    assert stitch_pieces([a, c], **STITCH) == [-1, -1]
    # 4 s hidden (behind a group): the gate has grown to 3 x (0.9 W, 0.45 H) = (54, 81) px
    # at 20 x 60 px; B taken 2 s back and A 2 s on meet 50 px apart across: linked, 60 px: not
    hid = _piece(90, 130, (100 + 30 * 4 + 50, 150, 30, 0), (400, 150, 30, 0))
    assert stitch_pieces([a, hid], **STITCH) == [1, -1]
    hid = _piece(90, 130, (100 + 30 * 4 + 60, 150, 30, 0), (400, 150, 30, 0))
    assert stitch_pieces([a, hid], **STITCH) == [-1, -1]
    # unknown end state (no ground point): never linked
    nan = _piece(0, 30, (40, 150, 30, 0), (math.nan,) * 4)
    assert stitch_pieces([nan, b], **STITCH) == [-1, -1]


def test_stitch_predicts_on_the_ground_plane_with_the_ekf_state():
    from rhythmjax.count import stitch_pieces
    from rhythmjax.count.patches import ShapeModel
    from rhythmjax.model.camera_np import project_3d

    shape = ShapeModel.from_config(CFG, "3d")
    cam = shape.camera
    # walking away from the camera at 1.4 m/s: lost at y = 6 m, back 1 s later at y = 7.4 m
    uv = lambda x, y: tuple(float(q) for q in project_3d(cam, x, y, 0.0))
    vel = lambda x, y, vx, vy: tuple((np.asarray(uv(x + 0.1 * vx, y + 0.1 * vy))
                                      - np.asarray(uv(x, y))) / 0.1)
    a = _piece(0, 30, (*uv(0.5, 3.2), *vel(0.5, 3.2, 0, 1.4)), (*uv(0.5, 6.0),
               *vel(0.5, 6.0, 0, 1.4)), ground=(0.5, 6.0, 0.0, 1.4))
    size = tuple(float(q) for q in shape.size(*uv(0.5, 7.4)))
    b = _piece(45, 80, (*uv(0.5, 7.4), *vel(0.5, 7.4, 0, 1.4)), (*uv(0.5, 12.0),
               *vel(0.5, 12.0, 0, 1.4)), size=size)
    assert stitch_pieces([a, b], camera=cam, **STITCH) == [1, -1]
    # the prediction runs on the ground plane: exact for a constant ground velocity, where a
    # straight line in the image (no EKF state) misses as the walker recedes
    from rhythmjax.count.stitch import _predict

    np.testing.assert_allclose(_predict(a, 1.0, cam), uv(0.5, 7.4), atol=1e-6)
    flat = dataclasses_replace(a, end_ground=None)
    assert abs(_predict(flat, 1.0, cam)[1] - uv(0.5, 7.4)[1]) > 0.05 * size[1]


def _hidden_walker_items():
    """One walker crossing; frames 25-44 show the empty background (1.33 s: longer than the
    1 s a pedestrian coasts before it ends)."""
    a = walker(-4.0, 7.0, 0.0, start_frame=3, phase=0.1)
    frames = render_scene(1, SceneSpec(n_frames=72, actors=(a,), camera=CFG.camera)).frames
    return [(k, k / 15.0, frames[0] if 25 <= k < 45 else f) for k, f in enumerate(frames)]


@pytest.mark.parametrize("dynamics", ["3d", "2d"])
def test_a_walker_hidden_longer_than_it_coasts_keeps_its_id(dynamics):
    items = _hidden_walker_items()
    opt = CountOptions(dynamics=dynamics, verdicts=QUIET)
    res = count_frames(CFG, iter(items), options=opt)
    assert res.counts["tracks"] == 1 and res.counts["walkers"] == 1
    assert res.summary["stitched"] == 1
    assert set(res.mot["id"].tolist()) == {1}
    f = res.mot["frame"]
    assert f.min() <= 6 and f.max() == 72 and not np.isin(f, np.arange(27, 46)).any()
    # without stitching: two tracks, two walkers
    off = count_frames(CFG, iter(items), options=dataclasses_replace(
        opt, stitch=StitchOptions(enabled=False)))
    assert off.counts["tracks"] == 2 and off.summary["stitched"] == 0


def dataclasses_replace(opt, **kw):
    import dataclasses

    return dataclasses.replace(opt, **kw)


def _place_by_loops(labels, related, claimed, shape, pu, pv, radius_px, v_max=None,
                    band=0.35, min_cover=0.08):
    """`pedestrians.place_patch` (no bbox) by plain loops over the candidates and pixels: the
    foot row is the lowest related pixel in the patch columns, the count is summed directly,
    patch and columns clipped to the search window."""
    from rhythmjax.count.patches import Placement

    H, W = labels.shape
    pix = np.isin(labels, related) & (True if claimed is None else ~claimed)
    w0, h0 = shape.size(pu, pv)
    if not (math.isfinite(w0) and math.isfinite(h0)) or w0 < 1 or h0 < 1:
        return None
    r = max(1, math.ceil(radius_px))
    x0, x1 = max(0, math.floor(pu - r - w0 / 2 - 1)), min(W, math.ceil(pu + r + w0 / 2 + 2))
    ylo = max(0, math.floor(pv - band * h0))
    yhi = min(H, math.ceil(pv + band * h0 if v_max is None else v_max) + 1)
    ytop = max(0, math.floor(pv - (1 + 2 * band) * h0))
    col = lambda q: min(max(math.floor(q + 0.5), x0), x1)  # noqa: E731
    best = None
    for k in range(-r, r + 1):
        u = pu + k
        c0, c1 = col(u - 0.5 * w0), col(u + 0.5 * w0)
        rows = [y for y in range(ylo, yhi) if c1 > c0 and pix[y, c0:c1].any()]
        if not rows:
            continue
        v = float(rows[-1])
        w, h = shape.size(u, v)
        a0, a1, b0 = col(u - 0.5 * w), col(u + 0.5 * w), max(math.floor(v - h + 1.5), ytop)
        cov = int(pix[b0:rows[-1] + 1, a0:a1].sum())
        if a1 <= a0 or b0 > rows[-1] or cov < min_cover * w * h:
            continue
        key = cov - 1e-6 * abs(u - pu) / (r + 1)
        if best is None or key > best[0]:
            best = (key, Placement(u, v, w, h, cov))
    return None if best is None else best[1]


def test_place_patch_matches_a_loop_reference():
    """`place_patch` (vectorised candidates, integral image, row-size table, label equality
    masks) gives the loop reference's placement exactly on random blob images."""
    from rhythmjax.count.patches import ShapeModel, place_patch
    from rhythmjax.vision.blobs import find_blobs

    rng = np.random.default_rng(17)
    found = 0
    for dyn in ("3d", "2d"):
        shape = ShapeModel.from_config(config_from_dict(SMALL), dyn)
        for _ in range(120):
            mask = np.zeros((192, 256), np.uint8)
            for _ in range(int(rng.integers(1, 6))):
                x, y = int(rng.integers(0, 240)), int(rng.integers(30, 190))
                mask[max(0, y - int(rng.integers(5, 70))):y, x:x + int(rng.integers(3, 40))] = 1
            blobs, labels = find_blobs(mask, min_area=1)
            rel = np.asarray([b.label for b in blobs if rng.random() < 0.6] or [1])
            claimed = rng.random(labels.shape) < 0.1 if rng.random() < 0.4 else None
            bu, bv = blobs[int(rel[0]) - 1].bottom_center  # near a related blob's feet
            pu, pv = bu + rng.normal(0, 10), bv + rng.normal(0, 8)
            kw = dict(radius_px=float(rng.uniform(0.5, 25)),
                      v_max=None if rng.random() < 0.5 else float(rng.uniform(pv, pv + 60)))
            want = _place_by_loops(labels, rel, claimed, shape, pu, pv, **kw)
            assert place_patch(labels, rel, claimed, shape, pu, pv, **kw) == want
            found += want is not None
    assert found > 120


def test_deferred_filter_results_give_the_same_tracks():
    """`PedestrianLevel(defer=True)` (count_frames without an overlay: a frame's filter results
    taken up in the next update) gives the undeferred level's outputs exactly."""
    from rhythmjax.count.counting import finish_count
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    frames, out = _crossing_frames(60), []
    for defer in (False, True):
        level = PedestrianLevel(CFG, FAST, defer)
        for k, f in enumerate(frames):
            level.update(k, k / 15.0, f)
        out.append(finish_count(level))
    assert out[0].counts == out[1].counts and len(out[0].mot["frame"]) > 40
    for c in MOT_COLUMNS:
        np.testing.assert_array_equal(out[0].mot[c], out[1].mot[c])
