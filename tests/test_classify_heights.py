"""`rhythmjax classify` judges stored tracks with rules 37 and 26 where they have top rows
(v_top, top_at_edge), as the tracker does, on every path (streamed, whole file, Dask's unit of
work), and the resume key holds the rules. Objects of known height in front of the paper's
camera, their top rows by the forward projection (3)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.io import read_table, write_table
from rhythmjax.io.stream import plan_partitions
from rhythmjax.model.camera_np import project_3d, upright_size
from rhythmjax.model.params import config_from_dict, config_to_dict
from rhythmjax.stream.classify import classify_partition, classify_source, run_key
from rhythmjax.track.options import SizeOptions


CONF = {"thresholds": {"range_max_m": 40.0}}  # the paper's camera; heads inside from 22 m on
CFG = config_from_dict(CONF)
FPS = 15.0


def _rows(tid: int, top_m: float, pace: float, n: int = 96, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FPS
    y = 22.0 + 1.3 * t
    u, v = project_3d(CFG.camera, 0 * y, y, 0 * y)
    _, v_top = project_3d(CFG.camera, 0 * y, y, top_m + 0 * y)
    w, _, _ = upright_size(CFG.camera, u, v, float(CFG.width.mean), 1.7)
    return {"track_id": np.full(n, tid), "frame": np.arange(n), "t": t, "u": np.asarray(u),
            "v": np.asarray(v), "width_px": np.asarray(w),
            "intensity": 20.0 + 5.0 * np.sin(2 * np.pi * pace * t) + rng.normal(0, 1.0, n),
            "v_top": np.asarray(v_top), "top_at_edge": np.zeros(n)}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A walker read at twice its pace (4.0 Hz, 1.7 m), a 0.6 m object at a walker's pace
    (2.0 Hz) and a walker at its pace; with and without the top-row columns."""
    d = tmp_path_factory.mktemp("heights")
    objs = [_rows(1, 1.7, 4.0), _rows(2, 0.6, 2.0, seed=1), _rows(3, 1.7, 2.0, seed=2)]
    cols = {k: np.concatenate([o[k] for o in objs]) for k in objs[0]}
    order = list(cols)
    write_table(d / "tops.parquet", cols, order)
    write_table(d / "plain.csv", cols, order[:7])
    conf = d / "conf.json"
    conf.write_text(json.dumps(config_to_dict(CFG)))
    return d, conf


RULES = ["matched-twice", "too-low", "matched"]  # tracks 1, 2, 3 with rules 37 and 26
PAPER = ["no-model-match", "matched", "matched"]  # ... without them


@pytest.mark.parametrize("path", ["streamed", "whole"])
def test_classify_judges_with_the_top_rows(files, tmp_path, path):
    d, conf = files
    extra = ["--whole-file"] if path == "whole" else []
    for name, flags, want in (("tops.parquet", [], RULES),
                              ("tops.parquet", ["--twice-pace-heights", "0",
                                                "--min-height-heights", "0"], PAPER),
                              ("plain.csv", [], PAPER)):
        out = tmp_path / f"{name}.{len(flags)}.csv"
        assert main(["classify", str(d / name), "-c", str(conf), "-o", str(out), "--quiet",
                     "--no-report", *extra, *flags]) == 0
        v = read_table(out, ["track_id", "verdict", "reason"])
        assert list(v["reason"]) == want, (name, flags)


def test_dask_unit_of_work_and_the_resume_key(files):
    """`classify_partition` (what each Dask worker runs) takes the rules too, and a rerun with
    other rules does not resume the parts of the first (its key differs)."""
    d, _ = files
    parts = plan_partitions([str(d / "tops.parquet")], 10**6)
    got = classify_partition(CFG, parts[0], size=SizeOptions())
    assert list(got["reason"]) == RULES
    assert list(classify_partition(CFG, parts[0])["reason"]) == PAPER
    key = {s: run_key(CFG, [str(d / "tops.parquet")], chunk=256, segment_rows=4096,
                      block_tracks=10, block_rows=10, size=s)
           for s in (None, SizeOptions(), SizeOptions(min_height_heights=0.4))}
    assert key[None]["heights"] is None
    assert key[SizeOptions()] != key[SizeOptions(min_height_heights=0.4)] != key[None]
    res = classify_source(CFG, str(d / "tops.parquet"), None, size=SizeOptions(), log=None)
    assert list(res["verdicts_table"]["reason"]) == RULES


def test_classify_refuses_a_negative_height(files, tmp_path, capsys):
    d, conf = files
    assert main(["classify", str(d / "tops.parquet"), "-c", str(conf), "-o",
                 str(tmp_path / "v.csv"), "--min-height-heights", "-1"]) == 2
    assert "--min-height-heights" in capsys.readouterr().err
    assert not (tmp_path / "v.csv").exists()
