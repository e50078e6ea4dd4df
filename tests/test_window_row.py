"""The deciding window the batch classifier keeps (`window_row` of `classify_tracks`: the first
batch row of the window that gave a track its verdict, -1 when no complete window was
classified), which `count` needs to draw its spectra.

Reference: `rhythm.classify_window` (the per-window classifier with jnp's float-sort medians)
on the batch rows window_row .. window_row + N - 1 alone, with the track's speed of (12) given,
must give the track's verdict, reason, pace, stride and peaks; a window one hop off gives other
peaks. Tolerances as tests/test_classify_fast.py: pace, stride 1e-5 relative, peak powers 1e-4
(float32, the same operations compiled in other programs)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from rhythmjax.io import read_tracks, to_batch, write_table
from rhythmjax.model.batch import classify_tracks
from rhythmjax.model.params import Config
from rhythmjax.model.rhythm import classify_window, window_times
from rhythmjax.model.status import REASON_LABELS, VERDICT_LABELS
from rhythmjax.sim.tracks import make_tracks


CFG = Config()
N = CFG.thresholds.n
GAP = max(1, round(float(CFG.thresholds.predict_timeout) * CFG.camera.fps))


def tracks_batch(tmp_path):
    """Walkers, bicycles, dogs and cars of `sim.tracks`; walker 0's first rows white noise (a
    later window decides); walker 1 cut by a 100-frame gap after 20 rows (a first segment too
    short to judge: its second segment decides, rows after the batch's first segment)."""
    cols, _ = make_tracks(n_walkers=5, n_bicycles=2, n_dogs=2, n_cars=1, seed=21,
                          min_frames=120, max_frames=200)
    cols = {k: np.asarray(v) for k, v in cols.items()}
    ids = list(dict.fromkeys(cols["track_id"]))
    walkers = [i for i in ids if str(cols["label"][cols["track_id"] == i][0]) == "pedestrian"]
    rng = np.random.default_rng(21)
    first = cols["track_id"] == walkers[0]
    row = np.cumsum(first) - 1
    noise = np.nanmean(cols["intensity"][first].astype(float)) + np.nanstd(
        cols["intensity"][first].astype(float)) * np.abs(rng.normal(size=len(row)))
    cols["intensity"] = np.where(first & (row < 56), noise, cols["intensity"])
    second = cols["track_id"] == walkers[1]
    row = np.cumsum(second) - 1
    shift = np.where(second & (row >= 20), 100, 0)
    cols["frame"] = cols["frame"] + shift
    cols["t"] = cols["t"] + shift / float(CFG.camera.fps)
    path = tmp_path / "t.csv"
    write_table(path, cols, list(cols))
    return to_batch(read_tracks(path, fps=CFG.camera.fps), max_gap_frames=GAP, min_len=N), \
        walkers


def reclassified(batch, i: int, w: int, speed: float):
    """`rhythm.classify_window` on rows w .. w + N - 1 of track i, the speed given."""
    dt = jnp.asarray(batch.dt[i, w:w + N])
    return classify_window(CFG, jnp.asarray(batch.intensity[i, w:w + N]), window_times(dt),
                           jnp.zeros((N, 2), jnp.float32), jnp.asarray(True),
                           speed=jnp.float32(speed))


def test_window_row_is_the_deciding_window(tmp_path):
    batch, walkers = tracks_batch(tmp_path)
    v = classify_tracks(CFG, batch, progress=False)
    w = np.asarray(v["window_row"])
    none = np.isin(v["reason"], ["too-short", "no-measurements"])
    assert np.array_equal(w < 0, none)
    assert (w >= 0).sum() >= 8
    ids = list(v["track_id"])
    # walker 0: window 0 is noise, a later window decides; walker 1: its second segment
    assert w[ids.index(walkers[0])] > 0 and v["verdict"][ids.index(walkers[0])] == "pedestrian"
    assert v["n_segments"][ids.index(walkers[1])] == 2 and w[ids.index(walkers[1])] >= 20
    for i in np.flatnonzero(w >= 0):
        r = reclassified(batch, i, int(w[i]), float(v["speed_mps"][i]))
        assert VERDICT_LABELS[int(r.verdict)] == v["verdict"][i], i
        assert REASON_LABELS[int(r.reason)] == v["reason"][i], i
        np.testing.assert_allclose([float(r.pace_hz), float(r.stride_m)],
                                   [v["pace_hz"][i], v["stride_m"][i]], rtol=1e-5,
                                   equal_nan=True)
        m = np.asarray(r.peak_mask)
        assert np.array_equal(m, v["peak_mask"][i])
        np.testing.assert_allclose(np.asarray(r.peak_power)[m], v["peak_power"][i][m],
                                   rtol=1e-4)
    # the check can fail: a window one hop off has other peaks
    hop = int(CFG.thresholds.hop_samples)
    room = [i for i in np.flatnonzero(w >= 0) if w[i] + hop + N <= batch.length[i]]
    assert len(room) >= 3
    for i in room:
        r = reclassified(batch, i, int(w[i]) + hop, float(v["speed_mps"][i]))
        assert not np.allclose(np.asarray(r.peak_power)[:1], v["peak_power"][i][:1], rtol=1e-4)


def test_window_row_of_long_tracks(tmp_path):
    """The long-track path (`long_tracks.classify_long_track`, tracks over `segment_rows` rows)
    keeps the same rows as the batch path."""
    batch, _ = tracks_batch(tmp_path)
    whole = classify_tracks(CFG, batch, progress=False, segment_rows=10**9)
    parts = classify_tracks(CFG, batch, progress=False, segment_rows=100)
    assert (np.asarray(batch.length) > 100).sum() >= 5
    np.testing.assert_array_equal(parts["window_row"], whole["window_row"])
    assert list(parts["verdict"]) == list(whole["verdict"])
