"""The EKF of `ekf` (equations (4)-(9)) unrolled entry by entry for XLA's CPU fusion: `step`,
`filter_track` and `filter_batch` with the same signatures and results as `ekf`'s (tested equal:
state, covariance, NIS, log-likelihood and gradients, tests/test_ekf_fused.py).

`ekf` is the reference that reads as the paper; this module is the fast path of batch
classification (`rhythm.track_windows`). A state is held as its 4 mean entries and the 10
upper-triangle covariance entries, each an array of the same shape (a scalar for one track).
Under vmap every entry becomes one contiguous (B,) vector and XLA fuses a whole step into a few
elementwise loops; with (B, 4, 4) arrays the same step is a chain of small products over minor
axes of length 4. H of (9) has non-zeros only in the position columns (h depends on x_p and y_p
alone), and the products below skip the structural zeros of F, H and I - K H. Measured on 2 CPU
cores, jax 0.10 (docs/design.md, The EKF): 3-10x the track-steps per second of `ekf.filter_batch`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from .camera import in_front, project
from .ekf import (
    AbstractValidity,
    Carry,
    FilterOutput,
    Gaussian,
    StepOutput,
    Update,
    can_start,
    initial_state,
    scan_track,
    select,
    vmap_in_chunks,
)
from .params import Camera, Noise


_LOG_2PI = math.log(2.0 * math.pi)

_UPPER = ((0, 0), (0, 1), (0, 2), (0, 3), (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3))


def _entries(p):
    """The full 4x4 covariance as nested lists from the 10 upper-triangle entries."""
    full = {}
    for k, (i, j) in enumerate(_UPPER):
        full[i, j] = full[j, i] = p[k]
    return [[full[i, j] for j in range(4)] for i in range(4)]


def _unpack(g: Gaussian):
    return (tuple(g.mean[..., i] for i in range(4)),
            tuple(g.cov[..., i, j] for i, j in _UPPER))


def _pack(m, p) -> Gaussian:
    P = _entries(p)
    return Gaussian(jnp.stack(m, axis=-1),
                    jnp.stack([jnp.stack(row, axis=-1) for row in P], axis=-2))


def _lin(*terms):
    """Sum of products a * b, skipping the terms whose Python factor is 0 and not multiplying
    by a Python 1 (the structural zeros and ones of F, H and I - K H)."""
    out = 0.0
    for a, b in terms:
        if isinstance(a, int) and a == 0 or isinstance(b, int) and b == 0:
            continue
        out = out + (b if isinstance(a, int) else a if isinstance(b, int) else a * b)
    return out


def _predict_entries(q2, m, p, dt):
    """(5), (8) for F of (1): positions advance by dt * velocity; Q = diag(0, qx^2, 0, qy^2) dt."""
    x, vx, y, vy = m
    p00, p01, p02, p03, p11, p12, p13, p22, p23, p33 = p
    mean = (x + dt * vx, vx, y + dt * vy, vy)
    cov = (p00 + dt * (2.0 * p01 + dt * p11), p01 + dt * p11,
           p02 + dt * (p12 + p03 + dt * p13), p03 + dt * p13,
           p11 + q2[0] * dt, p12 + dt * p13, p13,
           p22 + dt * (2.0 * p23 + dt * p33), p23 + dt * p33,
           p33 + q2[1] * dt)
    return mean, cov


def predict(noise: Noise, state: Gaussian, dt: Float[Array, ""]) -> Gaussian:
    """`ekf.predict` ((5), (8)), entry by entry."""
    return _pack(*_predict_entries(jnp.exp(2.0 * noise.log_q), *_unpack(state), dt))


class _Cand(NamedTuple):
    """The temporary update, unpacked: see `Update`."""

    mean: tuple
    cov: tuple
    zhat: tuple  # h(X(k|k-1)), px
    nu: tuple
    S: tuple  # (s00, s01, s11), px^2
    HPHt: tuple  # (hp00, hp01, hp11), px^2
    det: Array
    nis: Array
    ok: Array


def _computed_once(R):
    """A function that divides every float leaf of a pytree by a runtime 1.0 (exact).

    Under vmap each entry is a vector loop, and XLA's CPU fusion copies a cheap producer into
    every consumer that reads it, so the 14 state entries each recomputed H, K and S^-1
    (1 273 fused vector operations per step, 376 needed). A division counts as expensive, and
    XLA does not copy it: its result is computed once and read by its consumers (724 per step;
    1.15-1.35x faster, benchmarks/bench_ekf.py). `lax.optimization_barrier` does not do this on
    CPU (XLA removes it before fusion). Where R is a compile-time constant the 1.0 folds away
    and the filter is the same, only not faster."""
    one = jnp.where(R[0, 0] > -1.0, 1.0, 2.0).astype(R.dtype)
    return lambda tree: jax.tree.map(
        lambda a: a / one if jnp.issubdtype(jnp.result_type(a), jnp.floating) else a, tree)


def _update_entries(camera: Camera, R, m, p, z, available=True) -> _Cand:
    """(4), (6), (7) with H of (9) and the Joseph form; where `available` is False the
    measurement is replaced by the predicted one first (double where)."""
    x, _, y, _ = m
    one = jnp.ones_like(x)
    keep = _computed_once(R)
    (u, v), (hux, hvx) = jax.jvp(lambda xx: project(camera, xx, y), (x,), (one,))
    _, (huy, hvy) = jax.jvp(lambda yy: project(camera, x, yy), (y,), (one,))
    u, v, hux, hvx, huy, hvy = keep((u, v, hux, hvx, huy, hvy))
    H = ((hux, 0, huy, 0), (hvx, 0, hvy, 0))
    P = _entries(p)
    PHt = [[_lin(*zip(P[i], H[r])) for r in range(2)] for i in range(4)]  # 4x2
    hp = [[_lin(*zip(H[r], (PHt[k][c] for k in range(4)))) for c in range(2)] for r in range(2)]
    r00, r01, r11 = R[0, 0], 0.5 * (R[0, 1] + R[1, 0]), R[1, 1]
    hp00, hp01, hp11 = hp[0][0], 0.5 * (hp[0][1] + hp[1][0]), hp[1][1]
    s00, s01, s11 = hp00 + r00, hp01 + r01, hp11 + r11
    det = s00 * s11 - s01 * s01
    ok = (jnp.isfinite(det) & (det > 0) & (s00 > 0) & in_front(camera, y)
          & (s00 >= r00 * (1.0 - 1e-3)) & (s11 >= r11 * (1.0 - 1e-3)))
    safe = jnp.where(ok, det, 1.0)
    i00, i01, i11 = s11 / safe, -s01 / safe, s00 / safe
    ok = ok & jnp.isfinite(i00) & jnp.isfinite(i01) & jnp.isfinite(i11)
    # a failed check means "do not update" (the gate switch predicts); S^-1 := I there
    i00, i01, i11 = jnp.where(ok, i00, 1.0), jnp.where(ok, i01, 0.0), jnp.where(ok, i11, 1.0)
    K = [(_lin((g[0], i00), (g[1], i01)), _lin((g[0], i01), (g[1], i11))) for g in PHt]  # (6)
    zu = jnp.where(available, z[..., 0], u)
    zv = jnp.where(available, z[..., 1], v)
    nu0, nu1 = zu - u, zv - v
    K, nu0, nu1, i00, i01, i11 = keep((K, nu0, nu1, i00, i01, i11))
    mean = tuple(m[i] + K[i][0] * nu0 + K[i][1] * nu1 for i in range(4))
    A = [[int(i == j) - _lin((K[i][0], H[0][j]), (K[i][1], H[1][j])) if j in (0, 2)
          else int(i == j) for j in range(4)] for i in range(4)]  # I - K H
    AP = [[_lin(*zip(A[i], (P[k][c] for k in range(4)))) for c in range(4)] for i in range(4)]
    KR = [(K[i][0] * r00 + K[i][1] * r01, K[i][0] * r01 + K[i][1] * r11) for i in range(4)]
    cov = tuple(_lin(*zip(AP[i], A[j])) + KR[i][0] * K[j][0] + KR[i][1] * K[j][1]
                for i, j in _UPPER)
    nis = nu0 * (i00 * nu0 + i01 * nu1) + nu1 * (i01 * nu0 + i11 * nu1)
    return _Cand(mean, cov, (u, v), (nu0, nu1), (s00, s01, s11), (hp00, hp01, hp11), det, nis,
                 ok)


def _sym2(a, b, c):
    return jnp.stack([jnp.stack([a, b]), jnp.stack([b, c])])


def _to_update(c: _Cand) -> Update:
    logdet = jnp.log(jnp.where(c.ok, c.det, 1.0))
    return Update(_pack(c.mean, c.cov), jnp.stack(c.nu), _sym2(*c.S), _sym2(*c.HPHt), c.nis,
                  -0.5 * (c.nis + logdet + 2.0 * _LOG_2PI), c.ok)


def _tracked_step(camera, noise, validity, m, p, z, width, dt, available):
    """Predict, candidate update, gate, select on unpacked entries: the part of every step
    after the start. Returns the prior and the selected state (unpacked), the candidate as an
    `Update`, and `valid`."""
    prior = _predict_entries(jnp.exp(2.0 * noise.log_q), m, p, dt)
    c = _update_entries(camera, noise.R(), *prior, z, available)
    cand = _to_update(c)
    z_safe = jnp.where(available, z, jnp.stack(c.zhat))  # double where, module doc
    valid = available & c.ok & validity(camera, _pack(*prior), cand, z_safe, width)
    return prior, cand, valid, select(valid, (c.mean, c.cov), prior)


def _output(state, prior, cand, valid, available, started_before, started):
    state, prior_mean = _pack(*state), jnp.stack(prior[0])
    zero = jnp.zeros((), prior_mean.dtype)
    seen = available & started_before
    return StepOutput(
        mean=state.mean, cov=state.cov, pred_mean=prior_mean,
        innovation=jnp.where(seen, cand.innovation, 0.0), nis=jnp.where(seen, cand.nis, zero),
        loglik=jnp.where(valid, cand.loglik, zero), available=available, valid=valid,
        started=started)


def step(
    camera: Camera,
    noise: Noise,
    validity: AbstractValidity,
    carry: Carry,
    z: Float[Array, "2"],
    width: Float[Array, ""],
    dt: Float[Array, ""],
    present: Bool[Array, ""],
) -> tuple[Carry, StepOutput]:
    """`ekf.step`, entry by entry."""
    available = present & jnp.all(jnp.isfinite(z))
    before = _unpack(carry.state)
    prior, cand, valid, tracked = _tracked_step(camera, noise, validity, *before, z, width, dt,
                                                available)
    valid = valid & carry.started
    z_safe = jnp.where(available, z, 0.0)
    init, _ = initial_state(camera, noise, z_safe)
    start_now = ~carry.started & can_start(camera, validity, z_safe, width, available)
    state = select(start_now, _unpack(init), select(carry.started, tracked, before))
    started = carry.started | start_now
    return Carry(_pack(*state), started), _output(state, prior, cand, valid, available,
                                                  carry.started, started)


def filter_track(
    camera: Camera,
    noise: Noise,
    validity: AbstractValidity,
    z: Float[Array, "T 2"],
    width: Float[Array, " T"],
    dt: Float[Array, " T"],
    present: Bool[Array, " T"],
) -> FilterOutput:
    """`ekf.filter_track` (the same scan, `ekf.scan_track`) on this module's entry-by-entry
    state: the 4 mean and 10 upper-triangle covariance entries."""
    return scan_track(camera, noise, validity, z, width, dt, present,
                      lambda c, n, v, state, *rest: _tracked_step(c, n, v, *state, *rest),
                      _output, _unpack)


@eqx.filter_jit
def filter_batch(
    camera: Camera,
    noise: Noise,
    validity: AbstractValidity,
    z: Float[Array, "B T 2"],
    width: Float[Array, "B T"],
    dt: Float[Array, "B T"],
    present: Bool[Array, "B T"],
    chunk: int = 4096,
) -> FilterOutput:
    """`ekf.filter_batch` with this module's `filter_track`. Measured at 16384 tracks x 64 steps
    on 2 CPU cores (benchmarks/bench_ekf.py): chunks of 4096 or more are about 1.3x faster than
    1024 when only the means are used, and equal when the covariances are written as well."""
    return vmap_in_chunks(filter_track, camera, noise, validity, z, width, dt, present, chunk)
