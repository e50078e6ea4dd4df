"""benchmarks/eval_all.py's scoring (benchmarks/eval_all_score.py): config overrides, the table's
columns against hand-counted figures, the dev clips' truth files against eq. (3) evaluated here,
and the command line's bad input (exit 2)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest


BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import eval_all  # noqa: E402
import eval_all_score as es  # noqa: E402


def test_parse_and_apply_set():
    sets = es.parse_set(["thresholds.harmonic_max_ratio=0", "noise.r_std_px=[3, 6]",
                         "camera.name=abc"])
    assert sets == [("thresholds", "harmonic_max_ratio", 0), ("noise", "r_std_px", [3, 6]),
                    ("camera", "name", "abc")]
    base = {"thresholds": {"window_s": 2.0}}
    out = es.apply_set(base, sets)
    assert out["thresholds"] == {"window_s": 2.0, "harmonic_max_ratio": 0}
    assert out["noise"] == {"r_std_px": [3, 6]}
    assert base == {"thresholds": {"window_s": 2.0}}  # not mutated
    for bad in ("thresholds=0", "harmonic_max_ratio", ".x=1", "a.=1"):
        with pytest.raises(ValueError, match="SECTION.KEY=VALUE"):
            es.parse_set([bad])


def _row(kind, verdict, pace=math.nan, pace_true=2.0, stride=math.nan, stride_true=0.7,
         classifiable=True):
    return {"kind": kind, "verdict": verdict, "pace": pace, "pace_true": pace_true,
            "stride": stride, "stride_true": stride_true, "classifiable": classifiable}


def test_verdict_row_hand_counted():
    rows = [_row("pedestrian", "pedestrian", 2.01, 2.0, 0.72, 0.70),
            _row("pedestrian", "pedestrian", 1.95, 2.0, 0.66, 0.70),
            _row("pedestrian", "pedestrian", 2.10, 2.1, 0.80, 0.81, classifiable=False),
            _row("pedestrian", "non-pedestrian", 1.0, 2.0, 2.0, 0.7),
            _row("pedestrian", "unclassified"),
            _row("pedestrian", "missed", classifiable=False),
            _row("bicycle", "pedestrian"), _row("dog", "non-pedestrian"),
            _row("dog", "unclassified"), _row("car", "missed")]
    r = es.verdict_row(rows)
    assert (r["walkers"], r["walkers_judged"], r["walkers_pedestrian"]) == (6, 4, 3)
    assert (r["walkers_classifiable"], r["classifiable_pedestrian"]) == (4, 2)
    assert r["rate_judged"] == pytest.approx(0.75, abs=1e-12)
    assert r["rate_classifiable"] == pytest.approx(0.5, abs=1e-12)
    assert (r["others"], r["others_judged"], r["others_pedestrian"]) == (4, 2, 1)
    # pace errors 0.01, 0.05, 0.00 -> mean 0.02; step errors 2, 4, 1 cm -> median 2 cm
    assert r["pace_mae_hz"] == pytest.approx(0.02, abs=1e-12)
    assert r["step_median_err_cm"] == pytest.approx(2.0, abs=1e-9)
    line = es.table_line("x", r, None)
    assert "3/4 (75 %)" in line and "2/4 (50 %)" in line and "1/4 (/2)" in line
    assert "0.020" in line and "| 2.0 |" in line


def test_verdict_row_empty_is_nan():
    r = es.verdict_row([_row("dog", "missed")])
    assert r["walkers"] == 0 and math.isnan(r["rate_judged"]) and math.isnan(r["pace_mae_hz"])
    assert es.table_line("x", r, None).startswith("| x | - | - | 0/1 (/0) | - | - |")


def test_count_row_sums_per_clip_errors():
    clips = [{"counted": 5, "true": 4, "mota": 0.5, "idf1": 0.6, "others_counted": 1},
             {"counted": 4, "true": 6, "mota": 0.3, "idf1": math.nan},
             {"counted": 8, "true": 8, "mota": 0.1, "idf1": 0.4}]
    c = es.count_row(clips)
    assert (c["counted"], c["true"], c["others_counted"]) == (17, 18, 1)
    assert c["count_err_sum"] == pytest.approx(3 / 18, abs=1e-12)  # |+1| + |-2| + 0
    assert c["mota"] == pytest.approx(0.3, abs=1e-12)
    assert c["idf1"] == pytest.approx(0.5, abs=1e-12)  # the clip without IDF1 left out
    assert "17/18 (16.7 %)" in es.table_line("c", None, c)
    assert "distinct" not in c  # not every clip has the bound
    for clip, d in zip(clips, (4, 5, 7)):
        clip["distinct"] = d
    c = es.count_row(clips)
    assert c["distinct"] == 16
    assert c["distinct_err_sum"] == pytest.approx(2 / 18, abs=1e-12)  # 0 + |-1| + |-1|
    assert "range_holds" not in c  # no clip has counts.json's range
    for clip, (lo, hi) in zip(clips, ((4, 4), (1, 5), (8, 12))):
        clip["counts"] = {"walkers_low": lo, "walkers_high": hi}
    c = es.count_row(clips)  # true 4 in 4..4, 6 above 1..5, 8 in 8..12
    assert (c["range_holds"], c["true_below_range"], c["true_above_range"], c["clips"]) == \
        (2, 0, 1, 3)
    clips[2]["counts"] = {"walkers_low": 9, "walkers_high": 12}
    assert es.count_row(clips)["true_below_range"] == 1


def test_read_gt(tmp_path):
    p = tmp_path / "gt.txt"
    p.write_text("37,1,0.00,98.06,0.61,70.78,1,1,0.0014\n5,9,10.5,20,3,4,1,4,1.0\n")
    cols, kinds = es.read_gt(p)
    assert cols["frame"].tolist() == [37, 5] and cols["id"].tolist() == [1, 9]
    np.testing.assert_allclose(cols["bb_top"], [98.06, 20.0], atol=0)
    assert kinds == {1: "pedestrian", 9: "car"}


def _eq3(cam, x, y, z=0.0):
    """The rhythm paper's eq. (3) written out here (the dev README's form)."""
    th = math.radians(cam["theta_deg"])
    h = cam["h_m"] - z
    den = cam["f_m"] + y * math.cos(th) + h * math.sin(th)
    u = cam["uc_px"] + cam["a_px_per_m"] * cam["f_m"] * x / den
    v = cam["vc_px"] - cam["b_px_per_m"] * cam["f_m"] * (y * math.sin(th) - h * math.cos(th)) / den
    return u, v


def test_dev_truth_against_eq3():
    path = eval_all.DEV_ROOT / "dev_walk_01.json"
    if not path.is_file():
        pytest.skip("dev clips absent")
    truth = json.loads(path.read_text())
    objs = eval_all.dev_truth(truth)
    assert len(objs) == 1 and objs[0].kind == "pedestrian" and objs[0].classifiable
    o, tr = objs[0], truth["objects"][0]["track"]
    assert len(o.u) == truth["n_frames"]
    cam = truth["camera"]
    for k in (0, len(tr["frame"]) // 2, len(tr["frame"]) - 1):
        u, v = _eq3(cam, tr["x"][k], tr["y"][k])
        f = tr["frame"][k]
        assert abs(o.u[f] - u) < 1e-6 and abs(o.v[f] - v) < 1e-6
    assert o.visible.sum() == sum(1 for a, b in zip(tr["in_image"], tr["visible_frac"])
                                  if a and b > 0)
    cfg = eval_all.dev_camera(truth)["camera"]
    assert cfg["uc_px"] == 255.5 and cfg["fps"] == 15.0 and cfg["image_width_px"] == 512


def test_cli_bad_input_exit_2(capsys):
    assert eval_all.main(["--set", "harmonic_max_ratio"]) == 2
    assert "--set" in capsys.readouterr().err
    assert eval_all.main(["--only", "nowhere"]) == 2
    assert "nowhere" in capsys.readouterr().err


def test_pets_boxes_row_guarded(monkeypatch):
    monkeypatch.setattr(eval_all, "has_rhythm_verb", lambda: False)  # the verb absent
    r = eval_all.run_pets_boxes([], True, lambda s: None)
    assert r == {"skipped": "not yet (rhythmjax rhythm --boxes absent)"}


def test_ucsd_and_casia_rows():
    u = es.ucsd_row({"anomaly": {"non-pedestrian": 1, "unclassified": 1, "pedestrian": 1},
                     "other": {"pedestrian": 9, "unclassified": 9, "non-pedestrian": 5}})
    assert (u["others"], u["others_judged"], u["others_pedestrian"]) == (3, 2, 1)
    assert (u["walkers_pedestrian"], u["walkers_judged"]) == (9, 14)
    c = es.casia_row({"001-nm-01-090": "pedestrian", "001-nm-05-090": "non-pedestrian",
                      "001-bkgrd-090": "missed", "002-nm-01-090": "unclassified"})
    assert (c["walkers"], c["walkers_judged"], c["walkers_pedestrian"]) == (3, 2, 1)
