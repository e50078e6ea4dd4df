"""The crowd's mean stride in self-calibration (`fit.selfcal_cost.crowd_stride`,
`fit_selfcal(..., stride_mean_sd=...)`, `rhythmjax-fit selfcal --stride-mean-sd`; issue 19).

References: a hand-worked posterior mean, the gait residuals recomputed in NumPy from the raw
strides, central finite differences for the residuals' derivative in the camera height, and the
simulator's camera for a crowd that strolls (steps 0.85 of Table 1's 0.72 m) and is of Table 1's
height: with the mean stride held, the gait cue reads the short steps as a camera too high and
the height cue as one too low, and the fit tilts the camera to reconcile them (the signature
PETS09 shows, docs/selfcal.md); with the mean estimated, both come right."""

from __future__ import annotations

import inspect
import math
import types

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rhythmjax.sim.tracks as sim_tracks
from fit.cli import main as fit_main
from fit.selfcal import DEFAULT_CUES, fit_selfcal
from fit.selfcal_cost import N_BLOCKS, crowd_stride, cue_weights, raw_cues, standardised
from fit.selfcal_crowd import crowd_mean
from fit.selfcal_data import camera_values, make_data, scene_batch, select
from fit.selfcal_gait import STRIDE_MEAN_SD_M, relative_spread
from rhythmjax.model.params import Camera, Config, WalkingModel

from .helpers_selfcal import strolling_params, three_track_command, walkers_with


F = 0.008
TRUE = Camera(f=F, h=5.5, theta=math.radians(21.0), a=950 / F, b=950 / F, uc=640, vc=360,
              fps=15.0, image_width=1280, image_height=720)
START = Config(camera=Camera(f=F, h=4.0, theta=math.radians(15.0), a=1280 / F, b=1280 / F,
                             uc=640, vc=360, fps=15.0, image_width=1280, image_height=720))
STROLL_PACE_HZ = 1.75  # the strollers' mean pace; their steps 0.72 F / 2.05 m (0.85 x 0.72)


def test_crowd_stride_by_hand():
    """Strides 0.60, 0.66, 0.72 and 2.0 m (a bicycle) and one invalid track, Table 1's model
    (0.72 m, relative spread 0.125), prior spread 0.05 m: ratios 0.8333, 0.9167, 1, 2.7778,
    median 0.958333; n / 0.125^2 = 256, 1 / (0.05 / 0.72)^2 = 207.36, so the mean is (256 x
    0.958333 + 207.36) / 463.36 = 0.976980 and the prior residual (0.976980 - 1) / 0.069444 =
    -0.331492. Held (0 m): the mean is 1, residual 0."""
    with jax.enable_x64(True):
        data = types.SimpleNamespace(pace=jnp.full(5, 1.9),
                                     valid=jnp.array([True, True, True, True, False]))
        r = {"stride": jnp.array([0.60, 0.66, 0.72, 2.0, 0.1])}
        ratio, mean, prior = crowd_stride(r, data, START, cue_weights(("gait",),
                                                                      stride_mean_sd=0.05))
        assert float(mean) == pytest.approx(0.976980, abs=2e-6)
        assert float(prior) == pytest.approx(-0.331492, abs=2e-6)
        assert np.allclose(ratio[:4], [0.833333, 0.916667, 1.0, 2.777778], atol=1e-6)
        _, held, none = crowd_stride(r, data, START, cue_weights(("gait",)))
        assert float(held) == 1.0 and float(none) == 0.0
        # the gait cue off: nothing estimated whatever the spread
        _, off, zero = crowd_stride(r, data, START, cue_weights(("speed",), stride_mean_sd=0.05))
        assert float(off) == 1.0 and float(zero) == 0.0
    assert float(relative_spread(WalkingModel(), 0.0)) == pytest.approx(0.125, abs=1e-7)
    assert float(relative_spread(WalkingModel(), 1.0)) == pytest.approx(0.0875, abs=2e-4)


def test_crowd_mean_gradient_against_finite_differences():
    """d mean / d x of the posterior mean (through the median's sort) against central
    differences, float64, at distinct values: only the median's two middle values move it."""
    with jax.enable_x64(True):
        x = jnp.array([0.81, 0.93, 1.02, 1.10, 2.5, 0.7, 1.0])
        ok = jnp.array([True, True, True, True, True, True, False])
        fn = lambda v: crowd_mean(v, ok, 1.0, 0.07, 0.125)[0]
        g = np.asarray(jax.grad(fn)(x))
        eps = 1e-6
        fd = [(float(fn(x.at[i].add(eps))) - float(fn(x.at[i].add(-eps)))) / (2 * eps)
              for i in range(7)]
        assert np.allclose(g, fd, rtol=1e-7, atol=1e-9)
        # six usable: the median is the mean of 0.93 and 1.02, the others do not move it
        assert g[1] > 0 and g[2] > 0 and g[0] == g[3] == g[4] == g[5] == g[6] == 0.0


@pytest.fixture(scope="module")
def strollers():
    """20 walkers seen by TRUE (seed 5) who step at N(1.75, 0.12^2) Hz with steps of
    0.72 F / 2.05 m (about 0.61 m), heads N(1.70, 0.07^2) m high (the simulator's)."""
    cols, _ = walkers_with(TRUE, lambda mp: mp.setattr(
        sim_tracks, "kind_params", strolling_params(sim_tracks.kind_params, STROLL_PACE_HZ)))
    return cols, scene_batch(cols, START)


def _data(batch):
    used, pace = select(START, batch)
    return make_data(batch, used, pace), int(used.sum())


def test_gait_residuals_against_numpy(strollers):
    """The gait block of `standardised` through the true camera, recomputed from the raw
    strides in NumPy: held, (T - 0.72) / 0.09; estimated (0.05 m), (T / 0.72 / m - 1) / 0.125
    with m the posterior mean of the strides' median ratio. 1e-12 (float64)."""
    with jax.enable_x64(True):
        data, n = _data(strollers[1])
        T = np.asarray(raw_cues(TRUE, data, START)["stride"])[:n]
        # Table 1's constants as the config holds them (float32: 0.72 is 0.72000003)
        mu, sd_t = float(START.walking.stride_mean), float(START.walking.stride_std)
        cv = sd_t / mu
        for sd in (0.0, 0.05):
            wt = cue_weights(DEFAULT_CUES, stride_mean_sd=sd)
            gait = np.asarray(standardised(TRUE, data, START, wt)).reshape(N_BLOCKS, -1)[0, :n]
            if sd == 0:
                want = (T - mu) / sd_t
            else:
                a, prec = n / cv**2, 1 / (sd / mu) ** 2
                m = (a * np.median(T / mu) + prec) / (a + prec)
                want = (T / mu / m - 1) / cv
            assert np.allclose(gait, want, rtol=1e-12, atol=1e-12)


def test_residuals_differentiable_in_the_camera(strollers):
    """d (gait residuals) / d h through the estimated mean against central differences
    (float64, relative 1e-6): h scales every stride and their median alike, so the relative
    residuals move only through the prior's pull on the crowd's mean; finite through the
    median's sort."""
    with jax.enable_x64(True):
        data, n = _data(strollers[1])
        wt = cue_weights(DEFAULT_CUES, stride_mean_sd=0.05)
        cam = jax.tree.map(lambda q: jnp.asarray(q, jnp.float64)
                           if isinstance(q, float) else q, TRUE)
        fn = lambda h: standardised(eqx.tree_at(lambda c: c.h, cam, h), data, START,
                                    wt).reshape(N_BLOCKS, -1)[0, :n]
        g = np.asarray(jax.jacfwd(fn)(jnp.float64(5.5)))
        eps = 1e-5
        fd = (np.asarray(fn(jnp.float64(5.5 + eps))) - np.asarray(fn(jnp.float64(5.5 - eps)))) / (
            2 * eps)
        assert np.all(np.isfinite(g))
        assert np.allclose(g, fd, rtol=1e-6, atol=1e-8)


def test_estimated_mean_stride_undoes_the_tilt_of_strollers(strollers):
    """Held, the strollers' short steps and their heights disagree on the scale: measured h
    +6.4 %, tilt -1.23 deg (more than 4 % and 0.8 deg asserted). Estimated about the model's
    mean with the suggested 0.05 m, h within 2 % and the tilt within 0.3 deg (measured +0.9 %,
    -0.05 deg); the note gives the crowd's mean stride, the drawn 0.85 x 0.72 m seen through
    the fitted camera (within 0.06 of it: the prior keeps it nearer 1)."""
    truth = camera_values(TRUE)
    held = fit_selfcal(START, strollers[1])
    free = fit_selfcal(START, strollers[1], stride_mean_sd=STRIDE_MEAN_SD_M)
    assert held.camera is not None and free.camera is not None
    err = lambda r: r.values["h"] / truth["h"] - 1
    assert err(held) > 0.04 and held.values["theta"] - truth["theta"] < -0.8
    assert abs(err(free)) < 0.02 and abs(free.values["theta"] - truth["theta"]) < 0.3
    assert not any("mean stride" in q for q in held.notes)
    note = [q for q in free.notes if "mean stride" in q][0]
    ratio = float(note.split("mean stride ")[1].split(" x")[0])
    assert abs(ratio - (STROLL_PACE_HZ / 2.05) * (1 + err(free))) < 0.06


def test_default_and_cli(tmp_path, strollers, selfcal_calls, capsys):
    """Held by default (fit_selfcal and the command); `--stride-mean-sd 0.05` reaches
    fit_selfcal (three tracks: refused after the fit was asked); a negative spread is refused
    (ValueError; exit 2 from the command)."""
    assert inspect.signature(fit_selfcal).parameters["stride_mean_sd"].default == 0.0
    assert STRIDE_MEAN_SD_M == 0.05
    with pytest.raises(ValueError, match="stride_mean_sd -0.1"):
        fit_selfcal(START, None, stride_mean_sd=-0.1)
    cols = strollers[0]
    base = three_track_command(tmp_path, cols)
    for extra, want in (((), 0.0), (("--stride-mean-sd", "0.05"), 0.05)):
        assert fit_main([*base, *extra]) == 1 and selfcal_calls[-1].get("stride_mean_sd") == want
    with pytest.raises(SystemExit) as e:
        fit_main([*base, "--stride-mean-sd", "-1"])
    assert e.value.code == 2
    capsys.readouterr()
