import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model.params import (
    Config,
    ConfigError,
    Noise,
    WidthModel,
    config_from_dict,
    config_to_dict,
    host_float,
)


def test_table1_defaults():
    d = config_to_dict(Config())
    assert d["walking"] == pytest.approx({"pace_mean_hz": 2.05, "pace_std_hz": 0.183,
                                          "stride_mean_m": 0.72, "stride_std_m": 0.09}, rel=1e-6)
    t = d["thresholds"]
    assert (t["n_samples"], t["ar_order"]) == (64, 15)
    assert (t["p_thr"], t["r_thr"]) == pytest.approx((10.0, 0.1))
    assert (t["k_sigma1"], t["k_sigma2"], t["k_sigma3"]) == pytest.approx((3.0, 3.0, 3.0))
    assert (t["range_min_m"], t["range_max_m"]) == pytest.approx((3.0, 20.0))
    c = d["camera"]
    assert (c["h_m"], c["theta_deg"], c["fps"]) == pytest.approx((1.0, 15.0, 15.0), rel=1e-6)
    assert (c["image_width_px"], c["image_height_px"]) == (512, 512)


def test_json_round_trip_is_exact_enough():
    d = config_to_dict(Config())
    d["camera"]["h_m"] = 2.5
    d["noise"]["r_std_px"] = [1.5, 3.0]
    d["noise"]["r_corr"] = -0.3
    d["thresholds"]["n_samples"] = 128
    d2 = config_to_dict(config_from_dict(d))
    assert d2["camera"]["h_m"] == pytest.approx(2.5, rel=1e-7)
    assert d2["noise"]["r_std_px"] == pytest.approx([1.5, 3.0], rel=1e-6)
    assert d2["noise"]["r_corr"] == pytest.approx(-0.3, rel=1e-5)
    assert d2["thresholds"]["n_samples"] == 128
    assert d2["camera"]["theta_deg"] == pytest.approx(15.0, rel=1e-6)


def test_partial_config_takes_defaults():
    cfg = config_from_dict({"camera": {"h_m": 7.0}})
    assert float(cfg.camera.h) == pytest.approx(7.0)
    assert float(cfg.walking.pace_mean) == pytest.approx(2.05)


def test_noise_matrices_spd_and_match_their_parameters():
    n = Noise(q_std=(0.3, 0.5), r_std=(2.0, 4.0), r_corr=0.6)
    R = np.asarray(n.R(), float)
    np.testing.assert_allclose(R, [[4.0, 0.6 * 8.0], [0.6 * 8.0, 16.0]], rtol=1e-5)
    assert np.all(np.linalg.eigvalsh(R) > 0)
    Q = np.asarray(n.Q(0.1), float)
    np.testing.assert_allclose(np.diag(Q), [0, 0.09 * 0.1, 0, 0.25 * 0.1], rtol=1e-5)
    # any unconstrained value gives an SPD R: the optimiser can move freely
    n2 = jax.tree.map(lambda x: x + 3.7, n)
    assert np.all(np.linalg.eigvalsh(np.asarray(n2.R(), float)) > 0)


def test_params_are_pytrees_with_array_leaves():
    leaves = jax.tree.leaves(Config())
    assert all(isinstance(x, jnp.ndarray) for x in leaves)
    g = jax.grad(lambda c: c.camera.h * c.walking.pace_mean)(Config())
    assert float(g.camera.h) == pytest.approx(2.05)


@pytest.mark.parametrize(
    "d, match",
    [
        ({"camera": {"theta_degs": 15}},
         r"camera\.theta_degs: unknown key \(did you mean 'theta_deg'\?\)"),
        ({"camra": {}}, r"camra: unknown section \(did you mean 'camera'\?\)"),
        ({"camera": {"h_m": -1}}, r"camera\.h_m: must be > 0"),
        ({"camera": {"theta_deg": 0.26}}, r"looks like radians"),
        ({"camera": {"fps": 0}}, r"camera\.fps: must be > 0"),
        ({"noise": {"r_std_px": [1, -2]}}, r"noise\.r_std_px: must be > 0"),
        ({"noise": {"r_corr": 1.0}}, r"noise\.r_corr"),
        ({"thresholds": {"ar_order": 70}}, r"AR order 70 must be < n_samples - 1"),
        ({"thresholds": {"n_samples": 3.5}}, r"expected an integer"),
        ({"thresholds": {"window_hop_samples": -1}}, r"window_hop_samples: must be >= 0"),
        ({"thresholds": {"window_hop_samples": 16.5}}, r"window_hop_samples: expected an integer"),
        ({"thresholds": {"harmonic_max_ratio": -0.1}}, r"harmonic_max_ratio: must be >= 0"),
        ({"walking": {"pace_mean_hz": "2"}}, r"expected a number"),
        ({"width": {"height_m": 0.0}}, r"width\.height_m: must be > 0"),
        ({"width": {"height_m": "1.7"}}, r"width\.height_m: expected a number"),
        ({"width": {"heigth_m": 1.7}},
         r"width\.heigth_m: unknown key \(did you mean 'height_m'\?\)"),
        ({"walking": {"pace_std_hz": math.inf}}, r"must be finite"),
        ([1, 2], r"top level"),
    ],
)
def test_bad_config_values_name_the_key(d, match):
    with pytest.raises(ConfigError, match=match):
        config_from_dict(d)


def test_window_hop_and_harmonic_ratio_round_trip():
    """0 (the default) means N/2; the paper's back-to-back windows are hop = N; the half-pace
    rule off by default (0, the paper's (13)-(15)) and 0.25 when asked for."""
    t = config_to_dict(Config())["thresholds"]
    assert (t["window_hop_samples"], t["harmonic_max_ratio"]) == (0, 0.0)
    assert Config().thresholds.hop_samples == 32
    cfg = config_from_dict({"thresholds": {"window_hop_samples": 64, "harmonic_max_ratio": 0.25}})
    assert (cfg.thresholds.hop_samples, float(cfg.thresholds.harmonic_ratio)) == (64, 0.25)
    d = config_to_dict(cfg)["thresholds"]
    assert (d["window_hop_samples"], d["harmonic_max_ratio"]) == (64, 0.25)


def test_roll_key_round_trips_and_defaults_to_the_paper():
    assert config_to_dict(Config())["camera"]["roll_deg"] == 0.0
    cfg = config_from_dict({"camera": {"roll_deg": -3.09}})
    assert math.degrees(float(cfg.camera.roll)) == pytest.approx(-3.09, rel=1e-6)
    assert config_to_dict(cfg)["camera"]["roll_deg"] == pytest.approx(-3.09, rel=1e-6)
    with pytest.raises(ConfigError, match=r"camera\.roll_deg: must be < 45"):
        config_from_dict({"camera": {"roll_deg": 60.0}})


def test_pedestrian_height_in_the_width_section():
    """The pedestrian's height (1.7 m) sits beside its width model: printed by config_to_dict
    (so by `rhythmjax config`) after mean_m and std_m, read back, and a config written before
    the key existed (no height_m) loads with the default."""
    d = config_to_dict(Config())
    assert list(d["width"]) == ["mean_m", "std_m", "height_m"]
    assert d["width"]["height_m"] == pytest.approx(1.7, rel=1e-7)
    old = config_from_dict({"width": {"mean_m": 0.45, "std_m": 0.2}})
    assert host_float(old.width.height) == 1.7 and host_float(old.width.mean) == 0.45
    cfg = config_from_dict({"width": {"height_m": 1.8}})
    assert config_to_dict(cfg)["width"]["height_m"] == pytest.approx(1.8, rel=1e-7)
    assert config_to_dict(config_from_dict(config_to_dict(cfg))) == config_to_dict(cfg)
    assert float(cfg.width.mean) == 0.5  # the other width keys keep their defaults


def test_height_per_width_is_the_literal_ratio():
    """Host code took 1.7 / 0.5 as literals; reading them from the float32 config must give the
    same float (by hand: 3.4; 1.8 / 0.45 = 4.0), where float() of the float32 values gives
    1.7000000476837158 / 0.5 = 3.4000000953674316."""
    assert Config().width.height_per_width() == 1.7 / 0.5 == 3.4
    assert float(Config().width.height) / 0.5 != 3.4  # what the helper avoids
    assert WidthModel(mean=0.45, height=1.8).height_per_width() == 1.8 / 0.45
    # any decimal with up to 6 significant digits survives float32 and comes back exactly
    rng = np.random.default_rng(0)
    for x in np.round(rng.uniform(0.01, 99.0, 500), 4):
        x = float(f"{x:.6g}")
        assert host_float(np.float32(x)) == x
        assert host_float(jnp.asarray(x, jnp.float32)) == x
    assert host_float(np.float64(0.1 + 0.2)) == 0.1 + 0.2  # float64 values unchanged
