"""The online `ekf.step` and the batch `ekf.filter_track` are one filter: scanning `step` over a
track gives what `filter_track` gives, with either validity."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model import ekf
from rhythmjax.model.camera import image_width, project
from rhythmjax.model.gates import PaperGates, outlier_distance2, outlier_distance2_of_update
from rhythmjax.model.params import Config


def _track(seed, n=90):
    cfg = Config()
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 15
    x, y = -2 + 1.1 * t, 25.0 - 1.3 * t  # starts outside the 3-20 m range, walks into it
    u, v = project(cfg.camera, jnp.asarray(x, jnp.float32), jnp.asarray(y, jnp.float32))
    z = np.stack([u, v], -1) + rng.normal(0, 2, (n, 2))
    z[rng.random(n) < 0.2] = np.nan
    z[40] += 80.0  # an outlier for gate (11)
    w = np.asarray(image_width(cfg.camera, jnp.float32(0.5), jnp.asarray(y, jnp.float32)))
    dt = np.full(n, 1 / 15)
    present = np.arange(n) < n - 5
    return cfg, [jnp.asarray(a) for a in (z.astype(np.float32), w.astype(np.float32),
                                          dt.astype(np.float32), present)]


@pytest.mark.parametrize("gated", [False, True])
def test_scan_of_step_equals_filter_track(gated):
    cfg, (z, w, dt, p) = _track(0)
    val = PaperGates(cfg.width, cfg.thresholds) if gated else ekf.FromAnnotations()

    def body(carry, inp):
        return ekf.step(cfg.camera, cfg.noise, val, carry, *inp)

    _, online = jax.lax.scan(body, ekf.empty_carry(), (z, w, dt, p))
    batch = ekf.filter_track(cfg.camera, cfg.noise, val, z, w, dt, p).steps
    for name in ("started", "available", "valid"):
        np.testing.assert_array_equal(getattr(online, name), getattr(batch, name), err_msg=name)
    # float32, two differently fused programs: rounding differs at ~1e-4 relative
    for name in ("mean", "cov", "nis", "loglik"):
        np.testing.assert_allclose(getattr(online, name), getattr(batch, name), rtol=3e-4,
                                   atol=1e-5, err_msg=name)
    if gated:  # the start waits for the range, and the injected outlier is refused
        assert int(np.argmax(np.asarray(batch.started))) > 0
        assert not bool(batch.valid[40])


def test_update_form_of_gate_11_equals_the_definition():
    cfg, (z, *_rest) = _track(1)
    prior = ekf.Gaussian(jnp.array([0.5, 0.2, 10.0, -1.0]),
                         jnp.diag(jnp.array([0.05, 0.5, 0.4, 0.6])) + 0.01)
    for k in range(0, 80, 7):
        zk = jnp.where(jnp.isfinite(z[k]), z[k], 250.0) + 3.0
        cand = ekf.update(cfg.camera, cfg.noise, prior, zk)
        a = float(outlier_distance2_of_update(cand))
        b = float(outlier_distance2(prior, cand.posterior.mean))
        assert a == pytest.approx(b, rel=2e-4), (k, a, b)
