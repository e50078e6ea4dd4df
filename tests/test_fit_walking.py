"""fit.walking: walking/width models and thresholds from labelled synthetic tracks (issue 5).

One population of 250 labelled tracks (`rhythmjax.sim.tracks`, walkers with pace
N(2.05, 0.183) Hz and stride N(0.72, 0.09) m) is classified once; every test reuses its features
and compiled functions (module-scoped fixture).
"""

from __future__ import annotations

import dataclasses
import json
import math

import jax
import numpy as np
import pytest

from fit.cli import main
from fit.walking import (
    Features,
    balanced_accuracy,
    batch_of,
    decide,
    features,
    fit_walking,
    grid_verdicts,
    make_labelled,
    split,
    with_thresholds,
)
from rhythmjax.io import read_config, write_config, write_table
from rhythmjax.model import mem
from rhythmjax.model.params import config_from_dict
from rhythmjax.model.rhythm import classify_batch, match
from rhythmjax.model.status import Verdict


COLS = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y")


@pytest.fixture(scope="module")
def pop(tmp_path_factory):
    cfg = config_from_dict({"width": {"height_m": 1.8}})  # not fitted: must pass through
    cols, truth = make_labelled(n_walkers=200, n_bicycles=20, n_dogs=20, n_cars=10, seed=11,
                                min_frames=72, max_frames=72)
    d = tmp_path_factory.mktemp("walking")
    write_table(d / "tracks.parquet", cols, COLS)
    write_config(d / "c.json", cfg)
    b = batch_of(cols, cfg)
    f = features(cfg, b)
    fit = fit_walking(cfg, b, feats=f, seed=2)
    return {"cfg": cfg, "cols": cols, "truth": {t.track_id: t for t in truth}, "batch": b,
            "f": f, "fit": fit, "dir": d}


def test_gaussians_match_numpy(pop):
    r = pop["fit"]
    use = r.tracks["used_for_walking"]
    assert use.sum() >= 100 and not np.any(use & r.tracks["test"])
    for k, col in (("pace", "pace_hz"), ("stride", "stride_m")):
        x = r.tracks[col][use].astype(np.float64)
        e = r.estimates[k]
        n = x.size
        assert e["n"] == n
        np.testing.assert_allclose(e["mean"], np.mean(x), rtol=1e-12)
        np.testing.assert_allclose(e["std"], np.std(x, ddof=1), rtol=1e-12)
        np.testing.assert_allclose(e["se_mean"], np.std(x, ddof=1) / np.sqrt(n), rtol=1e-12)
        np.testing.assert_allclose(e["se_std"], np.std(x, ddof=1) / np.sqrt(2 * n - 2), rtol=1e-12)
    w = pop["fit"].config.walking
    assert float(w.pace_mean) == pytest.approx(r.estimates["pace"]["mean"], rel=1e-6)
    assert float(w.stride_std) == pytest.approx(r.estimates["stride"]["std"], rel=1e-6)
    assert float(pop["fit"].config.width.height) == pytest.approx(1.8)  # kept, not reset


def test_width_against_inverse_perspective_by_hand(pop):
    """Ground widths by solving (3) for y in float64 NumPy, pooled over the training walkers;
    SE of the mean clustered by track, by an explicit loop."""
    b, cam, r = pop["batch"], pop["cfg"].camera, pop["fit"]
    f, h, th, af, bf, vc = (float(x) for x in (cam.f, cam.h, cam.theta, cam.a * cam.f,
                                                cam.b * cam.f, cam.vc))
    rows = (np.asarray(b.labels) == "pedestrian") & ~r.tracks["test"]
    per_track = []
    for i in np.flatnonzero(rows):
        v, wpx = b.z[i, :, 1].astype(np.float64), b.width[i].astype(np.float64)
        q = (vc - v) / bf
        y = (q * (f + h * math.sin(th)) + h * math.cos(th)) / (math.sin(th) - q * math.cos(th))
        wid = wpx * (f + y * math.cos(th) + h * math.sin(th)) / af
        per_track.append(wid[np.isfinite(wid) & b.present[i]])
    allw = np.concatenate(per_track)
    e = r.estimates["width"]
    np.testing.assert_allclose([e["mean"], e["std"]], [allw.mean(), allw.std(ddof=1)],
                               rtol=2e-5)
    se = math.sqrt(sum(np.sum(w - allw.mean()) ** 2 for w in per_track)) / allw.size
    np.testing.assert_allclose(e["se_mean"], se, rtol=1e-3)
    assert e["n"] == len(per_track)


def test_decide_reproduces_classifier(pop):
    """At the config's thresholds the stored features give classify_batch's verdicts and reasons
    exactly, and its pace, stride and ratio to float32 rounding (another compiled batch shape
    fuses the spectra differently)."""
    cfg, b = pop["cfg"], pop["batch"]
    sel = np.r_[0:10, len(b.ids) - 22:len(b.ids)]  # walkers and every other kind
    res = classify_batch(cfg, *(jax.numpy.asarray(a[sel]) for a in (
        b.z, b.width, b.intensity, b.dt, b.present)))
    sub = jax.tree.map(lambda a: a[sel], pop["f"])
    got = decide(cfg.walking, cfg.thresholds, sub)
    np.testing.assert_array_equal(np.asarray(got[0]), np.asarray(res.verdict))
    np.testing.assert_array_equal(np.asarray(got[1]), np.asarray(res.reason))
    for a, ref in zip(got[2:], (res.pace_hz, res.stride_m, res.ratio)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(ref), rtol=1e-5, atol=1e-7)
    assert len(set(np.asarray(res.verdict).tolist())) >= 2


def test_grid_vmap_equals_python_loop(pop):
    """The vmapped grid equals a plain loop over grid points and tracks calling (13)-(15) per
    window (`rhythm.match`) and picking the first Pedestrian window, else the first."""
    cfg, f = pop["cfg"], pop["f"]
    walking = pop["fit"].config.walking
    sel = np.r_[0:20, len(pop["batch"].ids) - 30:len(pop["batch"].ids)]
    sub: Features = jax.tree.map(lambda a: np.asarray(a)[sel], f)
    P, R, K = (np.array(a, np.float32).ravel() for a in np.meshgrid(
        [3.0, 10.0, 40.0], [0.05, 0.2, 0.45], [1.0, 2.0, 3.5], indexing="ij"))
    got = np.asarray(grid_verdicts(walking, cfg.thresholds, jax.tree.map(jax.numpy.asarray, sub),
                                   P, R, K))
    one = jax.jit(lambda fr, pw, mk, sp, thr: match(mem.Peaks(fr, pw, mk), sp, walking, thr)[0])
    want = np.zeros_like(got)
    for g in range(P.size):
        thr = with_thresholds(cfg.thresholds, P[g], R[g], K[g])
        for i in range(len(sel)):
            ped = [bool(sub.usable[i, j]) and int(one(sub.peak_freq[i, j], sub.peak_power[i, j],
                                                      sub.peak_mask[i, j], sub.speed[i, j], thr))
                   == Verdict.PEDESTRIAN for j in range(sub.usable.shape[1])]
            want[g, i] = (Verdict.PEDESTRIAN if any(ped) else Verdict.NON_PEDESTRIAN
                          if sub.usable[i, 0] else Verdict.UNCLASSIFIED)
    np.testing.assert_array_equal(got, want)
    assert len(np.unique(got)) >= 2 and np.any(got[0] != got[-1])  # the thresholds matter


def test_recovers_generating_distributions(pop):
    """Within 5 % of the same walkers' true pace and stride moments; against the generating
    N(2.05, 0.183) Hz, N(0.72, 0.09) m within 3 reported standard errors (a sample of ~140)."""
    r, truth = pop["fit"], pop["truth"]
    ids = r.tracks["track_id"][r.tracks["used_for_walking"]]
    for k, attr, (m, s) in (("pace", "pace_hz", (2.05, 0.183)),
                            ("stride", "stride_m", (0.72, 0.09))):
        x = np.array([getattr(truth[i], attr) for i in ids])
        e = r.estimates[k]
        assert e["mean"] == pytest.approx(x.mean(), rel=0.05)
        assert e["std"] == pytest.approx(x.std(ddof=1), rel=0.05)
        assert abs(e["mean"] - m) < 3 * e["se_mean"] and abs(e["std"] - s) < 3 * e["se_std"]
        assert e["mean"] == pytest.approx(m, rel=0.05)


def test_held_out_balanced_accuracy(pop):
    r = pop["fit"]
    assert r.success and not r.reasons
    t = r.tracks["test"]
    lab = np.asarray(pop["batch"].labels) == "pedestrian"
    assert 0.2 < t[lab].mean() < 0.4 and 0.2 < t[~lab].mean() < 0.4  # stratified 30 %
    ba, tpr, tnr = balanced_accuracy(r.tracks["verdict"], lab, t)
    assert (ba, tpr, tnr) == (r.ba["test"], r.ba["test_tpr"], r.ba["test_tnr"])
    # bar: synthetic walkers against bicycles, dogs and cars are well separated
    assert r.ba["test"] >= 0.9 and r.ba["train"] >= 0.9
    assert r.ba["train"] == pytest.approx(np.nanmax(r.grid["ba_train"]))
    assert r.grid["ba_train"].shape == (13, 13, 9)


def test_split_is_stratified_and_seeded():
    labels = np.array(["pedestrian"] * 10 + ["dog"] * 5 + [""] * 3, dtype=object)
    a, b = split(labels, 0.3, 1), split(labels, 0.3, 1)
    np.testing.assert_array_equal(a, b)
    assert a[:10].sum() == 3 and a[10:15].sum() == 2 and not a[15:].any()
    assert not np.array_equal(a, split(labels, 0.3, 2))


def test_one_class_and_too_few(pop):
    b = pop["batch"]
    only = dataclasses.replace(b, labels=["pedestrian"] * len(b.ids))
    with pytest.raises(ValueError, match="one class only"):
        fit_walking(pop["cfg"], only, feats=pop["f"])
    few = [lab if lab != "pedestrian" or i < 8 else "" for i, lab in enumerate(b.labels)]
    with pytest.raises(ValueError, match="too few usable tracks"):
        fit_walking(pop["cfg"], dataclasses.replace(b, labels=few), feats=pop["f"])
    with pytest.raises(ValueError, match="held-out split"):
        fit_walking(pop["cfg"], b, feats=pop["f"], test_fraction=0.0)


def test_cli_round_trip(pop, capsys):
    d = pop["dir"]
    out = d / "c2.json"
    rc = main(["walking", str(d / "tracks.parquet"), "-c", str(d / "c.json"), "-o", str(out),
               "--json", "--seed", "2"])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0 and rep["written"] == str(out)
    r = pop["fit"]
    assert rep["estimates"]["pace"]["mean"] == pytest.approx(r.estimates["pace"]["mean"])
    assert rep["balanced_accuracy"]["test"] == pytest.approx(r.ba["test"])
    c2 = read_config(out)
    assert float(c2.walking.stride_mean) == pytest.approx(r.estimates["stride"]["mean"], 1e-6)
    assert float(c2.width.std) == pytest.approx(r.estimates["width"]["std"], 1e-6)
    assert float(c2.thresholds.p_thr) == pytest.approx(r.thresholds["p_thr"], 1e-6)
    assert float(c2.camera.h) == float(pop["cfg"].camera.h)
    rc = main(["walking", str(d / "tracks.parquet"), "-o", str(d / "c3.json"), "--seed", "2"])
    text = capsys.readouterr().out
    assert rc == 0 and "+-" in text and "held-out" in text and "wrote" in text


def test_cli_unsettled_keeps_config(pop, capsys):
    d = pop["dir"]
    keep = d / "keep.json"
    keep.write_text("previous\n")
    rc = main(["walking", str(d / "tracks.parquet"), "-c", str(d / "c.json"), "-o", str(keep),
               "--max-iter", "1"])
    cap = capsys.readouterr()
    assert rc == 1 and "not written" in cap.err and "iterations" in cap.out
    assert keep.read_text() == "previous\n"


def test_edge_notes_flag_an_optimum_on_the_grid_edge():
    from fit.walking import _edge_notes

    axes = {"p_thr": np.array([1.0, 3.0, 10.0]), "r_thr": np.array([0.0, 0.1]),
            "k_sigma3": np.array([2.0, 3.0, 4.0])}
    ba = np.full((3, 2, 3), 0.5)
    ba[0, 1, 1] = 0.9  # best at p_thr's lower edge, better than its inner neighbour
    ba[1, 1, 1] = 0.8
    ba[0, 0, 1] = 0.9  # r_thr's upper edge ties its inner neighbour here: no note for it
    notes = _edge_notes(axes, ba, (0, 1, 1))
    assert len(notes) == 1 and notes[0].startswith("p_thr 1 is at the lower edge")
    assert _edge_notes(axes, ba, (1, 1, 1)) == ["r_thr 0.1 is at the upper edge of its grid: "
                                                "the optimum may lie beyond it"]
