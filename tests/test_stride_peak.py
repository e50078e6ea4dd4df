"""Rule 56 (`size.stride_peak`, `track.twice.reads_stride`): a window refused by (14) whose
strongest peak f1 passes (14) at twice its frequency (a walker's stride frequency F/2: one foot
hidden from window B) is Pedestrian at pace 2 f1, stride v / (2 f1), reason matched-stride, on
rule 37's height test. Hand-worked cases against Table 1's walking model (pace 2.05 +- 3 x 0.183
Hz = [1.501, 2.599], step 0.72 +- 3 x 0.09 m = [0.45, 0.99]; P_thr 10, R_thr 0.1), a grid
against those bounds written out here, and the batch look against the tracker's."""

import argparse

import numpy as np
import pytest

from rhythmjax.cli.common import add_height_rules, height_rules
from rhythmjax.count.judge import judge_tracks
from rhythmjax.count.options import VerdictOptions
from rhythmjax.model.camera_np import project_3d, upright_size
from rhythmjax.model.params import Config, config_from_dict
from rhythmjax.model.status import Reason, Verdict
from rhythmjax.track.options import SizeOptions
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.twice import batch_second_look, judge_at_half, reads_stride

from .test_twice_pace import object_rows, refused_window


CFG = Config()
ON = SizeOptions()  # the default: rule 56 on, rule 37's height test (0.57 walker heights)
OFF = SizeOptions(stride_peak=False)
FAR = config_from_dict({"thresholds": {"range_max_m": 40.0}})  # the paper's, range to 40 m


def _rows(top_m: float, n: int = 64) -> list[TrackRow]:
    """n measured rows of a walker-like object `top_m` m tall at 25-30 m (`object_rows`)."""
    return object_rows(top_m, n)


def _out(f1=1.0, **kw):
    """A window's outcome refused by (14), its strongest peak f1 Hz (`refused_window`)."""
    return refused_window(f1=f1, **kw)


def test_a_walker_at_its_stride_frequency_is_judged_at_twice_it():
    """1.0 Hz at 1.4 m/s: (14) refuses 1.0 Hz, 1.4 m and accepts 2.0 Hz, 0.70 m; the rows read
    1.7 m, above 0.57 x 1.7 = 0.969 m."""
    out = judge_at_half(_out(), CFG, _rows(1.7), CFG.camera, 1.7, ON)
    assert int(out["verdict"]) == Verdict.PEDESTRIAN
    assert int(out["reason"]) == Reason.MATCHED_STRIDE
    assert float(out["pace_hz"]) == pytest.approx(2.0)
    assert float(out["stride_m"]) == pytest.approx(0.7)
    assert float(out["ratio"]) == pytest.approx(0.8)  # (15) of the peak itself


@pytest.mark.parametrize("why, out, top_m, options", [
    ("off", _out(), 1.7, OFF),
    ("rule 37 off turns its height test, so rule 56, off", _out(), 1.7,
     SizeOptions(stride_peak=True, twice_pace_heights=0.0)),
    ("a dog's height", _out(), 0.5, ON),
    ("twice 0.6 Hz is no pace", _out(f1=0.6), 1.7, ON),
    ("twice 1.3 Hz is no pace", _out(f1=1.3), 1.7, ON),
    ("1.15 m at twice 1.0 Hz and 2.3 m/s is no step", _out(speed=2.3), 1.7, ON),
    ("the peak below P_thr", _out(p1=9.0), 1.7, ON),
    ("its R below R_thr", _out(ratio=0.05), 1.7, ON),
    ("refused by (15), not (14)", _out(reason=Reason.BELOW_THRESHOLD), 1.7, ON),
    ("a peak inside the model", _out(f1=2.0), 1.7, ON),
])
def test_the_verdict_stands(why, out, top_m, options):
    assert judge_at_half(out, CFG, _rows(top_m), CFG.camera, 1.7, options) is out, why


def test_rule_37_is_tried_first():
    """4.0 Hz at 1.4 m/s reads at half (2.0 Hz, 0.70 m) with rule 56 on as without it."""
    out = judge_at_half(_out(f1=4.0), CFG, _rows(1.7), CFG.camera, 1.7, ON)
    assert int(out["reason"]) == Reason.MATCHED_TWICE
    assert float(out["pace_hz"]) == pytest.approx(2.0)


def test_reads_stride_matches_the_walking_model_bounds_on_a_grid():
    """Every (f1, v) on a grid: rule 56 reads the window exactly where (14) fails at f1 and
    holds at 2 f1, the bounds of Table 1 at 3 sigma written out in float64 here."""
    f1, v = np.meshgrid(np.linspace(0.5, 1.5, 41), np.linspace(0.3, 3.0, 28), indexing="ij")
    f1, v = f1.ravel(), v.ravel()
    n = len(f1)
    res = {"verdict": np.full(n, int(Verdict.NON_PEDESTRIAN)),
           "reason": np.full(n, int(Reason.NO_MODEL_MATCH)),
           "peak_freq": np.stack([f1, 3 * f1], -1), "peak_power": np.full((n, 2), 40.0),
           "peak_mask": np.ones((n, 2), bool), "speed_mps": v, "ratio": np.full(n, 0.8)}

    def walks(F, T):
        return (abs(F - 2.05) <= 3 * 0.183) & (abs(T - 0.72) <= 3 * 0.09)

    want = ~walks(f1, v / f1) & walks(2 * f1, v / (2 * f1))
    got = reads_stride(res, CFG)
    near_edge = (np.abs(np.abs(2 * f1 - 2.05) - 0.549) < 1e-5) | \
        (np.abs(np.abs(v / (2 * f1) - 0.72) - 0.27) < 1e-5)  # float32 thresholds at the bound
    assert want.sum() > 50
    assert (got == want)[~near_edge].all()


def test_a_peak_that_walks_itself_is_not_read_at_twice():
    """With a walking model wide enough (pace 2.05 +- 3 x 0.5 Hz, step 0.72 +- 3 x 0.2 m) that
    1.2 Hz at 1.0 m/s passes (14) both at (1.2, 0.83) and at (2.4, 0.42), rule 56 does not read
    it: it is for peaks (14) refuses."""
    wide = config_from_dict({"walking": {"pace_std_hz": 0.5, "stride_std_m": 0.2}})
    assert not reads_stride(_out(f1=1.2, speed=1.0), wide)[0]
    assert reads_stride(_out(f1=1.0, speed=1.4), CFG)[0]


def test_the_batch_look_judges_each_window_as_the_tracker_does():
    """Five windows (rule 56, rule 37, a dog, no pace at twice, inside the model) in one call:
    each window's verdict, reason, pace and stride equal `judge_at_half`'s on the same rows."""
    walker_rows, dog_rows = _rows(1.7, 128), _rows(0.5, 128)
    cases = [(_out(), walker_rows), (_out(f1=4.0), walker_rows), (_out(), dog_rows),
             (_out(f1=0.6), walker_rows), (_out(f1=2.0), walker_rows)]
    res = {k: np.stack([c[0][k] for c in cases]) for k in cases[0][0]}
    z = np.stack([[(r.u, r.v) for r in rows] for rows in (walker_rows, dog_rows)])
    v_top = np.stack([[r.v_top for r in rows] for rows in (walker_rows, dog_rows)])
    batch = type("B", (), {"z": z, "v_top": v_top})()
    got = batch_second_look(CFG, batch, ON)(res, np.asarray([0, 0, 1, 0, 0]), np.zeros(5, int))
    n = CFG.thresholds.n
    for w, (out, rows) in enumerate(cases):
        want = judge_at_half(out, CFG, rows[:n], CFG.camera, 1.7, ON)
        for key in ("verdict", "reason", "pace_hz", "stride_m"):
            assert float(got[key][w]) == pytest.approx(float(want[key]), rel=1e-6), (w, key)
    assert [int(r) for r in got["reason"]] == [Reason.MATCHED_STRIDE, Reason.MATCHED_TWICE,
                                               Reason.NO_MODEL_MATCH, Reason.NO_MODEL_MATCH,
                                               Reason.NO_MODEL_MATCH]


def _tracks_table(pace: float, speed: float = 1.4, n: int = 128, fps: float = 15.0) -> dict:
    """A counting run's tracks table of one object 1.7 m tall going away from 22 m at `speed`
    m/s in front of the paper's camera (range to 40 m), I(k) a sine at `pace` Hz plus noise."""
    cfg = FAR
    rng = np.random.default_rng(3)
    t = np.arange(n) / fps
    y = 22.0 + speed * t
    u, v = project_3d(cfg.camera, 0 * y, y, 0 * y)
    _, v_top = project_3d(cfg.camera, 0 * y, y, 1.7 + 0 * y)
    w, _, _ = upright_size(cfg.camera, u, v, float(cfg.width.mean), 1.7)
    return {"track_id": np.ones(n, np.int64), "frame": np.arange(n), "t": t,
            "u": np.asarray(u, np.float64), "v": np.asarray(v, np.float64),
            "v_top": np.asarray(v_top, np.float64), "top_at_edge": np.zeros(n),
            "width_px": np.asarray(w, np.float64),
            "intensity": 20.0 + 5.0 * np.sin(2 * np.pi * pace * t) + rng.normal(0, 1.0, n)}


def test_count_verdicts_read_rule_56_only_where_asked():
    """count's `judge_tracks` on a walker whose I(k) beats at its stride frequency, 1.0 Hz at
    1.4 m/s: Pedestrian at 2.0 Hz (matched-stride) with `stride_peak`, Non-pedestrian
    (no-model-match) without it, count's default (its screen: PETS09 counted 27 -> 30)."""
    cfg, tracks = FAR, _tracks_table(1.0)
    on = judge_tracks(cfg, tracks, stride_peak=True)
    off = judge_tracks(cfg, tracks)
    assert VerdictOptions().stride_peak is False
    assert (on["verdict"][0], on["reason"][0]) == ("pedestrian", "matched-stride")
    assert float(on["pace_hz"][0]) == pytest.approx(2.0, abs=0.06)
    assert (off["verdict"][0], off["reason"][0]) == ("non-pedestrian", "no-model-match")


def test_the_batch_verbs_flag():
    """`--stride-peak` (the default) and `--no-stride-peak` reach the batch classifier's
    `SizeOptions`."""
    p = argparse.ArgumentParser()
    add_height_rules(p)
    assert height_rules(p.parse_args([])).stride_peak is True
    assert height_rules(p.parse_args(["--no-stride-peak"])).stride_peak is False
