"""The pin-hole measurement model of equation (3) and its inverse on the ground plane.

Ground coordinates (m): x lateral, y horizontal distance ahead of the camera's foot. Image
coordinates (px): u to the right, v downwards. With sin(theta - pi/2) = -cos(theta) and
cos(theta - pi/2) = sin(theta), equation (3) reads

    u = Uc + a f x / (f + y cos(theta) + h sin(theta))
    v = Vc - b f (y sin(theta) - h cos(theta)) / (f + y cos(theta) + h sin(theta)).

The denominator (the `depth`, m) is the distance of the point from the image plane along the
optical axis plus f, exactly as the paper writes it. Where it is not positive the point is behind
the camera; every function here returns an `ok` flag instead of evaluating there (no NaN leaks).

Roll (an extension, `Camera.roll`, rad): the image of (3) is rotated by +roll about (Uc, Vc),

    u = Uc + cos(roll) du - sin(roll) dv,    v = Vc + sin(roll) du + cos(roll) dv,

where (du, dv) = (u - Uc, v - Vc) of (3). With u right and v down a positive roll turns the
picture clockwise on the screen: the horizon falls to the right with slope tan(roll). For
a = b this is exactly a rotation of the camera about its optical axis. roll = 0 is the paper's
model, and every function here then gives bit-identical results (cos 0 = 1, sin 0 = 0 exactly).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from .params import Camera


_EPS_DEPTH = 1e-3  # m; a point closer than this to the image plane is treated as behind it


def depth(camera: Camera, y: Float[Array, "..."]) -> Float[Array, "..."]:
    """The denominator of (3), f + y cos(theta) + h sin(theta), in m."""
    return camera.f + y * jnp.cos(camera.theta) + camera.h * jnp.sin(camera.theta)


def project(
    camera: Camera, x: Float[Array, "..."], y: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """Equation (3): image foot point (u, v) in px of the ground point (x, y) in m.

    Behind the camera (depth <= 1 mm) the depth is replaced by a safe value, so the result is
    finite but meaningless there; test `in_front(camera, y)` where that matters.
    """
    d = depth(camera, y)
    d_safe = jnp.where(d > _EPS_DEPTH, d, 1.0)  # double-where: no inf/NaN, finite gradients
    s, c = jnp.sin(camera.theta), jnp.cos(camera.theta)
    du = camera.a * camera.f * x / d_safe
    up = camera.b * camera.f * (y * s - camera.h * c) / d_safe  # = -(v - Vc) of (3)
    sr, cr = jnp.sin(camera.roll), jnp.cos(camera.roll)
    return camera.uc + (cr * du + sr * up), camera.vc - (cr * up - sr * du)


def unroll(
    camera: Camera, u: Float[Array, "..."], v: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """Image point (px) of the rolled camera -> the same point in the roll-free image of (3)."""
    du, dv = u - camera.uc, v - camera.vc
    sr, cr = jnp.sin(camera.roll), jnp.cos(camera.roll)
    return camera.uc + (cr * du + sr * dv), camera.vc + (cr * dv - sr * du)


def in_front(camera: Camera, y: Float[Array, "..."]) -> Bool[Array, "..."]:
    """True where the ground point at distance y (m) lies in front of the image plane."""
    return depth(camera, y) > _EPS_DEPTH


def measure(camera: Camera, state: Float[Array, "4"]) -> Float[Array, "2"]:
    """h(X) of (2)-(3) for the state X = (x_p, x_v, y_p, y_v): the predicted (u, v) in px."""
    u, v = project(camera, state[0], state[2])
    return jnp.stack([u, v])


def measure_jacobian(camera: Camera, state: Float[Array, "4"]) -> Float[Array, "2 4"]:
    """H of (9): the Jacobian of `measure` at `state`, by forward-mode autodiff."""
    return jax.jacfwd(measure, argnums=1)(camera, state)


def horizon_v(camera: Camera) -> Float[Array, ""]:
    """Image row (px) of the horizon, v as y -> infinity: Vc - b f tan(theta). With roll the
    horizon is a line of slope dv/du = tan(roll); this is its row at u = Uc,
    Vc - b f tan(theta) / cos(roll)."""
    return camera.vc - camera.b * camera.f * jnp.tan(camera.theta) / jnp.cos(camera.roll)


def ground_from_image(
    camera: Camera, u: Float[Array, "..."], v: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Float[Array, "..."], Bool[Array, "..."]]:
    """Inverse perspective: the ground point (x, y) in m of the image foot point (u, v) in px.

    Solves (3) for y from v, then x from u (after undoing the roll). `ok` is False for points on or
    above the horizon or whose ground point would lie behind the camera; there x and y are 0
    (finite, not NaN).
    """
    sr, cr = jnp.sin(camera.roll), jnp.cos(camera.roll)
    du = cr * (u - camera.uc) + sr * (v - camera.vc)  # roll-free offsets (see `unroll`)
    dv = cr * (camera.vc - v) + sr * (u - camera.uc)  # Vc - v of (3)
    s, c = jnp.sin(camera.theta), jnp.cos(camera.theta)
    bf = camera.b * camera.f
    den = bf * s - dv * c  # > 0 below the horizon
    ok_den = den > 1e-6 * bf
    den_safe = jnp.where(ok_den, den, 1.0)
    y = (dv * (camera.f + camera.h * s) + bf * camera.h * c) / den_safe
    d = depth(camera, y)
    ok = ok_den & (d > _EPS_DEPTH) & jnp.isfinite(u) & jnp.isfinite(v)
    d_safe = jnp.where(ok, d, 1.0)
    x = du * d_safe / (camera.a * camera.f)
    zero = jnp.zeros_like(y)
    return jnp.where(ok, x, zero), jnp.where(ok, y, zero), ok


def image_width(camera: Camera, width_m: Float[Array, "..."], y: Float[Array, "..."]):
    """Image width (px) of a ground width (m) at distance y (m): a f w cos(roll) / depth, from
    (3): the extent along the image rows of a lateral ground segment (a row-aligned box)."""
    d = depth(camera, y)
    d_safe = jnp.where(d > _EPS_DEPTH, d, 1.0)
    return camera.a * camera.f * width_m / d_safe * jnp.cos(camera.roll)


def ground_width(
    camera: Camera, width_px: Float[Array, "..."], u: Float[Array, "..."], v: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Bool[Array, "..."]]:
    """Real width (m) of an image width (px) seen at the foot point (u, v): the inverse of
    `image_width` at the ground point of (u, v). `ok` as in `ground_from_image`."""
    _, y, ok = ground_from_image(camera, u, v)
    d = jnp.where(ok, depth(camera, y), 1.0)
    return width_px * d / (camera.a * camera.f) / jnp.cos(camera.roll), ok
