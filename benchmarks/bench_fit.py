"""Fit benchmarks (issue 5): camera fit on 10 000 footprints, noise fit on 1 000 tracks x 100
steps, and one likelihood gradient (jax.grad of the noise NLL) against central differences.

Run: ``python -m benchmarks.bench_fit [n_tracks]`` (times after compilation, wall clock).
"""

from __future__ import annotations

import sys
import time

import equinox as eqx
import jax
import jax.flatten_util
import jax.numpy as jnp
import numpy as np

from fit.camera import fit_camera
from fit.noise import _spec, fit_noise, neg_loglik, simulate
from fit.synthetic import footprints, random_camera
from rhythmjax.model.params import Camera, Noise


def bench_camera(n: int = 10_000) -> None:
    cam = random_camera(np.random.default_rng(1))
    c0 = Camera(uc=float(cam.uc), vc=float(cam.vc))
    u, v, x, y, _ = footprints(cam, np.random.default_rng(7), n=n, n_walkers=500)
    fit_camera(u, v, x, y, c0)  # compile
    t0 = time.perf_counter()
    r = fit_camera(u, v, x, y, c0)
    print(f"camera fit, {u.size} footprints: {time.perf_counter() - t0:.3f} s after "
          f"compilation, {r.num_steps} LM steps, RMS {r.rms_px:.3f} px")


def bench_noise(n_tracks: int = 1000, n_steps: int = 100) -> None:
    cam = Camera(h=3.0, theta=np.radians(20.0))
    true = Noise(q_std=(0.3, 0.5), r_std=(1.5, 2.5), r_corr=0.2)
    z, width, dt, present = simulate(cam, true, np.random.default_rng(0), n_tracks, n_steps)
    fit_noise(cam, z, width, dt, present, max_steps=3)  # compile
    t0 = time.perf_counter()
    r = fit_noise(cam, z, width, dt, present)
    print(f"noise fit, {n_tracks} tracks x {n_steps} steps: {time.perf_counter() - t0:.2f} s, "
          f"{r.num_steps} BFGS steps, {r.result or 'successful'}; "
          + ", ".join(f"{k} {v:.3f}" for k, v in r.values.items()))
    # one gradient: jax.grad against central differences (float64)
    with jax.enable_x64(True):
        to64 = lambda a: jnp.asarray(a, jnp.float64) if eqx.is_inexact_array(a) else a  # noqa: E731
        dyn, static = eqx.partition(jax.tree.map(to64, Noise()), _spec(("log_q", "log_r_diag",
                                                                        "r_offdiag")))
        args = (static, jax.tree.map(to64, cam), *(jnp.asarray(a) for a in (z, width, dt)),
                jnp.asarray(present))
        flat, unravel = jax.flatten_util.ravel_pytree(dyn)
        # the data go in as arguments (closed over, XLA would constant-fold them at length)
        f = eqx.filter_jit(lambda p, a: neg_loglik(unravel(p), a))
        g = eqx.filter_jit(jax.grad(lambda p, a: neg_loglik(unravel(p), a)))
        f(flat, args).block_until_ready(), g(flat, args).block_until_ready()
        t0 = time.perf_counter()
        gj = np.asarray(g(flat, args).block_until_ready())
        t_grad = time.perf_counter() - t0
        t0 = time.perf_counter()
        eps = 1e-5
        fd = np.array([(float(f(flat.at[i].add(eps), args))
                        - float(f(flat.at[i].add(-eps), args))) / (2 * eps)
                       for i in range(flat.size)])
        t_fd = time.perf_counter() - t0
    rel = np.abs(gj - fd).max() / np.abs(gj).max()
    print(f"NLL gradient ({flat.size} parameters): jax.grad {t_grad * 1e3:.1f} ms, central "
          f"differences ({2 * flat.size} evaluations) {t_fd * 1e3:.1f} ms; max relative "
          f"difference {rel:.2e}")


if __name__ == "__main__":  # pragma: no cover
    bench_camera()
    bench_noise(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
