"""The foot-point outlier rule of self-calibration (`fit.selfcal_outliers`).

Reference: hand-built tracks, the foot points of a straight walk at constant speed projected by
a known camera (`rhythmjax.model.camera.project`) with 1.5 px Gaussian noise (seeded), and the
same track with one planted outlier. Tolerance: exact, the rule drops the planted row and no
other (the planted rows are 25-40 spreads out; the clean rows are under the 5-spread cut)."""

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
