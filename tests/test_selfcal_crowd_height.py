"""The crowd's mean height in self-calibration (`fit.selfcal_height.crowd_height`,
`fit_selfcal(..., height_mean_sd=...)`, `rhythmjax-fit selfcal --height-mean-sd`; issue 19).

References: a hand-worked posterior mean, central finite differences for its gradient, and the
simulator's camera for a crowd taller than the config's 1.70 m: with the mean held, the height
cue reads the tall people as a camera too low; with the mean estimated, the gait cue keeps the
scale."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rhythmjax.sim.tracks as sim_tracks
from fit.cli import main as fit_main
from fit.selfcal import fit_selfcal
from fit.selfcal_data import camera_values, scene_batch
from fit.selfcal_height import HEIGHT_MEAN_SD_M, HEIGHT_STD_M, crowd_height
from rhythmjax.model.params import Camera, Config

from .helpers_selfcal import three_track_command, walkers_with


F = 0.008
TRUE = Camera(f=F, h=5.5, theta=math.radians(21.0), a=950 / F, b=950 / F, uc=640, vc=360,
              fps=15.0, image_width=1280, image_height=720)
START = Config(camera=Camera(f=F, h=4.0, theta=math.radians(15.0), a=1280 / F, b=1280 / F,
                             uc=640, vc=360, fps=15.0, image_width=1280, image_height=720))
TALL_M = 1.82  # the tall crowd's mean height: 7 % above the config's 1.70 m


def test_crowd_height_by_hand():
    """Heights 1.70, 1.80, 1.90, 1.95 usable (9.0 and 0.5 not): median 1.85, n = 4;
    n / 0.07^2 = 816.327, 1 / 0.05^2 = 400, so the mean is (816.327 x 1.85 + 400 x 1.70) /
    1216.327 = 1.800671 and the prior residual (1.800671 - 1.70) / 0.05 = 2.013419."""
    with jax.enable_x64(True):
        h = jnp.array([1.70, 9.0, 1.80, 1.90, 0.5, 1.95])
        ok = jnp.array([True, False, True, True, False, True])
        mean, r = crowd_height(h, ok, 1.70, 0.05)
        assert float(mean) == pytest.approx(1.800671, abs=2e-6)
        assert float(r) == pytest.approx(2.013419, abs=2e-5)
        assert HEIGHT_STD_M == 0.07


def test_default_spread():
    """The default spread (set a priori, not fitted) is what fit_selfcal and the command use."""
    import inspect

    assert HEIGHT_MEAN_SD_M == 0.05
    default = inspect.signature(fit_selfcal).parameters["height_mean_sd"].default
    assert default == HEIGHT_MEAN_SD_M


def test_crowd_height_held():
    """Spread 0, or no usable walker: the prior's mean, residual 0."""
    h = jnp.array([1.9, 2.0, 1.8])
    for ok, sd in ((jnp.array([True, True, True]), 0.0), (jnp.zeros(3, bool), 0.05)):
        mean, r = crowd_height(h, ok, 1.70, sd)
        assert float(mean) == pytest.approx(1.70, abs=1e-7) and float(r) == 0.0
        g = jax.grad(lambda x, ok=ok, sd=sd: crowd_height(x, ok, 1.70, sd)[0])(h)
        assert np.all(np.isfinite(np.asarray(g)))


def test_crowd_height_gradient_matches_differences():
    """d mean / d heights against central differences (step 1e-6 m, float64): the median's
    middle values carry n / s^2 / (n / s^2 + 1 / sd^2), shared when the count is even."""
    with jax.enable_x64(True):
        h = jnp.array([1.62, 1.75, 1.71, 1.88, 1.79])
        ok = jnp.array([True, True, True, True, False])
        fn = lambda x: crowd_height(x, ok, 1.70, 0.05)[0]
        g = np.asarray(jax.grad(fn)(h))
        fd = np.array([(float(fn(h.at[i].add(1e-6))) - float(fn(h.at[i].add(-1e-6)))) / 2e-6
                       for i in range(h.size)])
        np.testing.assert_allclose(g, fd, atol=1e-6)
        a = 4 / 0.07**2
        share = a / (a + 1 / 0.05**2) / 2  # the two middle values 1.71 and 1.75
        np.testing.assert_allclose(g, [0, share, share, 0, 0], atol=1e-9)


def test_report_of_non_finite_residuals():
    """A degenerate camera whose residuals or Jacobian are not finite gets infinite SEs (the
    fit is then flagged "not determined"), not an SVD error."""
    from fit.selfcal_report import report

    J = np.array([[1.0, np.nan], [0.0, 1.0], [1.0, 1.0]])
    cov, se, cond, weak = report(J, np.eye(2), np.ones(3), ("h", "theta"), 3)
    assert np.all(np.isinf(cov)) and all(math.isinf(v) for v in se.values())
    assert math.isinf(cond) and weak == "residuals not finite"
    cov, se, cond, _ = report(np.eye(3)[:, :2], np.eye(2), np.ones(3), ("h", "theta"), 3)
    assert np.all(np.isfinite(cov)) and math.isfinite(cond)


def test_negative_spread_is_refused():
    with pytest.raises(ValueError, match="height_mean_sd -0.1"):
        fit_selfcal(START, None, height_mean_sd=-0.1)


@pytest.fixture(scope="module")
def tall_crowd():
    """20 walkers seen by TRUE (seed 5) whose heads stand N(1.82, 0.07^2) m high."""
    cols, _ = walkers_with(TRUE, lambda mp: mp.setitem(sim_tracks.HEIGHT_M, "pedestrian",
                                                        (TALL_M, 0.07)))
    return cols, scene_batch(cols, START)


def test_estimated_mean_moves_the_scale_towards_the_gait(tall_crowd):
    """Held at 1.70 m, the tall crowd's heights pull h low (more than 5 %; without the height
    cue within 4.5 %). Estimated about 1.70 +- 0.05 m, the crowd's mean takes part of the
    difference (the prior on the mean is about as strong as 20 strides): h rises by at least
    0.4 points and stays below the fit without heights; with a spread of 1 m the heights no
    longer set the scale, and h lies within 1 point of the fit without them. The notes' mean
    heights are the crowd's median through each fit's camera (within 0.05 m of the drawn
    1.82 m), the default's as `crowd_height` gives it for that median (0.008 m)."""
    truth = camera_values(TRUE)
    err = lambda r: r.values["h"] / truth["h"] - 1
    fits = {sd: fit_selfcal(START, tall_crowd[1], height_mean_sd=sd) for sd in (0.0, 0.05, 1.0)}
    no_heights = fit_selfcal(START, tall_crowd[1], cues=("gait", "speed", "width"))
    assert all(r.camera is not None for r in (*fits.values(), no_heights))
    assert err(fits[0.0]) < -0.05 and err(no_heights) > -0.045
    assert err(fits[0.0]) + 0.004 < err(fits[0.05]) < err(no_heights)
    assert abs(err(fits[1.0]) - err(no_heights)) < 0.01
    for r in (*fits.values(), no_heights):
        assert abs(r.values["theta"] - truth["theta"]) < 1.0
    assert not any("mean height" in n for n in fits[0.0].notes)
    mean = {sd: float([n for n in fits[sd].notes if "mean height" in n][0]
                      .split("mean height ")[1].split(" m")[0]) for sd in (0.05, 1.0)}
    # heights scale with h: the crowd's median through the true camera, from the nearly free
    # fit (its prior weighs 1 / (20 / 0.07^2 + 1) = 0.02 %), lies near the drawn 1.82 m ...
    crowd = mean[1.0] / (1 + err(fits[1.0]))
    assert abs(crowd - TALL_M) < 0.05
    # ... and the default's note is crowd_height's posterior mean of that median seen through
    # the default's camera (n = 20; measured 0.005 m apart: the per-track medians move a little
    # with the tilt)
    a, prec = 20 / HEIGHT_STD_M**2, 1 / 0.05**2
    seen = crowd * (1 + err(fits[0.05]))
    assert abs(mean[0.05] - (a * seen + prec * 1.70) / (a + prec)) < 0.008


def test_cli_passes_the_spread(tmp_path, tall_crowd, selfcal_calls, capsys):
    """`--height-mean-sd 0` reaches fit_selfcal; without it the default 0.05 m (three tracks:
    refused after the fit was asked); a negative spread is a usage error (exit 2)."""
    cols = tall_crowd[0]
    base = three_track_command(tmp_path, cols)
    for extra, want in (((), HEIGHT_MEAN_SD_M), (("--height-mean-sd", "0"), 0.0)):
        assert fit_main([*base, *extra]) == 1 and selfcal_calls[-1].get("height_mean_sd") == want
    with pytest.raises(SystemExit) as e:
        fit_main([*base, "--height-mean-sd", "-1"])
    assert e.value.code == 2
    capsys.readouterr()
