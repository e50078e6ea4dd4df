"""The gait residuals' and the heights' spreads estimated from the walkers
(`fit.selfcal_cost.model_spreads`, `fit_selfcal(..., cue_spreads=...)`, `rhythmjax-fit selfcal
--cue-spreads`; issue 19).

References: spreads worked by hand (1.4826 x the median absolute deviation, floored at 1), the
residual blocks of `standardised` with and without a spread (exact ratios), and a crowd whose
strides spread twice as much as Table 1's about the same mean, seen by a known camera: the
estimate must find the wider spread and stay at the model's on Table 1's crowd."""

from __future__ import annotations

import inspect
import math

import jax
import numpy as np
import pytest

import rhythmjax.sim.tracks as sim_tracks
from fit.cli import main as fit_main
from fit.selfcal import CUE_SPREADS, DEFAULT_CUES, fit_selfcal
from fit.selfcal_cost import N_BLOCKS, cue_weights, model_spreads, raw_cues, standardised
from fit.selfcal_data import make_data, scene_batch, select
from fit.selfcal_height import HEIGHT_STD_M
from rhythmjax.model.params import Camera, Config

from .helpers_selfcal import three_track_command, walkers_with


F = 0.008
TRUE = Camera(f=F, h=5.5, theta=math.radians(21.0), a=950 / F, b=950 / F, uc=640, vc=360,
              fps=15.0, image_width=1280, image_height=720)
START = Config(camera=Camera(f=F, h=4.0, theta=math.radians(15.0), a=1280 / F, b=1280 / F,
                             uc=640, vc=360, fps=15.0, image_width=1280, image_height=720))


def test_model_spreads_by_hand():
    """Two walkers' worth of padding after five used ones. Gait block 0, 1, 2, 3, 10: median 2,
    deviations 2, 1, 0, 1, 8, MAD 1, spread 1.4826. Height-level block (block 4) 0, 0.3, 0.6,
    0.9, 50 with the last walker without heights (hok False): median 0.45, deviations 0.45,
    0.15, 0.15, 0.45, MAD 0.3, 1.4826 x 0.3 = 0.445 floored at 1. Padding never enters."""
    B, n = 7, 5
    std = np.zeros((N_BLOCKS, B))
    std[0, :n] = [0, 1, 2, 3, 10]
    std[0, n:] = 1e3
    std[4, :n] = [0, 0.3, 0.6, 0.9, 50]
    hok = np.array([True, True, True, True, False])
    g, h = model_spreads(std.ravel(), n, hok)
    assert g == pytest.approx(1.4826, abs=1e-12) and h == 1.0
    std[4, :n] = [0, 3, 6, 9, 50]  # MAD 3 over the four with heights: 4.4478
    assert model_spreads(std.ravel(), n, hok)[1] == pytest.approx(4.4478, abs=1e-12)
    assert model_spreads(std.ravel(), n, np.zeros(n, bool))[1] == 1.0  # no heights


@pytest.fixture(scope="module")
def crowds():
    """(Table 1's crowd, a crowd whose strides are N(0.72, 0.18^2) m), 30 walkers each seen by
    TRUE (seed 5), as batches of the start config."""
    def wide(mp):
        draw = sim_tracks.kind_params

        def params(kind, rng, size=None):
            pace, stride, speed, depth = draw(kind, rng, size)
            if kind != "pedestrian":
                return pace, stride, speed, depth
            stride = 0.72 + 2.0 * (stride - 0.72)  # twice the spread about the same mean
            return pace, stride, pace * stride, depth

        mp.setattr(sim_tracks, "kind_params", params)

    return tuple(scene_batch(walkers_with(TRUE, p, n_walkers=30)[0], START)
                 for p in (lambda mp: None, wide))


def test_blocks_divided_by_the_spreads(crowds):
    """`standardised` with sd_gait 2 and sd_hlevel 3: the gait block is half, the height-level
    block a third of the model's, every other block unchanged (float64, 1e-12)."""
    with jax.enable_x64(True):
        used, pace = select(START, crowds[0])
        data = make_data(crowds[0], used, pace)
        one = np.asarray(standardised(TRUE, data, START, cue_weights(DEFAULT_CUES))).reshape(
            N_BLOCKS, -1)
        two = np.asarray(standardised(TRUE, data, START, cue_weights(
            DEFAULT_CUES, sd_gait=2.0, sd_hlevel=3.0))).reshape(N_BLOCKS, -1)
    assert np.abs(one[0]).max() > 0.5 and np.abs(one[4]).max() > 0.5
    assert np.allclose(two[0], one[0] / 2, rtol=1e-12, atol=1e-12)
    assert np.allclose(two[4], one[4] / 3, rtol=1e-12, atol=1e-12)
    rest = [1, 2, 3, 5, 6]
    assert np.allclose(two[rest], one[rest], rtol=1e-12, atol=1e-12)


def _true_camera_spreads(batch) -> tuple[float, float]:
    """The reference: 1.4826 x MAD, in NumPy, of the gait residuals (T - 0.72) / 0.09 and of
    the heights about their median (in 0.07 m at 1.70 m) of the walkers used, through the TRUE
    camera, floored at 1. Measured: Table 1's crowd 0.94 -> 1 and 1.16; the wide one 2.00 and
    0.78 -> 1."""
    with jax.enable_x64(True):
        used, pace = select(START, batch)
        n = int(used.sum())
        r = raw_cues(TRUE, make_data(batch, used, pace), START)
        gait = (np.asarray(r["stride"])[:n] - 0.72) / 0.09
        heights = np.asarray(r["height"])[:n][np.asarray(r["hok"])[:n]]
    mad = lambda a: 1.4826 * float(np.median(np.abs(a - np.median(a))))
    return max(1.0, mad(gait)), max(1.0, mad(heights / np.median(heights) * 1.70 / 0.07))


def test_estimated_spreads_find_a_wide_crowd(crowds):
    """The spreads the fit estimates (through its first fit's camera) against the same
    spreads through the true camera (`_true_camera_spreads`), within 12 % (the first fit's h
    is 1-7 % off); the crowd with twice Table 1's stride spread is found (> 1.5). Held (the
    default "model"): 1 and 1, reported likewise.
    Measured: 1.00 and 1.83 (heights 1.19 and 1.00); on the wide crowd h -6.98 % held and
    -3.99 % estimated (tilt +0.60 and +0.37 deg): asserted at least 1.5 points closer. The
    estimates are in the fit's notes with "data", not with "model"."""
    fits = {(k, how): fit_selfcal(START, b, cue_spreads=how)
            for k, b in enumerate(crowds) for how in ("model", "data")}
    for r in fits.values():
        assert r.camera is not None
    for k in (0, 1):
        held = fits[k, "model"].spreads
        assert held["stride_in_model"] == 1.0 and held["height_in_prior"] == 1.0
    for k, batch in enumerate(crowds):
        gait, heights = _true_camera_spreads(batch)
        got = fits[k, "data"].spreads
        assert got["stride_in_model"] == pytest.approx(gait, rel=0.12)
        assert got["height_in_prior"] == pytest.approx(heights, rel=0.12)
    assert fits[1, "data"].spreads["stride_in_model"] > 1.5  # the wide crowd found
    note = [q for q in fits[1, "data"].notes if q.startswith("spreads from the walkers")]
    assert note == [f"spreads from the walkers (--cue-spreads data): strides "
                    f"{fits[1, 'data'].spreads['stride_in_model']:.2f} x the walking model's, "
                    f"heights {fits[1, 'data'].spreads['height_in_prior']:.2f} x 0.07 m"]
    assert not any(q.startswith("spreads from") for q in fits[1, "model"].notes)
    h_err = lambda r: abs(r.values["h"] / 5.5 - 1)
    assert h_err(fits[1, "data"]) < h_err(fits[1, "model"]) - 0.015


def test_default_and_cli(tmp_path, crowds, selfcal_calls, capsys):
    """"model" by default (fit_selfcal and the command); `--cue-spreads data` reaches fit_selfcal
    (three tracks: refused after the fit was asked); an unknown value is a ValueError (exit 2
    from the command's parser)."""
    assert inspect.signature(fit_selfcal).parameters["cue_spreads"].default == "model"
    assert CUE_SPREADS == ("model", "data")
    assert HEIGHT_STD_M == 0.07
    with pytest.raises(ValueError, match="cue spreads 'wide'"):
        fit_selfcal(START, None, cue_spreads="wide")
    cols = walkers_with(TRUE, lambda mp: None, n_walkers=3)[0]
    base = three_track_command(tmp_path, cols)
    for extra, want in (((), "model"), (("--cue-spreads", "data"), "data")):
        assert fit_main([*base, *extra]) == 1 and selfcal_calls[-1].get("cue_spreads") == want
    with pytest.raises(SystemExit) as e:
        fit_main([*base, "--cue-spreads", "wide"])
    assert e.value.code == 2
    capsys.readouterr()
