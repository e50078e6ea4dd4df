"""Streaming classification (`io.stream`, `io.parts`, `stream.classify`): the same tracks, the
same errors and the same verdicts as the whole-file path, record batches cut inside tracks,
resumable parts, bounded memory."""

from __future__ import annotations

import os

import numpy as np
import pytest

from rhythmjax.io import BadInput, read_table, read_tracks, write_table
from rhythmjax.io.parts import parts_folder
from rhythmjax.io.stream import NotGrouped, Partition, iter_blocks, plan_partitions, read_blocks
from rhythmjax.model.params import Config, config_from_dict, config_to_dict
from rhythmjax.sim.tracks import make_tracks
from rhythmjax.stream.classify import classify_partition, classify_source, classify_whole


ORDER = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y"]
SMALL = dict(block_tracks=8, batch_rows=50)  # many blocks, record batches cut inside tracks
FIELDS = ("track_id", "frame", "t", "u", "v", "width_px", "intensity", "line", "label", "x", "y")


def _cols(seed=7, **kw):
    cols, _ = make_tracks(n_walkers=10, n_bicycles=3, n_dogs=3, n_cars=2, n_short=2, seed=seed,
                          **kw)
    return cols


def _shuffle_within_tracks(cols, seed=0):
    """Rows of each track in a random frame order; the tracks stay contiguous."""
    rng = np.random.default_rng(seed)
    tid = np.asarray(cols["track_id"]).astype(str)
    run = np.cumsum(np.r_[False, tid[1:] != tid[:-1]])
    order = np.lexsort((rng.random(len(tid)), run))
    return {k: np.asarray(v)[order] for k, v in cols.items()}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("stream")
    cols = _cols()
    out = {}
    for name, c in (("plain.csv", cols), ("plain.parquet", cols),
                    ("shuffled.csv", _shuffle_within_tracks(cols)),
                    ("shuffled.parquet", _shuffle_within_tracks(cols, 1))):
        write_table(d / name, c, ORDER)
        out[name] = str(d / name)
    nolabel = {k: v for k, v in _cols(seed=3).items() if k != "label"}
    write_table(d / "nolabel.csv", nolabel, ORDER[:7])
    out["nolabel.csv"] = str(d / "nolabel.csv")
    return out


def _same(a, b):
    if a.dtype == object or b.dtype == object:
        return a.shape == b.shape and bool(np.all(a.astype(str) == b.astype(str)))
    return np.array_equal(a, b, equal_nan=True)


# -- reading ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["plain.csv", "plain.parquet", "shuffled.csv",
                                  "shuffled.parquet"])
@pytest.mark.parametrize("batch_rows, block_tracks", [(7, 1), (50, 3), (1 << 16, 2048)])
def test_blocks_hold_the_rows_read_tracks_reads(files, name, batch_rows, block_tracks):
    whole = read_tracks(files[name], fps=15)
    blocks = list(read_blocks(files[name], fps=15, batch_rows=batch_rows,
                              block_tracks=block_tracks))
    for k in FIELDS:
        assert _same(getattr(whole, k), np.concatenate([getattr(b, k) for b in blocks])), k
    n = [len(b.ids) for b in blocks]
    assert sum(n) == len(whole.ids) and all(x == block_tracks for x in n[:-1])
    if name.startswith("shuffled"):
        assert blocks[0].notes and blocks[0].notes[0] == whole.notes[0]  # the same first row


def test_blocks_do_not_depend_on_the_record_batch_size(files):
    """What a resumed run relies on: the same blocks (so parts) whatever the batch size."""
    cut = [[len(b.lines) for _, b in iter_blocks(files["plain.csv"], batch_rows=r,
                                                 block_tracks=5, block_rows=300)]
           for r in (3, 64, 1 << 16)]
    assert cut[0] == cut[1] == cut[2] and len(cut[0]) > 3


HEADER = "track_id,frame,t,u,v,width_px,intensity,label\n"


def _rows(n_tracks=6, n=20, start=0):
    out = []
    for k in range(n_tracks):
        for f in range(n):
            out.append([k + start, f, round(f / 15, 4), 200 + f, 300, 20, 50, "pedestrian"])
    return out


def _csv(rows):
    return HEADER + "".join(",".join(str(x) for x in r) + "\n" for r in rows)


def _corrupt(i, col, value):
    rows = _rows()
    rows[i][col] = value
    return _csv(rows)


BAD = {
    "cell": _corrupt(77, 3, "1O2"),
    "empty_t": _corrupt(90, 2, ""),
    "inf_u": _corrupt(101, 3, "inf"),
    "neg_width": _corrupt(64, 5, "-3"),
    "label": _corrupt(88, 7, "horse"),
    "label_change": _corrupt(95, 7, "dog"),
    "dup_frame": _corrupt(70, 1, 9),
    "t_decreases": _corrupt(83, 2, "0.01"),
    "fields": _csv(_rows()).replace("\n4,3,", "\n4,3,0.2,1,\n4,99,", 1),
    "truncated": _csv(_rows())[:-12],
    "normalised": _csv(_rows()[:60] + [[9, f, f / 15, 0.5, 0.5, 2, 5, "dog"]
                                       for f in range(8)]),
    "ms": _csv([[r[0], r[1], round(r[1] * 66.667, 3), *r[3:]] for r in _rows()]),
    "no_column": _csv(_rows()).replace(",intensity", ",brightness", 1),
}


@pytest.mark.parametrize("case", sorted(BAD))
@pytest.mark.parametrize("fmt", [".csv", ".parquet"])
def test_bad_inputs_give_the_same_message(tmp_path, case, fmt):
    p = tmp_path / f"bad{fmt}"
    text = BAD[case]
    if fmt == ".parquet":
        if case in ("fields", "truncated", "cell"):
            pytest.skip("a CSV-only fault")
        c = tmp_path / "bad.csv"
        c.write_text(text)
        tab = read_table(c, types={"track_id": "id", "label": "str"})
        write_table(p, tab, list(tab))
    else:
        p.write_text(text)
    with pytest.raises(BadInput) as whole:
        read_tracks(p, fps=15)
    with pytest.raises(BadInput) as streamed:
        list(read_blocks(p, fps=15, batch_rows=16, block_tracks=2))
    assert str(streamed.value) == str(whole.value)


def test_a_track_that_comes_back_is_not_grouped(tmp_path):
    rows = _rows(3)
    rows = rows[:10] + rows[20:] + rows[10:20]  # track 0 again after tracks 1 and 2
    p = tmp_path / "ungrouped.csv"
    p.write_text(_csv(rows))
    with pytest.raises(NotGrouped, match=r"track 0: rows are not contiguous.*line 52"):
        list(read_blocks(p, batch_rows=8))
    with pytest.raises(NotGrouped):
        plan_partitions(p, 10)


def test_groups_by_length_class_long_tracks_alone(tmp_path):
    """100 tracks of 30 rows, 20 of 70, 3 of 1000 and 2 of 5000 (segment_rows 4096): each class
    (padded to 64, 128, 1024) apart, as joining would more than double a group's cells, the
    tracks over segment_rows alone; with chunk 200 the small classes join."""
    from rhythmjax.io.stream import by_length

    lengths = [30] * 50 + [1000] + [70] * 20 + [5000] + [30] * 50 + [1000, 5000, 1000]
    rows = [[k, f, round(f / 15, 4), 200, 300, 20, 50, "dog"]
            for k, n in enumerate(lengths) for f in range(n)]
    p = tmp_path / "lengths.csv"
    p.write_text(_csv(rows))
    tracks = read_tracks(p, fps=15)
    groups, order = by_length(tracks, chunk=8, segment_rows=4096, min_len=64)
    assert sorted(order) == list(range(len(lengths)))
    assert [i for g in groups for i in g.ids] == [tracks.ids[i] for i in order]
    assert [len(g.ids) for g in groups] == [100, 20, 3, 1, 1]
    assert [sorted({lengths[int(i)] for i in g.ids}) for g in groups] == \
        [[30], [70], [1000], [5000], [5000]]
    assert list(order[:50]) == list(range(50))  # file order within a group
    groups, _ = by_length(tracks, chunk=200, segment_rows=4096, min_len=64)
    assert [len(g.ids) for g in groups] == [123, 1, 1]


def test_partitions_cut_at_track_boundaries(files):
    whole = read_tracks(files["plain.parquet"], fps=15)
    for name in ("plain.csv", "plain.parquet"):
        parts = plan_partitions(files[name], 200, batch_rows=64)
        assert len(parts) > 5 and parts[0].row_start == 0
        assert all(a.row_stop == b.row_start for a, b in zip(parts, parts[1:], strict=False))
        ids = [i for part in parts for b in read_blocks(part, fps=15) for i in b.ids]
        assert ids == whole.ids
    with pytest.raises(ValueError):
        plan_partitions(files["plain.csv"], 0)
    assert Partition("a", 0, 1) == Partition("a", 0, 1)  # frozen, hashable, picklable


def test_parts_resume_start_over_and_assemble_in_order(tmp_path):
    from rhythmjax.io.parts import VerdictParts

    def cols(a, b):
        return {"track_id": np.asarray([f"t{i}" for i in range(a, b)], dtype=object),
                "x": np.arange(a, b, dtype=np.float32)}

    out, order = tmp_path / "v.parquet", ["track_id", "x"]
    first = VerdictParts(out, {"k": 1})
    assert first.open() is None and not os.path.exists(first.folder)
    first.write(cols(0, 3), order, {"tracks": 3})
    first.write(cols(3, 5), order, {"tracks": 2})
    again = VerdictParts(out, {"k": 1})
    msg = again.open()
    assert "resuming" in msg and "2 part(s), 5 tracks" in msg and again.resumed == 2
    again.write(cols(5, 9), order, {"tracks": 4})
    again.assemble()
    v = read_table(out, types={"track_id": "id"})
    assert list(v["track_id"]) == [f"t{i}" for i in range(9)] and list(v["x"]) == list(range(9))
    assert not os.path.exists(again.folder)
    VerdictParts(out, {"k": 1}).write(cols(0, 1), order, {"tracks": 1})
    other = VerdictParts(out, {"k": 2})
    assert "changed" in other.open() and other.done == []
    assert [n for n in os.listdir(other.folder) if n.startswith("part-")] == []
    other.write(cols(0, 1), order, {"tracks": 1})
    fresh = VerdictParts(out, {"k": 2})
    assert "--no-resume" in fresh.open(resume=False) and fresh.done == []
    d = tmp_path / "ds"
    d.mkdir()
    (d / "notes.txt").write_text("mine")
    with pytest.raises(BadInput, match="holds other files"):
        VerdictParts(f"{d}/", {}, dataset=True).open()


# -- classifying -----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cfg():
    return Config()


def _table(path):
    return read_table(path, types={"track_id": "id", "label": "str"})


@pytest.mark.parametrize("name, segment_rows", [("plain.csv", 4096), ("shuffled.parquet", 96),
                                                ("nolabel.csv", 4096)])
def test_streamed_verdicts_equal_the_whole_file_path(files, tmp_path, cfg, name, segment_rows):
    """Tracks of 22-108 rows; with segment_rows 96 the longer ones take the long-track path."""
    a, b = tmp_path / "whole.csv", tmp_path / "streamed.csv"
    sw = classify_whole(cfg, files[name], a, chunk=8, segment_rows=segment_rows)
    ss = classify_source(cfg, files[name], b, chunk=8, segment_rows=segment_rows, log=None,
                         **SMALL)
    assert a.read_bytes() == b.read_bytes()
    assert ss["parts"] > 2 and ss["streamed"]
    for k in ("n_tracks", "verdicts", "reasons", "notes"):
        assert ss[k] == sw[k], k
    assert ("label" in _table(b)) == (name != "nolabel.csv")
    assert not os.path.exists(parts_folder(b))
    part = classify_partition(cfg, plan_partitions(files[name], 1 << 20)[0], chunk=8,
                              segment_rows=segment_rows, block_tracks=5)
    verdicts = _table(a)
    for k in ("track_id", "verdict", "reason", "pace_hz", "n_samples"):
        got = np.asarray(part[k])
        assert _same(got, np.asarray(verdicts[k]).astype(got.dtype)), k  # CSV: float32 repr


def test_parquet_output_and_dataset_folder(files, tmp_path, cfg):
    import pyarrow.dataset as ds

    f = tmp_path / "v.parquet"
    classify_source(cfg, files["plain.parquet"], f, chunk=8, log=None, **SMALL)
    d = tmp_path / "verdicts"
    s = classify_source(cfg, files["plain.parquet"], str(d) + os.sep, chunk=8, log=None,
                        **SMALL)
    one = _table(f)
    parts = ds.dataset(d, format="parquet").to_table().to_pydict()
    assert s["parts"] == len([n for n in os.listdir(d) if n.startswith("part-")]) > 2
    assert list(parts["track_id"]) == list(one["track_id"])
    assert _same(np.asarray(parts["pace_hz"], float), np.asarray(one["pace_hz"]))


def test_not_grouped_file_falls_back_to_the_whole_file(tmp_path, cfg):
    cols = _cols(seed=5)
    tid = np.asarray(cols["track_id"]).astype(str)
    first = np.flatnonzero(tid == tid[0])
    order = np.r_[first[:30], np.flatnonzero(tid != tid[0]), first[30:]]
    p = tmp_path / "ungrouped.csv"
    write_table(p, {k: np.asarray(v)[order] for k, v in cols.items()}, ORDER)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    classify_whole(cfg, p, a, chunk=8)
    s = classify_source(cfg, p, b, chunk=8, log=None, **SMALL)
    assert a.read_bytes() == b.read_bytes()
    assert not s["streamed"] and "read the whole file into memory" in s["notes"][0]
    assert not os.path.exists(parts_folder(b))


class Stop(KeyboardInterrupt):
    pass


def _interrupt_after(n):
    seen = []

    def on_part(entry):
        seen.append(entry["file"])
        if len(seen) == n:
            raise Stop
    return on_part, seen


def test_an_interrupted_run_resumes_without_redoing_parts(files, tmp_path, cfg):
    out = tmp_path / "v.csv"
    out.write_text("previous\n")
    stop, first = _interrupt_after(2)
    with pytest.raises(Stop):
        classify_source(cfg, files["plain.csv"], out, chunk=8, log=None, on_part=stop, **SMALL)
    assert out.read_text() == "previous\n"  # the old output whole
    folder = parts_folder(out)
    done = sorted(n for n in os.listdir(folder) if n.startswith("part-"))
    assert done == first == ["part-000000.parquet", "part-000001.parquet"]
    mtimes = {n: os.stat(os.path.join(folder, n)).st_mtime_ns for n in done}
    said, again = [], []

    def on_part(entry):
        again.append(entry["file"])
        assert {n: os.stat(os.path.join(folder, n)).st_mtime_ns for n in done} == mtimes

    s = classify_source(cfg, files["plain.csv"], out, chunk=8, log=said.append,
                        on_part=on_part, **SMALL)
    assert "resuming" in said[0] and "2 part(s)" in said[0]
    assert again[0] == "part-000002.parquet" and s["resumed_parts"] == 2
    assert not os.path.exists(folder)
    ref = tmp_path / "ref.csv"
    classify_whole(cfg, files["plain.csv"], ref, chunk=8)
    assert out.read_bytes() == ref.read_bytes()


def test_a_changed_config_or_input_starts_over(files, tmp_path, cfg):
    out = tmp_path / "v.csv"
    stop, _ = _interrupt_after(1)
    with pytest.raises(Stop):
        classify_source(cfg, files["plain.csv"], out, chunk=8, log=None, on_part=stop, **SMALL)
    d = config_to_dict(cfg)
    d["thresholds"]["p_thr"] = float(d["thresholds"]["p_thr"]) * 1.01
    said = []
    s = classify_source(config_from_dict(d), files["plain.csv"], out, chunk=8,
                        log=said.append, **SMALL)
    assert "changed" in said[0] and "starting over" in said[0] and s["resumed_parts"] == 0
    assert os.path.isfile(out) and not os.path.exists(parts_folder(out))


def test_an_interrupt_before_any_part_leaves_nothing(files, tmp_path, cfg, monkeypatch):
    import rhythmjax.stream.classify as sc

    def interrupted(*a, **k):
        raise Stop

    monkeypatch.setattr(sc, "classify_prepared", interrupted)
    with pytest.raises(Stop):
        classify_source(cfg, files["plain.csv"], tmp_path / "v.csv", chunk=8, log=None,
                        **SMALL)
    assert os.listdir(tmp_path) == []


def test_memory_is_bounded_by_blocks_not_the_file(files, tmp_path, cfg):
    s = classify_source(cfg, files["plain.parquet"], None, chunk=8, log=None, prefetch=1,
                        block_tracks=3, batch_rows=50)
    assert s["n_tracks"] == 20 and s["parts"] == 7
    # blocks: one in the reader's hands, one queued, KERNEL_THREADS (2) in the kernels
    assert 0 < s["peak_tracks_in_memory"] <= s["memory_bound_tracks"] == 4 * 3
    one = classify_source(cfg, files["plain.parquet"], None, chunk=8, log=None, prefetch=1,
                          block_tracks=3, batch_rows=50, kernel_threads=1)
    assert 0 < one["peak_tracks_in_memory"] <= one["memory_bound_tracks"] == 3 * 3
    for k in s["verdicts_table"]:
        np.testing.assert_array_equal(s["verdicts_table"][k], one["verdicts_table"][k])
    assert set(s["timing"]) >= {"read_s", "prepare_s", "kernel_s", "write_s", "total_s"}
    assert len(s["verdicts_table"]["track_id"]) == 20


def test_a_folder_of_files_is_one_source(files, tmp_path, cfg):
    """A Hive-style folder of Parquet files reads as the files in path order; a track may not
    go on from one file into the next."""
    cols = read_table(files["plain.parquet"], types={"track_id": "id", "label": "str"})
    tid = np.asarray(cols["track_id"]).astype(str)
    cut = int(np.flatnonzero(tid != tid[0])[0]) + 200
    cut = int(np.flatnonzero(tid[cut:] != tid[cut])[0]) + cut  # at a track boundary
    d = tmp_path / "tracks"
    for k, (a, b) in enumerate([(0, cut), (cut, len(tid))]):
        (d / f"part={k}").mkdir(parents=True)
        write_table(d / f"part={k}" / "t.parquet", {n: v[a:b] for n, v in cols.items()}, ORDER)
    one, many = tmp_path / "one.csv", tmp_path / "many.csv"
    classify_source(cfg, files["plain.parquet"], one, chunk=8, log=None, **SMALL)
    s = classify_source(cfg, d, many, chunk=8, log=None, **SMALL)
    assert one.read_bytes() == many.read_bytes() and s["n_tracks"] == 20
    mid = cut - 10  # now the track at the cut goes on into the second file
    for k, (a, b) in enumerate([(0, mid), (mid, len(tid))]):
        write_table(d / f"part={k}" / "t.parquet", {n: v[a:b] for n, v in cols.items()}, ORDER)
    with pytest.raises(BadInput, match="not contiguous"):
        classify_source(cfg, d, many, chunk=8, log=None, **SMALL)
    assert not os.path.exists(parts_folder(many))
