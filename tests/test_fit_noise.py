"""fit.noise: Q and R by the EKF's innovation likelihood (issue 5). Tolerances inline."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.flatten_util
import jax.numpy as jnp
import numpy as np
import pytest

from fit.noise import _spec, fit_noise, neg_loglik, simulate
from rhythmjax.model.params import Camera, Noise


TRUE = {"q_x": 0.3, "q_y": 0.5, "r_u": 1.5, "r_v": 2.5}


def test_recovers_q_and_r():
    # 200 tracks x 100 steps simulated from (1)-(3) with known Q, R; start from Table 1's
    # defaults (q 0.4, r 2 px). Each value within 15 % and within 3.5 reported SE of the truth.
    cam = Camera()
    true = Noise(q_std=(0.3, 0.5), r_std=(1.5, 2.5), init_speed_std=1.0)
    z, w, dt, pr = simulate(cam, true, np.random.default_rng(0), 200, 100)
    r = fit_noise(cam, z, w, dt, pr, Noise(init_speed_std=1.0))
    assert r.success and not r.ill_determined, r.summary()
    for k, t in TRUE.items():
        assert abs(r.values[k] / t - 1) < 0.15, (k, r.values[k])
        assert abs(r.values[k] - t) < 3.5 * r.se[k], (k, r.values[k], r.se[k])
    assert abs(r.values["r_corr"]) < 3.5 * r.se["r_corr"]
    assert r.gain > 0 and r.num_steps > 0
    assert "init_speed_std" not in r.se  # held fixed
    np.testing.assert_allclose(np.asarray(r.noise.q_std()), [r.values["q_x"], r.values["q_y"]],
                               rtol=1e-5)


def test_loss_gradient_matches_central_differences():
    cam = Camera()
    z, w, dt, pr = simulate(cam, Noise(), np.random.default_rng(1), 6, 30)
    z[0, 5] = np.nan  # a missing measurement
    pr[1, 25:] = False  # padding
    with jax.enable_x64(True):
        to64 = lambda a: jnp.asarray(a, jnp.float64) if eqx.is_inexact_array(a) else a
        n0 = jax.tree.map(to64, Noise(q_std=(0.5, 0.3), r_std=(1.2, 2.2), r_corr=0.2))
        c = jax.tree.map(to64, cam)
        dyn, st = eqx.partition(n0, _spec(("log_q", "log_r_diag", "r_offdiag",
                                           "log_init_speed_std")))
        args = (st, c, jnp.asarray(z), jnp.asarray(w), jnp.asarray(dt), jnp.asarray(pr))
        flat, unravel = jax.flatten_util.ravel_pytree(dyn)
        fun = jax.jit(lambda p: neg_loglik(unravel(p), args))
        g = np.asarray(jax.grad(fun)(flat))
        eps = 1e-5
        fd = np.array([(float(fun(flat.at[i].add(eps))) - float(fun(flat.at[i].add(-eps))))
                       / (2 * eps) for i in range(flat.size)])
    assert np.all(np.isfinite(g)) and np.abs(g).max() > 1.0
    # float64 central differences: agreement to 1e-5 relative to the largest component
    np.testing.assert_allclose(g, fd, atol=1e-5 * np.abs(g).max())


def test_bad_input():
    cam = Camera()
    z, w, dt, pr = simulate(cam, Noise(), np.random.default_rng(2), 2, 5)
    with pytest.raises(ValueError, match="too few"):
        fit_noise(cam, z, w, dt, pr)
    with pytest.raises(ValueError, match="unknown noise parameter"):
        fit_noise(cam, z, w, dt, pr, fit=("log_s",))
    with pytest.raises(ValueError, match="expected z"):
        fit_noise(cam, z[..., 0], w, dt, pr)
