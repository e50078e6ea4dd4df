"""`ekf_fused` (the EKF unrolled entry by entry for XLA's CPU fusion) is the readable `ekf`:
same state, covariance, NIS, log-likelihood, gate decisions and gradients, online and batch,
with either validity, through NaN gaps, padding and an outlier."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model import ekf, ekf_fused
from rhythmjax.model.gates import PaperGates
from rhythmjax.model.params import Camera, Noise

from .helpers import CamRef, simulate_tracks
from .test_ekf_step import _track


# float32, two differently ordered programs: measured max scaled differences on these tracks
# [mean 3e-6, cov 2e-6, nis 2e-5, loglik 2e-6]; float64 [~1e-13]
TOL32, TOL64 = 1e-4, 1e-10
NOISE_ARGS = dict(q_std=(0.4, 0.4), r_std=(1.5, 1.5), init_speed_std=1.0)


def scaled(a, b) -> float:
    """max |a - b| / max |b| per trailing component (velocities cross zero), then max."""
    a = np.asarray(a, np.float64).reshape(np.shape(a)[0], -1)
    b = np.asarray(b, np.float64).reshape(np.shape(b)[0], -1)
    s = np.abs(b).max(0)
    return float((np.abs(a - b).max(0) / np.where(s > 0, s, 1.0)).max())


def _sims(dtype):
    sim = simulate_tracks(np.random.default_rng(5), 6, 120, CamRef(), missing=(0.1, 0.5),
                          dt_jitter=0.3, **NOISE_ARGS)
    present = np.arange(120)[None] < np.array([[40], [60], [80], [100], [120], [120]])
    f = lambda a: jnp.asarray(a, dtype)
    return f(sim["z"]), f(sim["width"]), f(sim["dt"]), jnp.asarray(present)


def _compare(a: ekf.FilterOutput, b: ekf.FilterOutput, tol):
    for name in ("available", "valid", "started"):
        np.testing.assert_array_equal(getattr(a.steps, name), getattr(b.steps, name), name)
    for name in ("mean", "cov", "pred_mean", "innovation", "nis", "loglik"):
        x, y = getattr(a.steps, name), getattr(b.steps, name)
        x, y = x.reshape((-1,) + x.shape[2:]), y.reshape((-1,) + y.shape[2:])
        assert scaled(x, y) <= tol, (name, scaled(x, y))
    assert scaled(a.loglik[:, None], b.loglik[:, None]) <= tol


@pytest.mark.parametrize("dtype, tol", [(jnp.float32, TOL32), (jnp.float64, TOL64)])
def test_filter_batch_equals_readable(dtype, tol):
    with jax.enable_x64(dtype == jnp.float64):
        args = (Camera(), Noise(**NOISE_ARGS), ekf.FromAnnotations(), *_sims(dtype))
        _compare(ekf_fused.filter_batch(*args), ekf.filter_batch(*args), tol)


def test_gated_track_and_online_step_equal_readable():
    """The paper's gates (10), (11): the same measurements refused (an outlier at frame 40), the
    same start (waits for the range); `step` scanned online equals too."""
    cfg, (z, w, dt, p) = _track(0)
    gates = PaperGates(cfg.width, cfg.thresholds)
    a = ekf_fused.filter_track(cfg.camera, cfg.noise, gates, z, w, dt, p)
    b = ekf.filter_track(cfg.camera, cfg.noise, gates, z, w, dt, p)
    batch = lambda o: jax.tree.map(lambda x: x[None], o)
    _compare(batch(a), batch(b), TOL32)
    assert not bool(b.steps.valid[40]) and int(np.argmax(np.asarray(b.steps.started))) > 0

    def scan(module):
        body = lambda c, inp: module.step(cfg.camera, cfg.noise, gates, c, *inp)
        return jax.lax.scan(body, ekf.empty_carry(), (z, w, dt, p))[1]

    on_a, on_b = scan(ekf_fused), scan(ekf)
    np.testing.assert_array_equal(on_a.valid, on_b.valid)
    assert scaled(on_a.mean, on_b.mean) <= TOL32 and scaled(on_a.nis, on_b.nis) <= TOL32


def test_gradients_equal_readable():
    """d(total log-likelihood)/d(camera, noise) of both filters, float64 (to rounding)."""
    with jax.enable_x64(True):
        z, w, dt, p = _sims(jnp.float64)
        params = (Camera(h=1.05), Noise(q_std=(0.3, 0.5), r_std=(1.2, 1.9), init_speed_std=1.0))

        def grads(module):
            loss = lambda cn: jnp.sum(module.filter_batch(cn[0], cn[1], ekf.FromAnnotations(),
                                                          z, w, dt, p).loglik)
            return jax.grad(loss)(params)

        ga, gb = jax.tree.leaves(grads(ekf_fused)), jax.tree.leaves(grads(ekf))
        assert len(ga) == len(gb) == 12 and ga[0].dtype == jnp.float64
        for x, y in zip(ga, gb):
            np.testing.assert_allclose(np.asarray(x), np.asarray(y), rtol=1e-8,
                                       atol=1e-8 * max(1.0, float(np.abs(y).max())))
        assert any(float(np.abs(y).max()) > 1.0 for y in gb)  # real slopes, not zeros


def test_computed_once_is_an_exact_identity_with_unit_gradient():
    """The division by a runtime 1.0 that keeps XLA from recomputing shared terms (ekf_fused)
    changes no bit, leaves booleans alone, and has derivative exactly 1."""
    keep = ekf_fused._computed_once(jnp.eye(2, dtype=jnp.float32) * 2.25)
    x = jnp.asarray(np.random.default_rng(3).standard_normal(1000) * 1e3, jnp.float32)
    flag = x > 0
    got_x, got_flag = jax.jit(keep)((x, flag))
    assert got_x.dtype == x.dtype and bool(jnp.all(got_x == x))
    assert got_flag.dtype == jnp.bool_ and bool(jnp.all(got_flag == flag))
    g = jax.grad(lambda a: jnp.sum(keep(a) * a))(x)
    assert bool(jnp.all(g == 2 * x))  # d/da (a * a) with the identity in between


def test_same_public_signatures():
    import inspect

    for name in ("step", "filter_track", "filter_batch"):
        fa, fb = getattr(ekf_fused, name), getattr(ekf, name)
        fa, fb = getattr(fa, "__wrapped__", fa), getattr(fb, "__wrapped__", fb)
        assert inspect.signature(fa) == inspect.signature(fb), name
    assert eqx.is_array(ekf.empty_carry().state.mean)


def test_predict_equals_readable_and_the_matrix_form():
    """`ekf_fused.predict` (the online trackers' prediction) against `ekf.predict` and against
    (5), (8) written with NumPy float64 matrices: F X, F P F^T + Q,
    Q = diag(0, qx^2, 0, qy^2) dt."""
    rng = np.random.default_rng(3)
    noise = Noise(q_std=(0.4, 0.7))
    for _ in range(5):
        a = rng.normal(size=(4, 4))
        state = ekf.Gaussian(jnp.asarray(rng.normal(size=4), jnp.float32),
                             jnp.asarray(a @ a.T + np.eye(4), jnp.float32))
        dt = float(rng.uniform(0.03, 0.5))
        fused = ekf_fused.predict(noise, state, jnp.float32(dt))
        readable = ekf.predict(noise, state, jnp.float32(dt))
        F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1]], np.float64)
        Q = np.diag([0.0, 0.4 ** 2, 0.0, 0.7 ** 2]) * dt
        m, P = np.asarray(state.mean, np.float64), np.asarray(state.cov, np.float64)
        for got in (fused, readable):
            np.testing.assert_allclose(np.asarray(got.mean), F @ m, rtol=1e-6, atol=1e-6)
            np.testing.assert_allclose(np.asarray(got.cov), F @ P @ F.T + Q, rtol=1e-5,
                                       atol=1e-5)
