"""The fast classification kernel (model.windows, model.fast_batch) against the reference
(`rhythm.window_speed`, `rhythm.classify_batch` on `segments.split_tracks`' segments).

Tolerances: verdict, reason, n_samples and n_segments equal on every track; the medians of
`nanmedian_exact` the same floats as `jnp.nanmedian` / `jnp.median`; `theil_sen_speed` within
1e-6 of `window_speed`; pace, stride, ratio and speed within 1e-5 relative, the reported peaks
within 1e-4 (float32: the same operations on the same operands compiled in other programs
round apart: measured 2.1e-7 on pace, stride, speed over 2 305 tracks, 2.2e-6 on a ratio,
1.6e-5 on a sharp peak's power, whose |A(f)|^2 is near 0)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.io import read_tracks, to_batch, write_table
from rhythmjax.model import window_block, windows
from rhythmjax.model.batch import classify_tracks, classify_tracks_reference
from rhythmjax.model.fast_batch import phases
from rhythmjax.model.fast_window import median_small
from rhythmjax.model.params import Config
from rhythmjax.model.rhythm import window_speed, window_times
from rhythmjax.model.windows import (
    float_keys,
    from_keys,
    nanmedian_exact,
    nanmedian_select,
    theil_sen_speed,
    theil_sen_speed_select,
    window_slopes,
)
from rhythmjax.sim.tracks import make_tracks


CFG = Config()
N = CFG.thresholds.n
GAP = max(1, round(float(CFG.thresholds.predict_timeout) * CFG.camera.fps))


def test_float_keys_order_as_the_total_order():
    x = np.array([-np.nan, -np.inf, -3.5, -1e-40, -0.0, 0.0, 1e-40, 2.0, np.inf, np.nan],
                 np.float32)
    x[0] = -x[-1]  # a negative NaN
    k = np.asarray(float_keys(jnp.asarray(x)))
    assert np.all(np.diff(k) > 0)
    np.testing.assert_array_equal(np.asarray(from_keys(jnp.asarray(k))).view(np.int32),
                                  x.view(np.int32))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_nanmedian_exact_is_jnp_nanmedian(seed):
    rng = np.random.default_rng(seed)
    for p in (1, 2, 3, 7, 64, 2016):
        x = (rng.normal(size=(6, p)) * 10.0 ** rng.integers(-4, 4)).astype(np.float32)
        x[rng.random(x.shape) < 0.3] = np.nan
        x[rng.random(x.shape) < 0.05] = np.inf
        x[rng.random(x.shape) < 0.05] = -np.inf
        x[rng.random(x.shape) < 0.05] = 0.0
        x[0] = np.nan  # all missing: NaN
        x[1] = np.where(rng.random(p) < 0.5, np.float32(1.25), np.float32(-2.0))  # ties
        x[2] = np.round(x[2])  # more ties
        got = np.asarray(jax.jit(nanmedian_exact)(jnp.asarray(x)))
        want = np.asarray(jnp.nanmedian(jnp.asarray(x), axis=-1))
        np.testing.assert_array_equal(got, want, err_msg=f"p={p}")
        finite = np.isfinite(x[3:]).all(axis=-1)
        np.testing.assert_array_equal(got[3:][finite],
                                      np.asarray(jnp.median(jnp.asarray(x[3:][finite]), -1)))


def _windows(seed, W=24):
    """Windows of a walker's rows: filtered positions (lagging), measured foot points with a
    varying share missing (either side of half), t with jitter."""
    rng = np.random.default_rng(seed)
    cam = CFG.camera
    t = np.cumsum(np.full((W, N), 1.0 / float(cam.fps)) * (1 + 0.02 * rng.random((W, N))), 1)
    x0, y0 = rng.uniform(-3, 3, (W, 1)), rng.uniform(5, 15, (W, 1))
    vx, vy = rng.normal(0, 1.2, (W, 1)), rng.normal(0, 1.2, (W, 1))
    x, y = x0 + vx * t, y0 + vy * t
    from rhythmjax.model.camera_np import project_3d

    u, v = project_3d(cam, x, y, 0.0)
    uv = np.stack([u + rng.normal(0, 1, u.shape), v + rng.normal(0, 1, v.shape)], -1)
    miss = rng.random((W, N)) < rng.uniform(0, 0.8, (W, 1))
    uv[miss] = np.nan
    xy = np.stack([x0 + 0.7 * vx * t, y0 + 0.7 * vy * t], -1)
    dt = np.diff(t, axis=1, prepend=t[:, :1] - 1.0 / float(cam.fps))
    return [jnp.asarray(a, jnp.float32) for a in (dt, xy, uv)]


def _assert_select_exact(x, **kw):
    """nanmedian_select(x) against nanmedian_exact bit for bit where ok (and against
    jnp.nanmedian by value: the two differ only in the sign of a zero median, which
    jnp.nanmedian takes from the input order of -0 and +0); the share of rows not ok."""
    x = jnp.asarray(x, jnp.float32)
    got, ok = (np.asarray(a) for a in jax.jit(lambda v: nanmedian_select(v, **kw))(x))
    want = np.asarray(jax.jit(nanmedian_exact)(x))
    np.testing.assert_array_equal(got[ok].view(np.int32), want[ok].view(np.int32))
    np.testing.assert_array_equal(got[ok], np.asarray(jnp.nanmedian(x, axis=-1))[ok])
    return 1.0 - ok.mean()


def _slope_sets(rng, p, rows=8):
    """Rows of p values: scaled normals with NaN, +-inf, +-0; all NaN; two tied values; ties
    from rounding; only +-0; heavy outliers (a tenth at +-1e30, Cauchy tails); constant; one
    or two valid entries."""
    x = (rng.normal(size=(rows + 8, p)) * 10.0 ** rng.integers(-4, 4)).astype(np.float32)
    x[rng.random(x.shape) < 0.3] = np.nan
    x[rng.random(x.shape) < 0.05] = np.inf
    x[rng.random(x.shape) < 0.05] = -np.inf
    x[rng.random(x.shape) < 0.05] = 0.0
    x[rng.random(x.shape) < 0.05] = -0.0
    x[0] = np.nan
    x[1] = np.where(rng.random(p) < 0.5, np.float32(1.25), np.float32(-2.0))
    x[2] = np.round(x[2])
    x[3] = np.where(rng.random(p) < 0.5, np.float32(0.0), np.float32(-0.0))
    x[4] = np.where(rng.random(p) < 0.1, np.float32(1e30) * rng.choice([-1, 1], p),
                    rng.standard_cauchy(p)).astype(np.float32)
    x[5] = np.float32(0.7)
    x[6] = np.nan
    x[6, rng.integers(p)] = 3.0
    x[7] = np.nan
    x[7, :2] = [-1.0, -0.0][:p]
    return x


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_nanmedian_select_is_nanmedian_exact(seed):
    rng = np.random.default_rng(seed)
    for p in (1, 2, 3, 7, 64, 300, 2016):
        _assert_select_exact(_slope_sets(rng, p))


def test_nanmedian_select_forced_fallback_is_flagged():
    """No interpolation pass and no spread (steps=0, spread=0): most rows stay unresolved
    and say so; the resolved ones are still exact."""
    rng = np.random.default_rng(7)
    x = rng.normal(1.0, 0.3, (64, 2016)).astype(np.float32)
    x[rng.random(x.shape) < 0.2] = np.nan
    assert _assert_select_exact(x, steps=0, spread=0) > 0.5
    assert _assert_select_exact(x, steps=2, spread=1, stride=128) > 0.05
    assert _assert_select_exact(np.concatenate([x, _slope_sets(rng, 2016)]), steps=0) > 0.2


def test_nanmedian_select_on_window_slopes():
    """The real slopes of simulated windows (both position sets): exact, and the fallback
    rare (benchmarks/bench_median.py measures ~3 % of windows)."""
    dt, xy, uv = _windows(11, W=128)
    slopes = jax.jit(jax.vmap(lambda d, p, o: window_slopes(CFG, window_times(d), p, o)[0]))(
        dt, xy, uv)
    assert _assert_select_exact(np.asarray(slopes).reshape(-1, slopes.shape[-1])) < 0.1
    fast = jax.jit(jax.vmap(lambda d, p, o: theil_sen_speed_select(CFG, window_times(d), p, o)))
    exact = jax.jit(jax.vmap(lambda d, p, o: theil_sen_speed(CFG, window_times(d), p, o)))
    (a, ok), b = fast(dt, xy, uv), exact(dt, xy, uv)
    ok = np.asarray(ok)
    assert ok.mean() > 0.8
    np.testing.assert_allclose(np.asarray(a)[ok], np.asarray(b)[ok], rtol=1e-6)


def _window_rows(seed, W):
    dt, xy, uv = (np.asarray(a) for a in _windows(seed, W))
    rng = np.random.default_rng(seed)
    t = np.cumsum(dt, axis=1)
    inten = (1.0 + 0.3 * np.sin(2 * np.pi * rng.uniform(1.5, 2.5, (W, 1)) * t)
             + 0.05 * rng.normal(size=t.shape)).astype(np.float32)
    return inten, dt, xy, uv


def test_classify_window_rows_falls_back_exactly(monkeypatch):
    """classify_window_rows (one program a block: select speeds, the unresolved medians again
    by bisection, FALLBACK windows a turn of a loop) against classify_window_block (one
    program, bisection) on the same windows: as is, and with the select median forced to
    leave most windows unresolved (steps=0, spread=0), in blocks of 8 (one turn) and of 24
    (more than FALLBACK unresolved: several turns)."""
    rows = _window_rows(12, 40)
    want = windows.classify_window_block(CFG, *(jnp.asarray(a) for a in rows))

    def check(got):
        for f in ("verdict", "reason", "n_samples", "peak_mask"):
            np.testing.assert_array_equal(got[f], np.asarray(getattr(want, f)), err_msg=f)
        for f in ("pace_hz", "stride_m", "ratio", "speed_mps", "peak_freq", "peak_power"):
            np.testing.assert_allclose(got[f], np.asarray(getattr(want, f)), rtol=1e-5,
                                       equal_nan=True, err_msg=f)

    check(windows.classify_window_rows(CFG, *rows, block=32))
    cols = window_block.nanmedian_select_cols
    monkeypatch.setattr(window_block, "nanmedian_select_cols",
                        lambda x: cols(x, steps=0, spread=0))
    unresolved = []
    block = windows.classify_block
    monkeypatch.setattr(windows, "classify_block",
                        lambda *a: (r := block(*a)) and unresolved.append(int(r[1])) or r)
    check(windows.classify_window_rows(CFG, *rows, block=8))  # new shapes: traced again
    assert 0 < max(unresolved) <= window_block.FALLBACK
    unresolved.clear()
    check(windows.classify_window_rows(CFG, *rows, block=24))
    assert max(unresolved) > window_block.FALLBACK


def _theil_sen_f64(t, px, py, use):
    """NumPy float64 Theil-Sen velocity norm of (12): per axis the median of (p_j - p_i) /
    (t_j - t_i) over the pairs i < j with both samples in `use`."""
    i, j = np.triu_indices(len(t), 1)
    keep = use[i] & use[j]
    d = (t[j] - t[i])[keep]
    vx = np.median((px[j] - px[i])[keep] / d)
    vy = np.median((py[j] - py[i])[keep] / d)
    return np.hypot(vx, vy)


@pytest.mark.parametrize("seed", [3, 4])
def test_block_speeds_against_numpy_float64(seed):
    """window_block: the slopes with the windows on the minor axis are `window_slopes`' floats,
    pair for pair; `block_speeds` (select median, in-program fallback) gives
    `theil_sen_speed` within 1e-6 (1 ulp: other programs) and a NumPy float64 Theil-Sen of
    the same position set (the measured foot points on the ground, by camera_np's float64
    inverse of (3), when half the window has one, else the filtered positions) within 2e-3
    relative (the float32 slopes' rounding can move the median to a neighbouring order
    statistic; a wrong pair, axis or position set is off by far more)."""
    from rhythmjax.model.camera_np import ground_of_pixels

    dt, xy, uv = _windows(seed, W=48)
    t = jax.vmap(window_times)(dt)
    cols, enough = jax.jit(lambda t, p, o: window_block.window_slopes_cols(
        CFG, t.T, jnp.swapaxes(p, 0, 1), jnp.swapaxes(o, 0, 1)))(t, xy, uv)
    rows = jax.jit(jax.vmap(lambda t, p, o: window_slopes(CFG, t, p, o)))(t, xy, uv)
    np.testing.assert_array_equal(np.transpose(np.asarray(cols), (2, 1, 0)).view(np.int32),
                                  np.asarray(rows[0]).view(np.int32))
    np.testing.assert_array_equal(np.asarray(enough), np.asarray(rows[1]))
    speed, unresolved = jax.jit(lambda d, p, o: window_block.block_speeds(CFG, d, p, o))(
        dt, xy, uv)
    assert int(unresolved) <= window_block.FALLBACK
    exact = jax.jit(jax.vmap(lambda d, p, o: theil_sen_speed(CFG, window_times(d), p, o)))
    np.testing.assert_allclose(np.asarray(speed), np.asarray(exact(dt, xy, uv)), rtol=1e-6)
    t64, xy64, uv64 = (np.asarray(a, np.float64) for a in (t, xy, uv))
    ref = []
    for w in range(len(t64)):
        seen = np.isfinite(uv64[w]).all(-1)
        gx, gy, ok = ground_of_pixels(CFG.camera, *np.where(seen[:, None], uv64[w], 0.0).T)
        if 2 * (seen & ok).sum() >= N:
            ref.append(_theil_sen_f64(t64[w], gx, gy, seen & ok))
        else:
            ref.append(_theil_sen_f64(t64[w], *xy64[w].T, np.ones(N, bool)))
    assert {True, False} <= set(np.asarray(enough).tolist())
    np.testing.assert_allclose(np.asarray(speed), ref, rtol=2e-3)


@pytest.mark.parametrize("seed", [3, 4])
def test_theil_sen_speed_is_window_speed(seed):
    dt, xy, uv = _windows(seed)
    fast = jax.jit(jax.vmap(lambda d, p, o: theil_sen_speed(CFG, window_times(d), p, o)))
    ref = jax.jit(jax.vmap(lambda d, p, o: window_speed(CFG, window_times(d), p, o)))
    a, b = np.asarray(fast(dt, xy, uv)), np.asarray(ref(dt, xy, uv))
    np.testing.assert_allclose(a, b, rtol=1e-6)
    assert np.isfinite(a).all() and (a > 0).all()


def test_phases_cover_every_window_once():
    got = [j for lo, hi in phases(37) for j in range(lo, hi)]
    assert got[:37] == list(range(37)) and len(set(got)) == len(got)


def _write(tmp_path, cols, name="t.csv"):
    path = tmp_path / name
    write_table(str(path), cols, list(cols))
    return read_tracks(str(path), fps=CFG.camera.fps)


def _edge_cases(seed, walkers=10, others=3):
    """Synthetic tracks (walkers, bicycles, dogs, cars, short walkers) plus: a walker with no
    measurement at all (no-measurements), one with most intensities missing (bad-signal), one
    with a long run of missing rows (two Fig. 3 segments)."""
    cols, _ = make_tracks(n_walkers=walkers, n_bicycles=others, n_dogs=others, n_cars=1,
                          n_short=1, seed=seed, max_frames=120)
    cols = {k: np.asarray(v) for k, v in cols.items()}
    walkers, rows = np.unique(cols["track_id"][cols["label"] == "pedestrian"],
                              return_counts=True)
    ids = walkers[np.argsort(-rows, kind="stable")]  # the longest walkers
    blind, noisy, gap = (cols["track_id"] == ids[i] for i in (0, 1, 2))
    for k in ("u", "v", "width_px"):
        cols[k] = np.where(blind, np.nan, cols[k].astype(float))
    rng = np.random.default_rng(seed)
    cols["intensity"] = np.where(noisy & (rng.random(len(noisy)) < 0.4), np.nan,
                                 cols["intensity"].astype(float))
    frame = cols["frame"] - np.min(np.where(gap, cols["frame"], 10**9))
    hole = gap & (frame >= 20) & (frame < 45)
    for k in ("u", "v", "width_px"):
        cols[k] = np.where(hole, np.nan, cols[k].astype(float))
    return cols


def assert_same(a: dict, b: dict):
    for k in ("track_id", "verdict", "reason", "n_samples", "n_segments"):
        assert list(a[k]) == list(b[k]), k
    for k in ("pace_hz", "stride_m", "ratio", "speed_mps"):
        np.testing.assert_allclose(np.asarray(a[k], float), np.asarray(b[k], float), rtol=1e-5,
                                   equal_nan=True, err_msg=k)
    m = np.asarray(a["peak_mask"])
    np.testing.assert_array_equal(m, b["peak_mask"])
    for k in ("peak_freq", "peak_power"):
        np.testing.assert_allclose(np.asarray(a[k])[m], np.asarray(b[k])[m], rtol=1e-4)


@pytest.mark.parametrize("seed", [5, 6])
def test_classify_tracks_is_the_reference(tmp_path, seed):
    batch = to_batch(_write(tmp_path, _edge_cases(seed)), max_gap_frames=GAP, min_len=N)
    fast = classify_tracks(CFG, batch, progress=False, chunk=16)
    ref = classify_tracks_reference(CFG, batch, chunk=16)
    assert_same(fast, ref)
    reasons = set(fast["reason"])
    assert {"too-short", "no-measurements", "bad-signal"} <= reasons, reasons
    assert fast["n_segments"].max() >= 2
    assert (fast["verdict"] == "pedestrian").sum() >= 5
    whole = classify_tracks(CFG, batch, progress=False, split=False)
    assert_same(whole, classify_tracks_reference(CFG, batch, split=False))


def test_later_windows_decide(tmp_path):
    """Walkers whose first rows carry no rhythm (white noise): window 0 is not Pedestrian, a
    later one is, and the kernel goes on past window 0 (phases), as `classify_track` does."""
    cols, _ = make_tracks(n_walkers=6, n_bicycles=0, n_dogs=0, n_cars=0, seed=8,
                          min_frames=150, max_frames=170)
    cols = {k: np.asarray(v) for k, v in cols.items()}
    starts = np.r_[0, np.flatnonzero(cols["track_id"][1:] != cols["track_id"][:-1]) + 1]
    row = np.arange(len(cols["frame"])) - np.repeat(starts, np.diff(np.r_[starts, len(
        cols["frame"])]))
    rng = np.random.default_rng(8)
    scale = np.nanstd(cols["intensity"].astype(float))
    cols["intensity"] = np.where(row < 56, np.nanmean(cols["intensity"].astype(float))
                                 + scale * np.abs(rng.normal(size=len(row))), cols["intensity"])
    batch = to_batch(_write(tmp_path, cols), max_gap_frames=GAP, min_len=N)
    fast = classify_tracks(CFG, batch, progress=False)
    ref = classify_tracks_reference(CFG, batch)
    assert_same(fast, ref)
    ref0 = classify_tracks_reference(CFG, _first_window_only(batch))
    later = (ref["verdict"] == "pedestrian") & (ref0["verdict"] != "pedestrian")
    assert later.sum() >= 1


def _first_window_only(batch):
    import dataclasses

    n = np.minimum(batch.length, N + CFG.thresholds.hop_samples - 1)
    keep = np.arange(batch.z.shape[1])[None, :] < n[:, None]
    nan = lambda a: np.where(keep.reshape(keep.shape + (1,) * (a.ndim - 2)), a, np.nan)
    return dataclasses.replace(batch, z=nan(batch.z), width=nan(batch.width),
                               intensity=nan(batch.intensity), present=keep,
                               length=n.astype(np.int32))


DEVICES_SCRIPT = textwrap.dedent("""
    import sys
    import jax
    jax.config.update("jax_num_cpu_devices", 2)
    import numpy as np
    from rhythmjax.io import read_tracks, to_batch
    from rhythmjax.model.batch import classify_tracks
    from rhythmjax.model.devices import local_mesh
    from rhythmjax.model.params import Config
    cfg = Config()
    assert len(jax.local_devices()) == 2 and local_mesh().devices.size == 2
    batch = to_batch(read_tracks(sys.argv[1], fps=cfg.camera.fps), max_gap_frames=15,
                     min_len=cfg.thresholds.n)
    runs = [classify_tracks(cfg, batch, progress=False, chunk=16, devices=d)
            for d in (None, 2)]
    for r in runs[1:]:
        for k in ("verdict", "reason", "n_samples", "n_segments"):
            assert list(r[k]) == list(runs[0][k]), k
        for k in ("pace_hz", "stride_m", "ratio", "speed_mps"):
            np.testing.assert_allclose(np.asarray(r[k], float), np.asarray(runs[0][k], float),
                                       rtol=1e-6, equal_nan=True, err_msg=k)
    print("ok", len(batch.ids), sorted(set(runs[0]["verdict"])))
""")


def test_two_devices_give_the_same_verdicts(tmp_path):
    _write(tmp_path, _edge_cases(9, walkers=4, others=1))
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    out = subprocess.run([sys.executable, "-c", DEVICES_SCRIPT, str(tmp_path / "t.csv")],
                         capture_output=True, text=True, env=env, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.startswith("ok")


@pytest.mark.parametrize("m", [1, 2, 5, 63, 64])
def test_median_small_is_jnp_median(m):
    """fast_window.median_small (ranks by counting, no sort) against jnp.median bit for bit and
    against np.median in float64 (exact for these: the median of float32 values, or the
    midpoint of two, rounded once): jittered steps, ties, a constant row, signed zeros, NaN."""
    rng = np.random.default_rng(m)
    x = (1 / 15 * (1 + 0.05 * rng.normal(size=(300, m)))).astype(np.float32)
    x[::7] = np.round(x[::7] * 100) / 100
    x[5] = 0.5
    x[6, : m // 2] = -0.0
    x[3, 0] = np.nan
    got = np.asarray(jax.jit(median_small)(jnp.asarray(x)))
    np.testing.assert_array_equal(got.view(np.int32),
                                  np.asarray(jnp.median(jnp.asarray(x), axis=-1)).view(np.int32))
    ref = np.median(x.astype(np.float64), axis=-1)
    np.testing.assert_allclose(got, ref, rtol=6e-8, equal_nan=True)


def test_packed_windows_equal_the_rows_path():
    """classify_windows_packed (a block up as one array, back as one: window_block's
    BLOCK_PROGRAM, the issue-18 host cut) gives classify_window_rows' results bit for bit,
    with a partial last block and with no window at all."""
    from rhythmjax.model.window_block import PACKED_FIELDS

    rows = _window_rows(12, 40)
    packed = np.stack([rows[0], rows[1], rows[2][..., 0], rows[2][..., 1], rows[3][..., 0],
                       rows[3][..., 1]]).astype(np.float32)
    for W in (40, 0):
        want = windows.classify_window_rows(CFG, *(a[:W] for a in rows), block=16)
        got = windows.classify_windows_packed(CFG, packed[:, :W], block=16)
        assert set(got) == {f for f, _, _ in PACKED_FIELDS}
        for f, v in want.items():
            assert got[f].dtype == v.dtype and got[f].shape == v.shape, f
            np.testing.assert_array_equal(got[f].view(np.uint8), v.view(np.uint8), err_msg=f)
