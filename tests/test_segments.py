"""Fig. 3 on stored tracks: a prediction longer than predict_timeout, or an estimate leaving the
detection range, ends a track segment (as in the online tracker); the segments are classified
exactly as their rows would be on their own."""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.io import read_tracks, to_batch, write_table
from rhythmjax.model import ekf_fused
from rhythmjax.model.batch import classify_each, classify_tracks
from rhythmjax.model.camera import image_width, project
from rhythmjax.model.gates import PaperGates
from rhythmjax.model.params import Config
from rhythmjax.model.segments import first_segment_end, split_tracks
from rhythmjax.sim.tracks import make_tracks


CFG = Config()
ORDER = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y"]
GAP = max(1, round(float(CFG.thresholds.predict_timeout) * CFG.camera.fps))
N = CFG.thresholds.n


def test_first_segment_end_by_hand():
    """dt 0.25 s, time-out 1 s, range 3-20 m. Rows: (started, valid, y)."""
    T = 8
    started = np.zeros((5, T), bool)
    started[[0, 2, 3, 4], :] = True
    started[1, 1:] = True
    valid = np.ones((5, T), bool)
    valid[1, 3:] = False  # predicted from row 3: 0.25, 0.5, 0.75, 1.0 (not > 1), 1.25 at row 7
    y = np.full((5, T), 10.0)
    y[3, 5:] = 20.5  # leaves the range at row 5
    dt = np.full((5, T), 0.25)
    dt[2, 4] = 1.5  # a frame gap of 1.5 s, then a used measurement: ends before row 4
    started[4] = False  # never started: no end
    length = np.array([T, T, T, T, T])
    end = first_segment_end(CFG, started, valid, y, dt, length)
    assert end.tolist() == [-1, 7, 3, 5, -1]
    # rows past a track's length (padding) never end it
    assert first_segment_end(CFG, started, valid, y, dt, np.array([T, 7, 4, 5, T]))[1:4] \
        .tolist() == [-1, -1, -1]


def _write(tmp_path, cols, name="tracks.csv"):
    path = tmp_path / name
    write_table(str(path), cols, ORDER)
    return read_tracks(str(path), fps=CFG.camera.fps)


def _subset(tr, keep):
    arrays = {f.name: getattr(tr, f.name) for f in dataclasses.fields(tr)}
    return dataclasses.replace(tr, **{k: (v[keep] if isinstance(v, np.ndarray) else v)
                                      for k, v in arrays.items()})


def _batch(tr):
    return to_batch(tr, max_gap_frames=GAP, min_len=N)


def _walker_with_gap(tmp_path):
    """A walker (156 frames) with 20 rows of missing measurements, frames 66-85."""
    cols, _ = make_tracks(n_walkers=1, n_bicycles=0, n_dogs=0, n_cars=0, seed=3,
                          min_frames=156, max_frames=157, gap_rate=0.0)
    cols = {k: np.asarray(v) for k, v in cols.items()}
    gap = (cols["frame"] >= 66) & (cols["frame"] < 86)  # 1.33 s of missing measurements
    for k in ("u", "v", "width_px"):
        cols[k] = np.where(gap, np.nan, cols[k].astype(float))
    return _write(tmp_path, cols)


def _pieces_are_judged_on_their_own(tr, segs, n1):
    """The two segments are the rows before and from row n1, padded as `to_batch` pads them
    alone, and classified exactly as those rows on their own."""
    pieces = [_batch(_subset(tr, np.arange(len(tr)) < n1)),
              _batch(_subset(tr, np.arange(len(tr)) >= n1))]
    for i, piece in enumerate(pieces):  # the same rows, padded to the track's longer T
        T = piece.z.shape[1]
        for k in ("z", "width", "intensity", "dt", "present"):
            np.testing.assert_array_equal(getattr(segs, k)[i][:T], getattr(piece, k)[0],
                                          err_msg=k)
        assert not segs.present[i][T:].any()
    each = classify_each(CFG, segs, 8, False)
    alone = [classify_each(CFG, p, 8, False) for p in pieces]
    for k in ("verdict", "reason", "pace_hz", "stride_m", "ratio", "n_samples"):
        np.testing.assert_array_equal(each[k], np.concatenate([a[k] for a in alone]), err_msg=k)
    return each


def test_long_nan_gap_splits_and_each_segment_is_judged_on_its_own(tmp_path):
    tr = _walker_with_gap(tmp_path)
    batch = _batch(tr)
    segs, owner = split_tracks(CFG, batch)
    assert owner.tolist() == [0, 0]
    n1, n2 = (int(n) for n in segs.length)
    # 15 missing rows are 1 s, not more than the time-out; the 16th ends the segment
    assert n1 == 66 + GAP + 1 and n1 + n2 == int(batch.length[0])
    each = _pieces_are_judged_on_their_own(tr, segs, n1)
    assert np.all(each["verdict"] != 0)  # both segments are long enough to be judged
    out = classify_tracks(CFG, batch, progress=False)
    assert out["n_segments"].tolist() == [2]
    assert out["n_samples"][0] == each["n_samples"].sum()
    assert out["verdict"][0] == "pedestrian" and out["reason"][0] == "matched"
    whole = classify_tracks(CFG, batch, progress=False, split=False)
    assert whole["n_segments"].tolist() == [1]


def test_frame_gap_longer_than_the_time_out_splits(tmp_path):
    """Rows missing from the file (frames 66-85): `to_batch` keeps one step of 1.4 s,
    and the segment ends there, before the next row (a measurement the gates accept)."""
    cols, _ = make_tracks(n_walkers=1, n_bicycles=0, n_dogs=0, n_cars=0, seed=3,
                          min_frames=156, max_frames=157, gap_rate=0.0)
    keep = (np.asarray(cols["frame"]) < 66) | (np.asarray(cols["frame"]) >= 86)
    tr = _write(tmp_path, {k: np.asarray(v)[keep] for k, v in cols.items()})
    batch = _batch(tr)
    assert float(batch.dt[0, 66]) == pytest.approx(21 / 15, rel=1e-6)  # frame 65 -> 86
    segs, owner = split_tracks(CFG, batch)
    assert owner.tolist() == [0, 0] and int(segs.length[0]) == 66
    each = _pieces_are_judged_on_their_own(tr, segs, 66)
    assert each["n_samples"].tolist() == [66, int(batch.length[0]) - 66]


def _leaving_walker(tmp_path):
    """A walker going away from y = 14 m to 26 m at 1.4 m/s: out of the 3-20 m range."""
    fps = float(CFG.camera.fps)
    k = np.arange(int(12 / 1.4 * fps))
    t = k / fps
    x, y = 0.5 + 0.0 * t, 14.0 + 1.4 * t
    u, v = (np.asarray(a, float) for a in project(CFG.camera, jnp.asarray(x, jnp.float32),
                                                  jnp.asarray(y, jnp.float32)))
    rng = np.random.default_rng(0)
    u, v = u + rng.normal(0, 1.0, len(k)), v + rng.normal(0, 1.0, len(k))
    w = np.asarray(image_width(CFG.camera, jnp.float32(0.5), jnp.asarray(y, jnp.float32)), float)
    intensity = 100 + 20 * np.sin(2 * np.pi * 2.0 * t) + rng.normal(0, 2, len(k))
    cols = {"track_id": np.array(["w"] * len(k), object), "frame": k, "t": t, "u": u, "v": v,
            "width_px": w, "intensity": intensity, "label": np.array(["pedestrian"] * len(k),
                                                                      object), "x": x, "y": y}
    return _write(tmp_path, cols)


def test_leaving_the_range_ends_the_segment(tmp_path):
    tr = _leaving_walker(tmp_path)
    batch = _batch(tr)
    gates = PaperGates(CFG.width, CFG.thresholds)
    out = ekf_fused.filter_track(CFG.camera, CFG.noise, gates, *(
        jnp.asarray(a[0]) for a in (batch.z, batch.width, batch.dt, batch.present))).steps
    y = np.asarray(out.mean[:, 2])
    first_out = int(np.argmax(np.asarray(out.started) & (y > float(CFG.thresholds.range_max))))
    assert 0 < first_out < int(batch.length[0]) - 1
    segs, owner = split_tracks(CFG, batch)
    assert np.all(owner == 0) and int(segs.length[0]) == first_out + 1
    assert int(segs.length.sum()) == int(batch.length[0])
    # a measurement still in range (noise, truth just below 20 m) may start a short segment
    # again (DETECT -> OBSERVE); past the range nothing starts (its ground point is out of range)
    each = classify_each(CFG, segs, 8, False)
    assert each["n_samples"][-1] == 0 and np.all(each["n_samples"][1:] < N)
    alone = classify_each(CFG, _batch(_subset(tr, np.arange(len(tr)) <= first_out)), 8, False)
    res = classify_tracks(CFG, batch, progress=False)
    for k in ("pace_hz", "stride_m", "ratio"):
        np.testing.assert_array_equal(res[k], alone[k], err_msg=k)
    assert res["n_segments"].tolist() == [len(owner)]


def test_tracks_without_an_end_are_unchanged(tmp_path):
    cols, _ = make_tracks(n_walkers=3, n_bicycles=1, n_dogs=1, n_cars=0, seed=11)
    batch = _batch(_write(tmp_path, {k: np.asarray(v) for k, v in cols.items()}))
    a = classify_tracks(CFG, batch, progress=False)
    b = classify_tracks(CFG, batch, progress=False, split=False)
    for k in ("verdict", "reason", "pace_hz", "stride_m", "ratio", "n_samples"):
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    assert a["n_segments"].tolist() == [1] * 5
