"""Candidate windows B in the online tracker and the `rhythm` verb (issue 16, item 2): I(k) summed
again with window B moved by `io.files.WINDOW_CANDIDATES`' offsets (`vision.window_b.
window_b_candidates`), written as the tracks' candidate columns, and each rhythm window judged
per candidate with the strongest kept (`track.toolkit.match_window`). Tolerances: every
comparison is exact (the same float sums and the same jitted kernel on the same inputs)."""

from __future__ import annotations

import dataclasses
import json
import math

import cv2
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.cli.main import main as cli_main
from rhythmjax.io import read_table
from rhythmjax.io.files import (
    ACROSS_CANDIDATES,
    ACROSS_COLUMNS,
    CANDIDATE_COLUMNS,
    WINDOW_CANDIDATES,
)
from rhythmjax.io.mot import write_mot
from rhythmjax.model.camera import project
from rhythmjax.model.params import Config
from rhythmjax.model.rhythm import classify_window_candidates_jit, classify_window_jit
from rhythmjax.model.status import TrackState, Verdict
from rhythmjax.sim import scene as synth
from rhythmjax.track import options as options_module
from rhythmjax.track.boxes import box_intensities, window_widths
from rhythmjax.track.columns import tracks_columns
from rhythmjax.track.options import BodyOptions, TrackerOptions
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.toolkit import RESULT_FIELDS, match_window, window_signal
from rhythmjax.track.tracker import OnlineTracker
from rhythmjax.vision import detect
from rhythmjax.vision.window_b import window_b_candidates, window_b_intensity


CFG = Config()
OFFSETS = tuple(off for _, off in WINDOW_CANDIDATES)
ON = TrackerOptions(body=BodyOptions(window_candidates=True))


# ----------------------------------------------------------------------------------------------
# window_b_candidates


def test_window_b_candidates_by_hand():
    """D: ones in rows 21..23 and threes in row 24, columns 10..29 (a 40 x 50 image). Window B
    at u 20, W 10 px: columns 15..24 (10 px), 2 rows ending at round(v). Per offset (W, the
    window's bottom row moved by offset x 10 px): the pixels counted by hand."""
    D = np.zeros((40, 50), np.uint8)
    D[21:24, 10:30] = 1
    D[24, 10:30] = 3
    offsets = (0.0, -0.1, -0.2, 0.1, -0.4, -3.0, 0.05)
    got = window_b_candidates(D, 20.0, 25.0, 10.0, offsets)
    # v 25: rows 24-25 -> 10 x 3; v 24: rows 23-24 -> 10 + 30; v 23: rows 22-23 -> 20;
    # v 26: rows 25-26 -> 0; v 21: rows 20-21 -> 10; v -5: above the image -> 0;
    # v 25.5: round 26 -> rows 25-26 -> 0
    assert got == (30.0, 40.0, 20.0, 0.0, 10.0, 0.0, 0.0)
    assert isinstance(got, tuple) and all(type(x) is float for x in got)
    # a fractional foot row: 24.6 - 1 = 23.6 rounds to 24 -> rows 23-24
    assert window_b_candidates(D, 20.0, 24.6, 10.0, (-0.1,)) == (40.0,)
    assert window_b_candidates(D, 20.0, 25.0, 10.0, ()) == ()
    # the NaN rules of window_b_intensity: all NaN where it is NaN
    for u, v, W in ((math.nan, 25.0, 10.0), (20.0, math.inf, 10.0), (20.0, 25.0, math.nan),
                    (20.0, 25.0, 0.0), (20.0, 25.0, -3.0)):
        assert math.isnan(window_b_intensity(D, u, v, W))
        assert all(math.isnan(x) for x in window_b_candidates(D, u, v, W, OFFSETS))


def test_window_b_candidates_equal_window_b_at_the_shifted_rows():
    rng = np.random.default_rng(5)
    D = rng.integers(0, 256, (60, 80)).astype(np.uint8)
    for _ in range(50):
        u, v, W = rng.uniform(-5, 85), rng.uniform(-5, 65), rng.uniform(0.5, 30)
        offs = tuple(rng.uniform(-1, 1, 4))
        want = tuple(window_b_intensity(D, u, v + o * W, W) for o in offs)
        assert window_b_candidates(D, u, v, W, offs) == want


# ----------------------------------------------------------------------------------------------
# the online tracker


@pytest.fixture(scope="module")
def hidden_walker():
    """A walker crossing at 12 m, hidden (the empty ground drawn instead) for frames 40..61:
    its track times out and is continued (relink rows with no sample), 110 frames."""
    act = synth.walker(-3.4, 12.0, 0.0, pace_hz=1.9, step_length_m=0.62)
    spec = synth.SceneSpec(n_frames=110, actors=(act,), camera=CFG.camera)
    walk = synth.render_scene(3, spec).frames
    empty = synth.render_scene(3, dataclasses.replace(spec, actors=())).frames
    return [empty[k] if 40 <= k < 62 else walk[k] for k in range(110)]


def _run(frames, options=None):
    tr = OnlineTracker(CFG, options)
    for k, f in enumerate(frames):
        tr.update(k, k / 15.0, f)
    tracks, verdicts, objs = tr.finish()
    return tr, tracks, verdicts, objs


@pytest.fixture(scope="module")
def runs(hidden_walker):
    """The scene tracked with the option off (the key given as False, rule 50b's windows moved
    across off too), by default and on; on, every window-B sum the tracker makes is recorded:
    (D, u, v, W, I)."""
    calls = []
    real = detect.window_b_intensity

    def spy(D, u, v, W, **kw):
        value = real(D, u, v, W, **kw)
        calls.append((D.copy(), u, v, W, value))
        return value

    off = _run(hidden_walker, TrackerOptions(body=BodyOptions(window_candidates=False,
                                                              across_candidates=False)))
    default = _run(hidden_walker)  # the default is on
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(detect, "window_b_intensity", spy)
        on = _run(hidden_walker, ON)
    return off, default, on, calls


def _same_columns(a: dict, b: dict, names) -> None:
    for k in names:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        if x.dtype.kind == "f":
            np.testing.assert_array_equal(x, y, err_msg=k)  # NaN equal to NaN
        else:
            assert x.tolist() == y.tolist(), k


def test_option_off_writes_no_candidates_and_changes_nothing(runs):
    (_, tracks, verdicts, objs), (_, tracks_d, verdicts_d, _), (_, tracks_on, verdicts_on, _), \
        _ = runs
    assert not set(CANDIDATE_COLUMNS) & set(tracks)
    assert all(o.candidate_rows is None and (o.result is None or "candidate" not in o.result)
               for o in objs)
    # the default is on: the same tables as the option given as True
    assert set(tracks_d) == set(tracks_on) == set(tracks) | set(CANDIDATE_COLUMNS + ACROSS_COLUMNS)
    _same_columns(tracks_d, tracks_on, tracks_on)
    _same_columns(verdicts_d, verdicts_on, verdicts_on)
    # the option changes what is sampled, never the tracking: every other column equal
    assert set(tracks_on) == set(tracks) | set(CANDIDATE_COLUMNS + ACROSS_COLUMNS)
    _same_columns(tracks, tracks_on, tracks)


def test_option_on_writes_the_candidate_columns(runs):
    _, _, (tr, tracks, _, objs), calls = runs
    assert tr.relinked == 1  # relink's gap rows carry candidates too
    inten = tracks["intensity"]
    cand = np.stack([tracks[c] for c in CANDIDATE_COLUMNS], axis=1)
    assert cand.dtype == np.float64 and cand.shape == (len(inten), len(OFFSETS))
    np.testing.assert_array_equal(np.isnan(cand), np.repeat(np.isnan(inten)[:, None], 3, 1))
    gap = tracks["state"] == "none"
    assert gap.sum() >= 3 and np.all(np.isnan(cand[gap]))
    assert all(len(o.candidate_rows) == len(o.rows) for o in objs)
    # each row's candidates recomputed independently from the tracker's own D, foot point and
    # W: a measured row is found by its foot row and I(k) (window B at the measured foot row,
    # `body.sample_estimate` off; its column the slice extent's, which rule 54 may leave apart
    # from the track's u), a predicted one (window B at the filter's foot point) by its I(k)
    # among the calls with that value
    at, by_value = {}, {}
    for D, u, v, W, value in calls:
        if math.isfinite(value):
            want = tuple(window_b_intensity(D, u, v + o * W, W) for o in OFFSETS)
            at[(float(v), value)] = want
            by_value.setdefault(value, []).append(want)
    ok = np.isfinite(inten)
    measured = ok & np.isfinite(tracks["u"])
    assert measured.sum() > 60
    for i in np.flatnonzero(ok):
        got = tuple(cand[i])
        if measured[i]:
            assert got == at[(tracks["v"][i], inten[i])], i
        else:
            assert got in by_value[inten[i]], i
    assert np.any(cand[ok] != inten[ok][:, None], axis=0).all()  # every window moved


def test_a_zero_offset_candidate_equals_intensity(hidden_walker, monkeypatch):
    """The mechanism with the first offset set to 0 (read by `BodyOptions.candidate_offsets`):
    that column is `intensity`, exactly."""
    zero = ((CANDIDATE_COLUMNS[0], 0.0),) + tuple(WINDOW_CANDIDATES[1:])
    monkeypatch.setattr(options_module, "WINDOW_CANDIDATES", zero)
    _, tracks, _, _ = _run(hidden_walker[:50], ON)
    assert np.isfinite(tracks["intensity"]).sum() > 30
    np.testing.assert_array_equal(tracks[CANDIDATE_COLUMNS[0]], tracks["intensity"])
    assert not np.array_equal(tracks[CANDIDATE_COLUMNS[1]], tracks["intensity"])


def test_tracks_columns_refuses_misaligned_candidates():
    class Obj:
        track_id, rows = 4, [TrackRow(0, 0.0, 1.0, 1.0, 1.0, 2.0, 0.0, 9.0, 2)] * 3
        candidate_rows = [(1.0, 2.0, 3.0)] * 2

    with pytest.raises(ValueError, match="track 4: candidate windows' I\\(k\\) for 2 of its 3"):
        tracks_columns([Obj()])
    Obj.candidate_rows = [(1.0, 2.0, 3.0)] * 3
    cols = tracks_columns([Obj()])
    assert [cols[c].tolist() for c in CANDIDATE_COLUMNS] == [[1.0] * 3, [2.0] * 3, [3.0] * 3]
    assert not set(CANDIDATE_COLUMNS) & set(tracks_columns([Obj()], candidates=False))


# ----------------------------------------------------------------------------------------------
# match_window with candidates


@dataclasses.dataclass
class Windows:
    """What `match_window` reads and updates (`toolkit.RhythmWindows`), with candidates."""

    rows: list
    candidate_rows: list | None
    win_start: int = 0
    windows_done: int = 0
    result: dict | None = None
    decided: bool = False


def _window_object(main: np.ndarray, cands: np.ndarray | None) -> Windows:
    """An object of N rows walking at 1.3 m/s across at 10 m, foot points projected from its
    ground track (OBSERVE rows), I(k) `main`, candidates `cands` (N, K) or None."""
    n = len(main)
    t = np.arange(n) / 15.0
    x, y = -2.0 + 1.3 * t, np.full(n, 10.0)
    u, v = (np.asarray(a, np.float64) for a in project(
        CFG.camera, jnp.asarray(x, jnp.float32), jnp.asarray(y, jnp.float32)))
    rows = [TrackRow(k, t[k], u[k], v[k], 30.0, main[k], x[k], y[k], int(TrackState.OBSERVE))
            for k in range(n)]
    return Windows(rows, None if cands is None else [tuple(map(float, c)) for c in cands])


def _alone(obj, signal):
    """`classify_window_jit` of the object's window with I(k) `signal`, as match_window calls
    it."""
    rows = obj.rows
    t = np.asarray([r.t for r in rows])
    xy = np.asarray([(r.x_est, r.y_est) for r in rows])
    uv = np.asarray([(r.u, r.v) for r in rows])
    res = classify_window_jit(CFG, jnp.asarray(signal, jnp.float32),
                              jnp.asarray(t - t[0], jnp.float32), jnp.asarray(xy, jnp.float32),
                              jnp.asarray(True), jnp.asarray(uv, jnp.float32))
    return {name: np.asarray(getattr(res, name)) for name in RESULT_FIELDS}


def assert_same_outcome(got, want, name):
    """One field of a window's outcome judged with the candidates in one vmapped call
    (`classify_window_candidates_jit`) against `classify_window_jit` on that signal alone: the
    same program batched, so float32 fields agree to a few ulp (reassociation), rtol 1e-5
    (peak powers 1e-4: P is a ratio of sums of 64 squares), integer and boolean fields exactly."""
    if np.issubdtype(np.asarray(want).dtype, np.floating):
        rtol = 1e-4 if name == "peak_power" else 1e-5
        np.testing.assert_allclose(got, want, rtol=rtol, atol=1e-6, err_msg=name)
    else:
        np.testing.assert_array_equal(got, want, err_msg=name)


def test_candidates_in_one_call_equal_each_alone(signals):
    """`classify_window_candidates_jit` row c against `classify_window_jit` of signal c alone,
    for noise, a walker's rhythm, and a rhythm with 10 missing samples."""
    noise, walk = signals
    gappy = walk.copy()
    gappy[20:30] = np.nan
    sigs = np.stack([noise[0], walk, gappy])
    obj = _window_object(walk, None)
    t = np.asarray([r.t for r in obj.rows])
    xy = np.asarray([(r.x_est, r.y_est) for r in obj.rows])
    uv = np.asarray([(r.u, r.v) for r in obj.rows])
    every = classify_window_candidates_jit(
        CFG, jnp.asarray(sigs, jnp.float32), jnp.asarray(t - t[0], jnp.float32),
        jnp.asarray(xy, jnp.float32), jnp.asarray(True), jnp.asarray(uv, jnp.float32))
    for c, sig in enumerate(sigs):
        want = _alone(obj, sig)
        for name in RESULT_FIELDS:
            assert_same_outcome(np.asarray(getattr(every, name))[c], want[name], name)
    assert [int(v) for v in np.asarray(every.verdict)] == \
        [int(_alone(obj, s)["verdict"]) for s in sigs]


@pytest.fixture(scope="module")
def signals():
    n = CFG.thresholds.n
    rng = np.random.default_rng(11)
    t = np.arange(n) / float(CFG.camera.fps)
    noise = [500 + 40 * rng.standard_normal(n) for _ in range(3)]
    walk = 500 + 200 * np.sin(2 * np.pi * 1.9 * t) + 40 * rng.standard_normal(n)
    return noise, walk


def test_the_candidate_with_the_gait_decides(signals):
    """Window B (and candidates 1 and 3) noise, candidate 2 a 1.9 Hz sinusoid: candidate 2
    decides, and the outcome is `classify_window_jit`'s on candidate 2 alone, field by field."""
    (main, c1, c3), walk = signals
    obj = _window_object(main, np.stack([c1, walk, c3], axis=1))
    match_window(CFG, obj)
    r = obj.result
    assert r["candidate"] == 2 and r["window"] == (0, len(main)) and obj.windows_done == 1
    want = _alone(obj, walk)
    assert int(want["verdict"]) == Verdict.PEDESTRIAN  # the sinusoid is a walker's rhythm
    assert int(_alone(obj, main)["verdict"]) != Verdict.PEDESTRIAN  # window B alone is not
    for name in RESULT_FIELDS:
        assert r[name].dtype == want[name].dtype and r[name].shape == want[name].shape, name
        assert_same_outcome(r[name], want[name], name)
    assert obj.decided
    np.testing.assert_array_equal(window_signal(obj, 0, len(main), 2), walk)
    # the spectra page redraws the window that decided: candidate 2's I(k)
    from rhythmjax.cli.spectra import track_spectrum

    plain = _window_object(walk, None)
    plain.result = {"window": (0, len(main))}
    for got, ref in zip(track_spectrum(CFG, obj), track_spectrum(CFG, plain)):
        np.testing.assert_array_equal(got, ref)


def test_candidates_equal_to_window_b_change_nothing(signals):
    (_, c1, _), walk = signals
    for main in (walk, c1):
        plain = _window_object(main, None)
        match_window(CFG, plain)
        same = _window_object(main, np.stack([main] * 3, axis=1))
        match_window(CFG, same)
        assert same.result.pop("candidate") == 0  # ties: the paper's window B
        assert same.result.keys() == plain.result.keys()
        for name in plain.result:  # equal rows of one batched call: a tie, window B kept
            if name == "window":
                assert same.result[name] == plain.result[name]
                continue
            assert_same_outcome(same.result[name], plain.result[name], name)
            assert np.asarray(same.result[name]).dtype == np.asarray(plain.result[name]).dtype
        assert (same.decided, same.win_start, same.windows_done) == \
            (plain.decided, plain.win_start, plain.windows_done)


def test_missing_rule_reads_window_b_only(signals):
    """More than a quarter of window B's samples missing: not judged, though every candidate is
    complete (the tracker never writes that; the rule is window B's)."""
    _, walk = signals
    main = walk.copy()
    main[:20] = np.nan
    obj = _window_object(main, np.stack([walk] * 3, axis=1))
    match_window(CFG, obj)
    assert obj.result is None and obj.win_start == 20


# ----------------------------------------------------------------------------------------------
# box_intensities and the rhythm verb


def _loop(prev, cur, u, v, W):
    """Window B by its definition in float64 loops (round = floor(x + 0.5), clipped)."""
    H, Wd = cur.shape
    wb, hb = max(1, math.floor(W + 0.5)), max(1, math.floor(W / 5 + 0.5))
    c0, r1 = math.floor(u - wb / 2 + 0.5), math.floor(v + 0.5)
    return float(sum(abs(float(cur[r, c]) - float(prev[r, c]))
                     for r in range(r1 - hb + 1, r1 + 1) for c in range(c0, c0 + wb)
                     if 0 <= r < H and 0 <= c < Wd))


def test_box_intensities_candidates_match_a_float64_loop():
    rng = np.random.default_rng(3)
    frames = [(100 + rng.integers(0, 12, (48, 64))).astype(np.uint8) for _ in range(3)]
    rows = [(0, 20.0, 30.0, 10.0), (1, 20.0, 30.0, 10.0), (1, 0.7, 47.0, 12.6),
            (2, 61.4, 10.49, 7.5), (2, 33.5, 2.5, 15.4), (2, 40.0, 44.0, math.nan),
            (2, 64.2, 20.0, 10.0)]
    f, u, v, W = (np.asarray(c) for c in zip(*rows))
    stream = lambda: ((i, i / 15.0, g) for i, g in enumerate(frames))  # noqa: E731
    sig = box_intensities(stream(), f, u, v, W, offsets=OFFSETS)
    assert box_intensities(stream(), f, u, v, W).candidates is None
    assert sig.candidates.shape == (len(rows), 3)
    for k, (fr, uu, vv, ww) in enumerate(rows):
        if math.isnan(sig.intensity[k]):
            assert fr == 0 or not math.isfinite(ww) or uu >= 63.5, k
            assert np.all(np.isnan(sig.candidates[k])), k
            continue
        for j, off in enumerate(OFFSETS):
            assert sig.candidates[k, j] == _loop(frames[fr - 1], frames[fr], uu, vv + off * ww,
                                                 ww), (k, j)


def test_rhythm_verb_writes_the_candidate_columns(tmp_path, capsys):
    """Eight 512 x 512 frames (PNG, lossless) and one MOT box track: with
    --window-candidates the tracks file has the three columns, each the float64 loop at the
    moved window (also by default); with --no-window-candidates none, also when BOXES is a
    tracks file that had them."""
    rng = np.random.default_rng(7)
    video = tmp_path / "frames"
    video.mkdir()
    ground = 100 + rng.integers(0, 40, (512, 512))  # a still textured ground (no shake read)
    frames = []
    for _ in range(8):  # where the box is, sensor noise below the motion threshold
        g = ground.copy()
        g[150:450, 100:400] += rng.integers(0, 12, (300, 300))
        frames.append(g.astype(np.uint8))
    for i, g in enumerate(frames):
        cv2.imwrite(str(video / f"{i:03d}.png"), g)
    gt = tmp_path / "gt.txt"
    k = np.arange(8)
    write_mot(gt, {"frame": k + 1, "id": np.ones(8, np.int64), "bb_left": 200.0 + 2 * k,
                   "bb_top": np.full(8, 300.0), "bb_width": np.full(8, 30.0),
                   "bb_height": np.full(8, 90.0)})
    base = ["rhythm", str(video), "--boxes", str(gt), "--json", "--no-camera-check", "--fps",
            "15"]
    out = tmp_path / "on"
    assert cli_main(base + ["-o", str(out), "--window-candidates"]) == 0
    assert json.loads(capsys.readouterr().out)["n_rows"] == 8
    t = read_table(out / "tracks.parquet", ["frame", "u", "v", "intensity"],
                   list(CANDIDATE_COLUMNS))
    assert np.isnan(t["intensity"][0]) and np.isfinite(t["intensity"][1:]).all()
    W = window_widths(CFG, t["u"], t["v"])
    assert np.isfinite(W).all()
    for name, off in WINDOW_CANDIDATES:
        col = t[name]
        assert math.isnan(col[0]), name
        for i in range(1, 8):
            fr = int(t["frame"][i])
            assert col[i] == _loop(frames[fr - 1], frames[fr], t["u"][i], t["v"][i] + off * W[i],
                                   W[i]), (name, i)
    plain = tmp_path / "off"
    assert cli_main(base + ["-o", str(plain), "--no-window-candidates"]) == 0
    capsys.readouterr()
    back = tmp_path / "again"
    assert cli_main(["rhythm", str(video), "--boxes", str(out / "tracks.parquet"), "-o", str(back),
                 "--json", "--no-camera-check", "--fps", "15", "--no-window-candidates"]) == 0
    capsys.readouterr()
    default = tmp_path / "default"  # the default is on
    assert cli_main(base + ["-o", str(default)]) == 0
    got = read_table(default / "tracks.parquet", ["intensity"], list(CANDIDATE_COLUMNS))
    for name in CANDIDATE_COLUMNS:
        np.testing.assert_array_equal(got[name], t[name])
    capsys.readouterr()
    for d in (plain, back):
        cols = read_table(d / "tracks.parquet", ["intensity"], list(CANDIDATE_COLUMNS))
        assert not set(CANDIDATE_COLUMNS) & set(cols), d
        np.testing.assert_array_equal(cols["intensity"], t["intensity"])
    # rule 50b's windows moved across (`--across-candidates`; off behind boxes, decision 51b):
    # two more columns after the three, each the float64 loop at window B moved 0.1 W left or
    # right; the default and the others without them (checked above and here)
    across = tmp_path / "across"
    assert cli_main(base + ["-o", str(across), "--across-candidates"]) == 0
    capsys.readouterr()
    got = read_table(across / "tracks.parquet", ["intensity"],
                     list(CANDIDATE_COLUMNS + ACROSS_COLUMNS))
    assert not set(ACROSS_COLUMNS) & set(read_table(default / "tracks.parquet", ["intensity"],
                                                    list(ACROSS_COLUMNS)))
    for name in ("intensity",) + CANDIDATE_COLUMNS:
        np.testing.assert_array_equal(got[name], t[name])
    for name, off in ACROSS_CANDIDATES:
        assert math.isnan(got[name][0]), name
        for i in range(1, 8):
            fr = int(t["frame"][i])
            assert got[name][i] == _loop(frames[fr - 1], frames[fr], t["u"][i] + off * W[i],
                                         t["v"][i], W[i]), (name, i)
    assert np.any(got[ACROSS_COLUMNS[0]][1:] != got[ACROSS_COLUMNS[1]][1:])


def test_a_trend_does_not_win_the_candidates(signals):
    """Rule 38b in `match_window`: window B noise on a steep ramp (its strongest peak a trend,
    under 2 cycles over the window), candidate 1 a weak 1.9 Hz sinusoid, candidates 2 and 3
    noise. The
    paper's comparison takes window B (the trend's peak is the strongest) and the window is not
    Pedestrian; with `thresholds.trend_max_cycles` 2 the trend is left out and candidate 1
    decides, with `classify_window_jit`'s outcome on it."""
    from rhythmjax.model.params import config_from_dict, config_to_dict

    (main, c2, c3), _ = signals
    n = len(main)
    t = np.arange(n) / float(CFG.camera.fps)
    # a weak gait (P ~ 35) against the ramp's trend (P ~ 68): the trend wins the paper's choice
    walk = 500 + 50 * np.sin(2 * np.pi * 1.9 * t) + 40 * np.random.default_rng(5).standard_normal(n)
    ramp = main + 60.0 * np.arange(n)  # grey levels a frame
    d = config_to_dict(CFG)
    d["thresholds"]["trend_max_cycles"] = 2.0
    trend_cfg = config_from_dict(d)
    paper = _window_object(ramp, np.stack([walk, c2, c3], axis=1))
    match_window(CFG, paper)
    assert paper.result["candidate"] == 0
    assert int(paper.result["verdict"]) != Verdict.PEDESTRIAN
    assert float(paper.result["peak_freq"][0]) * n / CFG.camera.fps < 2.0
    on = _window_object(ramp, np.stack([walk, c2, c3], axis=1))
    match_window(trend_cfg, on)
    assert on.result["candidate"] == 1
    assert int(on.result["verdict"]) == Verdict.PEDESTRIAN
    want = _alone(on, walk)
    assert_same_outcome(on.result["pace_hz"], want["pace_hz"], "pace_hz")
