"""Self-calibration from people walking (`fit.selfcal`, `rhythmjax-fit selfcal`, issue 19).

References: the simulator's truth (the camera that made the tracks, each walker's pace and
stride), central finite differences for the gradient, and refusals on data that cannot
determine the camera. One scene shape (1280x720 at 15 fps, tracks padded to 128 frames, 24
track slots) so that one compilation serves every fit."""

from __future__ import annotations

import json
import math

import equinox as eqx
import jax
import jax.flatten_util
import jax.numpy as jnp
import numpy as np
import pytest

from fit.cli import main as fit_main
from fit.selfcal import fit_selfcal, param_spec
from fit.selfcal_cost import cue_weights, raw_cues, residuals
from fit.selfcal_data import (
    Data,
    camera_of,
    camera_values,
    gait_peaks,
    make_data,
    make_params,
    scene_batch,
    select,
)
from fit.selfcal_height import height_from_top
from fit.walking import batch_of, make_labelled
from rhythmjax.io import write_table
from rhythmjax.model.camera import image_width, project, project_3d
from rhythmjax.model.params import Camera, Config
from rhythmjax.sim.tracks import rhythm_per_px


F = 0.008
TRUE = Camera(f=F, h=5.5, theta=math.radians(21.0), a=950 / F, b=950 / F, uc=640, vc=360,
              fps=15.0, image_width=1280, image_height=720)
START = Config(camera=Camera(f=F, h=4.0, theta=math.radians(15.0), a=1280 / F, b=1280 / F,
                             uc=640, vc=360, fps=15.0, image_width=1280, image_height=720))
COLUMNS = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "label")


@pytest.fixture(scope="module")
def mixed():
    """20 walkers, 4 bicycles, 4 dogs, 2 cars seen by TRUE (seed 11), as a batch + truth."""
    cols, truth = make_labelled(n_walkers=20, n_bicycles=4, n_dogs=4, n_cars=2, seed=11,
                                camera=TRUE)
    return cols, truth, batch_of(cols, START)


@pytest.fixture(scope="module")
def fitted(mixed):
    return fit_selfcal(START, mixed[2])


def test_pace_and_stride_against_the_simulators_truth(mixed):
    cols, truth, b = mixed
    used, pace = select(START, b)
    tr = {t.track_id: t for t in truth}
    ids = [i for i, u in zip(b.ids, used, strict=True) if u]
    walkers = [i for i in ids if tr[i].label == "pedestrian"]
    assert len(walkers) >= 18 and not any(tr[i].label in ("dog", "car") for i in ids)
    err = np.array([pace[b.ids.index(i)] - tr[i].pace_hz for i in walkers])
    assert np.median(np.abs(err)) < 0.02  # Hz; the MEM peak of the rhythm signal
    with jax.enable_x64(True):
        raw = eqx.filter_jit(raw_cues)(camera_of(camera_values(TRUE), TRUE),
                                       make_data(b, used, pace), START)
    stride = np.asarray(raw["stride"])[:len(ids)]
    rel = np.array([stride[ids.index(i)] / tr[i].stride_m - 1 for i in walkers])
    assert np.median(np.abs(rel)) < 0.01  # (12) through the true camera
    dspeed = np.asarray(raw["dspeed"])[:len(ids)]
    assert np.median(np.abs(dspeed)) < 0.05  # constant speed through the true camera


def assert_recovered(r, tv, *, h_rel, theta_deg, af_rel):
    """Each of h, theta, a f within its tolerance of the truth `tv` (relative for h and a f,
    deg for theta), within 3 of the fit's own SEs, and with an SE no larger than the
    tolerance."""
    for k, tol in (("h", h_rel * tv["h"]), ("theta", theta_deg), ("af", af_rel * tv["af"])):
        err = abs(r.values[k] - tv[k])
        assert err <= tol and err <= 3 * r.se[k] and r.se[k] <= tol, (
            k, r.values[k], tv[k], r.se[k])


def test_recovers_the_camera_with_non_walkers_mixed_in(fitted):
    r, tv = fitted, camera_values(TRUE)
    assert not r.ill_determined and r.success, r.reasons
    assert 18 <= r.n_walkers <= 22
    # tolerances: the 5 % for h; tilt and a f as the fit's own precision says (20
    # walkers with Table 1's 12 % spread of stride: SE about 2 deg, 10 %), and 3 SE
    assert_recovered(r, tv, h_rel=0.05, theta_deg=2.5, af_rel=0.15)
    assert r.determination()["h"] == "determined"


def test_bicycles_do_not_pull_the_scale(mixed, fitted):
    cols, truth, b = mixed
    walkers = [t.track_id for t in truth if t.label == "pedestrian"]
    keep = np.isin(cols["track_id"], walkers)
    only = fit_selfcal(START, batch_of({k: v[keep] for k, v in cols.items()}, START))
    assert abs(only.values["h"] / fitted.values["h"] - 1) < 0.03


def gradient_and_differences(data, weights):
    """(jax.grad, central differences with step 1e-6) of the summed squared residuals in the
    unconstrained (log a f, log h, tilt) at a camera off the truth (h 5 m, tilt 19 deg, a f 1000
    px); call inside ``jax.enable_x64``."""
    v = {**camera_values(TRUE), "h": 5.0, "theta": 19.0, "af": 1000.0, "bf": 1000.0}
    dyn, static = eqx.partition(make_params(v), param_spec(("af", "h", "theta")))
    args = (static, START.camera, jnp.float64(F), data, START, weights)
    flat, unravel = jax.flatten_util.ravel_pytree(dyn)
    cost = jax.jit(lambda q: jnp.sum(residuals(unravel(q), args) ** 2))
    eps = 1e-6
    fd = np.array([(cost(flat + eps * e) - cost(flat - eps * e)) / (2 * eps)
                   for e in np.eye(flat.size)])
    return np.asarray(jax.grad(cost)(flat)), fd


def test_gradient_matches_finite_differences(mixed):
    _, _, b = mixed
    used, pace = select(START, b)
    with jax.enable_x64(True):
        data = make_data(b, used, pace)
        g, fd = gradient_and_differences(data, cue_weights(("gait", "speed", "width"), 0.05, 0.03))
    np.testing.assert_allclose(g, fd, rtol=2e-4, atol=1e-6 * np.max(np.abs(fd)))


def test_data_is_padded_without_weight(mixed):
    _, _, b = mixed
    used, pace = select(START, b)
    with jax.enable_x64(True):
        d = make_data(b, used, pace)
    assert isinstance(d, Data) and d.valid.shape[0] % 8 == 0
    assert int(np.sum(np.asarray(d.valid))) == int(used.sum())


def _radial_tracks(cam: Camera, n: int, seed: int, lateral: bool = False) -> dict:
    """Walkers that all walk straight toward or away from the camera (x constant), or with
    `lateral` all across the view at 10-10.3 m (y constant: every walker at one depth)."""
    rng = np.random.default_rng(seed)
    cols = {k: [] for k in COLUMNS}
    for i in range(n):
        pace, stride = rng.normal(2.05, 0.15), rng.normal(0.72, 0.07)
        k = 100
        t = np.arange(k) / cam.fps
        sign = rng.choice([-1, 1])
        y = (6.0 if sign > 0 else 16.0) + sign * pace * stride * t
        x = np.full(k, rng.uniform(-3, 3))
        if lateral:
            x, y = -sign * (3.5 - pace * stride * t), np.full(k, rng.uniform(10.0, 10.3))
        u, v = (np.asarray(a, float) for a in project(cam, jnp.asarray(x), jnp.asarray(y)))
        w = np.asarray(image_width(cam, jnp.asarray(0.5), jnp.asarray(y)), float)
        per = rhythm_per_px(t, pace, rng.uniform(), 0.9, 1.0, rng.standard_normal(k), 0.15,
                            False)
        for key, a in (("track_id", [f"w{i}"] * k), ("frame", np.arange(k)), ("t", t),
                       ("u", u + rng.normal(0, 1.5, k)), ("v", v + rng.normal(0, 1.5, k)),
                       ("width_px", w), ("intensity", np.maximum(per, 0) * w * w / 5),
                       ("label", ["pedestrian"] * k)):
            cols[key] += list(a)
    return {k: np.asarray(v) for k, v in cols.items()}


def _cli(tmp_path, cols, *extra, columns=COLUMNS):
    tracks = tmp_path / "tracks.csv"
    write_table(tracks, cols, columns)
    start = tmp_path / "start.json"
    start.write_text(json.dumps({"camera": {"image_width_px": 1280, "image_height_px": 720,
                                            "fps": 15}}))
    out = tmp_path / "cam.json"
    rc = fit_main(["selfcal", str(tracks), "-c", str(start), "-o", str(out), *extra])
    return rc, out


def test_cli_writes_the_fitted_camera(tmp_path, mixed, fitted, capsys):
    rc, out = _cli(tmp_path, mixed[0], "--json")
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    cam = json.loads(out.read_text())["camera"]
    assert cam["image_width_px"] == 1280 and cam["fps"] == 15
    assert abs(cam["h_m"] - doc["values"]["h"]) < 1e-4
    # the CLI runs `fit_selfcal` on what it read: the same camera as the function's
    for key, name in (("h_m", "h"), ("theta_deg", "theta")):
        assert abs(cam[key] - fitted.values[name]) < 1e-4 * max(1.0, abs(fitted.values[name]))
    assert doc["n_walkers"] >= 18 and doc["written"] == str(out)


def test_cli_refuses_too_few_walkers(tmp_path, mixed, capsys):
    cols, truth, _ = mixed
    few = [t.track_id for t in truth if t.label == "pedestrian"][:3]
    keep = np.isin(cols["track_id"], few + [t.track_id for t in truth if t.label != "pedestrian"
                                            and t.label != "bicycle"])
    rc, out = _cli(tmp_path, {k: v[keep] for k, v in cols.items()})
    assert rc == 1 and not out.exists()
    assert "needs at least 5 walkers" in capsys.readouterr().err


def test_cli_refuses_a_scale_free_cue(tmp_path, mixed, capsys):
    rc, out = _cli(tmp_path, mixed[0], "--cues", "speed", "--max-steps", "30")
    assert rc == 1 and not out.exists()
    assert "h not determined" in capsys.readouterr().err


def test_cli_refuses_walkers_all_along_the_optical_axis(tmp_path, capsys):
    rc, out = _cli(tmp_path, _radial_tracks(TRUE, 20, 3), "--max-steps", "20")
    err = capsys.readouterr().err
    assert rc == 1 and not out.exists()
    assert "not determined" in err and "optical axis" in err


@pytest.mark.parametrize("extra, message", [
    (("--cues", "gait,smell"), "unknown cue"),
    (("--cues", "height"), "no top rows"),  # COLUMNS: no v_top
])
def test_cli_bad_cues(tmp_path, mixed, capsys, extra, message):
    rc, out = _cli(tmp_path, mixed[0], *extra)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and not out.exists() and len(err) == 1 and message in err[0]
    assert "tracks.csv" in err[0]


def test_cli_needs_the_image_size(tmp_path, mixed, capsys):
    tracks = tmp_path / "t.csv"
    write_table(tracks, mixed[0], COLUMNS)
    out = tmp_path / "o.json"
    assert fit_main(["selfcal", str(tracks), "-o", str(out)]) == 2 and not out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "image size is unknown" in err[0] and "t.csv" in err[0]


def test_gait_peaks_none_without_rhythm():
    x = np.full((2, 64), 5.0)
    x[1] = np.random.default_rng(0).normal(5, 1, 64)
    p = gait_peaks(START, x, np.array([64, 64]))
    assert not p.clear.any() and np.isnan(p.pace_hz).all()


# ----------------------------------------------------------------------------------------------
# the height cue (foot-head, `fit.selfcal_height`)

def test_height_of_a_level_camera_by_hand():
    # theta = 0, roll 0: v = Vc + b f (h - z) / (f + y), so z = (f + y) (v - v_top) / (b f).
    # h 5 m, b f 1000 px, the ground point 10 m ahead: foot row 360 + 5000 / 10.008 =
    # 859.6003 px; a 1.7 m head at 360 + 3300 / 10.008 = 689.7362 px.
    with jax.enable_x64(True):
        cam = Camera(f=F, h=5.0, theta=0.0, a=1000 / F, b=1000 / F, uc=640, vc=360, fps=15.0,
                     image_width=1280, image_height=720)
        H, ok = height_from_top(cam, jnp.float64(640.0), jnp.float64(859.6003197442047),
                                jnp.float64(689.7362110311751))
    assert bool(ok) and abs(float(H) - 1.7) < 1e-9


def test_height_inverts_the_projection_of_a_tilted_rolled_camera():
    x, y, z = np.array([-3.0, 0.5, 2.5, 4.0]), np.array([5.0, 9.0, 14.0, 19.0]), np.array(
        [1.55, 1.7, 1.82, 0.5])
    with jax.enable_x64(True):
        cam = Camera(f=F, h=6.0, theta=math.radians(27.0), a=900 / F, b=880 / F, uc=610,
                     vc=370, roll=math.radians(4.0), fps=15.0, image_width=1280,
                     image_height=720)
        u, v = project(cam, jnp.asarray(x), jnp.asarray(y))
        _, vt = project_3d(cam, jnp.asarray(x), jnp.asarray(y), jnp.asarray(z))
        H, ok = height_from_top(cam, u, v, vt)
        _, bad = height_from_top(cam, u, v, jnp.full(4, jnp.nan))
    assert np.all(np.asarray(ok)) and not np.any(np.asarray(bad))
    np.testing.assert_allclose(np.asarray(H), z, rtol=0, atol=1e-9)


@pytest.fixture(scope="module")
def with_tops(mixed):
    """The `mixed` scene's batch with its top rows and head columns (v_top, u_top: 1.5 px noise,
    heights N(1.7, 0.07))."""
    return scene_batch(mixed[0], START)


@pytest.mark.parametrize("cues", [("height",), ("gait", "speed", "width", "height"),
                                  ("height", "slant")])
def test_height_gradient_matches_finite_differences(with_tops, cues):
    used, pace = select(START, with_tops)
    with jax.enable_x64(True):
        data = make_data(with_tops, used, pace, head_columns="slant" in cues)
        assert np.isfinite(np.asarray(data.v_top)).sum() > 500
        g, fd = gradient_and_differences(data, cue_weights(cues, 0.05, 0.03, sd_hshape=0.03))
    assert np.max(np.abs(fd)) > 1.0  # the cue moves the cost
    np.testing.assert_allclose(g, fd, rtol=2e-4, atol=1e-6 * np.max(np.abs(fd)))


def test_height_alone_recovers_the_camera(mixed, with_tops):
    r, tv = fit_selfcal(START, with_tops, cues=("height",)), camera_values(TRUE)
    assert not r.ill_determined and r.success, r.reasons
    assert 18 <= r.n_walkers <= 22
    # tolerances: the fit's own precision with 20 walkers of N(1.7, 0.07^2) m (SE about 5 %,
    # 2 deg, 12 %: heights fix the horizon and the scale, a f apart from theta only weakly),
    # and 3 SE
    assert_recovered(r, tv, h_rel=0.08, theta_deg=3.0, af_rel=0.2)
    # the height cue through the true camera: the walkers' median heights, N(1.7, 0.07^2)
    used, pace = select(START, with_tops)
    with jax.enable_x64(True):
        raw = eqx.filter_jit(raw_cues)(camera_of(tv, TRUE), make_data(with_tops, used, pace),
                                       START)
    ids = [i for i, u in zip(with_tops.ids, used, strict=True) if u]
    labels = dict(zip(with_tops.ids, with_tops.labels, strict=True))
    hh = np.asarray(raw["height"])[:len(ids)][[labels[i] == "pedestrian" for i in ids]]
    assert abs(np.mean(hh) - 1.7) < 3 * 0.07 / math.sqrt(hh.size) + 0.01
    assert 0.03 < np.std(hh) < 0.12


def test_height_alone_refused_without_top_rows(mixed):
    r = fit_selfcal(START, mixed[2], cues=("height",))  # batch_of: no v_top column
    assert r.ill_determined and r.camera is None and "top rows" in r.reasons[0]


def test_cli_default_cues_use_the_top_rows(tmp_path, mixed, capsys):
    rc, out = _cli(tmp_path, mixed[0], "--json", columns=(*COLUMNS, "v_top"))
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["cues"] == ["gait", "speed", "width", "height"]
    tv = camera_values(TRUE)
    assert abs(doc["values"]["h"] / tv["h"] - 1) < 0.05 and abs(doc["values"]["theta"]
                                                                 - tv["theta"]) < 1.5


def test_cli_default_cues_without_top_rows_drop_height(tmp_path, mixed, capsys):
    rc, out = _cli(tmp_path, mixed[0], "--json")
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["cues"] == ["gait", "speed", "width"]
    assert any("cue height dropped" in n for n in doc["notes"])


def test_walkers_all_at_one_depth_are_refused():
    cols = _radial_tracks(TRUE, 12, 5, lateral=True)
    r = fit_selfcal(START, batch_of(cols, START), max_steps=20)
    assert r.n_walkers >= 5 and r.ill_determined
    assert any("same depth" in q for q in r.reasons), r.reasons


def test_horizon_clearance_against_the_projection_of_far_ground_points():
    """Reference: `project` of ground points 1e7 m ahead lies on the horizon (within
    b f h / y = 5e-4 px); 10 px below them the clearance is 10 px. Roll 3 deg: a sloped line."""
    import types

    from fit.selfcal_checks import horizon_clearance

    cam = Camera(f=F, h=5.5, theta=math.radians(21.0), a=950 / F, b=950 / F, uc=640, vc=360,
                 roll=math.radians(3.0), fps=15.0, image_width=1280, image_height=720)
    with jax.enable_x64(True):
        u, v = (np.asarray(q) for q in project(cam, jnp.array([-3e6, 0.0, 4e6]),
                                               jnp.full(3, 1e7)))
    for dv, want in ((0.0, 0.0), (10.0, 10.0)):
        z = np.stack([u, v + dv], -1)[:, None, :]  # three tracks of one row
        b = types.SimpleNamespace(z=z, present=np.ones((3, 1), bool))
        clear, k = horizon_clearance(cam, b, np.ones(3, bool))
        assert abs(clear - want) < 1e-2, (clear, want)


def test_a_fit_pinned_on_the_horizon_is_refused():
    """The dev clips' case: one foot point 2 px below the fitted horizon (the hinge's margin, a
    fit held by that point) gives the pinned-horizon reason; 50 px below, none. Foot points
    placed by `project` of a far ground point (on the horizon within 5e-4 px, test above)."""
    import types

    from fit.selfcal_checks import PINNED_CLEARANCE_PX, geometry_reasons

    with jax.enable_x64(True):
        u, v = (np.asarray(q) for q in project(TRUE, jnp.array([0.0]), jnp.array([1e7])))
    rows = np.linspace(400.0, 700.0, 8)  # seven ordinary walkers' foot rows, spread in depth
    for dv, pinned in ((2.0, True), (50.0, False)):
        z = np.zeros((8, 2, 2))
        z[:, :, 0] = 640.0
        z[:, :, 1] = rows[:, None]
        z[0, 1] = (u[0], v[0] + dv)  # one row of the first track near the horizon
        b = types.SimpleNamespace(z=z, present=np.ones((8, 2), bool))
        why = geometry_reasons(TRUE, b, np.ones(8, bool), 0.02, [f"w{k}" for k in range(8)])
        assert (dv < PINNED_CLEARANCE_PX) == pinned
        assert any("pinned" in q and "w0" in q for q in why) == pinned, why
        assert not any("same depth" in q for q in why)


def test_a_spurious_foot_point_above_the_horizon_is_left_out(mixed, fitted):
    """One walker's foot point moved 30 px above the true horizon (the dev clips' head sliver on
    a `predict` row): the outlier rule (`fit.selfcal_outliers`, `--outliers`) drops it and the
    fit is the clean one of the default (h within 0.5 %, tilt within 0.1 deg); without the rule
    (the default) the hinge holds the horizon above that point and the fit moves (h more than
    3 % away)."""
    import copy

    from rhythmjax.model.camera import horizon_v

    b = mixed[2]
    used, _ = select(START, b)
    k = int(np.flatnonzero(used)[0])
    rows = np.flatnonzero(np.isfinite(b.z[k, :, 1]))
    z = b.z.copy()
    z[k, rows[len(rows) // 2], 1] = float(horizon_v(TRUE)) - 30.0
    bad = copy.copy(b)
    bad.z = z
    on = fit_selfcal(START, bad, outliers=True)
    assert abs(on.values["h"] / fitted.values["h"] - 1) < 0.005
    assert abs(on.values["theta"] - fitted.values["theta"]) < 0.1
    assert any("left out as outliers" in n for n in on.notes)
    off = fit_selfcal(START, bad)
    assert abs(off.values["h"] / fitted.values["h"] - 1) > 0.03
