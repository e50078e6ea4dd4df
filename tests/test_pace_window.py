"""The pace window (rule 34, issue 16): I(k) summed in window B scaled by
`body.pace_window_widths` about the foot point, written as the tracks' `intensity_wide` column,
never deciding a verdict but giving a Pedestrian window's pace and stride where it says
Pedestrian too (`model.candidates.strongest`'s pace_last). Checked: the merge by hand, the window
sum by hand, the tracker against the same window re-judged from its written rows (the same
jitted kernel on the same float32 inputs: 1e-6 Hz), and the batch classifier (fast and long-track
paths) against the tracker (1e-5, the tolerance of tests/test_tracker.py)."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.cli.common import TRACK_ORDER
from rhythmjax.io import read_tracks, to_batch, write_table
from rhythmjax.io.errors import BadInput
from rhythmjax.io.files import ACROSS_COLUMNS, CANDIDATE_COLUMNS, PACE_COLUMN
from rhythmjax.model.batch import classify_tracks
from rhythmjax.model.candidates import strongest
from rhythmjax.model.params import Config
from rhythmjax.model.rhythm import classify_window_jit
from rhythmjax.model.status import Verdict
from rhythmjax.sim import scene as synth
from rhythmjax.track.columns import candidate_columns
from rhythmjax.track.options import BodyOptions, TrackerOptions
from rhythmjax.track.tracker import OnlineTracker
from rhythmjax.vision.window_b import window_b_candidates, window_b_extras, window_b_intensity


CFG = Config()
PED, NON = int(Verdict.PEDESTRIAN), int(Verdict.NON_PEDESTRIAN)


def _result(verdict, pace, stride, power, ratio):
    """Three windows' results as `strongest` reads them (one peak each)."""
    return {"verdict": np.asarray(verdict, np.int32), "pace_hz": np.asarray(pace, np.float32),
            "stride_m": np.asarray(stride, np.float32), "ratio": np.asarray(ratio, np.float32),
            "peak_power": np.asarray(power, np.float32)[:, None],
            "peak_mask": np.ones((3, 1), bool)}


def test_strongest_takes_pace_and_stride_only_where_both_say_pedestrian():
    """Window B, one candidate and the pace window over three windows. Chosen by power: B, the
    candidate, B. The pace window says Pedestrian in windows 0 and 1 (not 2): window 0's and
    1's pace and stride are its; window 2 (chosen Pedestrian, pace window not) keeps B's.
    Window 1 seen again with the chosen one Non-pedestrian: kept. Every other field and the
    choice are those without the pace window, whose column is never chosen."""
    b = _result([PED, NON, PED], [1.8, 1.0, 2.0], [0.70, 0.5, 0.60], [50, 10, 40], [.5, .1, .6])
    c = _result([NON, PED, NON], [3.0, 1.9, 2.2], [0.30, 0.8, 0.55], [20, 30, 10], [.2, .7, .3])
    p = _result([PED, PED, NON], [1.9, 2.1, 2.5], [0.66, 0.72, 0.40], [99, 99, 99], [.9, .9, .9])
    alone, chosen_alone = strongest([b, c])
    merged, chosen = strongest([b, c, p], pace_last=True)
    assert chosen.tolist() == chosen_alone.tolist() == [0, 1, 0]
    assert merged["pace_hz"].tolist() == pytest.approx([1.9, 2.1, 2.0])
    assert merged["stride_m"].tolist() == pytest.approx([0.66, 0.72, 0.60])
    for k in ("verdict", "ratio", "peak_power", "peak_mask"):
        np.testing.assert_array_equal(merged[k], alone[k], err_msg=k)
    c_non = dict(c, verdict=np.asarray([NON, NON, NON], np.int32))
    merged, _ = strongest([b, c_non, p], pace_last=True)
    assert merged["pace_hz"][1] == pytest.approx(1.9)  # the candidate's, not the pace window's
    # window B alone with the pace window (the candidates off)
    merged, chosen = strongest([b, p], pace_last=True)
    assert chosen.tolist() == [0, 0, 0]
    assert merged["pace_hz"].tolist() == pytest.approx([1.9, 1.0, 2.0])


def test_window_b_extras_by_hand():
    """D all ones (100 x 100): window B at W 10 px is 10 x 2 px (20); the pace window at 2 W is
    20 x 4 px (80), bottom row at v; scaled 1.5: 15 x 3 (45). After the candidates, in order."""
    D = np.ones((100, 100), np.uint8)
    assert window_b_intensity(D, 50.0, 60.0, 10.0) == 20.0
    assert window_b_extras(D, 50.0, 60.0, 10.0, (), 2.0) == (80.0,)
    assert window_b_extras(D, 50.0, 60.0, 10.0, (), 1.5) == (45.0,)
    assert window_b_extras(D, 50.0, 60.0, 10.0, (-0.1, 0.1), 2.0) == (20.0, 20.0, 80.0)
    assert window_b_extras(D, 50.0, 60.0, 10.0, (-0.1,), 0.0) == \
        window_b_candidates(D, 50.0, 60.0, 10.0, (-0.1,))
    D[58:61, :] = 0  # rows 58-60 empty: window B (rows 59-60) 0, the pace window (57-60) 20
    assert window_b_extras(D, 50.0, 60.0, 10.0, (0.0,), 2.0) == (0.0, 20.0)
    assert all(math.isnan(x) for x in window_b_extras(D, math.nan, 60.0, 10.0, (0.1,), 2.0))


# ----------------------------------------------------------------------------------------------
# the tracker and the batch classifier


@pytest.fixture(scope="module")
def crossing():
    """A walker crossing the view at 12 m (pace 1.9 Hz, step 0.62 m), 130 frames, tracked with
    the pace window (2 W) and without it (the default)."""
    act = synth.walker(-3.4, 12.0, 0.0, pace_hz=1.9, step_length_m=0.62)
    frames = synth.render_scene(3, synth.SceneSpec(n_frames=130, actors=(act,),
                                                   camera=CFG.camera)).frames

    def run(options):
        tr = OnlineTracker(CFG, options)
        for k, f in enumerate(frames):
            tr.update(k, k / CFG.camera.fps, f)
        return tr.finish()

    return run(TrackerOptions(body=BodyOptions(pace_window_widths=2.0))), run(None)


def test_the_pace_window_changes_no_verdict_and_no_other_column(crossing):
    (tracks, verdicts, objs), (tracks0, verdicts0, _) = crossing
    assert BodyOptions().pace_window_widths == 0.0  # off by default (docs/rules.md, rule 34)
    assert PACE_COLUMN in tracks and PACE_COLUMN not in tracks0
    assert set(tracks) == set(tracks0) | {PACE_COLUMN}
    for k in tracks0:  # the tracking and every other sample unchanged
        np.testing.assert_array_equal(np.asarray(tracks[k]), np.asarray(tracks0[k]), err_msg=k)
    np.testing.assert_array_equal(np.isnan(tracks[PACE_COLUMN]), np.isnan(tracks["intensity"]))
    for k in ("track_id", "verdict", "reason", "ratio", "speed_mps", "n_samples"):
        assert np.asarray(verdicts[k]).tolist() == np.asarray(verdicts0[k]).tolist(), k
    assert list(verdicts["verdict"]) == ["pedestrian"]
    # here the pace window gave the pace: nearer the truth (1.9 Hz) than window B's
    assert abs(verdicts["pace_hz"][0] - 1.9) < abs(verdicts0["pace_hz"][0] - 1.9)
    assert verdicts["pace_hz"][0] != verdicts0["pace_hz"][0]


def test_the_pace_is_the_pace_windows_over_the_deciding_rows(crossing):
    """The deciding window's rows re-judged from the written columns (I(k) of the pace window,
    t, the filtered ground track, the observed foot points): that window says Pedestrian and
    its pace and stride are the track's."""
    (tracks, verdicts, objs), _ = crossing
    (obj,) = objs
    k0, k1 = obj.result["window"]
    sl = slice(k0, k1)
    t = np.asarray(tracks["t"][sl])
    xy = np.stack([tracks["x_est"][sl], tracks["y_est"][sl]], 1)
    seen = np.asarray(tracks["state"][sl]) == "observe"
    observed = np.where(seen[:, None], np.stack([tracks["u"][sl], tracks["v"][sl]], 1), np.nan)
    res = classify_window_jit(CFG, jnp.asarray(tracks[PACE_COLUMN][sl], jnp.float32),
                              jnp.asarray(t - t[0], jnp.float32), jnp.asarray(xy, jnp.float32),
                              jnp.asarray(True), jnp.asarray(observed, jnp.float32))
    assert int(res.verdict) == PED
    assert float(res.pace_hz) == pytest.approx(float(verdicts["pace_hz"][0]), abs=1e-6)
    assert float(res.stride_m) == pytest.approx(float(verdicts["stride_m"][0]), abs=1e-6)


@pytest.mark.parametrize("segment_rows", [4096, 48])  # the fast path; the long-track path
def test_the_batch_classifier_reads_the_pace_column(crossing, tmp_path, segment_rows):
    """The written tracks (with the candidate and pace columns) read back and batch-classified
    give the tracker's verdict, pace and stride; without the pace column, window B's."""
    outs = []
    for i, (tracks, verdicts, _) in enumerate(crossing):
        path = tmp_path / f"tracks{i}.csv"
        write_table(str(path), tracks, TRACK_ORDER + candidate_columns(tracks))
        back = read_tracks(str(path), fps=CFG.camera.fps)
        assert back.pace_window == (i == 0)
        assert back.candidates.shape[1] == len(CANDIDATE_COLUMNS) + len(ACROSS_COLUMNS) + (i == 0)
        gap = max(1, round(float(CFG.thresholds.predict_timeout) * CFG.camera.fps))
        batch = to_batch(back, max_gap_frames=gap, min_len=CFG.thresholds.n)
        again = classify_tracks(CFG, batch, progress=False, segment_rows=segment_rows)
        assert list(again["verdict"]) == list(verdicts["verdict"])
        for k in ("pace_hz", "stride_m"):
            assert float(again[k][0]) == pytest.approx(float(verdicts[k][0]), abs=1e-5), k
        outs.append(float(again["pace_hz"][0]))
    assert outs[0] != outs[1]


def test_a_pace_column_alone_is_read_and_checked(tmp_path):
    """`intensity_wide` without the candidate columns: one extra column, flagged; a negative
    value is refused naming the file's column and line."""
    path = tmp_path / "t.csv"
    head = "track_id,frame,t,u,v,width_px,intensity,intensity_wide\n"
    path.write_text(head + "1,0,0.0,10,20,5,3.0,7.0\n1,1,0.0667,11,20,5,4.0,9.0\n")
    back = read_tracks(str(path))
    assert back.pace_window and back.candidates.shape == (2, 1)
    assert back.candidates[:, 0].tolist() == [7.0, 9.0]
    path.write_text(head + "1,0,0.0,10,20,5,3.0,7.0\n1,1,0.0667,11,20,5,4.0,-9.0\n")
    with pytest.raises(BadInput, match="intensity_wide") as err:
        read_tracks(str(path))
    assert "line 3" in str(err.value)
