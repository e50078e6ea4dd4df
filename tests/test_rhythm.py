"""Rhythm matching (12)-(15) and per-track verdicts, against a plain-Python reading of the paper."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.model import mem
from rhythmjax.model.camera import project
from rhythmjax.model.params import Config, Thresholds, WalkingModel
from rhythmjax.model.rhythm import (
    classify_batch,
    classify_track,
    fill_gaps,
    ground_speed,
    match,
    window_grid,
    window_speed,
)
from rhythmjax.model.status import Reason, Verdict


WALK, THR = WalkingModel(), Thresholds(harmonic_ratio=0.0)  # the paper's (13)-(15) exactly


def match_reference(freqs, powers, speed, p_thr=10.0, r_thr=0.1, k=3.0, harmonic=0.0):
    """Sec. 4.2 step by step, in plain Python floats; `harmonic` > 0: a matching peak is
    dropped when any peak within 10 % of twice its frequency has >= harmonic x its power."""
    peaks = [(f, p) for f, p in zip(freqs, powers) if p > p_thr]  # (13)
    if not peaks:
        return "non-pedestrian", "no-peak", None
    S = sum(p for _, p in peaks)
    sets = [(f, p, speed / f) for f, p in peaks]  # (12) with D = speed * N * dt
    ok = [(f, p, T) for f, p, T in sets
          if (f - 2.05) ** 2 / 0.183**2 <= k**2 and (T - 0.72) ** 2 / 0.09**2 <= k**2]  # (14)
    if harmonic > 0:
        ok = [(f, p, T) for f, p, T in ok
              if not any(abs(f2 - 2 * f) <= 0.1 * 2 * f and p2 >= harmonic * p
                         for f2, p2 in zip(freqs, powers))]
    if not ok:
        return "non-pedestrian", "no-model-match", None
    f, p, T = max(ok, key=lambda s: s[1] / S)  # (15): greatest R_m
    R = p / S
    return ("pedestrian", "matched", (f, T, R)) if R > r_thr else (
        "non-pedestrian", "below-threshold", (f, T, R))


def _peaks(freqs, powers, k=8):
    order = np.argsort(powers)[::-1]
    f = np.zeros(k, np.float32)
    p = np.zeros(k, np.float32)
    m = np.zeros(k, bool)
    f[: len(freqs)] = np.asarray(freqs, np.float32)[order]
    p[: len(freqs)] = np.asarray(powers, np.float32)[order]
    m[: len(freqs)] = True
    return mem.Peaks(jnp.asarray(f), jnp.asarray(p), jnp.asarray(m))


CASES = {  # name: (peak freqs Hz, powers, speed m/s, expected reason)
    "no peak at all": ([], [], 1.5, "no-peak"),
    "peaks below P_thr": ([2.0, 4.0], [9.9, 3.0], 1.5, "no-peak"),
    "pace outside the model": ([3.7], [50.0], 1.5, "no-model-match"),
    "stride outside the model (bicycle)": ([2.1], [50.0], 4.5, "no-model-match"),
    "model match, one peak": ([2.05], [50.0], 1.48, "matched"),
    "model match with low ratio": ([2.0] + [3.5 + 0.4 * i for i in range(7)],
                                   [11.0] + [100.0] * 7, 1.44, "below-threshold"),
    "greatest R among matching, not the strongest peak": ([4.1, 1.9], [80.0, 40.0], 1.4,
                                                          "matched"),
    "P exactly at P_thr is not a peak": ([2.05], [10.0], 1.48, "no-peak"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_match_branches_agree_with_reference(name):
    freqs, powers, speed, reason = CASES[name]
    v, r, *vals = match(_peaks(freqs, powers), jnp.float32(speed), WALK, THR)
    ref_v, ref_r, ref_vals = match_reference(freqs, powers, speed)
    assert ref_r == reason  # the case is what it says
    assert Reason(int(r)).label == ref_r
    assert Verdict(int(v)).label == ref_v
    pace, stride, ratio = (float(x) for x in vals)
    if ref_vals is not None:
        assert pace == pytest.approx(ref_vals[0], abs=1e-5)
        assert stride == pytest.approx(ref_vals[1], rel=1e-5)
        assert ratio == pytest.approx(ref_vals[2], rel=1e-5)


@pytest.mark.parametrize("harmonic", [0.0, 0.25])
def test_match_random_peak_sets_agree_with_reference(harmonic):
    """Random peak sets; with harmonic = 0.25 about a third of them hold a peak near twice a
    matching one (drawn so), so the half-pace rule decides some of the cases."""
    rng = np.random.default_rng(0)
    thr = Thresholds(harmonic_ratio=harmonic)
    decided = 0
    for _ in range(400):
        k = int(rng.integers(0, 8))
        freqs = list(rng.uniform(0.3, 7.0, k))
        if rng.random() < 0.35:  # a walker-like peak and one near its double
            f0 = float(rng.uniform(1.6, 2.5))
            freqs += [f0, 2 * f0 * float(rng.uniform(0.85, 1.15))]
        powers = [float(rng.uniform(0, 10) if rng.random() < 0.4 else rng.uniform(10, 300))
                  for _ in freqs]
        freqs, powers = freqs[:8], powers[:8]
        speed = float(rng.uniform(0.2, 3.0)) if rng.random() < 0.5 else 0.72 * freqs[-1] \
            if freqs else 1.0
        v, r, *_ = match(_peaks(freqs, powers), jnp.float32(speed), WALK, thr)
        ref_v, ref_r, _ = match_reference(freqs, powers, speed, harmonic=harmonic)
        assert (Verdict(int(v)).label, Reason(int(r)).label) == (ref_v, ref_r)
        decided += ref_r != match_reference(freqs, powers, speed)[1]
    assert (decided > 10) == (harmonic > 0)


def test_half_pace_rule_by_hand():
    """A trotting dog's window: peaks at 1.71 Hz (35.6) and 3.40 Hz (11.9, within 10 % of
    3.42): 11.9 / 35.6 = 0.33 >= 0.25, so 1.71 Hz is a half-pace component and the pace model
    match is refused; a walker's 2F harmonic at 12 % of its power is not (measured on the
    synthetic set); at 4.5 Hz the second peak is no longer near 2F (|4.5 - 3.42| > 0.342)."""
    dog = _peaks([1.71, 3.40, 0.22], [35.6, 11.9, 9.6])
    speed = jnp.float32(1.14)  # stride 0.67 m at 1.71 Hz: inside the walking model
    on, off = Thresholds(harmonic_ratio=0.25), Thresholds(harmonic_ratio=0.0)
    assert Reason(int(match(dog, speed, WALK, on)[1])).label == "no-model-match"
    assert Reason(int(match(dog, speed, WALK, off)[1])).label == "matched"
    walker = _peaks([1.71, 3.40], [35.6, 0.12 * 35.6])
    assert Reason(int(match(walker, speed, WALK, on)[1])).label == "matched"
    far = _peaks([1.71, 4.5], [35.6, 35.0])
    assert Reason(int(match(far, speed, WALK, on)[1])).label == "matched"
    edge = _peaks([2.0, 4.0 * 1.099], [40.0, 10.0])  # inside by 0.1 %, ratio exactly 0.25
    assert Reason(int(match(edge, jnp.float32(1.44), WALK, on)[1])).label == "no-model-match"


def test_fill_gaps_is_linear_interpolation():
    x = jnp.array([np.nan, 1.0, np.nan, np.nan, 4.0, 5.0, np.nan], jnp.float32)
    got = np.asarray(fill_gaps(x, jnp.isfinite(x)))
    np.testing.assert_allclose(got, [1, 1, 2, 3, 4, 5, 5], atol=1e-6)


def test_ground_speed_of_a_straight_walk():
    t = jnp.arange(64, dtype=jnp.float32) / 15
    xy = jnp.stack([0.3 + 1.2 * t, 10.0 - 0.5 * t], -1)
    assert float(ground_speed(t, xy)) == pytest.approx(math.hypot(1.2, 0.5), rel=1e-5)


def test_ground_speed_is_theil_sen_by_hand():
    # 5 samples at 1 s: x = 0, 1, 2, 3, 10 (the last one off the object), y = 0.
    # Pairwise x slopes (i < j): 1, 1, 1, 2.5 | 1, 1, 3 | 1, 4 | 7 -> median of the 10 is 1
    # (the least-squares slope is 2.2: the outlier drags it).
    t = jnp.arange(5, dtype=jnp.float32)
    xy = jnp.stack([jnp.array([0.0, 1.0, 2.0, 3.0, 10.0]), jnp.zeros(5)], -1)
    assert float(ground_speed(t, xy)) == pytest.approx(1.0, abs=1e-6)
    # a track whose last 10 of 64 estimates sit 1.5 m off (another object): the median keeps the
    # walker's 1.4 m/s within 5 %; the least-squares slope gives 1.68 m/s (+20 %)
    t = jnp.arange(64, dtype=jnp.float32) / 15
    x = 1.4 * t + jnp.where(jnp.arange(64) >= 54, 1.5, 0.0)
    assert float(ground_speed(t, jnp.stack([x, jnp.full(64, 8.0)], -1))) == pytest.approx(
        1.4, rel=0.05)


def test_ground_speed_over_the_used_pairs_matches_a_numpy_loop():
    rng = np.random.default_rng(3)
    t = np.arange(20) / 15.0
    xy = np.stack([0.5 + 1.3 * t, 9.0 - 0.4 * t], -1) + rng.normal(0, 0.05, (20, 2))
    use = rng.random(20) > 0.3
    xy_nan = np.where(use[:, None], xy, np.nan)  # unused samples hold NaN: ignored
    slopes = [(xy[j] - xy[i]) / (t[j] - t[i]) for i in range(20) for j in range(i + 1, 20)
              if use[i] and use[j]]
    want = float(np.hypot(*np.median(np.asarray(slopes), axis=0)))
    got = float(ground_speed(jnp.asarray(t, jnp.float32), jnp.asarray(xy_nan, jnp.float32),
                             jnp.asarray(use)))
    assert got == pytest.approx(want, rel=1e-5)


def _walk_seen(cfg, n=64, vx=2.5, vy=-1.0):
    """A straight walk on the ground and its exact foot points (px) through (3)."""
    t = np.arange(n) / 15.0
    x, y = -1.0 + vx * t, 14.0 + vy * t
    u, v = project(cfg.camera, jnp.asarray(x), jnp.asarray(y))
    return (jnp.asarray(t, jnp.float32), np.stack([x, y], -1),
            np.stack([np.asarray(u), np.asarray(v)], -1).astype(np.float32))


def test_window_speed_takes_the_measured_foot_points_not_the_lagging_filter():
    cfg = Config()
    t, xy, uv = _walk_seen(cfg)
    true = math.hypot(2.5, 1.0)
    lagging = jnp.asarray(xy[:1] + 0.6 * (xy - xy[:1]), jnp.float32)  # a filter at 60 % speed
    assert float(window_speed(cfg, t, lagging, None)) == pytest.approx(0.6 * true, rel=1e-4)
    holes = uv.copy()
    holes[::3] = np.nan  # a third of the frames without an accepted measurement
    got = float(window_speed(cfg, t, lagging, jnp.asarray(holes)))
    assert got == pytest.approx(true, rel=2e-3)  # float32 inverse perspective at 10-14 m
    holes[1::3] = np.nan  # two thirds without: under half measured, the filtered speed
    assert float(window_speed(cfg, t, lagging, jnp.asarray(holes))) == pytest.approx(
        0.6 * true, rel=1e-4)


def test_window_speed_gradient_in_camera_height_matches_finite_differences():
    # the NaN of frames without a measurement must not reach the gradient (double where)
    cfg = Config()
    t, xy, uv = _walk_seen(cfg)
    uv[5:9] = np.nan
    obs = jnp.asarray(uv)
    speed_of = lambda h: window_speed(eqx.tree_at(lambda c: c.camera.h, cfg, h), t,  # noqa: E731
                                      jnp.asarray(xy, jnp.float32), obs)
    h, e = float(cfg.camera.h), 0.02
    g = float(jax.grad(speed_of)(jnp.float32(h)))
    fd = (float(speed_of(jnp.float32(h + e))) - float(speed_of(jnp.float32(h - e)))) / (2 * e)
    assert math.isfinite(g) and g > 0.1
    assert g == pytest.approx(fd, rel=2e-3)


# ----------------------------------------------------------------------------------------------
# Whole tracks


def _walker(n=100, pace=2.0, stride=0.7, fps=15.0, intensity=None, seed=0):
    from rhythmjax.model.camera import image_width, project

    cfg = Config()
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fps
    speed = pace * stride
    x, y = -2.0 + speed * t, np.full(n, 12.0)
    u, v = (np.asarray(a, np.float64) for a in project(cfg.camera, jnp.asarray(x, jnp.float32),
                                                       jnp.asarray(y, jnp.float32)))
    z = np.stack([u, v], -1) + rng.normal(0, 1.0, (n, 2))
    w = np.asarray(image_width(cfg.camera, jnp.float32(0.45), jnp.asarray(y, jnp.float32)))
    if intensity is None:
        intensity = 100 + 80 * np.abs(np.sin(np.pi * pace * t + 0.3)) + rng.normal(0, 5, n)
    dt = np.full(n, 1 / fps)
    arrays = (z, w, intensity, dt, np.ones(n, bool))
    return cfg, [jnp.asarray(a, jnp.float32 if a.dtype.kind == "f" else None) for a in arrays]


def test_walker_track_matches_with_its_pace_and_stride():
    cfg, arrays = _walker(pace=2.0, stride=0.7)
    r = classify_track(cfg, *arrays)
    assert Verdict(int(r.verdict)) == Verdict.PEDESTRIAN
    assert Reason(int(r.reason)) == Reason.MATCHED
    assert float(r.pace_hz) == pytest.approx(2.0, abs=0.03)
    assert float(r.stride_m) == pytest.approx(0.7, rel=0.05)
    assert float(r.speed_mps) == pytest.approx(1.4, rel=0.05)
    assert int(r.n_samples) == 100


def test_constant_intensity_has_no_peak():
    cfg, arrays = _walker(intensity=np.full(100, 250.0))
    r = classify_track(cfg, *arrays)
    assert (Verdict(int(r.verdict)), Reason(int(r.reason))) == (Verdict.NON_PEDESTRIAN,
                                                                Reason.NO_PEAK)
    assert np.all(np.isfinite(np.asarray(r.peak_power)))


def test_too_short_and_no_measurements_are_unclassified():
    cfg, (z, w, i, dt, p) = _walker(n=100)
    short = p.at[40:].set(False)
    r = classify_track(cfg, z, w, i, dt, short)
    assert (Verdict(int(r.verdict)), Reason(int(r.reason))) == (Verdict.UNCLASSIFIED,
                                                                Reason.TOO_SHORT)
    assert int(r.n_samples) == 40 and math.isnan(float(r.pace_hz))
    r = classify_track(cfg, jnp.full_like(z, jnp.nan), w, i, dt, p)
    assert Reason(int(r.reason)) == Reason.NO_MEASUREMENTS
    assert Verdict(int(r.verdict)) == Verdict.UNCLASSIFIED


def test_bad_signal_gaps_and_irregular_sampling():
    """With the paper's back-to-back windows (hop N) a 100-frame track has one window, frames
    0-63; with the default hop N/2 also frames 32-95, which the damage below misses."""
    cfg, (z, w, i, dt, p) = _walker(n=100)
    paper = eqx.tree_at(lambda c: c.thresholds, cfg, Thresholds(hop=64))
    holes = i.at[5:25].set(jnp.nan)  # 20 of the first 64 missing > 25 %
    jitter = dt.at[30].set(dt[30] * 1.5)
    few = i.at[5:15].set(jnp.nan)  # 10 of 64: interpolated, still classified
    for c, bad in ((paper, Reason.BAD_SIGNAL), (cfg, Reason.MATCHED)):
        assert Reason(int(classify_track(c, z, w, holes, dt, p).reason)) == bad
        assert Reason(int(classify_track(c, z, w, i, jitter, p).reason)) == bad
        assert Reason(int(classify_track(c, z, w, few, dt, p).reason)) == Reason.MATCHED
    late = i.at[70:90].set(jnp.nan)  # only in the second window: the first one decides
    assert Reason(int(classify_track(cfg, z, w, late, dt, p).reason)) == Reason.MATCHED


def test_window_grid_by_hand():
    """Windows of N = 64 every 32 frames in a 128-frame padded track start at 0, 32, 64; with
    100 frames tracked the first two are complete (64 and 96 <= 100), the third is not."""
    j, complete = window_grid(128, 64, 32, jnp.asarray(100))
    assert np.asarray(j).tolist() == [0, 1, 2]
    assert np.asarray(complete).tolist() == [True, True, False]
    j, complete = window_grid(128, 64, 64, jnp.asarray(128))  # the paper's back-to-back
    assert np.asarray(j).tolist() == [0, 1] and np.asarray(complete).all()
    assert Thresholds().hop_samples == 32 and Thresholds(n=48).hop_samples == 24
    assert Thresholds(hop=5).hop_samples == 5


def test_batch_equals_single_tracks_and_isolates_a_bad_track():
    cfg, a = _walker(seed=1)
    _, b = _walker(seed=2, pace=1.8, stride=0.8)
    bad = [jnp.full_like(a[0], jnp.inf), *a[1:]]
    batch = [jnp.stack(x) for x in zip(a, bad, b)]
    res = classify_batch(cfg, *batch)
    for i, single in ((0, a), (2, b)):
        r = classify_track(cfg, *single)
        assert int(res.verdict[i]) == int(r.verdict)
        np.testing.assert_allclose(float(res.pace_hz[i]), float(r.pace_hz), rtol=1e-6)
    assert Reason(int(res.reason[1])) == Reason.NO_MEASUREMENTS
