"""benchmarks/diag_count_width_gate.py and benchmarks/paired_dumps.py: the two offline rules on
unjudged tracks against hand-made verdicts, the per-clip errors against a clip worked by hand,
the slowest walking speed against Table 1 by hand, and mismatched dumps refused."""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np
import pytest


BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import diag_count_width_gate as gate  # noqa: E402
import paired_dumps as pdumps  # noqa: E402


def _verdicts():
    # tracks 1-5: judged pedestrian (wide, slow), unclassified inside the gate and fast,
    # unclassified outside the gate and fast, unclassified inside and slow, non-pedestrian
    return {"track_id": np.arange(1, 6),
            "verdict": np.array(["pedestrian", "unclassified", "unclassified", "unclassified",
                                 "non-pedestrian"], dtype=object),
            "counted": np.array([True, True, True, True, False]),
            "width_ok": np.array([False, True, False, True, True]),
            "track_speed_mps": np.array([0.1, 1.3, 1.2, 0.3, 1.0])}


def test_width_rule_drops_only_unjudged_tracks_outside_the_gate(monkeypatch):
    monkeypatch.setattr(gate, "RULE", "width")
    assert gate.counted_with_gate(_verdicts()).tolist() == [True, True, False, True, False]


def test_slow_rule_drops_only_unjudged_tracks_below_the_slowest_walk(monkeypatch):
    monkeypatch.setattr(gate, "RULE", "slow")
    v = _verdicts()
    assert gate.counted_with_gate(v).tolist() == [True, True, True, False, False]
    v["track_speed_mps"][3] = np.nan  # no speed (span under 0.5 s): counted as before
    assert gate.counted_with_gate(v).tolist() == [True, True, True, True, False]


def test_slowest_walk_by_hand():
    from rhythmjax.model.params import config_from_dict

    c = config_from_dict({})
    w, k = c.walking, float(c.thresholds.k_sigma3)
    by_hand = (float(w.pace_mean) - k * float(w.pace_std)) * \
        (float(w.stride_mean) - k * float(w.stride_std))
    assert gate.walking_bottom_speed() == pytest.approx(by_hand, rel=1e-12)
    # Table 1: (2.05 - 3 x 0.183) x (0.72 - 3 x 0.09) = 1.501 x 0.45 = 0.6755 m/s
    assert by_hand == pytest.approx(0.6755, abs=0.001)


def _box(f, i, x):
    return {"frame": f, "id": i, "bb_left": x, "bb_top": 10.0, "bb_width": 10.0,
            "bb_height": 30.0}


def _table(rows):
    return {k: np.asarray([r[k] for r in rows]) for k in rows[0]}


def _clip(counted):
    # truth: walker 1 at x 0, dog 2 at x 50; tracks: 1 on the walker, 2 on the dog, 3 on
    # nothing (x 100); frames 1-3
    truth = _table([_box(f, i, x) for f in (1, 2, 3) for i, x in ((1, 0.0), (2, 50.0))])
    mot = _table([_box(f, i, x) for f in (1, 2, 3) for i, x in ((1, 0.0), (2, 50.0),
                                                                 (3, 100.0))])
    v = _verdicts()
    v = {k: x[:3] for k, x in v.items()}
    v["counted"] = np.asarray(counted, bool)
    return {"clip": "c", "truth": truth, "mot": mot, "offset": 0, "true": 1,
            "kinds": {1: "pedestrian", 2: "dog"}, "verdicts": v}


def test_clip_errors_by_hand():
    row = _clip([True, True, True])
    # 3 counted for 1 walker: |error| 2; one on the dog, one on nothing
    assert gate.clip_errors(row, np.array([True, True, True])) == (2, 1, 1)
    assert gate.clip_errors(row, np.array([True, False, False])) == (0, 0, 0)


def test_paired_dumps_by_hand_and_mismatch_refused(tmp_path):
    before, after = [_clip([True, True, True])], [_clip([True, False, False])]
    cols, nobody = pdumps.paired_columns(before, after, "t")
    assert cols["err_a"].tolist() == [2.0] and cols["err_b"].tolist() == [0.0]
    assert (cols["oth_a"].tolist(), cols["oth_b"].tolist()) == ([1.0], [0.0])
    assert nobody == [1, 0]
    other = [dict(after[0], clip="d")]
    with pytest.raises(SystemExit, match="different clips"):
        pdumps.paired_columns(before, other, "t")
    a, b = tmp_path / "a.pkl", tmp_path / "b.pkl"
    a.write_bytes(pickle.dumps(before))
    b.write_bytes(pickle.dumps(after))
    assert pdumps.main([str(a), str(b)]) == 0
    assert pdumps.main([str(a)]) == 2
