"""The online tracker's per-frame step of every object slot (`tracker.OnlineTracker`): ONE
jitted call (`toolkit.SlotSteps`) resets the new slots, advances each slot's filter with the
core's EKF step (`ekf_fused.step`) and the paper's gates (10) and (11) (`gates.PaperGates`), and
returns what the host needs: the filtered state, the predicted foot point for the next frame's
detection window and the window-B width W (px) of (3). Inputs and outputs are packed in one
array each (`rows.Layout`): one host-device transfer a frame each way."""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..model.camera import image_width, measure
from ..model.ekf import Carry, empty_carry
from ..model.ekf_fused import predict, step
from ..model.gates import PaperGates
from ..model.params import Config
from .rows import Layout


__all__ = ["FRAME_IN", "STEP_OUT", "FrameIn", "StepOut", "advance_slots"]


class FrameIn(NamedTuple):
    """A frame's inputs per slot, packed (`FRAME_IN`) in one (S, 6) float32 array: one
    host-to-device transfer instead of five halves the jitted call's cost (~110 to ~50 us)."""

    reset: np.ndarray  # (S,) 1: the slot starts a new object this frame
    z: np.ndarray  # (S, 2) measured foot point (u, v) px, NaN: none
    width: np.ndarray  # (S,) measured image width px (gate (10)), NaN: none
    present: np.ndarray  # (S,) 1: the slot holds an object
    dt: np.ndarray  # (S,) s since the last frame (the same in every row)


class StepOut(NamedTuple):
    """A frame's results per slot, packed (`STEP_OUT`) in one (S, 13) array: one transfer."""

    valid: np.ndarray  # (S,) 1: the gates accepted the measurement
    started: np.ndarray  # (S,) 1: the filter has started
    mean: np.ndarray  # (S, 4) filtered ground state (x, vx, y, vy) m, m/s
    next_uv: np.ndarray  # (S, 2) predicted foot point for the next frame px
    est_uv: np.ndarray  # (S, 2) foot point of the filtered state px
    W: np.ndarray  # (S,) window-B width W px at the filtered ground point
    W_next: np.ndarray  # (S,) W px at the predicted ground point


FRAME_IN = Layout(FrameIn, (1, 2, 1, 1, 1))
STEP_OUT = Layout(StepOut, (1, 1, 4, 2, 2, 1, 1))


def advance_slots(cfg: Config, carry: Carry, frame_in):
    """Every slot one frame (`FrameIn` packed): reset new slots, `ekf_fused.step` with the paper's
    gates, and what the next frame needs (predicted foot point) and this frame's window-B size
    W (px), packed as `StepOut`. Traced inside `toolkit.SlotSteps` (a static argument of its
    jit: keep it a module-level function)."""
    fin = FRAME_IN.unpack(frame_in)
    reset, z, width = fin.reset > 0.5, fin.z, fin.width
    present, dt = fin.present > 0.5, fin.dt[0]
    empty = empty_carry(z.dtype)
    carry = jax.vmap(lambda r, c: jax.tree.map(lambda a, b: jnp.where(r, b, a), c, empty))(
        reset, carry)
    gates = PaperGates(cfg.width, cfg.thresholds)
    run = jax.vmap(step, in_axes=(None, None, None, 0, 0, 0, None, 0))
    carry, out = run(cfg.camera, cfg.noise, gates, carry, z, width, dt, present)
    nxt = jax.vmap(lambda s: predict(cfg.noise, s, jnp.asarray(cfg.camera.dt, z.dtype)))(
        carry.state)
    next_uv = jax.vmap(lambda m: measure(cfg.camera, m))(nxt.mean)
    est_uv = jax.vmap(lambda m: measure(cfg.camera, m))(out.mean)
    W = image_width(cfg.camera, cfg.width.mean, out.mean[:, 2])
    W_next = image_width(cfg.camera, cfg.width.mean, nxt.mean[:, 2])
    return carry, STEP_OUT.pack(z.dtype, valid=out.valid, started=out.started, mean=out.mean,
                                next_uv=next_uv, est_uv=est_uv, W=W, W_next=W_next)
