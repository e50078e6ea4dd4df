"""The discrete gates (10), (11), (14) and the detection range, alone and inside the filter
(STYLE R8; RELIABILITY.md section 5, item 7).

Hand cases sit at d^2 = 8.9 and 9.1 against k_sigma = 3 (k^2 = 9).
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model import ekf
from rhythmjax.model.gates import (
    PaperGates,
    in_range,
    outlier_distance2,
    outlier_ok,
    walking_ok,
    width_distance2,
    width_ok,
)
from rhythmjax.model.params import Camera, Noise, Thresholds, WalkingModel, WidthModel

from .helpers import (
    CamRef,
    F_ref,
    PaperGatesRef,
    Q_ref,
    R_ref,
    depth_ref,
    ekf_reference,
    project_ref,
    simulate_tracks,
)


TOL = {  # measured (CPU, jax 0.10.2) in brackets
    "d2_hand": 1e-3,  # |d2 - planted d2|, float32 [1.1e-5]
    "identity_f64": 1e-10,  # relative, (11) three ways in float64 [2.3e-14]
    "f32_vs_f64_band": 1e-4,  # relative band around k^2 where f32/f64 decisions may differ
    # [relative error of d2 >= 1 in float32: median 2.3e-6, max 5.4e-5 for (11); 9.6e-6 for (10)]
    "f32_vs_f64_fraction": 1e-3,  # at most this fraction of disagreements, all in the band [0]
}
CAM, K2 = CamRef(), 9.0
WIDTH, WALK, THR = WidthModel(), WalkingModel(), Thresholds()
NOISE_ARGS = dict(q_std=(0.4, 0.4), r_std=(1.5, 1.5), init_speed_std=1.0)
SIDES = [(8.9, True), (9.1, False)]


def f32(a):
    return jnp.asarray(a, jnp.float32)


def _width_px(wid, y=10.0):
    return 800.0 * wid / float(depth_ref(CAM, y))


@pytest.mark.parametrize("d2, accept", SIDES)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_width_gate_10_hand_cases(d2, accept, sign):
    z = f32(project_ref(*CAM.args(), 0.4, 10.0))
    wid = 0.5 + sign * 0.12 * math.sqrt(d2)  # (wid - 0.5)^2 / 0.12^2 = d2
    w = f32(_width_px(wid))
    assert float(width_distance2(Camera(), WIDTH, z, w)) == pytest.approx(d2, abs=TOL["d2_hand"])
    assert bool(width_ok(Camera(), WIDTH, THR.k_sigma1, z, w)) is accept
    assert PaperGatesRef(CAM).width_d2(np.asarray(z, np.float64), float(w)) == pytest.approx(
        d2, abs=TOL["d2_hand"])


def _prior():
    P = np.array([[0.04, 0.01, 0.005, 0.0], [0.01, 0.3, 0.0, 0.02],
                  [0.005, 0.0, 0.25, 0.05], [0.0, 0.02, 0.05, 0.4]])
    return np.array([0.5, 1.2, 10.0, -0.3]), P


@pytest.mark.parametrize("d2, accept", SIDES)
def test_outlier_gate_11_hand_cases(d2, accept):
    m, P = _prior()
    w = np.array([1.0, -2.0, 0.5, 1.5])
    dx = np.linalg.cholesky(P) @ (w * math.sqrt(d2) / np.linalg.norm(w))  # dx^T P^-1 dx = d2
    prior = ekf.Gaussian(f32(m), f32(P))
    got = float(outlier_distance2(prior, f32(m + dx)))
    assert got == pytest.approx(d2, abs=TOL["d2_hand"])
    assert bool(outlier_ok(prior, f32(m + dx), THR.k_sigma2)) is accept
    assert bool(outlier_ok(prior, f32(m - dx), THR.k_sigma2)) is accept  # symmetric
    assert PaperGatesRef(CAM).outlier_d2(m, P, m + dx) == pytest.approx(d2, rel=1e-12)


@pytest.mark.parametrize("d2, accept", SIDES)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_walking_gate_14_hand_cases(d2, accept, sign):
    pace_ok, stride_ok = 2.05 + 0.183 * 2.0, 0.72 - 0.09 * 2.0  # d2 = 4 each
    pace = 2.05 + sign * 0.183 * math.sqrt(d2)
    stride = 0.72 + sign * 0.09 * math.sqrt(d2)
    assert bool(walking_ok(WALK, THR.k_sigma3, f32(pace), f32(stride_ok))) is accept
    assert bool(walking_ok(WALK, THR.k_sigma3, f32(pace_ok), f32(stride))) is accept
    assert bool(walking_ok(WALK, THR.k_sigma3, f32(pace), f32(stride))) is accept
    both = walking_ok(WALK, THR.k_sigma3, f32([pace_ok, pace]), f32([stride_ok, stride]))
    np.testing.assert_array_equal(np.asarray(both), [True, accept])


def test_detection_range_hand_cases():
    y = f32([2.99, 3.0, 10.0, 20.0, 20.01, -5.0, 1e6])
    np.testing.assert_array_equal(np.asarray(in_range(THR, y)),
                                  [False, True, True, True, False, False, False])


def test_nan_or_inf_in_any_input_rejects():
    cam, k = Camera(), THR.k_sigma1
    z, w = f32(project_ref(*CAM.args(), 0.0, 10.0)), f32(_width_px(0.5))
    assert bool(width_ok(cam, WIDTH, k, z, w))  # the clean case passes
    for zz, ww in ((z.at[0].set(jnp.nan), w), (z.at[1].set(jnp.nan), w), (z, f32(jnp.nan)),
                   (z, f32(jnp.inf)), (z.at[1].set(jnp.inf), w), (f32([256.0, 20.0]), w)):
        assert not bool(width_ok(cam, WIDTH, k, zz, ww))
    m, P = (f32(a) for a in _prior())
    prior = ekf.Gaussian(m, P)
    assert bool(outlier_ok(prior, m + 0.01, k))
    for pr, tm in ((ekf.Gaussian(m.at[2].set(jnp.nan), P), m), (prior, m.at[0].set(jnp.nan)),
                   (ekf.Gaussian(m, P.at[1, 1].set(jnp.nan)), m + 0.01),
                   (ekf.Gaussian(m, P.at[0, 0].set(-1.0)), m + 0.01),  # not PD
                   (prior, m.at[3].set(jnp.inf))):
        assert not bool(outlier_ok(pr, tm, k))
    assert bool(walking_ok(WALK, k, f32(2.0), f32(0.7)))
    for pace, stride in ((jnp.nan, 0.7), (2.0, jnp.nan), (jnp.inf, 0.7)):
        assert not bool(walking_ok(WALK, k, f32(pace), f32(stride)))
    assert not bool(in_range(THR, f32(jnp.nan)))


def test_outlier_distance_identity_float64():
    rng = np.random.default_rng(0)
    for _ in range(50):
        A = rng.standard_normal((4, 4))
        P = A @ A.T + 0.1 * np.eye(4)
        H = rng.standard_normal((2, 4)) * 50
        R = R_ref((1.5, 2.0), 0.3)
        nu = rng.standard_normal(2) * 3
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        m = rng.standard_normal(4)
        identity = nu @ np.linalg.solve(S, H @ P @ H.T @ np.linalg.solve(S, nu))
        naive = (K @ nu) @ np.linalg.inv(P) @ (K @ nu)
        with jax.enable_x64(True):
            got = float(outlier_distance2(ekf.Gaussian(jnp.asarray(m), jnp.asarray(P)),
                                          jnp.asarray(m + K @ nu)))
        assert got == pytest.approx(identity, rel=TOL["identity_f64"])
        assert got == pytest.approx(naive, rel=TOL["identity_f64"])


def _realistic_cases(n=10_000):
    """Priors P(k|k-1) from filtering 10 simulated walkers, and z whose d2 straddles k^2 = 9."""
    sim = simulate_tracks(np.random.default_rng(5), 10, 120, CAM, **NOISE_ARGS)
    outs = [_run(ekf.FromAnnotations(), sim["z"][i], sim["width"][i], sim["dt"][i])
            for i in range(10)]  # the program of the PaperGates tests below: no new compile
    rng = np.random.default_rng(6)
    b, k = rng.integers(0, 10, n), rng.integers(2, 120, n)
    dt = sim["dt"][b, k]
    F = np.stack([F_ref(d) for d in dt])
    post_m = np.stack([outs[i].steps.mean[j - 1] for i, j in zip(b, k, strict=True)])
    post_P = np.stack([outs[i].steps.cov[j - 1] for i, j in zip(b, k, strict=True)])
    means = np.einsum("nij,nj->ni", F, post_m.astype(np.float64)).astype(np.float32)
    Q = np.stack([Q_ref(NOISE_ARGS["q_std"], d) for d in dt])
    covs = (F @ post_P.astype(np.float64) @ np.swapaxes(F, 1, 2) + Q).astype(np.float32)
    nu = rng.standard_normal((n, 2)) * rng.uniform(1.0, 15.0, (n, 1))
    u, v = project_ref(*CAM.args(), means[:, 0].astype(np.float64), means[:, 2].astype(np.float64))
    zs = (np.stack([u, v], -1) + nu).astype(np.float32)
    return means, covs, zs


def _outlier_d2_float64(means, covs, zs):
    """(11) for a batch in float64 NumPy: H by central differences, K by a solve, and the
    explicit inverse of P(k|k-1), on the same float32-representable inputs."""
    m, P, z = (a.astype(np.float64) for a in (means, covs, zs))
    eps = 1e-4
    cols = []
    for j in range(4):
        e = np.zeros(4)
        e[j] = eps
        hp = np.stack(project_ref(*CAM.args(), (m + e)[:, 0], (m + e)[:, 2]), -1)
        hm = np.stack(project_ref(*CAM.args(), (m - e)[:, 0], (m - e)[:, 2]), -1)
        cols.append((hp - hm) / (2 * eps))
    H = np.stack(cols, -1)  # (n, 2, 4)
    S = H @ P @ np.swapaxes(H, 1, 2) + R_ref(NOISE_ARGS["r_std"])
    K = np.swapaxes(np.linalg.solve(S, H @ P), 1, 2)
    nu = z - np.stack(project_ref(*CAM.args(), m[:, 0], m[:, 2]), -1)
    dx = np.einsum("nij,nj->ni", K, nu)
    return np.einsum("ni,nij,nj->n", dx, np.linalg.inv(P), dx)


def test_float32_decisions_equal_float64_decisions():
    means, covs, zs = _realistic_cases()
    noise = Noise(**NOISE_ARGS)
    # float32 library: the temporary update, then (11); and (10) on random widths
    @jax.jit
    @jax.vmap
    def outlier_d2_float32(m, P, z):
        prior = ekf.Gaussian(m, P)
        return outlier_distance2(prior, ekf.update(Camera(), noise, prior, z).posterior.mean)

    @jax.jit
    @jax.vmap
    def width_d2_float32(z, w):
        return width_distance2(Camera(), WIDTH, z, w)

    d2_32 = np.asarray(outlier_d2_float32(f32(means), f32(covs), f32(zs)), np.float64)
    rng = np.random.default_rng(8)
    widths = (800.0 * 0.5 / depth_ref(CAM, means[:, 2].astype(np.float64))
              * rng.uniform(0.1, 1.9, len(means))).astype(np.float32)
    w2_32 = np.asarray(width_d2_float32(f32(zs), f32(widths)), np.float64)
    # float64 NumPy on the same (float32-representable) inputs
    d2_64 = _outlier_d2_float64(means, covs, zs)
    gates = PaperGatesRef(CAM)
    w2_64 = np.array([gates.width_d2(z, float(w)) for z, w in zip(zs.astype(np.float64), widths,
                                                                    strict=True)])
    report = {}
    for name, a, b in (("(11)", d2_32, d2_64), ("(10)", w2_32, w2_64)):
        assert np.isfinite(a).all() and np.isfinite(b).all()  # never NaN for finite input
        near = np.abs(b - K2) <= TOL["f32_vs_f64_band"] * K2
        differ = (a <= K2) != (b <= K2)
        rel = (np.abs(a - b) / b)[b >= 1.0]  # relative error of d2 where d2 >= 1
        report[name] = {"median rel err": float(np.median(rel)), "max": float(rel.max()),
                        "disagree": int(differ.sum()), "in band": int(near.sum()),
                        "accept": float((b <= K2).mean())}
        assert 0.2 < (b <= K2).mean() < 0.8, name  # the cases straddle the threshold
        assert np.all(near[differ]), name  # any disagreement is within the band ...
        assert differ.mean() <= TOL["f32_vs_f64_fraction"], name  # ... and rare
    print("\nfloat32 vs float64 gate distances:", report)


# ----------------------------------------------------------------------------------------------
# PaperGates inside the filter


@pytest.fixture(scope="module")
def walker():
    sim = simulate_tracks(np.random.default_rng(21), 1, 120, CAM, width_m=(0.5, 0.0),
                          **NOISE_ARGS)
    z, w = sim["z"][0].copy(), sim["width"][0].copy()
    z[40, 0] += 60.0  # an outlier: 60 px to the right
    w[70] *= 2.5  # a wrong width (an occlusion or a merged blob) with a good foot point
    return z, w, sim["dt"][0]


JIT_TRACK = eqx.filter_jit(ekf.filter_track)


def _run(validity, z, w, dt):
    return jax.tree.map(np.asarray, JIT_TRACK(Camera(), Noise(**NOISE_ARGS), validity, f32(z),
                                              f32(w), f32(dt), jnp.ones(len(z), bool)))


def test_paper_gates_reject_outlier_and_wrong_width(walker):
    z, w, dt = walker
    paper = _run(PaperGates(WIDTH, THR), z, w, dt)
    annot = _run(ekf.FromAnnotations(), z, w, dt)
    assert paper.steps.started[0] and annot.steps.started[0]
    assert not paper.steps.valid[40] and annot.steps.valid[40]  # (11) rejects the outlier
    assert not paper.steps.valid[70] and annot.steps.valid[70]  # (10) rejects the width
    assert float(width_distance2(Camera(), WIDTH, f32(z[70]), f32(w[70]))) > 9.0
    assert float(width_distance2(Camera(), WIDTH, f32(z[69]), f32(w[69]))) < 1.0
    assert paper.steps.valid[1:].mean() > 0.9  # and the rest goes through
    # the outlier drags the FromAnnotations estimate, not the gated one
    jump = lambda o: abs(o.steps.mean[40, 0] - o.steps.pred_mean[40, 0])
    assert jump(annot) > 5 * jump(paper)
    # the reference loop with PaperGatesRef makes the same decisions
    ref = ekf_reference(CAM, NOISE_ARGS["q_std"], R_ref(NOISE_ARGS["r_std"]), 1.0, z, w, dt,
                        gate=PaperGatesRef(CAM))
    np.testing.assert_array_equal(paper.steps.valid, ref["valid"])
    np.testing.assert_allclose(paper.steps.mean, ref["mean"], rtol=1e-4, atol=1e-4)


def test_paper_gates_start_in_range_and_predict_a_wrong_width(walker):
    z, w, dt = walker
    z, w = z.copy(), w.copy()
    z[:5] = [project_ref(*CAM.args(), 0.0, 25.0)] * 5  # beyond the detection range (Fig. 3)
    w[5:8] *= 3.0  # then in range but too wide for a pedestrian
    paper = _run(PaperGates(WIDTH, THR), z, w, dt)
    annot = _run(ekf.FromAnnotations(), z, w, dt)
    assert annot.steps.started[0] and annot.steps.valid[1:8].all()
    assert not paper.steps.started[:5].any() and paper.steps.started[5:].all()
    assert not paper.steps.valid[:8].any() and paper.steps.valid[8]  # (10) holds 6, 7 back
    ref = ekf_reference(CAM, NOISE_ARGS["q_std"], R_ref(NOISE_ARGS["r_std"]), 1.0, z, w, dt,
                        gate=PaperGatesRef(CAM))
    np.testing.assert_array_equal(paper.steps.started, ref["started"])
    np.testing.assert_array_equal(paper.steps.valid, ref["valid"])
