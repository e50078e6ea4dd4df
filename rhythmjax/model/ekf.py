"""The Extended Kalman Filter of equations (4)-(9), written once for inference and for fitting.

State X = (x_p, x_v, y_p, y_v) on the ground plane (m, m/s), constant velocity (1); measurement
Y = (u_p, v_p) in px through the camera of (3). Every step runs the same three calls (STYLE R5):

    prior = predict(noise, state, dt)       # (5), (8)
    cand = update(camera, noise, prior, z)  # (4), (6), (7), H of (9): the X~ of (11)
    state = select(valid, cand, prior)      # the gate switch of Fig. 2

Only the source of `valid` differs: `FromAnnotations` (fitting: the measurement is present) or
`gates.PaperGates` (inference: the width gate (10) and the outlier gate (11) exactly as written).
The algebra is the paper's, in 4x4 and 2x2 matrix form. The covariance update is the Joseph form,
so P stays symmetric positive definite in float32; the 2x2 innovation covariance S is inverted
in closed form (adjugate over determinant, guarded: S >= R > 0). A NaN or missing measurement
is replaced by the predicted measurement *before* it is used (double where), so it becomes a
prediction step with finite gradients.

`ekf_fused` is this filter unrolled entry by entry, with the same `step`, `filter_track` and
`filter_batch` (tested equal): 3-8x faster over batches of tracks on CPU (docs/design.md, The EKF),
the batch paths use it.
"""

from __future__ import annotations

import abc
import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float, PyTree

from .camera import ground_from_image, in_front, measure, measure_jacobian
from .params import Camera, Noise


_LOG_2PI = math.log(2.0 * math.pi)


def _mm(a: Array, b: Array) -> Array:
    """a @ b for the 4x4, 4x2, 2x4 and 2x2 matrices (or a vector b) of the filter, as a sum of
    outer products: under vmap these are elementwise vector loops, 7-9x faster on CPU than
    batched 4x4 dot products (docs/design.md, The EKF)."""
    if b.ndim == 1:
        return sum(a[:, k] * b[k] for k in range(a.shape[1]))
    return sum(a[:, k, None] * b[None, k, :] for k in range(a.shape[1]))


def _symmetric(a: Float[Array, "n n"]) -> Float[Array, "n n"]:
    return 0.5 * (a + a.T)


class Gaussian(eqx.Module):
    """A state estimate: mean (4,) and covariance (4, 4) in (m, m/s)."""

    mean: Float[Array, "4"]
    cov: Float[Array, "4 4"]


class Update(eqx.Module):
    """The temporary update with a measurement, and what it says about that measurement."""

    posterior: Gaussian
    innovation: Float[Array, "2"]  # nu = Y - h(X(k|k-1)), px
    innovation_cov: Float[Array, "2 2"]  # S = H P H^T + R, px^2
    prior_meas_cov: Float[Array, "2 2"]  # H P(k|k-1) H^T, px^2
    nis: Float[Array, ""]  # nu^T S^-1 nu
    loglik: Float[Array, ""]  # log N(nu; 0, S)
    ok: Bool[Array, ""]  # S finite and positive definite, prior in front of the camera


def inverse_2x2(S: Float[Array, "2 2"]) -> tuple[Float[Array, "2 2"], Float[Array, ""]]:
    """Closed-form inverse and determinant of a symmetric 2x2 matrix (no LAPACK call)."""
    a, b, c = S[0, 0], 0.5 * (S[0, 1] + S[1, 0]), S[1, 1]
    det = a * c - b * b
    safe = jnp.where(det > 0, det, 1.0)
    inv = jnp.stack([jnp.stack([c, -b]), jnp.stack([-b, a])]) / safe
    return inv, det


def transition(dt: Float[Array, ""]) -> Float[Array, "4 4"]:
    """F of (1) for a step of dt seconds: positions advance by dt times the velocities."""
    one, zero = jnp.ones_like(dt), jnp.zeros_like(dt)
    row = lambda *xs: jnp.stack(xs)
    return jnp.stack([row(one, dt, zero, zero), row(zero, one, zero, zero),
                      row(zero, zero, one, dt), row(zero, zero, zero, one)])


def predict(noise: Noise, state: Gaussian, dt: Float[Array, ""]) -> Gaussian:
    """(5) and (8): X(k+1|k) = F X(k|k), P(k+1|k) = F P(k|k) F^T + Q, with F of (1) and
    Q = diag(0, qx^2, 0, qy^2) dt (`Noise.Q`)."""
    F = transition(jnp.asarray(dt, state.mean.dtype))
    mean = _mm(F, state.mean)
    cov = _mm(_mm(F, state.cov), F.T) + noise.Q(dt).astype(state.cov.dtype)
    return Gaussian(mean, _symmetric(cov))


def update(camera: Camera, noise: Noise, prior: Gaussian, z: Float[Array, "2"]) -> Update:
    """(4), (6), (7) with H of (9); `z` must be finite (see `step`).

    The covariance uses the Joseph form (I - K H) P (I - K H)^T + K R K^T, algebraically equal to
    (7) and positive definite in float32 where (7) is not (RELIABILITY.md, finding 1). S is
    checked (finite, positive definite, S >= R on the diagonal, prior in front of the camera);
    a failed check sets `ok` False (and S^-1 := I), which the gate switch turns into a
    prediction.
    """
    R = _symmetric(noise.R()).astype(prior.cov.dtype)
    P = prior.cov
    z_pred = measure(camera, prior.mean)  # h(X(k|k-1)) of (2), (3)
    H = measure_jacobian(camera, prior.mean)  # (9)
    PHt = _mm(P, H.T)
    HPHt = _symmetric(_mm(H, PHt))
    S = HPHt + R
    S_inv, det = inverse_2x2(S)
    ok = (jnp.isfinite(det) & (det > 0) & (S[0, 0] > 0) & in_front(camera, prior.mean[2])
          & jnp.all(jnp.diag(S) >= jnp.diag(R) * (1.0 - 1e-3)) & jnp.all(jnp.isfinite(S_inv)))
    S_inv = jnp.where(ok, S_inv, jnp.eye(2, dtype=S.dtype))
    K = _mm(PHt, S_inv)  # (6)
    nu = z - z_pred
    mean = prior.mean + _mm(K, nu)  # (4)
    A = jnp.eye(4, dtype=P.dtype) - _mm(K, H)
    cov = _mm(_mm(A, P), A.T) + _mm(_mm(K, R), K.T)  # (7), Joseph form
    nis = nu @ _mm(S_inv, nu)
    logdet = jnp.log(jnp.where(ok, det, 1.0))
    return Update(Gaussian(mean, _symmetric(cov)), nu, S, HPHt, nis,
                  -0.5 * (nis + logdet + 2.0 * _LOG_2PI), ok)


def select(valid: Bool[Array, ""], cand: PyTree, prior: PyTree) -> PyTree:
    """The gate switch of Fig. 2: the update where valid, the prediction otherwise (any two
    matching pytrees, e.g. two `Gaussian`s)."""
    return jax.tree.map(lambda a, b: jnp.where(valid, a, b), cand, prior)


def initial_state(
    camera: Camera, noise: Noise, z: Float[Array, "2"]
) -> tuple[Gaussian, Bool[Array, ""]]:
    """The state after a track's first measurement (DETECT -> OBSERVE in Fig. 3).

    Position: the inverse perspective of z, with covariance J R J^T (J the Jacobian of the inverse
    projection); velocity: zero with standard deviation `noise.init_speed_std()` (m/s).
    `ok` is False when z has no ground point (on or above the horizon).
    """
    def ground(uv):
        x, y, _ = ground_from_image(camera, uv[0], uv[1])
        return jnp.stack([x, y])

    _, _, ok = ground_from_image(camera, z[0], z[1])
    xy = ground(z)
    J = jax.jacfwd(ground)(z)
    pos_cov = J @ noise.R() @ J.T
    sv2 = noise.init_speed_std() ** 2
    zero = jnp.zeros((), xy.dtype)
    mean = jnp.stack([xy[0], zero, xy[1], zero])
    cov = jnp.zeros((4, 4), xy.dtype)
    cov = cov.at[0, 0].set(pos_cov[0, 0]).at[0, 2].set(pos_cov[0, 1])
    cov = cov.at[2, 0].set(pos_cov[1, 0]).at[2, 2].set(pos_cov[1, 1])
    cov = cov.at[1, 1].set(sv2).at[3, 3].set(sv2)
    cov = jnp.where(ok, cov, jnp.eye(4, dtype=xy.dtype))
    return Gaussian(mean, cov), ok


# ----------------------------------------------------------------------------------------------
# Where `valid` comes from


class AbstractValidity(eqx.Module):
    """Decides whether an available measurement is used (OBSERVE) or not (PREDICT)."""

    @abc.abstractmethod
    def accept_initial(self, camera: Camera, z: Float[Array, "2"], width: Float[Array, ""],
                       ground_xy: Float[Array, "2"]) -> Bool[Array, ""]:
        """Whether a first measurement z, whose ground point is `ground_xy` (m), may start a
        track (DETECT -> OBSERVE)."""

    @abc.abstractmethod
    def __call__(self, camera: Camera, prior: Gaussian, cand: Update, z: Float[Array, "2"],
                 width: Float[Array, ""]) -> Bool[Array, ""]:
        """Whether the candidate update `cand` of `prior` with `z` is accepted."""


class FromAnnotations(AbstractValidity):
    """Fitting: every present, finite measurement is used, so the loss is smooth in the
    parameters. Absence is already expressed by NaN or the `present` mask."""

    def accept_initial(self, camera, z, width, ground_xy):
        return jnp.asarray(True)

    def __call__(self, camera, prior, cand, z, width):
        return jnp.asarray(True)


# ----------------------------------------------------------------------------------------------
# One step, one track (scan), a batch (vmap)


class Carry(eqx.Module):
    state: Gaussian
    started: Bool[Array, ""]


class StepOutput(eqx.Module):
    """Per step: the selected estimate and what the measurement did."""

    mean: Float[Array, "4"]
    cov: Float[Array, "4 4"]
    pred_mean: Float[Array, "4"]
    innovation: Float[Array, "2"]  # 0 where no measurement was available
    nis: Float[Array, ""]  # 0 where no measurement was available
    loglik: Float[Array, ""]  # innovation log-likelihood of a used measurement, else 0
    available: Bool[Array, ""]  # present and finite
    valid: Bool[Array, ""]  # used in an update (OBSERVE); False for PREDICT and the first one
    started: Bool[Array, ""]  # the track has been initialised at or before this step


def empty_carry(dtype=None) -> Carry:
    dtype = dtype or jnp.result_type(float)
    return Carry(Gaussian(jnp.zeros(4, dtype), jnp.eye(4, dtype=dtype)), jnp.asarray(False))


def _tracked_step(camera, noise, validity, state: Gaussian, z, width, dt, available):
    """Predict, candidate update, gate, select: the part of every step after the start.
    Returns the prior, the candidate `Update`, `valid` and the selected state."""
    prior = predict(noise, state, dt)  # (5), (8)
    z_safe = jnp.where(available, z, measure(camera, prior.mean))  # double where (module doc)
    cand = update(camera, noise, prior, z_safe)  # (4), (6), (7)
    valid = available & cand.ok & validity(camera, prior, cand, z_safe, width)
    return prior, cand, valid, select(valid, cand.posterior, prior)


def can_start(camera, validity, z, width, available):
    """Whether a measurement may start a track (DETECT -> OBSERVE): it is `available`, has a
    ground point, and the validity accepts it."""
    x, y, ok = ground_from_image(camera, z[0], z[1])
    return available & ok & validity.accept_initial(camera, z, width, jnp.stack([x, y]))


def _output(state: Gaussian, prior: Gaussian, cand: Update, valid, available, started_before,
            started) -> StepOutput:
    zero = jnp.zeros((), prior.mean.dtype)
    seen = available & started_before
    return StepOutput(
        mean=state.mean, cov=state.cov, pred_mean=prior.mean,
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
    """One frame of one object (the online tracker): start on the first usable measurement
    (`initial_state`), then predict-update-select. `filter_track` runs the same logic over a
    whole track."""
    available = present & jnp.all(jnp.isfinite(z))
    prior, cand, valid, tracked = _tracked_step(camera, noise, validity, carry.state, z, width,
                                                dt, available)
    valid = valid & carry.started
    z_safe = jnp.where(available, z, 0.0)
    init, _ = initial_state(camera, noise, z_safe)
    start_now = ~carry.started & can_start(camera, validity, z_safe, width, available)
    state = select(start_now, init, select(carry.started, tracked, carry.state))
    started = carry.started | start_now
    return Carry(state, started), _output(state, prior, cand, valid, available, carry.started,
                                          started)


class FilterOutput(eqx.Module):
    """Outputs of `filter_track` stacked over time (leading axis T; batch axis first if any)."""

    steps: StepOutput
    loglik: Float[Array, "*b"]  # total innovation log-likelihood of the used measurements


def filter_track(
    camera: Camera,
    noise: Noise,
    validity: AbstractValidity,
    z: Float[Array, "T 2"],
    width: Float[Array, " T"],
    dt: Float[Array, " T"],
    present: Bool[Array, " T"],
) -> FilterOutput:
    """Run one (padded) track: the start (the first measurement `step` would start on) is found
    for all frames at once, then `lax.scan` runs the tracked steps; dt[k] = t[k] - t[k-1] (s).
    Same results as scanning `step`, without the start logic inside the sequential loop."""
    return scan_track(camera, noise, validity, z, width, dt, present, _tracked_step, _output)


def scan_track(camera, noise, validity, z, width, dt, present, tracked_step, output,
               to_state=lambda g: g) -> FilterOutput:
    """The scan of `filter_track` over any state representation: `tracked_step(camera, noise,
    validity, state, z, width, dt, available)` -> (prior, cand, valid, tracked) and `output(state,
    prior, cand, valid, available, started_before, started)` -> `StepOutput` of one step on
    states `to_state` makes from a `Gaussian` (`ekf_fused` passes its entry-by-entry forms)."""
    z, width, dt = (jnp.asarray(a, jnp.result_type(float)) for a in (z, width, dt))
    present = jnp.asarray(present)
    available = present & jnp.all(jnp.isfinite(z), axis=-1)
    z0 = jnp.where(available[:, None], z, 0.0)
    can = jax.vmap(can_start, in_axes=(None, None, 0, 0, 0))(camera, validity, z0, width,
                                                             available)
    k0 = jnp.argmax(can)
    has_start = can[k0]
    init = to_state(initial_state(camera, noise, z0[k0])[0])

    def body(state, inp):
        k, zk, wk, dtk, ak = inp
        before = has_start & (k > k0)
        prior, cand, valid, tracked = tracked_step(camera, noise, validity, state, zk, wk, dtk,
                                                   ak)
        valid = valid & before
        now = has_start & (k == k0)
        new = select(now, init, select(before, tracked, state))
        return new, output(new, prior, cand, valid, ak, before, before | now)

    ks = jnp.arange(z.shape[0])
    first = to_state(empty_carry(z.dtype).state)
    _, out = jax.lax.scan(body, first, (ks, z, width, dt, available))
    return FilterOutput(out, jnp.sum(out.loglik))


def vmap_in_chunks(run_track, camera, noise, validity, z, width, dt, present, chunk: int):
    """`run_track` (a `filter_track`) vmapped over a batch of padded tracks sharing the
    parameters. Batches larger than `chunk` run as a sequential map over chunks of `chunk`
    tracks, which bounds the memory of one step's intermediates; the batch is padded with absent
    tracks to a multiple of `chunk` and the padding dropped."""
    run = jax.vmap(run_track, in_axes=(None, None, None, 0, 0, 0, 0))
    B = z.shape[0]
    if B <= chunk:
        return run(camera, noise, validity, z, width, dt, present)
    n = -(-B // chunk)
    pad = lambda a, v: jnp.concatenate([a, jnp.full((n * chunk - B,) + a.shape[1:], v, a.dtype)])
    split = lambda a: a.reshape((n, chunk) + a.shape[1:])
    args = (split(pad(z, 0.0)), split(pad(width, 0.0)), split(pad(dt, 0.0)),
            split(pad(present, False)))
    out = jax.lax.map(lambda a: run(camera, noise, validity, *a), args)
    return jax.tree.map(lambda a: a.reshape((n * chunk,) + a.shape[2:])[:B], out)


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
    """`filter_track` vmapped over a batch of padded tracks sharing the parameters, in chunks of
    `chunk` tracks (`vmap_in_chunks`). `ekf_fused.filter_batch` is the same, faster on CPU."""
    return vmap_in_chunks(filter_track, camera, noise, validity, z, width, dt, present, chunk)
