"""`placement.noise`: the counting filter's own (q, R) instead of the config's
(`slot_filter.filter_config`), against the same noise read from a config's JSON noise section
(an independent path: `config_from_dict`), through the pedestrians level; and the fitting script
`benchmarks/fit_count_noise.py` recovering a known noise from simulated walker tracks."""

from __future__ import annotations

import copy
import math
import os
import sys

import numpy as np
import pytest

from rhythmjax.count import CountOptions
from rhythmjax.count.options import with_changes
from rhythmjax.count.slot_filter import SlotFilter, check_noise, filter_config
from rhythmjax.model.params import config_from_dict, config_to_dict

from .test_pedestrians import CFG, QUIET, SMALL


VALUES = (0.85, 0.53, 2.87, 4.64, -0.39)  # q_x, q_y m/s/sqrt(s), r_u, r_v px, r_corr


def _run(cfg, T=30):
    """Velocity covariance and estimate of one slot fed a straight walk with 2 px noise."""
    rng = np.random.default_rng(5)
    k = np.arange(T)
    z = np.stack([60.0 + 2.0 * k, 150.0 - 1.0 * k], 1) + rng.normal(0, 2.0, (T, 2))
    sf = SlotFilter(cfg, "3d", slots=2)
    for i in range(T):
        zz = np.full((2, 2), np.nan, np.float32)
        zz[0] = z[i]
        out = sf.step(np.array([i == 0, False]), zz, np.array([True, False]), 1 / 15)
    return np.asarray(out.velocity_cov[0]), np.asarray(out.est_uv[0])


def test_filter_config_is_the_config_noise_section():
    d = copy.deepcopy(SMALL)
    d["noise"] = {"q_std_mps_per_sqrt_s": list(VALUES[:2]), "r_std_px": list(VALUES[2:4]),
                  "r_corr": VALUES[4]}
    want = config_from_dict(d)
    got = filter_config(CFG, VALUES)
    for name in ("q_std", "R", "init_speed_std"):
        np.testing.assert_allclose(np.asarray(getattr(got.noise, name)()),
                                   np.asarray(getattr(want.noise, name)()), rtol=1e-6)
    assert filter_config(CFG, ()) is CFG
    a, b = config_to_dict(got), config_to_dict(CFG)  # only the noise changes
    assert a.pop("noise") != b.pop("noise") and a == b
    cov_got, est_got = _run(got)
    cov_want, est_want = _run(want)
    np.testing.assert_allclose(cov_got, cov_want, rtol=1e-5)
    np.testing.assert_allclose(est_got, est_want, rtol=1e-5)
    cov_cfg, _ = _run(CFG)  # and it is another filter than the config's
    assert abs(cov_got[0] - cov_cfg[0]) > 0.1 * cov_cfg[0]


def test_the_option_reaches_the_level_filter():
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    opt = with_changes(CountOptions(verdicts=QUIET), {"placement.noise": list(VALUES)})
    assert opt.placement.noise == VALUES  # a JSON list becomes a tuple (options stay hashable)
    hash(opt.placement)
    level = PedestrianLevel(CFG, opt)
    sf = SlotFilter(filter_config(CFG, VALUES), "3d", slots=opt.max_pedestrians)
    a = level.filter.step(np.eye(1, opt.max_pedestrians, dtype=bool)[0],
                          np.full((opt.max_pedestrians, 2), 100.0, np.float32),
                          np.ones(opt.max_pedestrians, bool), 1 / 15)
    b = sf.step(np.eye(1, opt.max_pedestrians, dtype=bool)[0],
                np.full((opt.max_pedestrians, 2), 100.0, np.float32),
                np.ones(opt.max_pedestrians, bool), 1 / 15)
    np.testing.assert_array_equal(a.ground, b.ground)
    np.testing.assert_array_equal(a.velocity_cov, b.velocity_cov)


def test_fit_script_keeps_only_the_rows_on_the_owner():
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))
    from fit_count_noise import batch, labelled_rows

    # a walker (truth id 7) at boxes 10 px wide; track 1 on it in frames 0-5, then off it (6-7);
    # frame 2 predicted; track 2 on a bicycle (id 8): not a walker's, left out
    F = np.arange(8)
    truth = {"frame": np.r_[F, F], "id": np.r_[[7] * 8, [8] * 8],
             "bb_left": np.r_[100.0 + F, 300.0 + F], "bb_top": np.full(16, 50.0),
             "bb_width": np.full(16, 10.0), "bb_height": np.full(16, 30.0)}
    left = np.r_[100.0 + F[:6], 200.0, 201.0]
    mot = {"frame": np.r_[F, F], "id": np.r_[[1] * 8, [2] * 8],
           "bb_left": np.r_[left, 300.0 + F], "bb_top": np.full(16, 50.0),
           "bb_width": np.full(16, 10.0), "bb_height": np.full(16, 30.0)}
    states = ["observe"] * 8
    states[2] = "predict"
    tracks = {"track_id": np.r_[[1] * 8, [2] * 8], "frame": np.r_[F, F],
              "u": np.r_[left + 5.0, 305.0 + F], "v": np.full(16, 80.0),
              "state": np.array(states + ["observe"] * 8, dtype=object)}
    dump = [{"mot": mot, "truth": truth, "tracks": tracks, "offset": 0,
             "kinds": {7: "pedestrian", 8: "bicycle"}}]
    rows = labelled_rows(dump)
    assert len(rows) == 1
    got = rows[0]
    np.testing.assert_array_equal(got[:, 0], F)
    want_u = np.r_[105.0, 106.0, np.nan, 108.0, 109.0, 110.0, np.nan, np.nan]
    np.testing.assert_array_equal(got[:, 1], want_u)
    # batch: padded to the longest, a frame missing inside a track is present with z NaN
    z, width, dt, present = batch([got, got[[0, 3]]], fps=10.0)
    assert z.shape == (2, 8, 2) and np.all(np.isnan(width)) and np.allclose(dt, 0.1)
    assert present[0].all() and present[1].tolist() == [True] * 4 + [False] * 4
    assert np.isnan(z[1, 1:3]).all() and z[1, 3, 0] == 108.0


@pytest.mark.parametrize("bad", [[1.0, 2.0], [0.0, 0.5, 2.0, 2.0, 0.0], [0.5, 0.5, -2.0, 2.0, 0.0],
                                 [0.5, 0.5, 2.0, 2.0, 1.0], [0.5, math.nan, 2.0, 2.0, 0.0],
                                 [0.5, 0.5, 2.0, math.inf, 0.0]])
def test_bad_noise_is_refused_naming_the_key(bad):
    with pytest.raises(ValueError, match="placement.noise"):
        with_changes(CountOptions(), {"placement.noise": bad})
    with pytest.raises(ValueError, match="placement.noise"):
        check_noise(bad)


def test_set_on_the_command_line():
    from rhythmjax.cli.option_changes import apply_option_changes
    from rhythmjax.model.params import ConfigError

    item = "placement.noise=[0.85,0.53,2.87,4.64,-0.39]"
    opt, changes = apply_option_changes(CountOptions(), [item])
    assert opt.placement.noise == VALUES and changes == {"placement.noise": VALUES}
    with pytest.raises(ConfigError, match="placement.noise must be"):
        apply_option_changes(CountOptions(), ["placement.noise=[1, 2]"])
