"""The top rows' depth offset of the height cue (`fit.selfcal_height.height_from_top` with
`depth_m`; `rhythmjax-fit selfcal --top-depth`): the height of a head point D m beyond the foot
point along the ground, against the pin-hole of (3) written out here in NumPy float64 (no roll:
depth = f + y cos(theta) + (h - z) sin(theta), v = Vc - b f (y sin(theta) - (h - z)
cos(theta)) / depth, u = Uc + a f x / depth)."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from fit.cli import main
from fit.selfcal import fit_selfcal
from fit.selfcal_height import height_from_top
from rhythmjax.model.params import Camera, Config


F = 0.008
CAM = Camera(f=F, h=7.0, theta=math.radians(16.5), a=742 / F, b=742 / F, uc=240, vc=180,
             fps=7.0, image_width=480, image_height=360)


def image_of(x, y, z):
    f, h, th = float(CAM.f), float(CAM.h), float(CAM.theta)
    depth = f + y * math.cos(th) + (h - z) * math.sin(th)
    return (float(CAM.uc) + float(CAM.a) * f * x / depth,
            float(CAM.vc) - float(CAM.b) * f * (y * math.sin(th) - (h - z) * math.cos(th)) / depth)


@pytest.mark.parametrize("depth", [0.0, 0.23, 0.6])
def test_height_of_a_head_beyond_the_feet(depth):
    """Feet at (x, y), head top at (x, y + D, z): H == z to 2e-6 m (the camera is float32) with
    depth_m = D; the plain segment (depth 0) reads a taller walker when D > 0, by (h - z) D /
    (y + D) for a camera h m up (the bias the option removes: at 10 m from PETS09's 7 m camera,
    0.23 m beyond reads 1.7 m as 1.82 m)."""
    x, y, z = np.array([-3.0, 0.5, 2.5, 4.0]), np.array([6.0, 10.0, 14.0, 22.0]), np.array(
        [1.55, 1.7, 1.82, 0.5])
    foot = np.array([image_of(*p, 0.0) for p in zip(x, y)])
    top = np.array([image_of(a, b + depth, c)[1] for a, b, c in zip(x, y, z)])
    with jax.enable_x64(True):
        H, ok = height_from_top(CAM, jnp.asarray(foot[:, 0]), jnp.asarray(foot[:, 1]),
                                jnp.asarray(top), depth)
        plain, _ = height_from_top(CAM, jnp.asarray(foot[:, 0]), jnp.asarray(foot[:, 1]),
                                   jnp.asarray(top))
    assert np.all(np.asarray(ok))
    np.testing.assert_allclose(np.asarray(H), z, rtol=0, atol=2e-6)
    if depth == 0.23:
        assert float(plain[1]) == pytest.approx(1.7 + 5.3 * 0.23 / 10.23, abs=1e-3)
    if depth > 0:
        assert np.all(np.asarray(plain) > z)


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf])
def test_a_bad_depth_is_refused(bad):
    with pytest.raises(ValueError, match="top_depth_m"):
        fit_selfcal(Config(camera=CAM), None, top_depth_m=bad)


def test_the_command_refuses_a_negative_depth(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["selfcal", str(tmp_path / "t.csv"), "-o", str(tmp_path / "c.json"),
              "--top-depth", "-1"])
    assert e.value.code == 2 and "--top-depth" in capsys.readouterr().err
