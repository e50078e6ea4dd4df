"""Rules 37 and 26 behind any tracker (`rhythm --boxes`): a box's top row as the object's
height (`track.boxes.top_rows`) and the size rule on every window the batch classifier judges
(`track.size.batch_size_look`). Heights come from the forward projection (3) of objects of
known height, so the reference does not go through the inverse the looks use."""

from __future__ import annotations

import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.io import read_table
from rhythmjax.io.files import Tracks, to_batch
from rhythmjax.io.mot import read_mot_numbered
from rhythmjax.model.batch import classify_tracks
from rhythmjax.model.camera_np import project_3d, upright_size
from rhythmjax.model.params import config_from_dict
from rhythmjax.model.status import Reason, Verdict
from rhythmjax.track.boxes import top_rows, tracks_from_mot
from rhythmjax.track.options import SizeOptions
from rhythmjax.track.size import batch_size_look, median_height, too_low
from rhythmjax.track.twice import batch_second_look


CFG = config_from_dict({"thresholds": {"range_max_m": 40.0}})  # the paper's camera; from 22 m
# on a walker's head is inside the image
FPS = 15.0
WALKER_M = 1.7  # the config's walker height (width.height_m)


def _object(top_m: float, pace: float = 2.0, speed: float = 1.3, n: int = 96, seed: int = 0):
    """n rows of an object `top_m` m tall going away from 22 m at `speed` m/s: foot point and
    top row by the forward projection (3), a walker's width, I(k) a sine at `pace` Hz."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FPS
    y = 22.0 + speed * t
    u, v = project_3d(CFG.camera, 0 * y, y, 0 * y)
    _, v_top = project_3d(CFG.camera, 0 * y, y, top_m + 0 * y)
    w, _, _ = upright_size(CFG.camera, u, v, float(CFG.width.mean), WALKER_M)
    return {"t": t, "u": np.asarray(u), "v": np.asarray(v), "v_top": np.asarray(v_top),
            "width_px": np.asarray(w),
            "intensity": 20.0 + 5.0 * np.sin(2 * np.pi * pace * t) + rng.normal(0, 1.0, n)}


def _batch(objects: list[dict]):
    cols = {k: np.concatenate([o[k] for o in objects])
            for k in ("t", "u", "v", "v_top", "width_px", "intensity")}
    ids = np.concatenate([np.full(len(o["t"]), str(i + 1), dtype=object)
                          for i, o in enumerate(objects)])
    frame = np.concatenate([np.arange(len(o["t"])) for o in objects])
    tracks = Tracks(path="<test>", track_id=ids, frame=frame, t=cols["t"], u=cols["u"],
                    v=cols["v"], width_px=cols["width_px"], intensity=cols["intensity"],
                    line=np.arange(len(frame)), fps=FPS, v_top=cols["v_top"],
                    top_at_edge=np.zeros(len(frame)))
    return to_batch(tracks, max_gap_frames=15, min_len=CFG.thresholds.n)


def test_top_rows_of_boxes_and_the_image_edge():
    """A box's first row is its top edge; a top on the image's first row (< 1 px after
    scaling) is an edge row with no top row (the tracker's convention)."""
    v_top, edge = top_rows([-3.0, 0.0, 0.6, 1.0, 17.5])
    np.testing.assert_array_equal(edge, [1.0, 1.0, 1.0, 0.0, 0.0])
    np.testing.assert_array_equal(v_top, [np.nan, np.nan, np.nan, 1.0, 17.5])
    v_top, edge = top_rows([0.4, 0.5, 8.25], scale=2.0)
    np.testing.assert_array_equal(edge, [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(v_top, [np.nan, 1.0, 16.5])


def test_mot_boxes_carry_their_top_rows_in_track_order(tmp_path):
    p = tmp_path / "gt.txt"
    p.write_text("2,9,10,0,6,30\n1,9,10,4,6,30\n1,3,50,20,8,40\n")
    tr = tracks_from_mot(read_mot_numbered(p), str(p), fps=10.0)
    assert list(tr.track_id) == ["3", "9", "9"] and list(tr.frame) == [0, 0, 1]
    np.testing.assert_array_equal(tr.v_top, [20.0, 4.0, np.nan])
    np.testing.assert_array_equal(tr.top_at_edge, [0.0, 0.0, 1.0])


@pytest.mark.parametrize("top_m, refused", [(0.6, True), (0.8, True), (0.9, False),
                                            (1.7, False)])
def test_the_size_look_refuses_windows_below_half_a_walker(top_m, refused):
    """An object read at a walker's pace (2.0 Hz at 1.3 m/s: (13)-(15) pass it) is
    Pedestrian without the look; with rule 26 at 0.5 walker heights (0.85 m) it is
    Non-pedestrian, reason too-low, exactly when it is lower than that."""
    batch = _batch([_object(top_m)])
    off = classify_tracks(CFG, batch, progress=False)
    assert off["verdict"][0] == "pedestrian" and off["reason"][0] == "matched"
    on = classify_tracks(CFG, batch, progress=False,
                         second_look=batch_size_look(CFG, batch, SizeOptions()))
    want = ("non-pedestrian", "too-low") if refused else ("pedestrian", "matched")
    assert (on["verdict"][0], on["reason"][0]) == want
    assert float(on["pace_hz"][0]) == pytest.approx(float(off["pace_hz"][0]))


def test_the_size_look_runs_after_rule_37():
    """A 1.0 m object read at twice a walker's pace (4.0 Hz): with rule 37 at 0.5 walker
    heights it is judged at half (matched-twice), and rule 26 at 0.65 walker heights (1.1 m),
    run after it, refuses that window (too-low); at 0.5 (0.85 m) it stands. A walker is
    judged at half and kept. The window a look refuses is one the other never saw."""
    batch = _batch([_object(1.0, pace=4.0), _object(1.7, pace=4.0, seed=1)])
    for heights, want in ((0.65, ("non-pedestrian", "too-low")),
                          (0.5, ("pedestrian", "matched-twice"))):
        size = SizeOptions(twice_pace_heights=0.5, twice_pace_edge=False,
                           min_height_heights=heights)
        look = batch_size_look(CFG, batch, size, then=batch_second_look(CFG, batch, size))
        got = classify_tracks(CFG, batch, progress=False, second_look=look)
        assert (got["verdict"][0], got["reason"][0]) == want
        assert (got["verdict"][1], got["reason"][1]) == ("pedestrian", "matched-twice")


def test_the_size_look_is_the_other_look_when_off_or_without_top_rows():
    batch = _batch([_object(0.6)])
    other = batch_second_look(CFG, batch, SizeOptions())
    assert batch_size_look(CFG, batch, SizeOptions(min_height_heights=0.0), then=other) is other
    batch.v_top = None
    assert batch_size_look(CFG, batch, SizeOptions(), then=None) is None


def test_the_size_look_leaves_other_verdicts_and_reads_each_window_on_its_rows():
    """Only windows judged Pedestrian are read; each on its own rows: a track that is a
    walker for its first 64 rows and a 0.6 m object after keeps window 0, loses window 2."""
    walker, dog = _object(1.7, n=64), _object(0.6, n=64)
    z = np.stack([np.stack([np.r_[walker["u"], dog["u"]], np.r_[walker["v"], dog["v"]]], -1)])
    batch = type("B", (), {"z": z, "v_top": np.r_[walker["v_top"], dog["v_top"]][None]})()
    res = {"verdict": np.asarray([Verdict.PEDESTRIAN, Verdict.NON_PEDESTRIAN,
                                  Verdict.PEDESTRIAN], np.int32),
           "reason": np.asarray([Reason.MATCHED, Reason.NO_MODEL_MATCH, Reason.MATCHED],
                                np.int32)}
    got = batch_size_look(CFG, batch, SizeOptions())(res, np.zeros(3, int),
                                                     np.asarray([0, 32, 64]))
    assert got["verdict"].tolist() == [Verdict.PEDESTRIAN, Verdict.NON_PEDESTRIAN,
                                       Verdict.NON_PEDESTRIAN]
    assert got["reason"].tolist() == [Reason.MATCHED, Reason.NO_MODEL_MATCH, Reason.TOO_LOW]
    assert got["verdict"].dtype == np.int32 and res["reason"][2] == Reason.MATCHED  # a copy


def test_the_size_look_equals_rule_26_window_by_window():
    """40 windows on tracks of 0.5-1.9 m with noisy top rows, some rows unmeasured (NaN) and
    tracks whose near rows have a walker's head above the image: the vectorised look refuses
    exactly the Pedestrian windows that `too_low(median_height(...))` refuses on their rows."""
    rng = np.random.default_rng(3)
    objs = []
    for k, top in enumerate(rng.uniform(0.5, 1.9, 6)):
        o = _object(float(top), n=160, seed=k)
        o["v_top"] = o["v_top"] + rng.normal(0, 1.5, 160)
        o["v_top"][rng.random(160) < 0.3] = np.nan
        if k % 3 == 0:  # from 2 m on: a walker's head leaves the image at the near rows
            y = np.linspace(2.0, 8.0, 160)
            o["u"], o["v"] = (np.asarray(a) for a in project_3d(CFG.camera, 0 * y, y, 0 * y))
        objs.append(o)
    z = np.stack([np.stack([o["u"], o["v"]], -1) for o in objs])
    batch = type("B", (), {"z": z, "v_top": np.stack([o["v_top"] for o in objs])})()
    W = 40
    track, start = rng.integers(0, 6, W), rng.integers(0, 160 - 64 + 1, W)
    verdict = np.where(rng.random(W) < 0.8, Verdict.PEDESTRIAN, Verdict.NON_PEDESTRIAN)
    res = {"verdict": verdict.astype(np.int32), "reason": np.zeros(W, np.int32)}
    options = SizeOptions()
    got = batch_size_look(CFG, batch, options)(res, track, start)
    want = []
    for w in range(W):
        o, rows = objs[track[w]], slice(start[w], start[w] + 64)
        h, n = median_height(CFG.camera, o["u"][rows], o["v"][rows], o["v_top"][rows],
                             WALKER_M, options.top_inside_heights)
        want.append(too_low(int(verdict[w]), h, n, WALKER_M, options))
    assert (got["reason"] == Reason.TOO_LOW).tolist() == want
    assert 5 <= sum(want) <= 35  # both kinds of windows are there


def test_rhythm_writes_the_box_tops_and_refuses_a_bad_height(tmp_path, capsys):
    """`rhythm` on drawn frames: its tracks file carries each box's top row and edge flag; a
    negative --min-height-heights or a NaN --twice-pace-heights exits 2 naming the option."""
    import cv2

    frames = tmp_path / "frames"
    frames.mkdir()
    rng = np.random.default_rng(0)
    for k in range(70):
        img = np.full((120, 160), 90, np.uint8)
        img[30 + k % 4:60, 40:50] = 200 if k % 2 else 30
        cv2.imwrite(str(frames / f"{k:04d}.png"), img + rng.integers(0, 3, img.shape,
                                                                     dtype=np.uint8))
    gt = tmp_path / "gt.txt"
    gt.write_text("".join(f"{k + 1},1,40,{0 if k < 10 else 30},10,60\n" for k in range(70)))
    out = tmp_path / "out"
    assert main(["rhythm", str(frames), "--boxes", str(gt), "-o", str(out), "--fps", "15",
                 "--no-camera-check", "--quiet"]) == 0
    t = read_table(out / "tracks.parquet", ["frame", "v_top", "top_at_edge"])
    np.testing.assert_array_equal(t["top_at_edge"], [1.0] * 10 + [0.0] * 60)
    np.testing.assert_array_equal(t["v_top"][10:], 30.0)
    assert np.isnan(t["v_top"][:10]).all()
    capsys.readouterr()
    for flag, value in (("--min-height-heights", "-0.5"), ("--twice-pace-heights", "nan")):
        assert main(["rhythm", str(frames), "--boxes", str(gt), "-o", str(tmp_path / "bad"),
                     "--fps", "15", flag, value]) == 2
        assert flag in capsys.readouterr().err
        assert not (tmp_path / "bad" / "verdicts.csv").exists()
