"""`rhythmjax simulate` + `rhythmjax classify`, in-process, and their bad-input behaviour."""

import json
import os

import numpy as np
import pytest

from rhythmjax.cli.main import main
from rhythmjax.io import read_table


ORDER = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y"]


@pytest.fixture(scope="module")
def tracks_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "tracks.csv"
    assert main(["simulate", "-o", str(path), "--seed", "7", "--walkers", "16", "--bicycles",
                 "4", "--dogs", "4", "--cars", "2", "--short", "2", "--quiet"]) == 0
    return path


def test_classify_reproduces_the_generator_labels(tracks_csv, tmp_path, capsys):
    out = tmp_path / "verdicts.csv"
    assert main(["classify", str(tracks_csv), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    v = read_table(out, required=["track_id", "verdict", "reason", "pace_hz", "n_samples",
                                  "label"])
    verdict, reason, label = (np.asarray(v[k]).astype(str) for k in ("verdict", "reason",
                                                                       "label"))
    tracks = read_table(tracks_csv, required=["track_id", "frame"])
    ids, counts = np.unique(np.asarray(tracks["track_id"]).astype(str), return_counts=True)
    n_frames = dict(zip(ids, counts))
    long_enough = np.array([n_frames[i] >= 64 for i in np.asarray(v["track_id"]).astype(str)])
    # every track shorter than N frames is 'too-short'; a longer one is judged unless Fig. 3's
    # 1 s PREDICT time-out cut it into segments shorter than N (the gates (10), (11) refused
    # its measurements: here a car, wider than a pedestrian, and a bicycle), never a walker's
    cut = long_enough & (verdict == "unclassified")
    assert np.all(verdict[~long_enough] == "unclassified")
    assert np.all(reason[verdict == "unclassified"] == "too-short")
    assert np.all(label[cut] != "pedestrian") and cut.sum() <= 3
    judged = long_enough & ~cut
    walkers = label == "pedestrian"
    assert np.all(verdict[judged & walkers] == "pedestrian")
    assert np.all(verdict[judged & ~walkers] == "non-pedestrian")
    assert summary["n_tracks"] == len(verdict) == 28
    assert summary["labels"]["walkers_judged_pedestrian"] == np.sum(judged & walkers)
    pace = np.asarray(v["pace_hz"], float)
    assert np.all((pace[judged & walkers] > 1.5) & (pace[judged & walkers] < 2.7))


def test_classify_parquet_equals_csv(tracks_csv, tmp_path):
    pq = tmp_path / "tracks.parquet"
    cols = read_table(tracks_csv, required=ORDER)
    from rhythmjax.io import write_table

    write_table(pq, cols, ORDER)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["classify", str(tracks_csv), "-o", str(a), "-q"]) == 0
    assert main(["classify", str(pq), "-o", str(b), "-q"]) == 0
    assert a.read_bytes() == b.read_bytes()


def _bad(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


HEADER = "track_id,frame,t,u,v,width_px,intensity\n"


@pytest.mark.parametrize(
    "name, text, pattern",
    [
        ("missing.csv", None, r"missing\.csv: no such file"),
        ("empty.csv", "", r"empty\.csv: empty file"),
        ("nocol.csv", "track_id,frame,t,u,v,width_px\n1,0,0,1,1,1\n",
         r"nocol\.csv: missing column 'intensity'"),
        ("text.csv", HEADER + "1,0,0,10,10,5,1\n1,1,0.07,1O2,10,5,1\n",
         r"text\.csv line 3, column 'u': '1O2' is not a number"),
        ("nan_t.csv", HEADER + "1,0,0,10,10,5,1\n1,1,,10,10,5,1\n", r"nan_t\.csv line 3.*'t'"),
        ("dec_t.csv", HEADER + "1,0,0.5,10,10,5,1\n1,1,0.2,10,10,5,1\n",
         r"dec_t\.csv.*track 1: t decreases at frame 1"),
        ("dup.csv", HEADER + "1,0,0,10,10,5,1\n1,0,0,10,10,5,1\n",
         r"dup\.csv.*track 1: frame 0 appears twice \(lines 2 and 3\)"),
        ("data.xlsx", "x", r"data\.xlsx.*unsupported table format '\.xlsx'"),
    ],
)
def test_bad_tracks_exit_2_with_one_line(tmp_path, capsys, name, text, pattern):
    path = tmp_path / name if text is None else _bad(tmp_path, name, text)
    out = tmp_path / "v.csv"
    out.write_text("previous\n")
    assert main(["classify", str(path), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert pytest.importorskip("re").search(pattern, err), err
    assert out.read_text() == "previous\n"  # nothing half-written


def test_one_row_track_is_unclassified_not_an_error(tmp_path, capsys):
    p = _bad(tmp_path, "one.csv", HEADER + "7,0,0,250,300,30,100\n")
    out = tmp_path / "v.csv"
    assert main(["classify", str(p), "-o", str(out), "-q"]) == 0
    v = read_table(out, required=["track_id", "verdict", "reason"])
    assert list(np.asarray(v["reason"]).astype(str)) == ["too-short"]


@pytest.mark.parametrize(
    "config, pattern",
    [
        ('{"camera": {"theta_degs": 15}}', r"cfg\.json.*theta_degs.*did you mean 'theta_deg'"),
        ('{"noise": {"r_std_px": [1, -2]}}', r"cfg\.json.*noise\.r_std_px"),
        ('{"camera": {"h_m": 1,}}', r"cfg\.json line 1 col"),
    ],
)
def test_bad_config_exit_2(tracks_csv, tmp_path, capsys, config, pattern):
    cfg = _bad(tmp_path, "cfg.json", config)
    assert main(["classify", str(tracks_csv), "--config", str(cfg), "-q"]) == 2
    err = capsys.readouterr().err
    assert pytest.importorskip("re").search(pattern, err), err


def test_unwritable_output_fails_before_work(tracks_csv, tmp_path, capsys):
    target = tmp_path / "no_such_dir" / "v.csv"
    assert main(["classify", str(tracks_csv), "-o", str(target), "-q"]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not os.path.exists(target)


def test_config_prints_valid_json_defaults(capsys):
    assert main(["config"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["walking"]["pace_mean_hz"] == pytest.approx(2.05)
    assert d["thresholds"]["ar_order"] == 15


def test_a_camera_that_sees_none_of_the_tracks_is_said(tracks_csv, tmp_path, capsys):
    """theta 89 deg from 5 cm up: no foot point is on the ground in the range (issue 17)."""
    cfg = tmp_path / "blind.json"
    cfg.write_text(json.dumps({"camera": {"theta_deg": 89, "h_m": 0.05},
                               "thresholds": {"range_min_m": 3, "range_max_m": 20}}))
    assert main(["classify", str(tracks_csv), "-c", str(cfg), "-o",
                 str(tmp_path / "v.csv")]) == 0
    err = capsys.readouterr().err
    assert "warning: the config's camera sees none of the" in err and "Traceback" not in err


# -- streaming (issue 18): the default path -------------------------------------------------
def _shuffled_copy(src, dst, seed=0):
    """The tracks with each track's rows in a random frame order (tracks stay contiguous)."""
    from rhythmjax.io import write_table

    cols = read_table(src, required=ORDER, types={"track_id": "id", "label": "str"})
    tid = np.asarray(cols["track_id"]).astype(str)
    run = np.cumsum(np.r_[False, tid[1:] != tid[:-1]])
    order = np.lexsort((np.random.default_rng(seed).random(len(tid)), run))
    write_table(dst, {k: np.asarray(v)[order] for k, v in cols.items()}, ORDER)
    return dst


@pytest.mark.parametrize("fmt, extra", [(".csv", []), (".parquet", ["--segment-rows", "96"])])
def test_streaming_equals_the_whole_file_path(tracks_csv, tmp_path, capsys, fmt, extra):
    """Unsorted rows within tracks, record batches and blocks cut inside the file, and (with
    --segment-rows 96) the tracks over 96 rows through the long-track path."""
    src = _shuffled_copy(tracks_csv, tmp_path / f"shuffled{fmt}")
    a, b = tmp_path / "whole.csv", tmp_path / "streamed.csv"
    assert main(["classify", str(src), "-o", str(a), "--whole-file", "-q", *extra]) == 0
    assert main(["classify", str(src), "-o", str(b), "--json", "--block-tracks", "5",
                 "--chunk", "8", "--devices", "1", *extra]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert a.read_bytes() == b.read_bytes()
    assert summary["streamed"] and summary["parts"] == 6 and summary["n_tracks"] == 28
    assert set(summary["timing"]) == {"read_s", "prepare_s", "kernel_s", "write_s", "wait_s",
                                      "total_s"}
    assert 0 < summary["peak_tracks_in_memory"] <= 20  # 4 blocks of 5 (stream.classify)
    assert "sorted by (track_id, frame)" in summary["notes"][0]
    assert sorted(os.listdir(tmp_path)) == sorted([src.name, "whole.csv", "streamed.csv",
                                                   "whole.report.html", "streamed.report.html"])


def test_dataset_output_folder(tracks_csv, tmp_path, capsys):
    import pyarrow.dataset as ds

    out = tmp_path / "verdicts"
    assert main(["classify", str(tracks_csv), "-o", f"{out}/", "--block-tracks", "10",
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["parts"] == 3
    v = ds.dataset(out, format="parquet").to_table()
    assert v.num_rows == 28 and v.column_names[:2] == ["track_id", "verdict"]
    assert main(["classify", str(tracks_csv), "-o", str(tracks_csv.parent) + "/", "-q"]) == 2
    assert "is the input" in capsys.readouterr().err


@pytest.mark.parametrize("devices", ["0", "two"])
def test_bad_devices_refused_by_argparse(tracks_csv, devices, capsys):
    with pytest.raises(SystemExit) as e:
        main(["classify", str(tracks_csv), "--devices", devices])
    assert e.value.code == 2


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGKILL"])
def test_a_killed_run_resumes_where_it_stopped(tracks_csv, tmp_path, capsys, sig):
    """kill -9 or SIGTERM once a part is written; the same command resumes after it."""
    import signal
    import subprocess
    import sys
    import time

    from rhythmjax.io.parts import MANIFEST, parts_folder

    def listed_parts(folder):
        """The parts the manifest names (a part is renamed in with its manifest entry; the
        signal goes once one is there, so the resumed run has work to skip)."""
        try:
            with open(os.path.join(folder, MANIFEST), encoding="utf-8") as f:
                return json.load(f).get("parts", [])
        except (OSError, ValueError):
            return []

    out = tmp_path / "v.csv"
    cmd = ["classify", str(tracks_csv), "-o", str(out), "--block-tracks", "2", "--chunk", "8"]
    env = {**os.environ, "RHYTHMJAX_CACHE_DIR": "0", "JAX_PLATFORMS": "cpu"}
    proc = subprocess.Popen([sys.executable, "-m", "rhythmjax.cli.main", *cmd], env=env,
                            stderr=subprocess.PIPE, text=True)
    folder = parts_folder(out)
    t0 = time.monotonic()
    while proc.poll() is None and time.monotonic() - t0 < 300:
        if listed_parts(folder):
            break
        time.sleep(0.05)
    proc.send_signal(getattr(signal, sig))
    err = proc.communicate(timeout=60)[1]
    if proc.returncode == 0:
        pytest.skip("the run finished before the signal")
    assert proc.returncode == (143 if sig == "SIGTERM" else -9), err
    if sig == "SIGTERM":
        assert "resumes from them" in err and "Traceback" not in err
    assert not out.exists()
    done = sorted(n for n in os.listdir(folder) if n.startswith("part-"))
    assert done and all(not n.startswith(".") for n in done)
    capsys.readouterr()
    assert main(cmd) == 0
    err = capsys.readouterr().err
    assert f"resuming the interrupted run from {folder}" in err
    ref = tmp_path / "ref.csv"
    assert main(["classify", str(tracks_csv), "-o", str(ref), "--whole-file", "-q"]) == 0
    assert out.read_bytes() == ref.read_bytes() and not os.path.exists(folder)
