"""The pedestrians level's dynamics (Masoud & Papanikolopoulos, part 3; PAPERS.md): equation (1)
with zero-mean Gaussian acceleration noise, every pedestrian's filter advanced by ONE jitted,
vmapped call per frame (`SlotFilter`, through `track.toolkit.SlotSteps` as the online tracker's
filters), compiled once per (variant, slot count, gate). Variants (`patches.DYNAMICS`):

    "2d", "3d-shape": constant velocity in the image, state (u, du/dt, v, dv/dt) (px, px/s), a
        linear Kalman filter: the core's `ekf_fused.predict` (F, Q of (1)) with a px/s noise and
        a linear update (H picks u and v; Joseph form);
    "3d" (default): constant velocity on the ground plane, state (x, vx, y, vy) (m, m/s), the
        core's EKF (`ekf_fused.step`, measurement (3)) with `ekf.FromAnnotations` validity (the
        pedestrians level does its own association, so every measurement it gives is used) or,
        as an option, a gate on each measurement (`OUTLIER_GATES`).

Each frame's results come back packed in one array (`FilterOut`, `FILTER_OUT`): one host
transfer per frame. A slot can also be put back to an earlier state of its own (`restore`: the
mean and covariance it had, predicted forward by the same `ekf_fused.predict`), which the
pedestrians level does when a track's last rows were another object's (`life.jump_rewind`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..model.camera import measure
from ..model.camera_np import image_width_of
from ..model.ekf import Carry, FromAnnotations, Gaussian, empty_carry, inverse_2x2, select
from ..model.ekf_fused import predict, step
from ..model.gates import InnovationGate, OutlierGate
from ..model.params import Camera, Config, Noise
from ..track.rows import Layout
from ..track.toolkit import SlotSteps
from .patches import DYNAMICS, ground_point, middle_foot_point


__all__ = ["FILTER_OUT", "OUTLIER_GATES", "FilterOut", "Restore", "SlotFilter", "check_noise",
           "filter_config", "image_noise", "image_velocity"]

OUTLIER_GATES = ("none", "paper", "innovation")  # `SlotFilter`'s gate on the "3d" measurements


def check_noise(values) -> None:
    """`placement.noise` is () or (q_x, q_y, r_u, r_v, r_corr): q in m/s per sqrt(s) and r in
    px finite and > 0, |r_corr| < 1; else ValueError naming the key."""
    v = tuple(values)
    if not v:
        return
    if (len(v) != 5 or not all(math.isfinite(x) for x in v) or min(v[:4]) <= 0
            or not -1.0 < v[4] < 1.0):
        raise ValueError("placement.noise must be [] or [q_x, q_y, r_u, r_v, r_corr] with q "
                         f"(m/s/sqrt(s)) and r (px) > 0 and |r_corr| < 1, got {list(v)}")


def filter_config(cfg: Config, values) -> Config:
    """`cfg` with its noise replaced by `values` = (q_x, q_y, r_u, r_v, r_corr) (`check_noise`;
    the initial speed spread kept), or `cfg` itself for (): the counting filter's own noise,
    fitted from labelled tracks (`benchmarks/fit_count_noise.py`), apart from the config's,
    which the rhythm tracker uses."""
    check_noise(values)
    if not values:
        return cfg
    q_x, q_y, r_u, r_v, r_corr = (float(x) for x in values)
    noise = Noise(q_std=(q_x, q_y), r_std=(r_u, r_v), r_corr=r_corr,
                  init_speed_std=float(cfg.noise.init_speed_std()))
    return eqx.tree_at(lambda c: c.noise, cfg, noise)


def image_noise(cfg: Config) -> Noise:
    """Image-plane noise for the 2-D dynamics: the ground q and initial speed spread times the
    px per m at the middle of the detection range; R as the config's (px)."""
    _, y, _ = ground_point(cfg.camera, *middle_foot_point(cfg))
    px_per_m = float(image_width_of(cfg.camera, 1.0, float(y)))  # (3) with roll, px per m
    R = np.asarray(cfg.noise.R(), np.float64)
    r = np.sqrt(np.diag(R))
    return Noise(q_std=tuple(np.asarray(cfg.noise.q_std(), np.float64) * px_per_m), r_std=r,
                 r_corr=float(R[0, 1] / (r[0] * r[1])),
                 init_speed_std=float(cfg.noise.init_speed_std()) * px_per_m)


def _linear_step(noise: Noise, carry: Carry, z, dt, present) -> Carry:
    """Constant-velocity Kalman step in the image: (1)-(2) prediction by `ekf_fused.predict`, linear
    update with H = [[1,0,0,0],[0,0,1,0]] (Joseph form), start on the first measurement."""
    available = present & jnp.all(jnp.isfinite(z))
    zs = jnp.where(available, z, 0.0)
    prior = predict(noise, carry.state, dt)
    R = noise.R()
    P, m = prior.cov, prior.mean
    Hm = jnp.zeros((2, 4), m.dtype).at[0, 0].set(1.0).at[1, 2].set(1.0)
    S = Hm @ P @ Hm.T + R
    Sinv, _ = inverse_2x2(S)
    K = P @ Hm.T @ Sinv
    A = jnp.eye(4, dtype=m.dtype) - K @ Hm
    post = Gaussian(m + K @ (zs - Hm @ m), A @ P @ A.T + K @ R @ K.T)
    s2 = noise.init_speed_std() ** 2
    init_cov = jnp.zeros((4, 4), m.dtype).at[0, 0].set(R[0, 0]).at[2, 2].set(R[1, 1])
    init_cov = init_cov.at[0, 2].set(R[0, 1]).at[2, 0].set(R[1, 0])
    init_cov = init_cov.at[1, 1].set(s2).at[3, 3].set(s2)
    init = Gaussian(jnp.stack([zs[0], 0.0 * zs[0], zs[1], 0.0 * zs[1]]), init_cov)
    tracked = select(available, post, prior)
    start = ~carry.started & available
    state = select(start, init, select(carry.started, tracked, carry.state))
    return Carry(state, carry.started | start)


class FilterOut(NamedTuple):
    """A frame's results per slot of `SlotFilter`, packed (`FILTER_OUT`) in one (S, 28) array;
    the whole state (`mean`) and the velocity's covariance (`velocity_cov`) are read from it."""

    started: np.ndarray  # (S,) 1: the filter has started (the first measurement was usable)
    est_uv: np.ndarray  # (S, 2) estimated foot point (u, v) px
    next_uv: np.ndarray  # (S, 2) predicted foot point for the next frame px
    ground: np.ndarray  # (S, 2) state position: ground (x, y) m for "3d", else (u, v) px
    velocity: np.ndarray  # (S, 2) state velocity: (vx, vy) m/s for "3d", else (du, dv) px/s
    image_velocity: np.ndarray  # (S, 2) d(u, v)/dt px/s of the estimated foot point
    used: np.ndarray  # (S,) 1: the measurement started or updated the filter (0: none, refused)
    cov: np.ndarray  # (S, 16) the state's posterior covariance, row-major 4 x 4 (order x, vx,
    # y, vy; `SlotFilter`'s restore)

    @property
    def mean(self) -> np.ndarray:
        """(S, 4) the state (x, vx, y, vy): (m, m/s) for "3d", else (px, px/s)."""
        g, v = np.asarray(self.ground), np.asarray(self.velocity)
        return np.stack([g[:, 0], v[:, 0], g[:, 1], v[:, 1]], axis=1)

    @property
    def velocity_cov(self) -> np.ndarray:
        """(S, 3) the velocity's posterior covariance (var vx, cov, var vy): (m/s)^2 for "3d",
        else (px/s)^2."""
        return np.asarray(self.cov)[:, [5, 7, 15]]


FILTER_OUT = Layout(FilterOut, (1, 2, 2, 2, 2, 2, 1, 16))


def image_velocity(camera: Camera, mean):
    """d(u, v)/dt (px/s) of the foot point (3) of a ground state (x, vx, y, vy) moving at its
    velocity: the Jacobian of `camera.measure` times (vx, 0, vy, 0) (`jax.jvp`, exact)."""
    rate = jnp.stack([mean[1], jnp.zeros_like(mean[1]), mean[3], jnp.zeros_like(mean[3])])
    return jax.jvp(lambda m: measure(camera, m), (mean,), (rate,))[1]


def _restored(noise: Noise, carry: Carry, restore, state, lead) -> Carry:
    """Slots with `restore` put back to `state` (S, 20: the mean (4) and row-major covariance
    (16) of a `FilterOut`) predicted `lead` s forward (`ekf_fused.predict`, (1)), started; the
    others as they are."""
    def one(r, s, tau, c):
        back = Carry(predict(noise, Gaussian(s[:4], s[4:].reshape(4, 4)), tau), jnp.array(True))
        return select(r, back, c)
    return jax.vmap(one)(restore, state, lead, carry)


def _advance(dynamics: str, outlier_gate: str, params, carry, reset, z, dt, dt_next, present,
             restore, state, lead):
    """Every slot one frame (restored slots first put back, `_restored`); returns the carry and
    the packed `FilterOut` (S, 28). "3d": a measurement `outlier_gate` refuses ("paper": (11),
    "innovation") is not used (it predicts)."""
    cfg, noise_img = params
    empty = empty_carry(z.dtype)
    carry = jax.vmap(lambda r, c: select(r, empty, c))(reset, carry)
    carry = _restored(cfg.noise if dynamics == "3d" else noise_img, carry, restore,
                      state.astype(z.dtype), lead.astype(z.dtype))
    was_started = carry.started
    if dynamics == "3d":
        width = jnp.full(z.shape[:1], jnp.nan, z.dtype)
        run = jax.vmap(step, in_axes=(None, None, None, 0, 0, 0, None, 0))
        valid = FromAnnotations() if outlier_gate == "none" else \
            (OutlierGate if outlier_gate == "paper" else InnovationGate)(cfg.thresholds)
        carry, out = run(cfg.camera, cfg.noise, valid, carry, z, width, dt, present)
        used = out.valid | (carry.started & ~was_started)
        nxt = jax.vmap(lambda s: predict(cfg.noise, s, dt_next))(carry.state)
        est_uv = jax.vmap(lambda m: measure(cfg.camera, m))(carry.state.mean)
        next_uv = jax.vmap(lambda m: measure(cfg.camera, m))(nxt.mean)
        duv = jax.vmap(lambda m: image_velocity(cfg.camera, m))(carry.state.mean)
    else:
        run = jax.vmap(_linear_step, in_axes=(None, 0, 0, None, 0))
        carry = run(noise_img, carry, z, dt, present)
        used = present & jnp.all(jnp.isfinite(z), axis=1)
        nxt = jax.vmap(lambda s: predict(noise_img, s, dt_next))(carry.state)
        est_uv = carry.state.mean[:, jnp.array([0, 2])]
        next_uv = nxt.mean[:, jnp.array([0, 2])]
        duv = carry.state.mean[:, jnp.array([1, 3])]  # the state's own (du, dv)
    mean, cov = carry.state.mean, carry.state.cov
    return carry, FILTER_OUT.pack(z.dtype, started=carry.started, est_uv=est_uv,
                                  next_uv=next_uv, ground=mean[:, jnp.array([0, 2])],
                                  velocity=mean[:, jnp.array([1, 3])], image_velocity=duv,
                                  used=used, cov=cov.reshape(cov.shape[0], 16))


class Restore(NamedTuple):
    """Slots to put back to an earlier state of theirs before a `SlotFilter` step: `slots` (S,)
    bool, `state` (S, 20) the `FilterOut` mean (4) and cov (16) they had, `lead` (S,) s from
    that state's frame to the frame before the step (it is predicted that far, then the step's
    dt as every slot)."""

    slots: np.ndarray
    state: np.ndarray
    lead: np.ndarray

    @classmethod
    def none(cls, slots: int) -> Restore:
        """No slot restored."""
        return cls(np.zeros(slots, bool), np.zeros((slots, 20)), np.zeros(slots))


class SlotFilter:
    """`slots` pedestrian filters advanced together by one jitted call per frame
    (`track.toolkit.SlotSteps`)."""

    def __init__(self, cfg: Config, dynamics: str = "3d", slots: int = 32,
                 outlier_gate: str = "none"):
        if dynamics not in DYNAMICS:
            raise ValueError(f"dynamics must be one of {DYNAMICS}, got {dynamics!r}")
        if outlier_gate not in OUTLIER_GATES:
            raise ValueError(f"outlier_gate must be one of {OUTLIER_GATES}, got {outlier_gate!r}")
        self.dynamics, self.slots = dynamics, int(slots)
        self._steps = SlotSteps(_advance, (cfg, image_noise(cfg)), self.slots,
                                (dynamics, outlier_gate))
        self.dt_nominal = float(cfg.camera.dt)
        self._unrestored = Restore(np.zeros(self.slots, bool),  # made once: most frames
                                   np.zeros((self.slots, 20), np.float32),
                                   np.zeros(self.slots, np.float32))

    def step(self, reset: np.ndarray, z: np.ndarray, present: np.ndarray, dt: float,
             dt_next: float | None = None, restore: Restore | None = None) -> FilterOut:
        """Advance every slot by dt s (reset slots start afresh from their measurement z, NaN =
        none; `restore`'s slots first go back to its states); returns the `FilterOut` of
        float64 host arrays."""
        return FILTER_OUT.unpack(np.asarray(self.dispatch(reset, z, present, dt, dt_next,
                                                          restore), np.float64))

    def dispatch(self, reset: np.ndarray, z: np.ndarray, present: np.ndarray, dt: float,
                 dt_next: float | None = None, restore: Restore | None = None) -> jax.Array:
        """`step` without waiting: the packed `FilterOut` (float32) as the jitted call returns
        it."""
        dt_next = self.dt_nominal if dt_next is None else dt_next
        r = self._unrestored if restore is None else restore
        return self._steps(np.asarray(reset, bool), np.asarray(z, np.float32), np.float32(dt),
                           np.float32(dt_next), np.asarray(present, bool),
                           np.asarray(r.slots, bool), np.asarray(r.state, np.float32),
                           np.asarray(r.lead, np.float32))
