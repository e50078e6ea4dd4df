"""Rule 49 (`SizeOptions.twice_pace_sub`, `track.twice.reads_twice`): rule 37 judges a window at
half its strongest peak f1 only where the spectrum also holds a masked peak within 0.2 Hz of f1/2
with at least `twice_pace_sub` times f1's power.

Reference: the peaks written by hand (a walker read at twice its pace keeps a peak at its own
pace; a dog's leg cycle has none there), and a spectrum from the library's Burg MEM (`rhythm.
judge_window`) of a signal built here: a sine at 4 Hz plus, for the walker, one at 2 Hz of a
tenth its amplitude. Walking model of Table 1 (pace [1.501, 2.599] Hz, step [0.45, 0.99] m)."""

import numpy as np
import pytest

from rhythmjax.model.params import config_from_dict
from rhythmjax.model.status import Reason, Verdict
from rhythmjax.track.options import SizeOptions
from rhythmjax.track.twice import SUB_HZ, batch_second_look, judge_at_half, reads_twice


CFG = config_from_dict({"thresholds": {"range_max_m": 40.0}})


def outcome(peaks, speed=1.4, ratio=0.8):
    """A window refused by (14) (no-model-match) whose peaks (Hz, power) are `peaks`, the
    strongest first, every one masked in."""
    f, p = (np.asarray(x, np.float32) for x in zip(*peaks))
    return {"verdict": np.asarray(int(Verdict.NON_PEDESTRIAN)),
            "reason": np.asarray(int(Reason.NO_MODEL_MATCH)),
            "pace_hz": np.asarray(f[0]), "stride_m": np.asarray(speed / f[0], np.float32),
            "ratio": np.asarray(ratio, np.float32), "speed_mps": np.asarray(speed, np.float32),
            "peak_freq": f, "peak_power": p, "peak_mask": np.ones(len(f), bool)}


def stack(outs):
    return {k: np.stack([o[k] for o in outs]) for k in outs[0]}


def test_sub_harmonic_by_hand():
    walker = outcome([(4.0, 40.0), (2.05, 4.0), (0.3, 9.0)])  # 0.10 of f1's power at 2.05 Hz
    weak = outcome([(4.0, 40.0), (1.95, 0.4), (0.3, 9.0)])  # 0.01 of it
    dog = outcome([(4.0, 40.0), (0.3, 9.0), (5.9, 3.0)])  # nothing near 2 Hz
    far = outcome([(4.0, 40.0), (2.3, 30.0), (0.3, 9.0)])  # strong, but 0.3 Hz off
    near = outcome([(4.0, 40.0), (1.85, 30.0), (0.3, 9.0)])  # 0.15 Hz off: within 0.2 Hz
    res = stack([walker, weak, dog, far, near])
    assert SUB_HZ == 0.2
    assert reads_twice(res, CFG).tolist() == [True] * 5  # off: rule 37 as before
    assert reads_twice(res, CFG, 0.02).tolist() == [True, False, False, False, True]
    assert reads_twice(res, CFG, 0.005).tolist() == [True, True, False, False, True]
    assert reads_twice(res, CFG, 0.2).tolist() == [False, False, False, False, True]
    masked = dict(res, peak_mask=res["peak_mask"].copy())
    masked["peak_mask"][0, 1] = False  # a peak left out of the mask does not count
    assert reads_twice(masked, CFG, 0.02).tolist() == [False, False, False, False, True]


def test_the_other_tests_of_rule_37_still_hold_with_the_rule():
    """A window that rule 37 would not read (passing (14) at f1, too fast) stays unread."""
    at_f1 = outcome([(2.0, 40.0), (1.0, 20.0)])  # (14) passes at f1: not rule 37's
    fast = outcome([(4.0, 40.0), (2.0, 20.0)], speed=3.5)  # twice the step too long at half
    assert reads_twice(stack([at_f1, fast]), CFG, 0.02).tolist() == [False, False]


def test_judge_at_half_reads_the_option():
    from rhythmjax.model.camera_np import project_3d
    from rhythmjax.track.rows import TrackRow

    n = int(CFG.thresholds.n)
    y = 22.0 + 1.4 * np.arange(n) / 15.0
    u, v = (np.asarray(a) for a in project_3d(CFG.camera, 0 * y, y, 0 * y))
    _, top = project_3d(CFG.camera, 0 * y, y, 1.7 + 0 * y)
    rows = [TrackRow(k, k / 15.0, float(u[k]), float(v[k]), 20.0, 1.0, 0.0, float(y[k]), 2,
                     float(top[k])) for k in range(n)]
    dog = outcome([(4.0, 40.0), (0.3, 9.0)])
    walker = outcome([(4.0, 40.0), (2.0, 8.0)])  # 0.2 of f1's power at f1/2
    on, off = SizeOptions(twice_pace_sub=0.02), SizeOptions()
    for out, options, want in ((dog, off, Verdict.PEDESTRIAN), (dog, on, Verdict.NON_PEDESTRIAN),
                               (walker, on, Verdict.PEDESTRIAN)):
        got = judge_at_half(out, CFG, rows, CFG.camera, 1.7, options)
        assert int(got["verdict"]) == want
    got = judge_at_half(walker, CFG, rows, CFG.camera, 1.7, on)
    assert float(got["pace_hz"]) == pytest.approx(2.0) and int(got["reason"]) == \
        Reason.MATCHED_TWICE


def test_the_batch_look_reads_the_option():
    """`count`'s and the batch classifier's rule 37 (`batch_second_look`) on a walker's rows:
    a dog's spectrum judged at half with the rule off, left refused with it on; a walker's
    judged at half both ways, as `judge_at_half` judges them."""
    from rhythmjax.model.camera_np import project_3d

    n = int(CFG.thresholds.n)
    y = 22.0 + 1.4 * np.arange(n) / 15.0
    u, v = (np.asarray(a, np.float64) for a in project_3d(CFG.camera, 0 * y, y, 0 * y))
    top = np.asarray(project_3d(CFG.camera, 0 * y, y, 1.7 + 0 * y)[1], np.float64)
    batch = type("B", (), {"z": np.stack([u, v], -1)[None], "v_top": top[None]})()
    res = stack([outcome([(4.0, 40.0), (0.3, 9.0)]), outcome([(4.0, 40.0), (2.0, 8.0)])])
    track, start = np.zeros(2, int), np.zeros(2, int)
    for options, want in ((SizeOptions(twice_pace_edge=False), [True, True]),
                          (SizeOptions(twice_pace_edge=False, twice_pace_sub=0.02),
                           [False, True])):
        got = batch_second_look(CFG, batch, options)(res, track, start)
        assert [int(x) == Verdict.PEDESTRIAN for x in got["verdict"]] == want


def test_mem_spectra_of_a_walker_and_a_dog():
    """Through the library's spectrum: a 4 Hz sine alone (a dog's leg cycle) has no peak near
    2 Hz; with a 2 Hz sine of a tenth its amplitude (a walker's uneven steps) it has one above
    0.02 of the 4 Hz peak's power (MEM peak powers are no squared amplitudes: at a sixth the
    amplitude the 2 Hz peak already reads stronger than the 4 Hz one)."""
    import jax.numpy as jnp

    from rhythmjax.model.rhythm import judge_window

    t = np.arange(int(CFG.thresholds.n)) / 15.0
    rng = np.random.default_rng(3)
    base = 20.0 + 6.0 * np.sin(2 * np.pi * 4.0 * t)
    outs = []
    for extra in (0.0, 0.6):
        sig = base + extra * np.sin(2 * np.pi * 2.0 * t + 0.4) + rng.normal(0, 0.3, t.size)
        peaks = judge_window(CFG, jnp.asarray(sig, jnp.float32),
                             jnp.asarray(1 / 15.0, jnp.float32), jnp.asarray(1.4, jnp.float32))[-1]
        outs.append({"peak_freq": np.asarray(peaks.freq), "peak_power": np.asarray(peaks.power),
                     "peak_mask": np.asarray(peaks.mask)})
    for o in outs:
        assert abs(float(o["peak_freq"][0]) - 4.0) < 0.1  # the strongest peak at 4 Hz
    ratio = []
    for o in outs:
        near = o["peak_mask"] & (np.abs(o["peak_freq"] - 2.0) < SUB_HZ)
        ratio.append(float(o["peak_power"][near].max() / o["peak_power"][0]) if near.any()
                     else 0.0)
    assert ratio[0] < 0.02 < ratio[1]
