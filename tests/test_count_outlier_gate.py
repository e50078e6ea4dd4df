"""Gates on the counting tracker's measurements (`placement.outlier_gate`, "3d"): the rhythm
paper's outlier gate (11) ("paper") and the innovation gate ("innovation"). Each gate alone
against a float64 NumPy evaluation ((11); nu^T S^-1 nu), the slot filter with it against the
core EKF scanned with the same gate, and the pedestrians level turning a refused measurement into
a predicted row."""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.count import CountOptions
from rhythmjax.count.options import PlacementOptions
from rhythmjax.count.pedestrian_level import PedestrianLevel
from rhythmjax.count.slot_filter import SlotFilter
from rhythmjax.model import ekf
from rhythmjax.model.camera import measure
from rhythmjax.model.gates import InnovationGate, OutlierGate
from rhythmjax.model.status import TrackState

from .test_pedestrians import CFG, QUIET


def _numpy_d2(prior_mean, prior_cov, temporary_mean) -> float:
    """(11) in float64: [X(k|k-1) - X~]^T P(k|k-1)^-1 [X(k|k-1) - X~] by a linear solve."""
    d = np.asarray(prior_mean, np.float64) - np.asarray(temporary_mean, np.float64)
    return float(d @ np.linalg.solve(np.asarray(prior_cov, np.float64), d))


def test_the_gate_is_eq_11_alone():
    gate = OutlierGate(CFG.thresholds)
    k2 = float(CFG.thresholds.k_sigma2) ** 2
    prior = ekf.Gaussian(jnp.array([0.5, 0.8, 9.0, -0.6]),
                         jnp.diag(jnp.array([0.04, 0.3, 0.2, 0.3])) + 0.005)
    u0, v0 = (float(q) for q in measure(CFG.camera, prior.mean))  # the predicted foot point
    decisions = []
    for du, dv in [(0, 0), (2, -3), (6, 8), (15, -10), (25, 30), (-40, 5), (0, 60), (80, 80)]:
        z = jnp.array([u0 + du, v0 + dv], jnp.float32)
        cand = ekf.update(CFG.camera, CFG.noise, prior, z)
        want = _numpy_d2(prior.mean, prior.cov, cand.posterior.mean) <= k2
        got = bool(gate(CFG.camera, prior, cand, z, jnp.float32(jnp.nan)))  # width not read
        assert got == want, (du, dv)
        decisions.append(got)
    assert decisions[0] and not decisions[-1]  # both outcomes are exercised
    # any first measurement may start a track, even beyond the detection range
    assert bool(gate.accept_initial(CFG.camera, jnp.zeros(2), jnp.nan, jnp.array([0.0, 1e3])))


def test_the_innovation_gate_is_the_chi_square_test_of_nu():
    gate = InnovationGate(CFG.thresholds)
    k2 = float(CFG.thresholds.k_sigma2) ** 2
    prior = ekf.Gaussian(jnp.array([0.5, 0.8, 9.0, -0.6]),
                         jnp.diag(jnp.array([0.04, 0.3, 0.2, 0.3])) + 0.005)
    u0, v0 = (float(q) for q in measure(CFG.camera, prior.mean))
    R = np.asarray(CFG.noise.R(), np.float64)
    decisions = []
    for du, dv in [(0, 0), (2, -3), (6, 8), (9, 0), (15, -10), (0, 13), (-40, 5), (80, 80)]:
        z = jnp.array([u0 + du, v0 + dv], jnp.float32)
        cand = ekf.update(CFG.camera, CFG.noise, prior, z)
        S = np.asarray(cand.prior_meas_cov, np.float64) + R  # H P H^T + R
        nu = np.asarray(z, np.float64) - np.array([u0, v0])  # Y - h(X(k|k-1))
        want = float(nu @ np.linalg.solve(S, nu)) <= k2
        assert bool(gate(CFG.camera, prior, cand, z, jnp.float32(jnp.nan))) == want, (du, dv)
        decisions.append(want)
    assert decisions[0] and not decisions[-1]
    # 13 px down the foot row: the innovation gate refuses what (11) lets through
    z = jnp.array([u0, v0 + 13.0], jnp.float32)
    cand = ekf.update(CFG.camera, CFG.noise, prior, z)
    assert bool(OutlierGate(CFG.thresholds)(CFG.camera, prior, cand, z, jnp.nan))
    assert not bool(gate(CFG.camera, prior, cand, z, jnp.nan))


def _walk(T=40, outlier_at=25, seed=0):
    rng = np.random.default_rng(seed)
    k = np.arange(T)
    z = np.stack([60.0 + 2.5 * k, 120.0 - 0.8 * k], 1) + rng.normal(0, 2.0, (T, 2))
    z[outlier_at, 1] += 45.0  # the foot row slid down a nearer object's blob for one frame
    return z.astype(np.float32)


def _slot_run(z, gate: str):
    sf = SlotFilter(CFG, "3d", slots=3, outlier_gate=gate)
    rows = []
    for k in range(len(z)):
        zz = np.full((3, 2), np.nan, np.float32)
        zz[2] = z[k]
        got = sf.step(np.array([False, False, k == 0]), zz, np.array([False, False, True]),
                      1 / 15)
        rows.append((got.used[2], *got.ground[2], *got.velocity[2]))
    return np.asarray(rows)  # used, x, y, vx, vy


@pytest.mark.parametrize("name,gate", [("paper", OutlierGate), ("innovation", InnovationGate)])
def test_slot_filter_with_the_gate_is_the_core_ekf_with_it(name, gate):
    z = _walk()
    T = len(z)
    ref = eqx.filter_jit(ekf.filter_track)(
        CFG.camera, CFG.noise, gate(CFG.thresholds), jnp.asarray(z), jnp.full(T, jnp.nan),
        jnp.full(T, 1 / 15), jnp.ones(T, bool)).steps
    got = _slot_run(z, gate=name)
    used_ref = np.asarray(ref.valid) | (np.arange(T) == 0)  # the first measurement starts it
    np.testing.assert_array_equal(got[:, 0] > 0.5, used_ref)
    mean = np.asarray(ref.mean)
    np.testing.assert_allclose(got[:, 1:], mean[:, [0, 2, 1, 3]], rtol=1e-4, atol=2e-4)
    assert not used_ref[25] and used_ref[1:25].all() and used_ref[26:].all()
    # without the gate the same row is used and drags the ground velocity off
    free = _slot_run(z, gate="none")
    assert (free[:, 0] > 0.5).all()
    jump = lambda r: math.hypot(r[25, 3] - r[24, 3], r[25, 4] - r[24, 4])
    assert jump(free) > 1.0 > 10 * jump(got)


def _level_rows(gate: str, z):
    opt = CountOptions(verdicts=QUIET, placement=PlacementOptions(outlier_gate=gate))
    level = PedestrianLevel(CFG, opt)
    level.image_shape = (192, 256)
    p = level.new_pedestrian(0)
    level.peds.append(p)
    for k in range(len(z)):
        p.z = (float(z[k, 0]), float(z[k, 1]))
        out = level.filter.step(np.array([k == 0] + [False] * 31), np.vstack(
            [z[k][None], np.full((31, 2), np.nan, np.float32)]),
            np.array([True] + [False] * 31), 1 / 15)
        level._after(p, out, k, k / 15, 1 / 15, [], None)
    return p


def test_a_refused_measurement_is_a_predicted_row():
    z = _walk()
    on, off = _level_rows("paper", z), _level_rows("none", z)
    states = [r.state for r in on.rows]
    assert states[25] == TrackState.PREDICT and math.isnan(on.rows[25].u)
    assert all(s == TrackState.OBSERVE for i, s in enumerate(states) if i != 25)
    assert all(r.state == TrackState.OBSERVE for r in off.rows)
    assert off.rows[25].v == z[25, 1]
    assert on.coast == 0.0 and on.hits == len(z) - 1  # measured again after the refused row


def test_the_gate_is_off_by_default_and_checked():
    assert CountOptions().placement.outlier_gate == "none"
    with pytest.raises(ValueError, match="outlier_gate"):
        CountOptions(placement=PlacementOptions(outlier_gate="chi2"))
    with pytest.raises(ValueError, match="outlier_gate"):
        SlotFilter(CFG, "3d", slots=2, outlier_gate="yes")
