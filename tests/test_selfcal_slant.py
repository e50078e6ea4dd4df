"""The slant cue of self-calibration (`fit.selfcal_slant`; `rhythmjax-fit selfcal --cues
...,slant`): the predicted head column against the pin-hole of (3) written out here in NumPy
float64 (no roll: depth = f + y cos(theta) + (h - z) sin(theta), u = Uc + a f x / depth,
v = Vc - b f (y sin(theta) - (h - z) cos(theta)) / depth), the per-track median and its
standard error against a plain loop, and a fit on simulated walkers whose heads slant."""

from __future__ import annotations

import json
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from fit.cli import main as fit_main
from fit.selfcal import fit_selfcal
from fit.selfcal_data import camera_values, scene_batch
from fit.selfcal_slant import MAD_SD, MEDIAN_SE, head_column, profile_lean, slant_cue
from fit.walking import make_labelled
from rhythmjax.io import write_table
from rhythmjax.model.params import Camera, Config


F = 0.008
CAM = Camera(f=F, h=7.0, theta=math.radians(16.5), a=742 / F, b=742 / F, uc=240, vc=180,
             fps=7.0, image_width=480, image_height=360)


def image_of(cam, x, y, z):
    f, h, th = float(cam.f), float(cam.h), float(cam.theta)
    depth = f + y * math.cos(th) + (h - z) * math.sin(th)
    return (float(cam.uc) + float(cam.a) * f * x / depth,
            float(cam.vc) - float(cam.b) * f * (y * math.sin(th) - (h - z) * math.cos(th)) / depth)


@pytest.mark.parametrize("depth", [0.0, 0.23])
def test_head_column_is_the_pin_hole_image_of_the_head(depth):
    """Feet at (x, y), head at (x, y + D, z): the head column to 1e-3 px; off the centre column
    the head lies farther out than the feet (people lean outwards)."""
    x, y, z = np.array([-4.0, -1.0, 0.0, 3.0]), np.array([8.0, 12.0, 15.0, 25.0]), np.array(
        [1.6, 1.7, 1.8, 1.75])
    foot = np.array([image_of(CAM, a, b, 0.0) for a, b in zip(x, y)])
    head = np.array([image_of(CAM, a, b + depth, c) for a, b, c in zip(x, y, z)])
    with jax.enable_x64(True):
        uh, ok = head_column(CAM, jnp.asarray(foot[:, 0]), jnp.asarray(foot[:, 1]),
                             jnp.asarray(head[:, 1]), depth)
    assert np.all(np.asarray(ok))
    np.testing.assert_allclose(np.asarray(uh), head[:, 0], rtol=0, atol=1e-3)
    lean = (head[:, 0] - foot[:, 0]) * np.sign(x)
    assert np.all(lean[x != 0] > 0.5)


def test_slant_cue_median_and_its_error_against_a_loop():
    """Two tracks of true heads plus known offsets: the per-track median offset
    and 1.2533 x 1.4826 x MAD / sqrt(n) as a plain loop computes them (to 1e-4 px and 1e-4
    relative: the camera's parameters are float32); a track with fewer than `MIN_TOP_ROWS` head
    columns is not usable."""
    rng = np.random.default_rng(3)
    T = 30
    x = np.stack([np.linspace(-4, 2, T), np.linspace(3, 3.5, T)])
    y = np.stack([np.linspace(9, 14, T), np.linspace(20, 12, T)])
    foot = np.array([[image_of(CAM, a, b, 0.0) for a, b in zip(xr, yr)] for xr, yr in zip(x, y)])
    head = np.array([[image_of(CAM, a, b, 1.7) for a, b in zip(xr, yr)] for xr, yr in zip(x, y)])
    off = rng.normal(0, 1.5, (2, T)) + np.array([[0.8], [-0.3]])
    u_top = head[..., 0] + off
    use = np.ones((2, T), bool)
    use[1, 5:] = False  # 5 rows: too few
    with jax.enable_x64(True):
        med, se, ok, g = slant_cue(CAM, jnp.asarray(foot[..., 0]), jnp.asarray(foot[..., 1]),
                                jnp.asarray(head[..., 1]), jnp.asarray(u_top), jnp.asarray(use))
    assert bool(ok[0]) and not bool(ok[1])
    r = sorted(off[0])
    want = 0.5 * (r[T // 2 - 1] + r[T // 2])
    dev = sorted(abs(q - want) for q in off[0])
    mad = 0.5 * (dev[T // 2 - 1] + dev[T // 2])
    assert float(med[0]) == pytest.approx(want, abs=1e-4)
    assert float(se[0]) == pytest.approx(MEDIAN_SE * MAD_SD * mad / math.sqrt(T), rel=1e-4)


TRUE = Camera(f=F, h=6.0, theta=math.radians(18.0), a=900 / F, b=900 / F, uc=640, vc=360,
              fps=15.0, image_width=1280, image_height=720)
START = Config(camera=Camera(f=F, h=4.0, theta=math.radians(10.0), a=600 / F, b=600 / F,
                             uc=640, vc=360, fps=15.0, image_width=1280, image_height=720))


@pytest.fixture(scope="module")
def slanted():
    cols, _ = make_labelled(n_walkers=20, seed=100, camera=TRUE)
    assert "u_top" in cols
    return cols


def test_heads_over_feet_separate_the_focal_length_from_the_tilt(slanted):
    """20 simulated walkers (1.5 px noise on feet, top rows and head columns): heights alone
    leave a f against the tilt loosely determined (measured: h -4.2 %, tilt +1.72 deg, SE 1.42,
    a f -13.9 %); heights with the slant give h within 3 %, the tilt within 0.5 deg and a f
    within 3 % (measured: +1.2 %, -0.03 deg, SE 0.10, -0.5 %), the tilt within 3 SEs, and the
    tilt's SE at most half the heights-alone SE."""
    batch = scene_batch(slanted, START)
    tv = camera_values(TRUE)
    alone = fit_selfcal(START, batch, cues=("height",))
    both = fit_selfcal(START, batch, cues=("height", "slant"))
    assert both.success and both.camera is not None, both.reasons
    v, se = both.values, both.se
    msg = (v, se, alone.values, alone.se)
    assert abs(v["h"] / tv["h"] - 1) < 0.03, msg
    assert abs(v["theta"] - tv["theta"]) < 0.5 and abs(v["theta"] - tv["theta"]) < 3 * se[
        "theta"] + 0.05, msg
    assert abs(v["af"] / tv["af"] - 1) < 0.03, msg
    assert se["theta"] <= 0.5 * alone.se["theta"], msg
    assert "slant" in both.cue_rms and math.isfinite(both.cue_rms["slant"])


def test_without_head_columns_the_cue_is_dropped_or_refused(slanted, tmp_path, capsys):
    cols = {k: v for k, v in slanted.items() if k != "u_top"}
    keep = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "v_top")
    tracks = tmp_path / "tracks.csv"
    write_table(tracks, cols, [k for k in keep if k in cols])
    start = tmp_path / "start.json"
    start.write_text(json.dumps({"camera": {"image_width_px": 1280, "image_height_px": 720,
                                            "fps": 15}}))
    rc = fit_main(["selfcal", str(tracks), "-c", str(start), "--cues", "slant", "-o",
                   str(tmp_path / "c.json")])
    err = capsys.readouterr().err
    assert rc == 2 and "u_top" in err and not (tmp_path / "c.json").exists()
    rc = fit_main(["selfcal", str(tracks), "-c", str(start), "--cues", "height,slant",
                   "--json", "-o", str(tmp_path / "c.json")])
    doc = json.loads(capsys.readouterr().out)
    assert rc in (0, 1) and any("cue slant dropped" in n for n in doc["notes"])
    assert doc["cues"] == ["height"]


def test_lean_change_per_metre_against_the_derivative():
    """g of `slant_cue` (the head column's change per metre of lean along the heading) against
    the NumPy pin-hole's derivative (central difference, 1e-4 m): within 1 % (the module's
    forward step of 0.1 m; measured 0.4 %); a wrong axis or sign would be off by far more."""
    x, y = np.linspace(-4, 3, 12), np.linspace(9, 20, 12)
    foot = np.array([image_of(CAM, a, b, 0.0) for a, b in zip(x, y)])
    head = np.array([image_of(CAM, a, b, 1.7) for a, b in zip(x, y)])
    hd = np.array([0.6, -0.8])
    with jax.enable_x64(True):
        *_, g = slant_cue(CAM, jnp.asarray(foot[None, :, 0]), jnp.asarray(foot[None, :, 1]),
                          jnp.asarray(head[None, :, 1]), jnp.asarray(head[None, :, 0]),
                          jnp.ones((1, 12), bool), 0.0, jnp.asarray(hd[None]))
    e = 1e-4
    d = np.array([(image_of(CAM, a + e * hd[0], b + e * hd[1], 1.7)[0]
                   - image_of(CAM, a - e * hd[0], b - e * hd[1], 1.7)[0]) / (2 * e)
                  for a, b in zip(x, y)])
    assert float(g[0]) == pytest.approx(float(np.median(d)), rel=1e-2)


def test_profile_lean_is_weighted_least_squares():
    """delta of `profile_lean` equals NumPy's weighted least squares of the residuals on g over
    the usable tracks (1e-10), and the residuals it returns are theirs less delta g."""
    rng = np.random.default_rng(5)
    r, se, g = rng.normal(0, 2, 9), rng.uniform(0.2, 1.0, 9), rng.normal(0, 30, 9)
    usable = np.array([1, 1, 0, 1, 1, 1, 0, 1, 1], bool)
    with jax.enable_x64(True):
        delta, rest = profile_lean(jnp.asarray(r), jnp.asarray(se), jnp.asarray(g),
                                   jnp.asarray(usable))
    w = 1.0 / se[usable]
    want = np.linalg.lstsq((g[usable] * w)[:, None], r[usable] * w, rcond=None)[0][0]
    assert float(delta) == pytest.approx(want, abs=1e-10)
    np.testing.assert_allclose(np.asarray(rest), r - want * g, atol=1e-10)
