"""The gait cue's stride model of self-calibration (`fit.selfcal_gait.expected_stride`,
`fit_selfcal(..., stride_model=...)`, `rhythmjax-fit selfcal --stride-model`; issue 19).

References: hand-worked values of the model with Table 1's walking model, and the simulator's
camera for walkers who stroll at a constant walk ratio (their steps shorter than Table 1's
0.72 m because they step slowly): Table 1's stride model puts the camera too high by about the
ratio of the paces, the walk-ratio model does not."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest

import rhythmjax.sim.tracks as sim_tracks
from fit.cli import main as fit_main
from fit.selfcal import fit_selfcal
from fit.selfcal_data import camera_values
from fit.selfcal_gait import STRIDE_MODELS, expected_stride
from fit.walking import batch_of, make_labelled
from rhythmjax.io import write_table
from rhythmjax.model.params import Camera, Config, WalkingModel

from .helpers_selfcal import strolling_params


F = 0.008
TRUE = Camera(f=F, h=5.5, theta=math.radians(21.0), a=950 / F, b=950 / F, uc=640, vc=360,
              fps=15.0, image_width=1280, image_height=720)
START = Config(camera=Camera(f=F, h=4.0, theta=math.radians(15.0), a=1280 / F, b=1280 / F,
                             uc=640, vc=360, fps=15.0, image_width=1280, image_height=720))
STROLL_PACE_HZ = 1.75  # the strollers' mean pace: 0.85 of Table 1's 2.05 Hz
CUES = ("gait", "speed", "width")  # no height cue: the stride alone sets the scale


def test_table1_model_by_hand():
    """Power 0: Table 1's stride N(0.72, 0.09^2) m whatever the pace."""
    wk = WalkingModel()
    for pace in (1.5, 2.05, 2.6):
        mean, sd = expected_stride(jnp.float32(pace), wk, 0.0)
        assert float(mean) == pytest.approx(0.72, abs=1e-6)
        assert float(sd) == pytest.approx(0.09, abs=1e-6)


def test_walk_ratio_model_by_hand():
    """Power 1 at F = 1.64 Hz (0.8 of 2.05): mean 0.72 x 0.8 = 0.576 m; spread 0.09 x 0.8 x s,
    s = sqrt(1 - (0.183 / 2.05)^2 / 0.125^2) = sqrt(1 - 0.51001) = 0.69999, so 0.050399 m."""
    mean, sd = expected_stride(jnp.float32(1.64), WalkingModel(), 1.0)
    assert float(mean) == pytest.approx(0.576, abs=1e-5)
    assert float(sd) == pytest.approx(0.050399, abs=2e-5)


def test_walk_ratio_spread_floor():
    """A pace spread as large, relatively, as the stride's leaves nothing for the ratio: the
    spread is floored at half Table 1's relative spread (0.09 x 0.5 at the mean pace)."""
    wk = WalkingModel(pace_std=0.4)
    _, sd = expected_stride(jnp.float32(2.05), wk, 1.0)
    assert float(sd) == pytest.approx(0.045, abs=1e-6)


def test_unknown_stride_model_is_refused():
    with pytest.raises(ValueError, match="stride model 'ratio'"):
        fit_selfcal(START, None, stride_model="ratio")
    assert set(STRIDE_MODELS) == {"table1", "walk-ratio"}


@pytest.fixture(scope="module")
def strollers(monkeypatch_module):
    """20 walkers seen by TRUE (seed 5) who step at N(1.75, 0.12^2) Hz with steps of
    0.72 F / 2.05 m (a constant walk ratio): about 0.61 m, 0.85 of Table 1's mean."""
    monkeypatch_module.setattr(sim_tracks, "kind_params",
                               strolling_params(sim_tracks.kind_params, STROLL_PACE_HZ))
    cols, truth = make_labelled(n_walkers=20, n_bicycles=0, n_dogs=0, n_cars=0, seed=5,
                                camera=TRUE)
    paces = [t.pace_hz for t in truth if t.label == "pedestrian"]
    assert np.mean(paces) == pytest.approx(STROLL_PACE_HZ, abs=0.1)
    return cols, batch_of(cols, START)


@pytest.fixture(scope="module")
def monkeypatch_module():
    mp = pytest.MonkeyPatch()
    yield mp
    mp.undo()


def test_walk_ratio_recovers_the_scale_of_strollers(strollers):
    """Table 1's model reads the short steps as a camera too high (h +10 % or more: the pace
    ratio 2.05 / 1.75 is 1.17); the walk-ratio model puts h within 5 % and the tilt within
    1.5 deg of the truth."""
    truth = camera_values(TRUE)
    table1 = fit_selfcal(START, strollers[1], cues=CUES)
    ratio = fit_selfcal(START, strollers[1], cues=CUES, stride_model="walk-ratio")
    assert table1.camera is not None and ratio.camera is not None
    assert table1.values["h"] / truth["h"] - 1 > 0.10
    assert abs(ratio.values["h"] / truth["h"] - 1) < 0.05
    assert abs(ratio.values["theta"] - truth["theta"]) < 1.5
    assert abs(ratio.values["h"] / truth["h"] - 1) < abs(table1.values["h"] / truth["h"] - 1)


def test_cli_passes_the_stride_model(tmp_path, strollers, selfcal_calls, capsys):
    """`--stride-model walk-ratio` reaches fit_selfcal; without it, Table 1's (three tracks:
    refused after the fit was asked)."""
    cols = strollers[0]
    keep = np.isin(cols["track_id"], np.unique(cols["track_id"])[:3])
    path = tmp_path / "tracks.parquet"
    names = ["track_id", "frame", "t", "u", "v", "width_px", "intensity"]
    write_table(path, {k: np.asarray(cols[k])[keep] for k in names}, names)
    for extra, want in (((), "table1"), (("--stride-model", "walk-ratio"), "walk-ratio")):
        rc = fit_main(["selfcal", str(path), "--image-size", "1280x720", "--fps", "15",
                       "-o", str(tmp_path / "cam.json"), *extra])
        assert rc == 1 and selfcal_calls[-1].get("stride_model") == want
    capsys.readouterr()
