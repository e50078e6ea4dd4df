"""`life.jump_sigma`: the velocity-jump end asks that the change of the ground velocity be more
than `sigma` standard deviations of the filter's own velocity noise (`track.toolkit.
velocity_jump`'s sigma). The covariance it reads (`slot_filter.FilterOut.velocity_cov`) against
the float64 EKF loop of tests/helpers.py; the test on hand-worked 2x2 cases and against
`np.linalg.solve` on random ones; the option through the pedestrians level."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from rhythmjax.count import CountOptions
from rhythmjax.count.options import with_changes
from rhythmjax.count.rows import GroundRow
from rhythmjax.count.slot_filter import SlotFilter
from rhythmjax.track.toolkit import velocity_jump

from .helpers import cam_ref_of, ekf_reference
from .test_pedestrians import CFG, FAST


def _v(vx, vy, sxx=math.nan, sxy=math.nan, syy=math.nan):
    return SimpleNamespace(vx=vx, vy=vy, var_vx=sxx, cov_vxy=sxy, var_vy=syy)


def test_velocity_cov_is_the_ekf_posterior():
    rng = np.random.default_rng(3)
    T = 40
    k = np.arange(T)
    z = (np.stack([60.0 + 2.5 * k, 120.0 - 0.8 * k], 1) + rng.normal(0, 2.0, (T, 2)))
    present = np.ones(T, bool)
    present[[7, 8, 20]] = False  # predicted frames: the covariance grows
    z = z.astype(np.float32)
    sf = SlotFilter(CFG, "3d", slots=3)
    got = []
    for i in range(T):
        zz = np.full((3, 2), np.nan, np.float32)
        zz[2] = z[i] if present[i] else np.nan
        out = sf.step(np.array([False, False, i == 0]), zz, np.array([False, False, True]),
                      1 / 15)
        got.append(out.velocity_cov[2])
    nz = CFG.noise
    ref = ekf_reference(cam_ref_of(CFG.camera), np.asarray(nz.q_std(), np.float64),
                        np.asarray(nz.R(), np.float64), float(nz.init_speed_std()),
                        np.where(present[:, None], z, np.nan), dt=np.full(T, 1 / 15),
                        present=present)
    want = np.stack([ref["cov"][:, 1, 1], ref["cov"][:, 1, 3], ref["cov"][:, 3, 3]], 1)
    got = np.asarray(got)
    # float32 filter against the float64 loop: 1e-3 of the variances' scale
    scale = np.max(np.abs(want[:, [0, 2]]), axis=1, keepdims=True)
    assert np.max(np.abs(got - want) / scale) < 1e-3
    assert want[21, 2] > want[19, 2]  # a predicted frame widens it


def test_the_sigma_test_by_hand():
    k, steady = 7, [_v(1.4, 0.0, 0.25, 0.0, 0.25)] * 15
    # dv (2, 0) over 1.5 m/s; S = diag(0.5, 0.5): dv^T S^-1 dv = 4 / 0.5 = 8
    jump = steady + [_v(3.4, 0.0, 0.25, 0.0, 0.25)]
    assert velocity_jump(jump, k, 1.5) == k  # the m/s test alone
    assert velocity_jump(jump, k, 1.5, sigma=3.0) == 0  # 8 <= 9: the filter's noise
    assert velocity_jump(jump, k, 1.5, sigma=2.8) == k  # 8 > 7.84
    # correlated: each P = [[0.5, 0.25], [0.25, 0.5]], S = [[1, 0.5], [0.5, 1]], det 0.75;
    # dv (2, 2): (4 - 4 + 4) / 0.75 = 5.33; dv (2, -2): (4 + 4 + 4) / 0.75 = 16
    base = [_v(0.0, 0.0, 0.5, 0.25, 0.5)] * 15
    assert velocity_jump(base + [_v(2.0, 2.0, 0.5, 0.25, 0.5)], k, 1.5, sigma=3.0) == 0
    assert velocity_jump(base + [_v(2.0, -2.0, 0.5, 0.25, 0.5)], k, 1.5, sigma=3.0) == k
    # under 1.5 m/s: never, however small the noise
    assert velocity_jump(steady + [_v(2.8, 0.0, 1e-6, 0.0, 1e-6)], k, 1.5, sigma=3.0) == 0
    # no covariance (NaN) or a singular one: the m/s test alone
    assert velocity_jump([_v(1.4, 0.0)] * 15 + [_v(3.4, 0.0)], k, 1.5, sigma=3.0) == k
    assert velocity_jump([_v(0.0, 0.0, 0.5, 0.5, 0.5)] * 16, k, 1.5, sigma=3.0) == 0
    assert velocity_jump([_v(0.0, 0.0, 0.5, 0.5, 0.5)] * 15 + [_v(2.0, 0.0, 0.5, 0.5, 0.5)], k,
                         1.5, sigma=3.0) == k
    # 2k rows or fewer: never
    assert velocity_jump([_v(1.4, 0.0, 0.01, 0.0, 0.01)] * 13 + [_v(9.0, 0.0, 0.01, 0.0, 0.01)],
                         k, 1.5, sigma=3.0) == 0


def test_the_sigma_test_against_a_solve():
    rng = np.random.default_rng(11)
    k, checked = 3, 0
    for _ in range(600):
        A = rng.normal(0, 0.6, (2, 2))
        B = rng.normal(0, 0.6, (2, 2))
        Pa, Pb = A @ A.T + 1e-3 * np.eye(2), B @ B.T + 1e-3 * np.eye(2)
        dv = rng.normal(0, 2.5, 2)
        sigma = float(rng.uniform(0.5, 4.0))
        d2 = float(dv @ np.linalg.solve(Pa + Pb, dv))
        if abs(d2 - sigma**2) < 1e-6 * sigma**2 or abs(np.hypot(*dv) - 1.5) < 1e-9:
            continue
        rows = [_v(0.0, 0.0, Pb[0, 0], Pb[0, 1], Pb[1, 1])] * (2 * k) + \
            [_v(dv[0], dv[1], Pa[0, 0], Pa[0, 1], Pa[1, 1])]
        want = k if (np.hypot(*dv) > 1.5 and d2 > sigma**2) else 0
        assert velocity_jump(rows, k, 1.5, sigma=sigma) == want
        checked += 1
    assert checked > 550


@pytest.mark.parametrize("sigma", [0.0, 3.0])
def test_the_option_reaches_the_level(sigma):
    from rhythmjax.count.pedestrian_level import Pedestrian, PedestrianLevel

    level = PedestrianLevel(CFG, with_changes(FAST, {"life.jump_sigma": sigma}))
    k, p = round(0.5 * 15), Pedestrian(slot=0, born=0)
    # a 2 m/s swing in depth where the filter's velocity variance in depth is 1 (m/s)^2:
    # 4 / 2 = 2 <= 9, noise; across, where it is 0.01: 4 / 0.02 = 200 > 9, a jump
    far = [GroundRow(0.0, 14.0, 1.4, 0.0, 0.0, 0.0, 0.01, 0.0, 1.0)] * 20
    p.ground = far + [GroundRow(3.0, 14.0, 1.4, 2.0, 0.0, 0.0, 0.01, 0.0, 1.0)]
    assert level._velocity_jump(p) == (0 if sigma else k)
    p.ground = far + [GroundRow(3.0, 14.0, 3.4, 0.0, 0.0, 0.0, 0.01, 0.0, 1.0)]
    assert level._velocity_jump(p) == k


def test_a_negative_or_nan_sigma_is_refused():
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="life.jump_sigma"):
            with_changes(CountOptions(), {"life.jump_sigma": bad})
