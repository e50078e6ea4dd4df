"""benchmarks/paired_count.py: the paired change in per-clip count errors against hand-worked
figures, its bootstrap interval against a NumPy loop drawing the same clips, and mismatched runs
refused."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest


BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import paired_count as pc  # noqa: E402


def _run(counted, true, others=None, source="count:1"):
    others = others or [0] * len(true)
    return {"changes": {}, "clothing": "any", "focal_px": 0.0,
            source: {"count": {}, "clips": [{"counted": c, "true": t, "others_counted": o}
                                           for c, t, o in zip(counted, true, others)]}}


def test_change_by_hand():
    true = [4, 6, 5, 5]
    before = _run([3, 6, 7, 5], true, [0, 1, 0, 0])  # |e| 1, 0, 2, 0: 3 of 20
    after = _run([4, 5, 5, 5], true, [0, 0, 0, 1])   # |e| 0, 1, 0, 0: 1 of 20
    r = pc.paired_change(pc.paired_arrays(before, after, "t"), resamples=2000)
    assert r["before"] == pytest.approx(0.15, abs=1e-12)
    assert r["after"] == pytest.approx(0.05, abs=1e-12)
    assert r["delta"] == pytest.approx(-0.10, abs=1e-12)
    assert (r["clips_better"], r["clips_worse"]) == (2, 1)
    assert (r["others_before"], r["others_after"]) == (1, 1)
    assert r["lo"] <= r["delta"] <= r["hi"]


def test_interval_against_a_loop():
    rng = np.random.default_rng(3)
    true = rng.integers(2, 9, 30)
    before = _run(list(true + rng.integers(-3, 3, 30)), list(true))
    after = _run(list(true + rng.integers(-2, 2, 30)), list(true))
    cols = pc.paired_arrays(before, after, "t")
    r = pc.paired_change(cols, resamples=500, seed=7)
    # the same draws, one resample at a time in float64
    draw = np.random.default_rng(7).integers(0, 30, size=(500, 30))
    d = []
    for k in range(500):
        i = draw[k]
        d.append((cols["err_b"][i].sum() - cols["err_a"][i].sum()) / cols["true"][i].sum())
    lo, hi = np.percentile(d, [2.5, 97.5])
    assert r["lo"] == pytest.approx(lo, abs=1e-12) and r["hi"] == pytest.approx(hi, abs=1e-12)


def test_equal_runs_give_a_zero_interval():
    run = _run([3, 6, 7], [4, 6, 5])
    r = pc.paired_change(pc.paired_arrays(run, run, "t"), resamples=200)
    assert (r["delta"], r["lo"], r["hi"]) == (0.0, 0.0, 0.0)


def test_mismatched_runs_are_refused(tmp_path, capsys):
    with pytest.raises(SystemExit, match="sources differ"):
        pc.paired_arrays(_run([1], [1]), _run([1], [1], source="count:2"), "x")
    with pytest.raises(SystemExit, match="clips differ"):
        pc.paired_arrays(_run([1], [1]), _run([1], [2]), "x")
    with pytest.raises(SystemExit, match="2 clips against 1"):
        pc.paired_arrays(_run([1, 1], [1, 1]), _run([1], [1]), "x")
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(_run([3, 6], [4, 6])))
    b.write_text(json.dumps(_run([4, 6], [4, 6])))
    assert pc.main([str(a)]) == 2
    assert pc.main([str(a), str(b), str(a), str(b), "--resamples", "100"]) == 0
    out = capsys.readouterr().out
    assert "| pooled | 4 | 10.0 % | 0.0 % | -10.0" in out
