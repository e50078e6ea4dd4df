"""Rule 55 (`recheck.strongest_pace`, on by default since decision 55): a Pedestrian track's pace F
and stride T are those of its window judged Pedestrian (the deciding one or a later one) whose
chosen peak is the strongest (P of (13)); its verdict stays the deciding window's; rule 47's median
takes its place where that is on. `chosen_peak_power` by hand; hand-made tracks on the paper's
camera (`test_recheck`'s helpers: I(k) a sine at a set pace plus noise) where the noise sets which
window is the strongest; the tracker on a rendered lone walker."""

import math

import numpy as np
import pytest

from rhythmjax.model.params import Config
from rhythmjax.model.status import Verdict
from rhythmjax.track.options import RecheckOptions
from rhythmjax.track.recheck import chosen_peak_power, later_windows, median_pace

from .test_median_pace import (
    PACE_TOL,
    SPEED,
    STRIDE_TOL,
    assert_verdict_kept,
    lone_walker_tracked,
)
from .test_recheck import judged_online, walk_rows


CFG = Config()
ON = RecheckOptions(strongest_pace=True)


def noisy(obj, rows: slice, sd: float, seed: int = 1):
    """`obj` with noise of standard deviation `sd` added to I(k) on `rows` (the sine's
    amplitude is 5): from 1 up, more noise, a weaker peak relative to the white-noise level
    (measured on 64 rows at 2.0 Hz: P about 700 at sd 1, 50-150 at sd 3; a nearly pure sine's
    peak is too narrow for the frequency grid, P 11 at `walk_rows`' 0.1, so every window here
    gets at least 1)."""
    rng = np.random.default_rng(seed)
    for k in range(*rows.indices(len(obj.rows))):
        r = obj.rows[k]
        obj.rows[k] = r._replace(intensity=r.intensity + float(rng.normal(0, sd)))
    return obj


def pedestrian_windows(obj) -> list[dict]:
    return [obj.result] + [r for r in later_windows(CFG, obj, tail=True)
                           if int(r["verdict"]) == Verdict.PEDESTRIAN]


def test_chosen_peak_power_by_hand():
    """The reported peak nearest the pace, among those the mask keeps; NaN without one."""
    result = {"pace_hz": 2.0, "peak_freq": np.array([1.0, 2.01, 3.0, np.nan]),
              "peak_power": np.array([30.0, 20.0, 8.0, 99.0]),
              "peak_mask": np.array([True, True, False, False])}
    assert chosen_peak_power(result) == 20.0
    assert chosen_peak_power(dict(result, pace_hz=2.9)) == 20.0  # 3.0 is masked out
    assert math.isnan(chosen_peak_power(dict(result, pace_hz=math.nan)))
    assert math.isnan(chosen_peak_power(dict(result, peak_mask=np.zeros(4, bool))))


def test_a_stronger_later_window_gives_its_pace():
    """64 rows at 2.0 Hz with noise of 3 (the deciding window 0..64, still Pedestrian), then 128
    rows at 1.7 Hz with noise of 1: the later windows are the strongest, so the pace reads 1.7 Hz
    and T = 1.3 / 1.7 = 0.765 m; off, the deciding window's 2.0 Hz. Verdict, reason, speed, ratio
    and window stay the deciding window's."""
    obj = walk_rows([SPEED] * 192, paces_hz=[2.0] * 64 + [1.7] * 128)
    obj = judged_online(noisy(noisy(obj, slice(0, 64), 3.0), slice(64, 192), 1.0, seed=2))
    assert int(obj.result["verdict"]) == Verdict.PEDESTRIAN and obj.result["window"] == (0, 64)
    powers = [chosen_peak_power(r) for r in pedestrian_windows(obj)]
    assert len(powers) >= 2 and max(powers[1:]) > 1.5 * powers[0]
    assert median_pace(CFG, obj, RecheckOptions(strongest_pace=False)) is obj.result
    assert obj.result["pace_hz"] == pytest.approx(2.0, abs=PACE_TOL)
    on = median_pace(CFG, obj, ON)
    assert on["pace_hz"] == pytest.approx(1.7, abs=PACE_TOL)
    assert on["stride_m"] == pytest.approx(SPEED / 1.7, abs=STRIDE_TOL)
    assert_verdict_kept(on, obj.result)


def test_a_stronger_deciding_window_keeps_its_pace_where_the_median_would_not():
    """64 rows at 2.0 Hz with noise of 1, then 128 rows at 1.7 Hz with noise of 3: the deciding
    window is the strongest, so the pace stays 2.0 Hz, where rule 47's median over the same
    windows (at least two later ones at 1.7 Hz judged Pedestrian) reads 1.7 Hz."""
    obj = walk_rows([SPEED] * 192, paces_hz=[2.0] * 64 + [1.7] * 128)
    obj = judged_online(noisy(noisy(obj, slice(0, 64), 1.0), slice(64, 192), 3.0, seed=2))
    windows = pedestrian_windows(obj)
    assert len(windows) >= 3
    powers = [chosen_peak_power(r) for r in windows]
    assert int(np.argmax(powers)) == 0
    on = median_pace(CFG, obj, ON)
    assert on["pace_hz"] == obj.result["pace_hz"] == pytest.approx(2.0, abs=PACE_TOL)
    assert on["stride_m"] == obj.result["stride_m"]
    median = median_pace(CFG, obj, RecheckOptions(median_pace=True))  # rule 55 on too: 47 wins
    assert median["pace_hz"] == pytest.approx(1.7, abs=PACE_TOL)


def test_off_disabled_or_not_pedestrian_leaves_the_result():
    obj = judged_online(noisy(walk_rows([SPEED] * 192, paces_hz=[2.0] * 64 + [1.7] * 128),
                              slice(0, 192), 1.0))
    assert median_pace(CFG, obj, RecheckOptions(enabled=False, strongest_pace=True)) \
        is obj.result
    fast = judged_online(walk_rows([4.0] * 192))  # faster than any walk: Non-pedestrian
    assert int(fast.result["verdict"]) != Verdict.PEDESTRIAN
    assert median_pace(CFG, fast, ON) is fast.result
    assert median_pace(CFG, walk_rows([SPEED] * 40), ON) is None  # too short for a window


def test_the_tracker_reports_the_strongest_of_a_lone_walkers_windows():
    """`test_median_pace`'s lone walker: with the rule on its Pedestrian track's pace is that of
    the window with the strongest chosen peak among its deciding and later Pedestrian windows
    (read on the objects the tracker returns off), within 0.05 Hz of 1.9."""
    pace, obj = lone_walker_tracked("recheck.strongest_pace")
    windows = pedestrian_windows(obj)
    assert len(windows) >= 2
    best = windows[int(np.argmax([chosen_peak_power(r) for r in windows]))]
    assert pace == pytest.approx(float(best["pace_hz"]), abs=1e-6)
    assert pace == pytest.approx(1.9, abs=0.05)


def test_the_pace_window_is_named_and_the_spectra_panel_draws_it():
    """The result names the window its pace came from (`pace_window`, `pace_candidate`), and the
    spectra gallery draws that window's spectrum, so the panel's F sits on its peak: the
    spectrum's maximum within 0.05 Hz of 1.7 Hz (the later windows' pace), where the deciding
    window's peaks at 2.0 Hz."""
    from types import SimpleNamespace

    from rhythmjax.cli.spectra import track_spectrum

    obj = walk_rows([SPEED] * 192, paces_hz=[2.0] * 64 + [1.7] * 128)
    obj = judged_online(noisy(noisy(obj, slice(0, 64), 3.0), slice(64, 192), 1.0, seed=2))
    on = median_pace(CFG, obj, ON)
    best = max(pedestrian_windows(obj)[1:], key=chosen_peak_power)
    assert on["pace_window"] == tuple(best["window"]) != tuple(obj.result["window"])
    assert on["pace_candidate"] == 0
    for result, pace in ((on, 1.7), (obj.result, 2.0)):
        f, p = track_spectrum(CFG, SimpleNamespace(rows=obj.rows, result=result))
        assert abs(f[np.argmax(p)] - pace) < 0.05
