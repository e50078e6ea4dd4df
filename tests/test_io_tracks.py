"""Tracks files: every bad input of RELIABILITY.md section 3 (items 17-30) made in tmp_path, and
the padded batch of `to_batch` checked number by number."""

import re

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from rhythmjax.io import BadInput, read_footprints, read_tracks, to_batch, write_table


HEADER = "track_id,frame,t,u,v,width_px,intensity"
FPS = 15.0


def row(tid, frame, *, t=None, u=100.0, v=200.0, w=20.0, i=500.0) -> str:
    t = frame / FPS if t is None else t
    return f"{tid},{frame},{t!r},{u},{v},{w},{i}"


def track_rows(tid, frames) -> list[str]:
    return [row(tid, f, u=100.0 + f, v=200.0 + f) for f in frames]


def write(tmp_path, lines, name="tracks.csv", header=HEADER, end="\n"):
    p = tmp_path / name
    p.write_text("\n".join([header, *lines]) + end, encoding="utf-8")
    return p


def bad(msg: str):
    return pytest.raises(BadInput, match=re.escape(msg))


# -- item 17-20: the file as a whole ---------------------------------------------------------
@pytest.mark.parametrize("name", ["tracks.xlsx", "tracks.txt", "tracks"])
def test_unsupported_extension(tmp_path, name):
    p = tmp_path / name
    p.write_text(HEADER + "\n")
    shown = name[name.rfind("."):] if "." in name else "(no extension)"
    with bad(f"{name}: unsupported table format '{shown}' (use .csv or .parquet)"):
        read_tracks(p)


def test_missing_file_and_directory(tmp_path):
    with bad("nope.csv: no such file"):
        read_tracks(tmp_path / "nope.csv")
    (tmp_path / "dir.csv").mkdir()
    with bad("dir.csv: is a directory"):
        read_tracks(tmp_path / "dir.csv")


@pytest.mark.parametrize("content", [b"", b"\n\n", b"   \r\n"])
def test_empty_file(tmp_path, content):
    p = tmp_path / "tracks.csv"
    p.write_bytes(content)
    with bad("tracks.csv: empty file (no header)"):
        read_tracks(p)


@pytest.mark.parametrize("end", ["\n", ""])
def test_header_only_is_zero_tracks(tmp_path, end):
    tr = read_tracks(write(tmp_path, [], end=end))
    assert len(tr) == 0 and tr.ids == []
    b = to_batch(tr, max_gap_frames=5, min_len=64)
    assert b.z.shape == (0, 64, 2) and b.present.shape == (0, 64) and b.ids == []


def test_missing_column(tmp_path):
    p = write(tmp_path, [row(1, 0)[: row(1, 0).rfind(",")]],
              header="track_id,frame,t,u,v,width_px")
    with bad("tracks.csv: missing column 'intensity' (found: track_id, frame, t, u, v, width_px)"):
        read_tracks(p)


def test_missing_column_case_hint_and_extra_columns_ignored(tmp_path):
    p = write(tmp_path, [row(1, 0)], header=HEADER.replace(",u,", ",U,"))
    with bad("missing column 'u'") as e:
        read_tracks(p)
    assert "'U' differs only in case" in str(e.value)
    p = write(tmp_path, [row(1, 0) + ",whatever"], header=HEADER + ",comment")
    assert read_tracks(p).u[0] == 100.0


@pytest.mark.parametrize(("sep", "word"), [(";", "';'"), ("\t", "tab")])
def test_wrong_delimiter(tmp_path, sep, word):
    p = write(tmp_path, [row(1, 0).replace(",", sep)], header=HEADER.replace(",", sep))
    with bad(f"tracks.csv line 1: 1 column named 'track_id{sep}frame".replace("\t", "\\t")) as e:
        read_tracks(p)
    assert f"the file looks {word}-separated" in str(e.value)


def test_duplicate_header_column(tmp_path):
    p = write(tmp_path, [row(1, 0) + ",1"], header=HEADER + ",u")
    with bad("tracks.csv line 1: column 'u' appears twice in the header"):
        read_tracks(p)


# -- items 21-22: field counts -----------------------------------------------------------------
def test_extra_field_on_first_data_row(tmp_path):
    p = write(tmp_path, [row(1, 0) + ",9", *track_rows(1, range(1, 6))])
    with bad("tracks.csv line 2: expected 7 fields, saw 8") as e:
        read_tracks(p)
    assert e.value.line == 2


def test_extra_field_in_the_middle_lists_other_bad_lines(tmp_path):
    lines = track_rows(1, range(10))
    lines[5] += ",9"  # line 7
    lines[8] += ",9,9"  # line 10
    with bad("tracks.csv line 7: expected 7 fields, saw 8; 2 such rows, also line(s) 10"):
        read_tracks(write(tmp_path, lines))


@pytest.mark.parametrize("end", ["\n", "", "\n\n"])
def test_truncated_last_row(tmp_path, end):
    lines = track_rows(1, range(6))
    lines[-1] = ",".join(lines[-1].split(",")[:4])  # line 7 cut after 4 fields
    with bad("tracks.csv line 7: expected 7 fields, saw 4 (file truncated?)"):
        read_tracks(write(tmp_path, lines, end=end))


def test_short_row_in_the_middle_has_no_truncation_hint(tmp_path):
    lines = track_rows(1, range(6))
    lines[2] = ",".join(lines[2].split(",")[:5])
    with pytest.raises(BadInput, match=r"line 4: expected 7 fields, saw 5$"):
        read_tracks(write(tmp_path, lines))


# -- items 23-25: cells ------------------------------------------------------------------------
def test_text_in_numeric_column(tmp_path):
    lines = track_rows(1, range(6))
    lines[2] = row(1, 2, u="1O2")  # line 4
    with bad("tracks.csv line 4, column 'u': '1O2' is not a number") as e:
        read_tracks(write(tmp_path, lines))
    assert (e.value.line, e.value.column) == (4, "u")


def test_first_bad_cell_is_reported_by_line_then_column(tmp_path):
    lines = track_rows(1, range(8))
    lines[5] = row(1, 5, u="abc")  # line 7
    lines[3] = row(1, 3, i="x1")  # line 5, a later column but an earlier line
    with bad("tracks.csv line 5, column 'intensity': 'x1' is not a number"):
        read_tracks(write(tmp_path, lines))


@pytest.mark.parametrize("col", ["u", "v", "width_px", "intensity"])
@pytest.mark.parametrize("value", ["inf", "-inf", "1e308", "-3e12"])
def test_non_finite_or_absurd_measurement(tmp_path, col, value):
    lines = track_rows(1, range(6))
    kw = {"u": "u", "v": "v", "width_px": "w", "intensity": "i"}[col]
    lines[3] = row(1, 3, **{kw: value})  # line 5
    with bad(f"tracks.csv line 5, column '{col}': ") as e:
        read_tracks(write(tmp_path, lines))
    assert str(e.value).endswith("leave the cell empty for a missing measurement")
    assert (e.value.line, e.value.column) == (5, col)


def test_empty_measurements_are_missing_not_errors(tmp_path):
    lines = track_rows(1, range(6))
    lines[2] = row(1, 2, u="", v="", w="", i="")
    lines[3] = row(1, 3, u="NaN", v="nan")
    tr = read_tracks(write(tmp_path, lines))
    assert np.isnan([tr.u[2], tr.v[2], tr.width_px[2], tr.intensity[2], tr.u[3]]).all()
    assert np.isfinite(tr.u[[0, 1, 4, 5]]).all()


@pytest.mark.parametrize(("line", "col", "msg"), [
    ("  ,3,0.2,1,1,1,1", "track_id", "empty cell: a value is required in every row"),
    ("1,,0.2,1,1,1,1", "frame", "empty cell: a value is required in every row"),
    ("1,3,,1,1,1,1", "t", "empty cell: a value is required in every row"),
    ("1,3,NaN,1,1,1,1", "t", "'NaN': a value is required in every row"),
    ("1,3,inf,1,1,1,1", "t", "inf is not a finite time (s)"),
    ("1,3.5,0.2,1,1,1,1", "frame", "'3.5' is not an integer"),
    ("1,x3,0.2,1,1,1,1", "frame", "'x3' is not a number"),
])
def test_bad_key_cells(tmp_path, line, col, msg):
    lines = track_rows(1, range(3)) + [line] + track_rows(1, range(4, 7))
    with bad(f"tracks.csv line 5, column '{col}': {msg}"):
        read_tracks(write(tmp_path, lines))


def test_integral_float_frames_and_string_ids_keep_their_text(tmp_path):
    lines = [row("007", 0).replace(",0,", ",0.0,", 1), row("007", 1), row(" 7 ", 2)]
    tr = read_tracks(write(tmp_path, lines))
    assert tr.frame.tolist() == [0, 1, 2] and tr.frame.dtype == np.int64
    assert tr.ids == ["007", "7"]


# -- items 26-27: duplicates and order --------------------------------------------------------
def test_duplicate_frame(tmp_path):
    frames = [f for f in range(200) if f != 42][:93]
    frames.insert(86, 42)  # line 88
    frames.insert(93, 42)  # line 95 (and the rows are out of order before the check)
    lines = [row(17, f) for f in frames]
    assert lines[86].split(",")[1] == "42" and lines[93].split(",")[1] == "42"
    with bad("tracks.csv: track 17: frame 42 appears twice (lines 88 and 95)") as e:
        read_tracks(write(tmp_path, lines))
    assert e.value.track_id == "17"


def test_out_of_order_rows_are_sorted_and_noted(tmp_path):
    # frame-major order (all tracks at frame 0, then frame 1, ...) and one swapped pair
    lines = [row(tid, f, u=10.0 * f + tid) for f in range(6) for tid in (5, 2)]
    lines[4], lines[6] = lines[6], lines[4]
    tr = read_tracks(write(tmp_path, lines))
    assert tr.ids == ["5", "2"]  # order of first appearance, not lexicographic
    assert tr.track_id.tolist() == ["5"] * 6 + ["2"] * 6
    assert tr.frame.tolist() == list(range(6)) * 2
    np.testing.assert_array_equal(tr.u[:6], 10.0 * np.arange(6) + 5)
    assert tr.line[:3].tolist() == [2, 4, 8]
    assert len(tr.notes) == 1 and "sorted by (track_id, frame)" in tr.notes[0]
    assert read_tracks(write(tmp_path, track_rows(1, range(5)))).notes == []


def test_t_decreasing(tmp_path):
    lines = [row(1, f) for f in range(30)] + [row(5, f) for f in range(12)]
    lines.append(row(5, 12, t=0.1))  # line 2 + 42 = 44
    lines[37], lines[-1] = lines[-1], lines[37]  # frame 12 of track 5 now on line 39
    with bad("tracks.csv: track 5: t decreases at frame 12 (line 39)"):
        read_tracks(write(tmp_path, lines))


def test_t_not_increasing(tmp_path):
    lines = track_rows(1, range(4)) + [row(1, 4, t=3 / FPS)]
    with bad("tracks.csv: track 1: t does not increase (0.2 s at frames 3 and 4) at frame 4 "
             "(line 6)"):
        read_tracks(write(tmp_path, lines))


# -- item 28: units ----------------------------------------------------------------------------
@pytest.mark.parametrize("fps", [FPS, None])
def test_t_in_milliseconds(tmp_path, fps):
    lines = [row(1, f, t=1000.0 * f / FPS) for f in range(20)]
    with bad("tracks.csv: column 't' looks like milliseconds (median step 66.67 per frame"):
        read_tracks(write(tmp_path, lines), fps=fps)


def test_t_disagreeing_with_fps_is_noted(tmp_path):
    tr = read_tracks(write(tmp_path, [row(1, f, t=f / 5.0) for f in range(20)]), fps=FPS)
    assert any("disagrees with 15 fps" in n for n in tr.notes)


def test_normalised_image_coordinates(tmp_path):
    lines = track_rows(1, range(5)) + [row(9, f, u=0.1 + 0.01 * f, v=0.5) for f in range(5)]
    with bad("tracks.csv: track 9: u, v all lie in [0, 1]: looks normalised, expected pixels "
             "(line 7)"):
        read_tracks(write(tmp_path, lines))
    # three measurements are too few to judge
    lines = [row(9, f, u=0.1, v=0.5) for f in range(3)]
    assert len(read_tracks(write(tmp_path, lines))) == 3


def test_centimetre_footprints_are_noted(tmp_path):
    lines = [row(1, f) + f",{100.0 * f},{1000.0}" for f in range(5)]
    tr = read_footprints(write(tmp_path, lines, header=HEADER + ",x,y"))
    assert any("look like centimetres" in n for n in tr.notes)
    np.testing.assert_array_equal(tr.y, 1000.0)


def test_footprints_need_x_and_y(tmp_path):
    with bad("tracks.csv: footprints need columns 'x' and 'y'"):
        read_footprints(write(tmp_path, [row(1, 0) + ",3.0"], header=HEADER + ",x"))


# -- item 29: labels ---------------------------------------------------------------------------
def test_labels_are_normalised(tmp_path):
    lines = [row(1, f) + ",Pedestrian " for f in range(3)] + [row(2, 0) + ", DOG", row(3, 0) + ","]
    tr = read_tracks(write(tmp_path, lines, header=HEADER + ",label"))
    assert tr.label.tolist() == ["pedestrian"] * 3 + ["dog", ""]
    assert to_batch(tr, max_gap_frames=1, min_len=4).labels == ["pedestrian", "dog", ""]


def test_unknown_label(tmp_path):
    lines = [row(1, f) + ",pedestrian" for f in range(3)] + [row(2, 0) + ",walker"]
    with bad("tracks.csv line 5, column 'label': unknown label 'walker' (expected one of "
             "pedestrian, bicycle, dog, car, other"):
        read_tracks(write(tmp_path, lines, header=HEADER + ",label"))


def test_label_changing_within_a_track(tmp_path):
    lines = [row(1, 0) + ",dog", row(1, 1) + ",car"]
    with bad("tracks.csv: track 1: label changes from 'dog' to 'car' at frame 1 (line 3)"):
        read_tracks(write(tmp_path, lines, header=HEADER + ",label"))


# -- item 30: Parquet --------------------------------------------------------------------------
def _parquet_columns(n=6):
    f = np.arange(n)
    return {"track_id": np.array(["a"] * n), "frame": f, "t": f / FPS, "u": 100.0 + f,
            "v": 200.0 + f, "width_px": np.full(n, 20.0), "intensity": np.full(n, 500.0)}


def test_parquet_reads_like_csv(tmp_path):
    cols = _parquet_columns()
    cols["u"][2] = np.nan
    write_table(tmp_path / "tracks.parquet", cols, list(cols))
    tr = read_tracks(tmp_path / "tracks.parquet", fps=FPS)
    assert tr.unit == "row" and tr.line.tolist() == [1, 2, 3, 4, 5, 6]
    np.testing.assert_array_equal(tr.u, cols["u"])


def test_parquet_with_integer_ids_and_nulls(tmp_path):
    cols = _parquet_columns()
    t = pa.table({**cols, "track_id": pa.array([17] * 6, pa.int32()),
                  "u": pa.array([1.0, None, 3.0, 4.0, 5.0, 6.0])})
    pq.write_table(t, tmp_path / "tracks.parquet")
    tr = read_tracks(tmp_path / "tracks.parquet")
    assert tr.ids == ["17"] and np.isnan(tr.u[1]) and tr.u[2] == 3.0


def test_parquet_missing_column_and_categorical_labels(tmp_path):
    cols = _parquet_columns()
    del cols["intensity"]
    pq.write_table(pa.table(cols), tmp_path / "tracks.parquet")
    with bad("tracks.parquet: missing column 'intensity' (found: track_id, frame, t, u, v, "
             "width_px)"):
        read_tracks(tmp_path / "tracks.parquet")
    cols = _parquet_columns()
    label = pa.array(["Dog"] * 6).dictionary_encode()  # pandas categorical
    pq.write_table(pa.table({**cols, "label": label}), tmp_path / "tracks.parquet")
    assert read_tracks(tmp_path / "tracks.parquet").label.tolist() == ["dog"] * 6
    pq.write_table(pa.table({**cols, "t": pa.array(np.arange(6) * 10**9, pa.timestamp("ns"))}),
                   tmp_path / "tracks.parquet")
    with bad("tracks.parquet: column 't' has type timestamp[ns], expected float"):
        read_tracks(tmp_path / "tracks.parquet")


def test_truncated_parquet(tmp_path):
    cols = _parquet_columns(200)
    p = tmp_path / "tracks.parquet"
    write_table(p, cols, list(cols))
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2])
    with bad("tracks.parquet: not a valid Parquet file (truncated?)"):
        read_tracks(p)


@pytest.mark.parametrize("content", [HEADER.encode() + b"\n1,0,0,1,1,1,1\n", b"", b"\x00" * 99])
def test_csv_or_garbage_named_parquet(tmp_path, content):
    p = tmp_path / "tracks.parquet"
    p.write_bytes(content)
    with bad("tracks.parquet: not a valid Parquet file (truncated?)"):
        read_tracks(p)


def test_parquet_wrongly_typed_column(tmp_path):
    cols = _parquet_columns()
    cols["u"] = np.array(["1", "2", "x", "4", "5", "6"])
    write_table(tmp_path / "tracks.parquet", cols, list(cols))
    with bad("tracks.parquet: column 'u' has type string, expected float"):
        read_tracks(tmp_path / "tracks.parquet")


def test_parquet_bad_cells_name_the_row(tmp_path):
    cols = _parquet_columns()
    cols["frame"] = np.array([0.0, 1.0, 2.0, 3.5, 4.0, 5.0])
    write_table(tmp_path / "tracks.parquet", cols, list(cols))
    with bad("tracks.parquet row 4, column 'frame': 3.5 is not an integer"):
        read_tracks(tmp_path / "tracks.parquet")
    cols = _parquet_columns()
    pq.write_table(pa.table({**cols, "track_id": pa.array(["a", None, "a", "a", "a", "a"])}),
                   tmp_path / "tracks.parquet")
    with bad("tracks.parquet row 2, column 'track_id': empty cell"):
        read_tracks(tmp_path / "tracks.parquet")


# -- to_batch ----------------------------------------------------------------------------------
def test_to_batch_gap_expansion_and_padding(tmp_path):
    lines = [row("a", f, u=float(f), i=10.0 * f) for f in (0, 1, 2, 5, 6)]  # 2-frame gap
    lines += [row("b", f, u=float(f)) for f in (0, 1, 20, 21)]  # 18-frame gap: one step
    lines += [row("c", 3)]
    tr = read_tracks(write(tmp_path, lines), fps=FPS)
    b = to_batch(tr, max_gap_frames=5, min_len=4)
    assert b.ids == ["a", "b", "c"]
    assert b.length.tolist() == [7, 4, 1] and b.length.dtype == np.int32
    assert b.z.shape == (3, 8, 2) and b.z.dtype == np.float32  # max(4, 7) -> 8
    assert b.present.tolist()[0] == [True] * 7 + [False]
    # track a: frames 0 1 2 (3) (4) 5 6 on the grid, inserted rows missing but present
    np.testing.assert_array_equal(b.z[0, :7, 0], [0, 1, 2, np.nan, np.nan, 5, 6])
    np.testing.assert_array_equal(b.intensity[0, :7], [0, 10, 20, np.nan, np.nan, 50, 60])
    np.testing.assert_allclose(b.t[0, :7], np.arange(7) / FPS, rtol=1e-6)
    np.testing.assert_allclose(b.dt[0], np.full(8, 1 / FPS), rtol=1e-5)
    # track b: the long gap stays one step of the real duration
    np.testing.assert_array_equal(b.z[1, :4, 0], [0, 1, 20, 21])
    np.testing.assert_allclose(b.dt[1, :5], [1 / FPS, 1 / FPS, 19 / FPS, 1 / FPS, 1 / FPS],
                               rtol=1e-5)
    np.testing.assert_allclose(b.t[1, 4:], (21 + np.arange(1, 5)) / FPS, rtol=1e-6)
    assert np.isnan(b.z[1, 4:]).all() and np.isnan(b.width[2, 1:]).all()
    assert b.labels is None and b.xy is None


@pytest.mark.parametrize(("longest", "min_len", "bucket", "T"), [
    (70, 64, True, 128), (70, 64, False, 70), (10, 64, True, 64), (10, 64, False, 64),
    (129, 64, True, 256), (1, 1, True, 1), (3, 1, True, 4)])
def test_to_batch_bucket_shapes(tmp_path, longest, min_len, bucket, T):
    tr = read_tracks(write(tmp_path, track_rows("x", range(longest)) + [row("y", 0)]))
    b = tr.to_batch(max_gap_frames=3, min_len=min_len, bucket=bucket)
    assert b.z.shape == (2, T, 2) and b.dt.shape == b.t.shape == b.present.shape == (2, T)
    assert b.present.sum(axis=1).tolist() == [longest, 1]
    assert np.isfinite(b.dt).all() and np.isfinite(b.t).all()


def test_to_batch_nominal_step_without_fps(tmp_path):
    lines = [row("a", f, t=0.1 * f) for f in (0, 1, 2, 4)] + [row("b", 7, t=0.7)]
    tr = read_tracks(write(tmp_path, lines))
    b = to_batch(tr, max_gap_frames=1, min_len=2, bucket=False)
    np.testing.assert_allclose(b.dt[0], [0.1, 0.1, 0.1, 0.2], rtol=1e-5)  # gap > 1: one step
    np.testing.assert_allclose(b.dt[1], [0.1] * 4, rtol=1e-5)  # padding: the median step
    np.testing.assert_allclose(b.t[1], [0.7, 0.8, 0.9, 1.0], rtol=1e-6)
    assert b.present[1].tolist() == [True, False, False, False]
    b15 = to_batch(tr, max_gap_frames=1, min_len=2, bucket=False, fps=20)
    assert b15.dt[1, 0] == np.float32(0.05)


def test_to_batch_carries_ground_truth(tmp_path):
    lines = [row("a", f) + f",{f}.5,{10 + f}" for f in (0, 2)]
    tr = read_tracks(write(tmp_path, lines, header=HEADER + ",x,y"))
    b = to_batch(tr, max_gap_frames=2, min_len=4)
    assert b.xy.shape == (1, 4, 2)
    np.testing.assert_array_equal(b.xy[0, :3], [[0.5, 10], [np.nan, np.nan], [2.5, 12]])


def test_to_batch_rejects_nonsense_arguments(tmp_path):
    tr = read_tracks(write(tmp_path, [row("a", 0)]))
    with pytest.raises(ValueError, match="must be >= 1"):
        to_batch(tr, max_gap_frames=0, min_len=4)
