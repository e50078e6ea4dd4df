"""benchmarks/study_tracker_gap.py: the same objects judged behind truth boxes and by the
tracker, paired scene by scene (hand-made runs)."""

from __future__ import annotations

import json
import os
import sys

import pytest


sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))

import study_tracker_gap as stg  # noqa: E402


def _run(tmp_path, name, objects_by_seed, source="synthetic"):
    path = tmp_path / name
    path.write_text(json.dumps({"sources": {source: {
        seed: {"objects": objs} for seed, objs in objects_by_seed.items()}}}))
    return str(path)


def _obj(scene, name, kind, verdict, classifiable=True):
    return {"scene": scene, "object": name, "kind": kind, "verdict": verdict,
            "classifiable": classifiable}


def test_pairs_match_objects_in_truth_order_and_skip_scenes_in_one_run(tmp_path):
    run = _run(tmp_path, "a.json", {"7": [
        _obj(0, "ped000", "pedestrian", "unclassified"),
        _obj(0, "dog001", "dog", "pedestrian", classifiable=False),
        _obj(1, "ped000", "pedestrian", "pedestrian")]})
    lateral = _run(tmp_path, "b.json", {"8": [_obj(0, "ped000", "pedestrian", "missed")]},
                   source="synthetic_lateral")
    boxes = {"own_7_0": [{"kind": "pedestrian", "verdict": "pedestrian", "reason": "matched"},
                         {"kind": "dog", "verdict": "non-pedestrian", "reason": "too-low"}],
             "own_8_0": [{"kind": "pedestrian", "verdict": "non-pedestrian", "reason": "no-peak"}],
             "own_9_0": [{"kind": "pedestrian", "verdict": "pedestrian"}]}  # not tracked: skipped
    recs = stg.pairs(boxes, stg.tracker_objects([run, lateral]))
    got = [(r["scene"], r["object"], r["kind"], r["classifiable"], r["tracker"], r["boxes"],
            r["boxes_reason"]) for r in recs]
    assert got == [
        ("7:0", "ped000", "pedestrian", True, "unclassified", "pedestrian", "matched"),
        ("7:0", "dog001", "dog", False, "pedestrian", "non-pedestrian", "too-low"),
        ("8:0", "ped000", "pedestrian", True, "missed", "non-pedestrian", "no-peak")]


def test_a_scene_whose_objects_differ_is_an_error(tmp_path):
    run = _run(tmp_path, "a.json", {"7": [_obj(0, "ped000", "pedestrian", "pedestrian")]})
    boxes = {"own_7_0": [{"kind": "bicycle", "verdict": "non-pedestrian"}]}
    with pytest.raises(SystemExit, match="own_7_0"):
        stg.pairs(boxes, stg.tracker_objects([run]))
    boxes = {"own_7_0": [{"kind": "pedestrian", "verdict": "pedestrian"}] * 2}
    with pytest.raises(SystemExit, match="1 tracked, 2 boxed"):
        stg.pairs(boxes, stg.tracker_objects([run]))


def test_main_prints_the_gap(tmp_path, capsys):
    run = _run(tmp_path, "a.json", {"7": [
        _obj(0, "ped000", "pedestrian", "unclassified"),
        _obj(0, "ped001", "pedestrian", "pedestrian")]})
    boxes = tmp_path / "boxes.json"
    boxes.write_text(json.dumps({"own": {"own_7_0": [
        {"kind": "pedestrian", "verdict": "pedestrian", "reason": "matched"},
        {"kind": "pedestrian", "verdict": "pedestrian", "reason": "matched-twice"}]}}))
    assert stg.main([str(boxes), run]) == 0
    out = capsys.readouterr().out
    assert "tracker 1/2, boxes 2/2" in out
    assert "7:0 ped000: tracker unclassified, boxes matched" in out
