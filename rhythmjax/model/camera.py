"""The pin-hole measurement model of equation (3) and its inverse on the ground plane.

Ground coordinates (m): x lateral, y horizontal distance ahead of the camera's foot. Image
coordinates (px): u to the right, v downwards. With sin(theta - pi/2) = -cos(theta) and
cos(theta - pi/2) = sin(theta), equation (3) reads

    u = Uc + a f x / (f + y cos(theta) + h sin(theta))
    v = Vc - b f (y sin(theta) - h cos(theta)) / (f + y cos(theta) + h sin(theta)).

The denominator (the `depth`, m) is the distance of the point from the image plane along the
optical axis plus f, exactly as the paper writes it. Where it is not positive the point is behind
the camera; every function here returns an `ok` flag instead of evaluating there (no NaN leaks).
A point z m above the ground is seen as a ground point by a camera h - z high: (3) with h
replaced by h - z (the renderer's 3-D parts, a pedestrian's head); z = 0 is (3) exactly.

Roll (an extension, `Camera.roll`, rad): the image of (3) is rotated by +roll about (Uc, Vc),

    u = Uc + cos(roll) du - sin(roll) dv,    v = Vc + sin(roll) du + cos(roll) dv,

where (du, dv) = (u - Uc, v - Vc) of (3). With u right and v down a positive roll turns the
picture clockwise on the screen: the horizon falls to the right with slope tan(roll). For
a = b this is exactly a rotation of the camera about its optical axis. roll = 0 is the paper's
model, and every function here then gives bit-identical results (cos 0 = 1, sin 0 = 0 exactly).

Written once: the formulas are the `*_with` functions below, plain arithmetic on a `Terms`
(the camera's constants) and arrays, with `where` and `isfinite` taken from an array namespace
`xp`. The JAX functions (`project`, `ground_from_image`, ...) call them with `jax.numpy` and
`terms(camera)`; the host code's float64 NumPy path (`camera_np`) calls the same functions with
`numpy` and Python-float constants, and `camera_np.SCALAR` runs them on plain Python floats.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from .params import Camera


MIN_DEPTH_M = 1e-3  # m; a point closer than this to the image plane is treated as behind it


class Terms(NamedTuple):
    """The camera's constants as the formulas of (3) use them: f, h (m), a, b (px/m), uc, vc
    (px), and sin / cos of theta and roll. JAX scalars (`terms`) or Python floats
    (`camera_np.host_terms`)."""

    f: Any
    h: Any
    a: Any
    b: Any
    uc: Any
    vc: Any
    sin_theta: Any
    cos_theta: Any
    sin_roll: Any
    cos_roll: Any


def terms(camera: Camera) -> Terms:
    """`Terms` of a `Camera` as JAX scalars (traceable: the fit differentiates through them)."""
    return Terms(camera.f, camera.h, camera.a, camera.b, camera.uc, camera.vc,
                 jnp.sin(camera.theta), jnp.cos(camera.theta), jnp.sin(camera.roll),
                 jnp.cos(camera.roll))


# ----------------------------------------------------------------------------------------------
# the formulas, once (any array namespace xp with `where` and `isfinite`)


def depth_with(k: Terms, y, z=None):
    """The denominator of (3) in m, f + y cos(theta) + (h - z) sin(theta), for a point z m above
    the ground (None: on it, the paper's f + y cos(theta) + h sin(theta))."""
    hz = k.h if z is None else k.h - z
    return k.f + y * k.cos_theta + hz * k.sin_theta


def _is_host_zero_roll(sin_roll, cos_roll) -> bool:
    """True only for host constants (Python floats; never under JAX) with roll exactly 0: the
    rotation is then the identity and is skipped (the same bits for finite values, less work)."""
    return type(sin_roll) is float and sin_roll == 0.0 and cos_roll == 1.0


def unroll_offsets(k: Terms, du, dv):
    """Offsets (du, dv) px from (Uc, Vc) in the rolled image (v down) -> in the image of (3):
    the rotation by -roll (the inverse of the one in `project_with`)."""
    sr, cr = k.sin_roll, k.cos_roll
    if _is_host_zero_roll(sr, cr):
        return du, dv
    return cr * du + sr * dv, cr * dv - sr * du


def project_with(xp, k: Terms, x, y, z=None):
    """Equation (3) with roll: image point (u, v) px of the point (x, y) m on the ground plane
    and z m above it (None: on it). Behind the camera (depth <= `MIN_DEPTH_M`) the depth is
    replaced by 1 m (a double `where`: finite values and gradients, meaningless there)."""
    f, h, a, b, uc, vc, s, c, sr, cr = k
    hz = h if z is None else h - z
    d = depth_with(k, y, z)
    d_safe = xp.where(d > MIN_DEPTH_M, d, 1.0)
    du = a * f * x / d_safe  # u - Uc of (3)
    up = b * f * (y * s - hz * c) / d_safe  # Vc - v of (3)
    if _is_host_zero_roll(sr, cr):
        return uc + du, vc - up
    # the rotation by +roll (v down): u - Uc = cr du - sr (v - Vc), v - Vc = sr du + cr (v - Vc)
    return uc + (cr * du + sr * up), vc - (cr * up - sr * du)


def ground_with(xp, k: Terms, u, v):
    """Inverse perspective: ground point (x, y) m of the image foot point (u, v) px, and `ok`.

    Undoes the roll, solves (3) for y from v, then x from u. `ok` is False on or above the
    horizon, where the ground point would lie behind the camera, and for non-finite (u, v);
    there x = y = 0 (finite, not NaN)."""
    f, h, a, b, uc, vc, s, c, _, _ = k
    where = xp.where
    du, dv = unroll_offsets(k, u - uc, v - vc)  # dv = v - Vc of (3)
    bf = b * f
    den = bf * s + dv * c  # > 0 below the horizon
    ok = xp.isfinite(u) & xp.isfinite(v) & (den > 1e-6 * bf)
    y = (bf * h * c - dv * (f + h * s)) / where(ok, den, 1.0)
    d = depth_with(k, y)
    ok = ok & (d > MIN_DEPTH_M)
    x = du * where(ok, d, 1.0) / (a * f)
    return where(ok, x, 0.0), where(ok, y, 0.0), ok


def image_width_with(xp, k: Terms, width_m, y):
    """Image width (px) of a lateral ground segment width_m m wide at distance y m, measured
    along the image rows: a f w cos(roll) / depth, from (3) and the roll."""
    d = depth_with(k, y)
    return k.a * k.f * width_m / xp.where(d > MIN_DEPTH_M, d, 1.0) * k.cos_roll


def upright_size_with(xp, k: Terms, u, v, width_m, height_m):
    """(w, h, ok): image size in px of an upright box width_m m wide and height_m m tall standing
    on the ground point of the foot point (u, v) px: w its width at the feet along the rows
    (`image_width_with`), h = v - the image row of its top (the point height_m above the ground
    point). `ok` as in `ground_with` and the top in front of the camera; w = h = NaN where not."""
    x, y, ok = ground_with(xp, k, u, v)
    ok = ok & (depth_with(k, y, height_m) > MIN_DEPTH_M)
    _, v_top = project_with(xp, k, x, y, height_m)
    nan = xp.where(ok, 1.0, float("nan"))
    return image_width_with(xp, k, width_m, y) * nan, (v - v_top) * nan, ok


def height_from_top_with(xp, k: Terms, x, y, v_top):
    """(H, ok): the height H m of the vertical segment standing on the ground point (x, y) m
    whose top projects to the image row v_top px, (3) with roll solved for the top's height z:
    with q = Vc - v_top, d0 = the depth of (x, y), N0 = cos(roll) b f (y sin(theta) - h
    cos(theta)) - sin(roll) a f x, H = (q d0 - N0) / (b f cos(theta) cos(roll) + q sin(theta)).
    `ok` is False where v_top is not finite or lies at or beyond the vertical vanishing point
    (denominator <= 1e-6 b f); H is 0 there (finite)."""
    bf, af = k.b * k.f, k.a * k.f
    q = k.vc - xp.where(xp.isfinite(v_top), v_top, k.vc)
    den = bf * k.cos_theta * k.cos_roll + q * k.sin_theta
    n0 = k.cos_roll * bf * (y * k.sin_theta - k.h * k.cos_theta) - k.sin_roll * af * x
    ok = xp.isfinite(v_top) & (den > 1e-6 * bf)
    H = (q * depth_with(k, y) - n0) / xp.where(ok, den, 1.0)
    return xp.where(ok, H, 0.0), ok


# ----------------------------------------------------------------------------------------------
# the JAX front (what the EKF and the fits use)


def depth(camera: Camera, y: Float[Array, "..."]) -> Float[Array, "..."]:
    """The denominator of (3), f + y cos(theta) + h sin(theta), in m."""
    return depth_with(terms(camera), y)


def project(
    camera: Camera, x: Float[Array, "..."], y: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """Equation (3) with roll: image foot point (u, v) in px of the ground point (x, y) in m.

    Behind the camera (depth <= 1 mm) the depth is replaced by a safe value, so the result is
    finite but meaningless there; test `in_front(camera, y)` where that matters.
    """
    return project_with(jnp, terms(camera), x, y)


def project_3d(
    camera: Camera, x: Float[Array, "..."], y: Float[Array, "..."], z: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """`project` for the point (x, y) m on the ground plane and z m above it."""
    return project_with(jnp, terms(camera), x, y, z)


def unroll(
    camera: Camera, u: Float[Array, "..."], v: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """Image point (px) of the rolled camera -> the same point in the roll-free image of (3)."""
    k = terms(camera)
    du, dv = unroll_offsets(k, u - k.uc, v - k.vc)
    return k.uc + du, k.vc + dv


def in_front(camera: Camera, y: Float[Array, "..."]) -> Bool[Array, "..."]:
    """True where the ground point at distance y (m) lies in front of the image plane."""
    return depth(camera, y) > MIN_DEPTH_M


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
    return ground_with(jnp, terms(camera), u, v)


def image_width(camera: Camera, width_m: Float[Array, "..."], y: Float[Array, "..."]):
    """Image width (px) of a ground width (m) at distance y (m): a f w cos(roll) / depth, from
    (3): the extent along the image rows of a lateral ground segment (a row-aligned box)."""
    return image_width_with(jnp, terms(camera), width_m, y)


def ground_width(
    camera: Camera, width_px: Float[Array, "..."], u: Float[Array, "..."], v: Float[Array, "..."]
) -> tuple[Float[Array, "..."], Bool[Array, "..."]]:
    """Real width (m) of an image width (px) seen at the foot point (u, v): the inverse of
    `image_width` at the ground point of (u, v). `ok` as in `ground_from_image`."""
    _, y, ok = ground_from_image(camera, u, v)
    d = jnp.where(ok, depth(camera, y), 1.0)
    return width_px * d / (camera.a * camera.f) / jnp.cos(camera.roll), ok
