"""A long track classified in segments (model.long_tracks) gives the batch path's verdicts.

Tolerance: verdict, reason, n_samples and n_segments equal; pace, stride, ratio and speed
(float32) within 1e-4 relative (the same operations compiled in other programs)."""

from __future__ import annotations

import numpy as np
import pytest

from rhythmjax.io import read_tracks, to_batch, write_table
from rhythmjax.model.batch import classify_tracks
from rhythmjax.model.camera_np import image_width_of, project_3d
from rhythmjax.model.long_tracks import filter_rows
from rhythmjax.model.params import Config
from rhythmjax.model.status import Verdict


def walker_rows(track_id: str, rows: int, seed: int, *, lap_s=12.5, gap_at=None, away_at=None):
    """A walker going round an ellipse in the detection range at 15 fps; `gap_at`: a frame gap
    of 100 frames there (the PREDICT time-out ends the piece); `away_at`: from that row on 30 m
    ahead (out of range, the range exit ends the piece)."""
    cfg = Config()
    cam = cfg.camera
    rng = np.random.default_rng(seed)
    frame = np.arange(rows, dtype=np.int64)
    if gap_at is not None:
        frame[gap_at:] += 100
    t = frame / float(cam.fps)
    w = 2 * np.pi / lap_s
    x, y = 3.0 * np.sin(w * t), 10.0 + 3.0 * np.cos(w * t)
    if away_at is not None:
        y[away_at:away_at + 200] = 40.0
    u, v = project_3d(cam, x, y, 0.0)
    u, v = u + rng.normal(0, 1.0, rows), v + rng.normal(0, 1.0, rows)
    width = image_width_of(cam, 0.5, y) * (1 + rng.normal(0, 0.05, rows))
    inten = np.abs(1000.0 * (1.0 + 0.5 * np.sin(2 * np.pi * 2.05 * t)
                             + 0.3 * rng.normal(size=rows)))
    gone = rng.random(rows) < 0.03
    u[gone] = v[gone] = np.nan
    return {"track_id": np.full(rows, track_id), "frame": frame, "t": t, "u": u, "v": v,
            "width_px": width, "intensity": inten}


def batch_of(tmp_path, parts):
    cols = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    path = tmp_path / "t.csv"
    write_table(path, cols, list(cols))
    cfg = Config()
    tr = read_tracks(path, fps=cfg.camera.fps)
    gap = max(1, round(float(cfg.thresholds.predict_timeout) * cfg.camera.fps))
    return cfg, to_batch(tr, max_gap_frames=gap, min_len=cfg.thresholds.n)


def assert_same(a: dict, b: dict) -> None:
    for k in ("track_id", "verdict", "reason", "n_samples", "n_segments"):
        assert list(a[k]) == list(b[k]), k
    for k in ("pace_hz", "stride_m", "ratio", "speed_mps"):
        np.testing.assert_allclose(np.asarray(a[k], float), np.asarray(b[k], float),
                                   rtol=1e-4, atol=1e-6, equal_nan=True, err_msg=k)


@pytest.mark.parametrize("segment_rows", [500, 1000])
def test_segmented_equals_whole(tmp_path, segment_rows):
    # 3000 rows; boundaries at 500 (or 1000) lie inside rhythm windows (N 64, hop 32, the start
    # not at row 0 when the first rows are missing); one track split by a gap and a range exit,
    # and short tracks beside them
    parts = [walker_rows("a", 3000, 1), walker_rows("b", 2600, 2, gap_at=1200, away_at=2000),
             walker_rows("c", 200, 3), walker_rows("d", 40, 4), walker_rows("e", 1800, 5,
                                                                            lap_s=40.0)]
    cfg, batch = batch_of(tmp_path, parts)
    whole = classify_tracks(cfg, batch, progress=False, segment_rows=10**9)
    seg = classify_tracks(cfg, batch, progress=False, segment_rows=segment_rows)
    assert_same(seg, whole)
    assert list(whole["n_segments"]) == [1, 3, 1, 1, 1]  # b: the gap and the range exit end it
    assert (whole["verdict"][[0, 1, 4]] != "unclassified").all()
    assert whole["reason"][3] == "too-short"


def test_small_window_chunks_pick_the_first_pedestrian(tmp_path):
    from rhythmjax.model.long_tracks import classify_long_track

    cfg, batch = batch_of(tmp_path, [walker_rows("a", 3000, 7)])
    whole = classify_tracks(cfg, batch, progress=False, segment_rows=10**9)
    L = int(batch.length[0])
    pieces = classify_long_track(cfg, batch.z[0, :L], batch.width[0, :L],
                                 batch.intensity[0, :L], batch.dt[0, :L], segment_rows=300,
                                 window_chunk=3)
    assert len(pieces) == 1
    assert pieces[0]["verdict"] == list(Verdict)[[v.label for v in Verdict].index(
        whole["verdict"][0])]
    np.testing.assert_allclose(pieces[0]["pace_hz"], whole["pace_hz"][0], rtol=1e-4)


def test_filter_carry_across_segments(tmp_path):
    # the filter's rows do not depend on where the segments are cut
    cfg, batch = batch_of(tmp_path, [walker_rows("a", 1500, 9)])
    L = int(batch.length[0])
    args = (batch.z[0, :L], batch.width[0, :L], batch.dt[0, :L], batch.present[0, :L])
    s1, v1, xy1 = filter_rows(cfg, *args, segment_rows=2048)
    s2, v2, xy2 = filter_rows(cfg, *args, segment_rows=97)
    assert (s1 == s2).all() and (v1 == v2).all() and v1.sum() > 1000
    np.testing.assert_allclose(xy1, xy2, rtol=1e-5, atol=1e-5)


def test_classify_verb_groups_long_tracks(tmp_path):
    """`rhythmjax classify --segment-rows`: long tracks are padded and classified apart from
    the short ones (`Tracks.by_span`), the table keeps the file's order, and the verdicts equal
    those of one batch."""
    import pandas as pd

    from rhythmjax.cli.main import main

    parts = [walker_rows("c", 200, 3), walker_rows("a", 2000, 1), walker_rows("d", 40, 4),
             walker_rows("b", 1500, 2, gap_at=700)]
    cols = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    path = tmp_path / "t.csv"
    write_table(path, cols, list(cols))
    out = {}
    for rows in (300, 100000):
        o = tmp_path / f"v{rows}.csv"
        assert main(["classify", str(path), "-o", str(o), "--segment-rows", str(rows), "-q"]) == 0
        out[rows] = pd.read_csv(o, dtype={"track_id": str})
    a, b = out[300], out[100000]
    assert list(a["track_id"]) == ["c", "a", "d", "b"]
    assert_same({k: a[k].to_numpy() for k in a} | {"n_segments": [0]},
                {k: b[k].to_numpy() for k in b} | {"n_segments": [0]})
