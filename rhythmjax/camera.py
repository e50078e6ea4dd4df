"""The pin-hole measurement model of equation (3) and its inverse on the ground plane.

Ground coordinates (m): x lateral, y horizontal distance ahead of the camera's foot. Image
coordinates (px): u to the right, v downwards. With sin(theta - pi/2) = -cos(theta) and
cos(theta - pi/2) = sin(theta), equation (3) reads

    u = Uc + a f x / (f + y cos(theta) + h sin(theta))
    v = Vc - b f (y sin(theta) - h cos(theta)) / (f + y cos(theta) + h sin(theta)).

The denominator (the `depth`, m) is the distance of the point from the image plane along the
optical axis plus f, exactly as the paper writes it. Where it is not positive the point is behind
the camera; every function here returns an `ok` flag instead of evaluating there (no NaN leaks).
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
    u = camera.uc + camera.a * camera.f * x / d_safe
    v = camera.vc - camera.b * camera.f * (y * s - camera.h * c) / d_safe
    return u, v


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
    """Image row (px) of the horizon, v as y -> infinity: Vc - b f tan(theta)."""
    return camera.vc - camera.b * camera.f * jnp.tan(camera.theta)


def ground_from_image(
    camera: Camera, u: Float[Array, "..."], v: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Float[Array, "..."], Bool[Array, "..."]]:
    """Inverse perspective: the ground point (x, y) in m of the image foot point (u, v) in px.

    Solves (3) for y from v, then x from u. `ok` is False for points on or above the horizon or
    whose ground point would lie behind the camera; there x and y are 0 (finite, not NaN).
    """
    s, c = jnp.sin(camera.theta), jnp.cos(camera.theta)
    bf = camera.b * camera.f
    dv = camera.vc - v
    den = bf * s - dv * c  # > 0 below the horizon
    ok_den = den > 1e-6 * bf
    den_safe = jnp.where(ok_den, den, 1.0)
    y = (dv * (camera.f + camera.h * s) + bf * camera.h * c) / den_safe
    d = depth(camera, y)
    ok = ok_den & (d > _EPS_DEPTH) & jnp.isfinite(u) & jnp.isfinite(v)
    d_safe = jnp.where(ok, d, 1.0)
    x = (u - camera.uc) * d_safe / (camera.a * camera.f)
    zero = jnp.zeros_like(y)
    return jnp.where(ok, x, zero), jnp.where(ok, y, zero), ok


def image_width(camera: Camera, width_m: Float[Array, "..."], y: Float[Array, "..."]):
    """Image width (px) of a ground width (m) at distance y (m): a f w / depth, from (3)."""
    d = depth(camera, y)
    d_safe = jnp.where(d > _EPS_DEPTH, d, 1.0)
    return camera.a * camera.f * width_m / d_safe


def ground_width(
    camera: Camera, width_px: Float[Array, "..."], u: Float[Array, "..."], v: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Bool[Array, "..."]]:
    """Real width (m) of an image width (px) seen at the foot point (u, v): the inverse of
    `image_width` at the ground point of (u, v). `ok` as in `ground_from_image`."""
    _, y, ok = ground_from_image(camera, u, v)
    d = jnp.where(ok, depth(camera, y), 1.0)
    return width_px * d / (camera.a * camera.f), ok
