"""Tables, atomic writes, config and JSON files (RELIABILITY.md items 17-23, 33-35, 39-40)."""

import errno
import json
import math
import os
import re
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pyarrow.csv as pacsv
import pytest

from rhythmjax.io import (
    BadInput,
    atomic,
    atomic_path,
    atomic_write,
    check_writable,
    dumps_json,
    read_config,
    read_table,
    tables as io_tables,
    write_config,
    write_table,
)
from rhythmjax.model.params import Config, config_from_dict, config_to_dict


ROOT = str(Path(__file__).resolve().parents[1])


def run_child(code: str, cwd, **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": ROOT, "JAX_PLATFORMS": "cpu"}
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def bad(msg: str):
    return pytest.raises(BadInput, match=re.escape(msg))


def leftovers(d) -> list[str]:
    return sorted(n for n in os.listdir(d) if ".tmp" in n)


# -- BadInput --------------------------------------------------------------------------------
def test_bad_input_is_one_line_with_its_location():
    e = BadInput("d/tracks.csv", "'a\nb' is not a number", line=4, column="u")
    assert str(e) == "d/tracks.csv line 4, column 'u': 'a b' is not a number"
    assert (e.path, e.line, e.column, e.track_id) == ("d/tracks.csv", 4, "u", None)
    assert isinstance(e, ValueError)
    e = BadInput("tracks.csv", "frame 42 appears twice (lines 88 and 95)", track_id="17", line=95)
    assert str(e) == "tracks.csv: track 17: frame 42 appears twice (lines 88 and 95)"
    assert str(BadInput("c.json", "Expecting value", line=2, column=18)) == (
        "c.json line 2 col 18: Expecting value")
    assert str(BadInput("t.parquet", "x", row=3, column="u")) == "t.parquet row 3, column 'u': x"


# -- tables ----------------------------------------------------------------------------------
VERDICTS = {
    "track_id": np.array(["ped001", "a,b", 'say "hi"', "17"], dtype=object),
    "verdict": np.array(["pedestrian", "unclassified", "non-pedestrian", "pedestrian"]),
    "pace_hz": np.array([2.05, np.nan, 1.5, 0.1]),
    "ratio": np.array([0.5, np.nan, np.nan, 1e-7], dtype=np.float32),
    "n_samples": np.array([64, 0, 12, 64]),
}
TYPES = {"track_id": "id", "verdict": "str", "pace_hz": "float", "ratio": "float",
         "n_samples": "int"}


@pytest.mark.parametrize("ext", ["csv", "parquet"])
def test_write_read_table_round_trip(tmp_path, ext):
    p = tmp_path / f"verdicts.{ext}"
    write_table(p, VERDICTS, list(VERDICTS))
    got = read_table(p, required=list(VERDICTS), types=TYPES)
    assert list(got) == list(VERDICTS)
    assert got["track_id"].tolist() == VERDICTS["track_id"].tolist()
    assert got["verdict"].tolist() == VERDICTS["verdict"].tolist()
    np.testing.assert_array_equal(got["pace_hz"], VERDICTS["pace_hz"])  # NaN <-> empty/null
    assert got["ratio"].dtype == np.float64  # float32 is written by its shortest repr
    np.testing.assert_array_equal(got["ratio"].astype(np.float32), VERDICTS["ratio"])
    assert got["n_samples"].dtype == np.int64 and got["n_samples"].tolist() == [64, 0, 12, 64]
    assert leftovers(tmp_path) == []


def test_csv_writes_nan_as_empty_cell(tmp_path):
    p = tmp_path / "verdicts.csv"
    write_table(p, VERDICTS, ["track_id", "pace_hz", "ratio"])
    text = p.read_text(encoding="utf-8")
    assert "nan" not in text.lower()
    assert text.splitlines()[0].replace('"', "") == "track_id,pace_hz,ratio"
    assert text.splitlines()[2] == '"a,b",,'
    assert text.splitlines()[1] == '"ped001",2.05,0.5'


def test_read_table_infers_types_and_returns_all_columns(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("a,b,c,d\n1,2.5,x,7\n2,,y,8\n", encoding="utf-8")
    got = read_table(p)
    assert got["a"].dtype == np.int64 and got["a"].tolist() == [1, 2]
    assert got["b"].dtype == np.float64 and np.isnan(got["b"][1])
    assert got["c"].tolist() == ["x", "y"]
    assert got.lines.tolist() == [2, 3] and got.unit == "line"
    assert list(read_table(p, required=["c"], optional=["zz", "a"])) == ["c", "a"]


def test_read_table_bom_crlf_and_blank_lines_keep_line_numbers(tmp_path):
    p = tmp_path / "t.csv"
    p.write_bytes(b"\xef\xbb\xbfa,b\r\n1,2\r\n\r\n3,x\r\n")
    with bad("t.csv line 4, column 'b': 'x' is not a number"):
        read_table(p, types={"b": "float"})
    got = read_table(p, types={"b": "str"})
    assert got["a"].tolist() == [1, 3] and got.lines.tolist() == [2, 4]


def test_read_table_not_utf8(tmp_path):
    p = tmp_path / "t.csv"
    p.write_bytes(b"a,b\n1,\xff\xfe\n")
    with bad("t.csv: not UTF-8 text"):
        read_table(p)


def test_write_table_rejects_unknown_extension_and_bad_columns(tmp_path):
    with bad("out.xlsx: unsupported table format '.xlsx' (use .csv or .parquet)"):
        write_table(tmp_path / "out.xlsx", VERDICTS, ["track_id"])
    with pytest.raises(ValueError, match="no column 'nope'"):
        write_table(tmp_path / "out.csv", VERDICTS, ["nope"])
    with pytest.raises(ValueError, match="differ in length"):
        write_table(tmp_path / "out.csv", {"a": [1, 2], "b": [1]}, ["a", "b"])
    assert os.listdir(tmp_path) == []


# -- atomic writes -----------------------------------------------------------------------------
def test_atomic_write_replaces_and_keeps_suffix(tmp_path):
    p = tmp_path / "out.mp4"
    p.write_bytes(b"old")
    with atomic_write(p) as f:
        name = os.path.basename(f.name)
        f.write(b"new")
        assert p.read_bytes() == b"old"  # nothing visible before the rename
    assert re.fullmatch(r"\.out\.[0-9a-f]{8}\.tmp\.mp4", name)
    assert p.read_bytes() == b"new" and leftovers(tmp_path) == []


def test_atomic_write_text_mode(tmp_path):
    p = tmp_path / "c.json"
    with atomic_write(p, "w") as f:
        f.write("{\"é\": 1}\n")
    assert p.read_bytes() == '{"é": 1}\n'.encode()
    with pytest.raises(ValueError, match="write mode"):
        with atomic_write(p, "r"):
            pass


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt(),
                                 OSError(errno.ENOSPC, "No space left on device")])
def test_atomic_write_failure_mid_way_keeps_old_file(tmp_path, exc):
    p = tmp_path / "verdicts.csv"
    p.write_bytes(b"old complete file\n")
    with pytest.raises(type(exc)):
        with atomic_write(p) as f:
            f.write(b"half of the new")
            f.flush()
            assert leftovers(tmp_path)  # the temp file exists while writing
            raise exc
    assert p.read_bytes() == b"old complete file\n"
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("target", ["fsync", "replace"])
def test_atomic_write_enospc_from_the_os_keeps_old_file(tmp_path, monkeypatch, target):
    p = tmp_path / "out.json"
    p.write_text("old")

    def fail(*a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(io_tables.os, target, fail)
    with pytest.raises(OSError) as e:
        write_config(p, Config())
    monkeypatch.undo()
    assert e.value.errno == errno.ENOSPC
    assert p.read_text() == "old" and leftovers(tmp_path) == []


def test_write_table_enospc_mid_write_keeps_old_file(tmp_path, monkeypatch):
    p = tmp_path / "verdicts.csv"
    write_table(p, VERDICTS, list(VERDICTS))
    before = p.read_bytes()

    def full_disk(table, f, *a, **k):
        f.write(b"track_id,verd")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(io_tables.pacsv, "write_csv", full_disk)
    with pytest.raises(OSError, match="No space left"):
        write_table(p, {"track_id": ["x"]}, ["track_id"])
    assert p.read_bytes() == before and leftovers(tmp_path) == []
    assert pacsv.write_csv is full_disk  # the patch was in force


@pytest.mark.parametrize("ext", ["csv", "parquet"])
def test_write_table_real_write_failure_keeps_old_file(tmp_path, ext):
    """The kernel refuses the write mid-way (file size limit: EFBIG, as ENOSPC would)."""
    (tmp_path / f"out.{ext}").write_bytes(b"old")
    child = run_child("""
        import resource, signal
        import numpy as np
        from rhythmjax.io import write_table
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, resource.RLIM_INFINITY))
        try:
            write_table("out.EXT", {"a": np.arange(200_000.0)}, ["a"])
        except OSError as e:
            print("errno", e.errno)
        """.replace("EXT", ext), tmp_path)
    out, err = child.communicate(timeout=120)
    assert f"errno {errno.EFBIG}" in out, err
    assert (tmp_path / f"out.{ext}").read_bytes() == b"old"
    assert leftovers(tmp_path) == []


def test_sigkill_mid_write_leaves_old_file(tmp_path):
    (tmp_path / "verdicts.csv").write_bytes(b"old")
    child = run_child("""
        import sys, time
        from rhythmjax.io.atomic import atomic_write
        with atomic_write("verdicts.csv") as f:
            f.write(b"half"); f.flush()
            print("writing", flush=True)
            time.sleep(60)
        """, tmp_path)
    assert child.stdout.readline().strip() == "writing"
    child.send_signal(signal.SIGKILL)
    child.communicate(timeout=30)
    assert (tmp_path / "verdicts.csv").read_bytes() == b"old"
    left = leftovers(tmp_path)  # a killed process cannot clean up: a hidden, ignorable temp
    assert len(left) == 1 and re.fullmatch(r"\.verdicts\.[0-9a-f]{8}\.tmp\.csv", left[0])


def test_atomic_write_keeps_permissions_of_replaced_file(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("a")
    os.chmod(p, 0o640)
    with atomic_write(p) as f:
        f.write(b"b")
    assert os.stat(p).st_mode & 0o777 == 0o640


def test_atomic_path_for_writers_that_take_a_name(tmp_path):
    p = tmp_path / "plot.png"
    p.write_bytes(b"old")
    with atomic_path(p) as tmp:
        assert os.path.dirname(tmp) == str(tmp_path)
        assert re.fullmatch(r"\.plot\.[0-9a-f]{8}\.tmp\.png", os.path.basename(tmp))
        with open(tmp, "wb") as f:
            f.write(b"new")
    assert p.read_bytes() == b"new" and leftovers(tmp_path) == []


def test_atomic_path_failure_and_missing_output_keep_old_file(tmp_path):
    p = tmp_path / "video.mp4"
    p.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with atomic_path(p) as tmp:
            with open(tmp, "wb") as f:
                f.write(b"torn")
            raise RuntimeError("killed")
    assert p.read_bytes() == b"old" and leftovers(tmp_path) == []
    with pytest.raises(FileNotFoundError, match="created no file"):
        with atomic_path(p):
            pass  # e.g. a cv2.VideoWriter that never opened
    assert p.read_bytes() == b"old"


def test_check_writable(tmp_path, monkeypatch):
    check_writable(tmp_path / "ok.csv")
    assert os.listdir(tmp_path) == []  # the probe is removed
    with bad("out.csv: output directory '" + str(tmp_path / "nope") + "' does not exist"):
        check_writable(tmp_path / "nope" / "out.csv")
    with bad(f"{tmp_path}: is a directory"):
        check_writable(tmp_path)

    def denied(*a, **k):
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(atomic, "open", denied, raising=False)  # the module's open()
    with bad(f"out.csv: cannot write in '{tmp_path}': Permission denied"):
        check_writable(tmp_path / "out.csv")
    with bad(f"out.csv: cannot write in '{tmp_path}': Permission denied"):
        write_table(tmp_path / "out.csv", VERDICTS, ["track_id"])


def test_writers_name_a_missing_output_directory(tmp_path):
    missing = tmp_path / "nope"
    with bad(f"c.json: output directory '{missing}' does not exist"):
        write_config(missing / "c.json", Config())
    with bad(f"v.parquet: output directory '{missing}' does not exist"):
        write_table(missing / "v.parquet", VERDICTS, ["track_id"])
    with bad(f"o.mp4: output directory '{missing}' does not exist"):
        with atomic_path(missing / "o.mp4"):
            pass
    with bad(f"{tmp_path}: is a directory"):
        with atomic_write(tmp_path):
            pass
    assert os.listdir(tmp_path) == []


# -- config JSON (items 33-35) -----------------------------------------------------------------
def test_config_round_trip(tmp_path):
    cfg = config_from_dict({"camera": {"h_m": 2.5, "theta_deg": 20.0}, "noise": {"r_corr": -0.3},
                            "thresholds": {"n_samples": 128}})
    p = tmp_path / "config.json"
    write_config(p, cfg)
    d = json.loads(p.read_text())
    assert list(d) == ["camera", "noise", "width", "walking", "thresholds"]
    assert p.read_text().startswith('{\n  "camera": {\n    "f_m"')
    back = config_to_dict(read_config(p))
    want = config_to_dict(cfg)
    for sec in want:
        assert list(back[sec]) == list(want[sec])
        for key, value in want[sec].items():
            assert back[sec][key] == pytest.approx(value, rel=1e-6), (sec, key)
    assert back["camera"]["h_m"] == pytest.approx(2.5) and back["thresholds"]["n_samples"] == 128


def test_partial_config_takes_defaults(tmp_path):
    p = tmp_path / "config.json"
    p.write_text('{"camera": {"h_m": 3.0}}')
    d = config_to_dict(read_config(p))
    default = config_to_dict(Config())
    assert d["camera"]["h_m"] == pytest.approx(3.0)
    assert d["walking"] == pytest.approx(default["walking"])
    assert d["camera"]["theta_deg"] == pytest.approx(default["camera"]["theta_deg"])


def test_malformed_json_names_line_and_col(tmp_path):
    p = tmp_path / "config.json"
    text = '{\n  "camera": {h_m: 1.0}\n}'
    p.write_text(text)
    with bad("config.json line 2 col 14: Expecting property name enclosed in double quotes") as e:
        read_config(p)
    assert (e.value.line, e.value.column) == (2, 14)
    assert text.splitlines()[1][13] == "h"


@pytest.mark.parametrize(("token", "col"), [("NaN", 21), ("Infinity", 21), ("-Infinity", 21)])
def test_nan_and_infinity_tokens_rejected(tmp_path, token, col):
    p = tmp_path / "config.json"
    p.write_text('{\n  "camera": {"h_m": ' + token + "}\n}")
    with bad(f"config.json line 2 col {col}: {token} is not valid JSON"):
        read_config(p)


def test_duplicate_keys_rejected(tmp_path):
    p = tmp_path / "config.json"
    p.write_text('{"camera": {"h_m": 1.0, "h_m": 2.0}}')
    with bad("config.json: duplicate key 'h_m'"):
        read_config(p)


@pytest.mark.parametrize(("body", "key", "msg"), [
    ('{"camera": {"theta_degs": 15}}', "camera.theta_degs",
     "unknown key (did you mean 'theta_deg'?)"),
    ('{"camera": {"theta_deg": 0.26}}', "camera.theta_deg", "0.26 looks like radians"),
    ('{"camera": {"h_m": -1}}', "camera.h_m", "must be > 0.0, got -1"),
    ('{"camera": {"fps": 0}}', "camera.fps", "must be > 0.0"),
    ('{"camera": {"theta_deg": 95}}', "camera.theta_deg", "must be < 90.0"),
    ('{"thresholds": {"ar_order": 63}}', "thresholds.ar_order", "must be < n_samples - 1"),
    ('{"camra": {}}', "camra", "unknown section (did you mean 'camera'?)"),
    ('{"camera": {"h_m": "1.0"}}', "camera.h_m", "expected a number"),
    ("[1, 2]", "config", "expected a JSON object"),
])
def test_config_errors_name_file_and_key(tmp_path, body, key, msg):
    p = tmp_path / "config.json"
    p.write_text(body)
    with pytest.raises(BadInput) as e:
        read_config(p)
    assert str(e.value).startswith(f"{p}: {key}: ") and msg in str(e.value)
    assert e.value.key == key


@pytest.mark.parametrize(("content", "msg"), [
    (None, "config.json: no such file"), (b"", "config.json: empty file"),
    (b"\xff\xfe{}", "config.json: not UTF-8 text")])
def test_config_file_problems(tmp_path, content, msg):
    p = tmp_path / "config.json"
    if content is not None:
        p.write_bytes(content)
    with bad(msg):
        read_config(p)


def test_dumps_json_is_always_valid_json():
    obj = {"pace_hz": float("nan"), "ratio": np.float32(np.inf), "n": np.int64(3),
           "arr": np.array([1.5, np.nan]), "t": (1, -math.inf), 7: "x"}
    s = dumps_json(obj)
    assert json.loads(s) == {"pace_hz": None, "ratio": None, "n": 3, "arr": [1.5, None],
                             "t": [1, None], "7": "x"}
    assert "NaN" not in s and "Infinity" not in s
    assert dumps_json({"a": 1}, indent=2) == '{\n  "a": 1\n}'
