"""The foot-point outlier rule of self-calibration (`fit.selfcal_outliers`).

Reference: hand-built tracks, the foot points of a straight walk at constant speed projected by
a known camera (`rhythmjax.model.camera.project`) with 1.5 px Gaussian noise (seeded), and the
same track with one planted outlier. Tolerance: exact, the rule drops the planted row and no
other (the planted rows are 25-40 spreads out; the clean rows are under the 5-spread cut).

Also the observed-rows rule (`fit.selfcal_rows`, `--observed-only`): hand-built rows of each
state, and the tests' scene of 20 walkers (seed 11) with every 5th row turned into a refused
detection (state predict, a deliberately wrong foot point), against the same tracks with those
rows' foot points missing: equal fits to 1e-9 relative with the state, different without it."""

from __future__ import annotations

import math
import types

import jax.numpy as jnp
import numpy as np
import pytest

from fit.selfcal_outliers import (
    K_SIGMA,
    WINDOW_S,
    outlier_rows,
    track_outliers,
    without_outliers,
)
from rhythmjax.model.camera import project
from rhythmjax.model.params import Camera


F = 0.008
CAM = Camera(f=F, h=5.5, theta=math.radians(21.0), a=950 / F, b=950 / F, uc=640, vc=360,
             fps=15.0, image_width=1280, image_height=720)


def walk(n: int, seed: int, *, towards: bool) -> tuple[np.ndarray, np.ndarray]:
    """(t s, foot points (n, 2) px) of a walk at 1.3 m/s, 15 fps, 1.5 px noise: from 16 m
    towards the camera (strong foreshortening) or across the view at 9 m."""
    t = np.arange(n) / 15.0
    if towards:
        x, y = -2.0 + 0.3 * t, 16.0 - 1.3 * t
    else:
        x, y = -5.0 + 1.3 * t, 9.0 + 0.1 * t
    u, v = (np.asarray(q, np.float64) for q in project(CAM, jnp.asarray(x), jnp.asarray(y)))
    rng = np.random.default_rng(seed)
    return t, np.stack([u, v], -1) + rng.normal(0.0, 1.5, (n, 2))


@pytest.mark.parametrize("towards", [True, False])
@pytest.mark.parametrize("n", [60, 150])  # 4 s (one fit) and 10 s (windows of WINDOW_S)
def test_a_clean_walk_loses_nothing(towards, n):
    assert n / 15.0 > WINDOW_S or n == 60
    for seed in range(3):
        t, z = walk(n, seed, towards=towards)
        assert not track_outliers(t, z).any(), (seed, np.flatnonzero(track_outliers(t, z)))


@pytest.mark.parametrize("towards", [True, False])
@pytest.mark.parametrize("where", [0, 37, -1])  # first row, inside, the last row (dev_walk_03)
def test_one_planted_foot_point_is_dropped_alone(towards, where):
    t, z = walk(150, 1, towards=towards)
    z[where, 1] -= 60.0  # a head sliver above the walker's feet
    drop = track_outliers(t, z)
    assert np.flatnonzero(drop).tolist() == [np.arange(150)[where]]
    t, z = walk(150, 2, towards=towards)
    z[where, 0] += 40.0  # a jump to a neighbouring blob, in u only
    assert np.flatnonzero(track_outliers(t, z)).tolist() == [np.arange(150)[where]]


def test_short_tracks_are_left_alone():
    t, z = walk(7, 0, towards=False)
    z[3, 1] -= 100.0
    assert not track_outliers(t, z).any()


def test_the_batch_loses_the_row_s_foot_point_width_and_top_but_keeps_its_rhythm():
    t, z = walk(120, 4, towards=True)
    z[50, 1] -= 80.0
    T = 128
    pad = lambda a, fill=np.nan: np.concatenate([a, np.full((T - len(a),) + a.shape[1:], fill)])
    batch = types.SimpleNamespace(
        z=pad(z)[None].astype(np.float32), t=pad(t, 0.0)[None].astype(np.float32),
        width=np.full((1, T), 30.0, np.float32), intensity=np.ones((1, T), np.float32),
        v_top=np.full((1, T), 100.0, np.float32),
        present=(np.arange(T) < 120)[None])
    assert np.flatnonzero(outlier_rows(batch)[0]).tolist() == [50]
    # a dataclass is needed for dataclasses.replace: the library's TrackBatch
    from rhythmjax.io import TrackBatch

    tb = TrackBatch(ids=["a"], z=batch.z, width=batch.width, intensity=batch.intensity,
                    t=batch.t, dt=np.full((1, T), 1 / 15, np.float32), present=batch.present,
                    length=np.array([120], np.int32), v_top=batch.v_top)
    clean, drop = without_outliers(tb)
    assert np.flatnonzero(drop[0]).tolist() == [50]
    assert np.isnan(clean.z[0, 50]).all() and np.isnan(clean.width[0, 50])
    assert np.isnan(clean.v_top[0, 50]) and clean.intensity[0, 50] == 1.0
    assert np.isfinite(clean.z[0, :120]).sum() == 2 * 119
    assert K_SIGMA == 5.0  # the constant docs/selfcal.md states


# ----------------------------------------------------------------------------------------------
# rows used: measured and observed (`fit.selfcal_rows`, the tracker's `state` column)

def _tracks_of(**cols):
    from rhythmjax.io import Tracks

    n = len(cols["u"])
    base = dict(path="t", track_id=np.array(["a"] * n, object), frame=np.arange(n),
                t=np.arange(n) / 15.0, width_px=np.full(n, 30.0), intensity=np.ones(n),
                line=np.arange(n) + 2, v_top=np.full(n, 100.0))
    return Tracks(**{**base, **cols})


def test_only_observed_rows_keep_their_foot_point_width_and_top():
    from fit.selfcal_rows import observed_rows, unobserved

    state = np.array(["observe", "predict", "none", "", "detect", "predict"], object)
    u = np.array([1.0, 2.0, np.nan, 4.0, 5.0, np.nan])
    tr = _tracks_of(u=u, v=u + 100, state=state)
    assert unobserved(tr).tolist() == [False, True, True, False, True, True]
    out, n = observed_rows(tr)
    assert n == 2  # rows 1 and 4 held a foot point
    assert np.isfinite(out.u).tolist() == [True, False, False, True, False, False]
    for a in (out.v, out.width_px, out.v_top):
        assert np.isfinite(a).tolist() == [True, False, False, True, False, False]
    assert (out.intensity == 1.0).all() and out.state is tr.state  # the rhythm is kept
    same, n = observed_rows(_tracks_of(u=u, v=u + 100))  # no state column: used as before
    assert n == 0 and same.u is u


@pytest.fixture(scope="module")
def gated_out():
    """20 walkers (seed 11) and, on every 5th row of each track, a detection the gates refused:
    state predict, the foot point 40 px up and 25 px right, width x 1.6, top 30 px up."""
    from fit.walking import make_labelled

    cols, _ = make_labelled(n_walkers=20, seed=11, camera=CAM)
    keep = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "v_top")
    cols = {k: cols[k] for k in keep}
    first = np.r_[True, cols["track_id"][1:] != cols["track_id"][:-1]]
    pos = np.arange(len(first)) - np.maximum.accumulate(np.where(first, np.arange(len(first)),
                                                                 0))
    bad = (pos % 5 == 3) & np.isfinite(cols["u"])
    missing = {**cols, **{k: np.where(bad, np.nan, cols[k]) for k in ("u", "v", "width_px",
                                                                     "v_top")}}
    wrong = {**cols, "u": np.where(bad, cols["u"] + 25.0, cols["u"]),
             "v": np.where(bad, cols["v"] - 40.0, cols["v"]),
             "width_px": np.where(bad, 1.6 * cols["width_px"], cols["width_px"]),
             "v_top": np.where(bad, cols["v_top"] - 30.0, cols["v_top"]),
             "state": np.where(bad, "predict", "observe").astype(object)}
    return missing, wrong, int(bad.sum())


def _selfcal(tmp_path, name, cols, capsys, *extra):
    import json

    from fit.cli import main as fit_main
    from rhythmjax.io import write_table

    p, out = tmp_path / f"{name}.parquet", tmp_path / f"{name}.json"
    write_table(p, cols, list(cols))
    capsys.readouterr()
    rc = fit_main(["selfcal", str(p), "--image-size", "1280x720", "--fps", "15", "-o",
                   str(out), "--json", *extra])
    return rc, json.loads(capsys.readouterr().out)


def test_predicted_rows_do_not_reach_the_fit_when_the_state_is_given(tmp_path, gated_out,
                                                                     capsys):
    """With `--observed-only` the refused detections (deliberately wrong foot points on predict
    rows) change nothing when the tracks give the state: the fit is the one of the tracks
    without those rows (to 1e-9); without the state column they are used and the fit moves (h by
    more than 1 % or the tilt by more than 0.3 deg), so the test can fail."""
    missing, wrong, n_bad = gated_out
    assert n_bad > 300
    rc0, ref = _selfcal(tmp_path, "missing", missing, capsys)
    rc1, given = _selfcal(tmp_path, "given", wrong, capsys, "--observed-only")
    assert rc0 == 0 and rc1 == 0, (ref["reasons"], given["reasons"])
    for k in ("h", "theta", "af"):
        assert abs(given["values"][k] - ref["values"][k]) <= 1e-9 * abs(ref["values"][k]), k
    assert any(f"{n_bad} foot points of rows the tracker did not observe" in q
               for q in given["notes"]), given["notes"]
    absent = {k: v for k, v in wrong.items() if k != "state"}
    _, used = _selfcal(tmp_path, "absent", absent, capsys, "--observed-only")
    assert used["values"] is not None
    moved = (abs(used["values"]["h"] / ref["values"]["h"] - 1) > 0.01
             or abs(used["values"]["theta"] - ref["values"]["theta"]) > 0.3)
    assert moved, (used["values"], ref["values"])
