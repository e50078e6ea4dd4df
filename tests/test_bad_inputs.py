"""The bad-input corpus (issue 17): every verb given unusable input or output exits 2 with one
line on stderr naming the file and the line/column, key or argument, never a traceback, and
changes nothing on disk (no output created, the previous outputs intact, no temp file, no
folder made). Argument errors are argparse's (exit 2 before any work, the last line names the
argument). In-process calls of `main(argv)`; the fault cases that need a signal are in
`test_io_outputs.py`."""

from __future__ import annotations

import os
import shutil
import stat

import cv2
import numpy as np
import pytest

from fit.cli import main as fit_main
from rhythmjax.cli.main import main
from rhythmjax.io import write_table
from rhythmjax.sim.tracks import make_tracks


ORDER = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y"]
DEEP = "[" * 100_000 + "]" * 100_000


def _with_frame(cols: dict, value) -> dict:
    out = {k: np.asarray(v) for k, v in cols.items()}
    out["frame"] = out["frame"].astype(object)
    out["frame"][1] = value
    return out


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Inputs and a previous output set; each case runs in a fresh copy."""
    d = tmp_path_factory.mktemp("corpus")
    cols, _ = make_tracks(n_walkers=2, n_bicycles=1, n_dogs=0, n_cars=0, n_short=0, seed=1)
    write_table(d / "t.csv", cols, ORDER)
    write_table(d / "t.parquet", cols, ORDER)
    lines = (d / "t.csv").read_text().splitlines()
    for name, frame in (("f20.csv", "1e20"), ("f20b.csv", "1" + "0" * 20)):
        row = lines[2].split(",")
        row[1] = frame
        (d / name).write_text("\n".join(lines[:2] + [",".join(row)] + lines[3:]) + "\n")
    fcols = {k: np.asarray(v) for k, v in cols.items()}
    fcols["frame"] = fcols["frame"].astype(float)
    fcols["frame"][1] = 1e20
    write_table(d / "f20.parquet", fcols, ORDER)
    w = cv2.VideoWriter(str(d / "v.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (128, 96), False)
    rng = np.random.default_rng(0)
    for _ in range(12):
        w.write(rng.integers(0, 255, (96, 128), np.uint8))
    w.release()
    (d / "b.txt").write_text("1,1,10,10,20,40,1,-1,-1,-1\n2,1,12,10,20,40,1,-1,-1,-1\n")
    configs = {
        "c_5000.json": '{"camera": {"h_m": ' + "9" * 5000 + "}}",
        "c_401.json": '{"camera":\n {"h_m": ' + "9" * 401 + "}}",
        "c_deep.json": DEEP,
        "c_deep_value.json": '{"camera": {"h_m": ' + "[" * 50 + "]" * 50 + "}}",
        "c_timeout.json": '{"thresholds": {"predict_timeout_s": 1e300}}',
        "c_timeout_day.json": '{"thresholds": {"predict_timeout_s": 1e6}}',
        "c_nsamples.json": '{"thresholds": {"n_samples": 1e9}}',
        "c_window.json": '{"thresholds": {"window_s": 1e6}}',
        "c_uc.json": '{"camera": {"uc_px": 1e300}}',
        "c_vc.json": '{"camera": {"vc_px": -1e7}}',
        "c_h.json": '{"camera": {"h_m": 1e200}}',
        "c_bigint.json": '{"camera": {"h_m": 123456789012345678901234567890}}',
        "c_fps.json": '{"camera": {"fps": 1e9}}',
        "c_width.json": '{"camera": {"image_width_px": 10000000}}',
        "c_hop.json": '{"thresholds": {"n_samples": 64, "window_hop_samples": 65}}',
        "c_nan.json": '{"camera": {"h_m": NaN}}',
        "c_dup.json": '{"camera": {"h_m": 3, "h_m": 4}}',
        "c_unknown.json": '{"camera": {"hm": 3}}',
        "c_string.json": '{"camera": {"h_m": "3"}}',
        "c_bool.json": '{"camera": {"h_m": true}}',
        "c_theta.json": '{"camera": {"theta_deg": 95}}',
        "c_list.json": "[1, 2]",
        "c_syntax.json": '{"camera": {"h_m": 3,}}',
        "c_empty.json": "",
        "c_longlist.json": '{"noise": {"r_std_px": [' + ",".join(["1"] * 5000) + "]}}",
        "ok.json": "{}",
    }
    for name, text in configs.items():
        (d / name).write_text(text)
    (d / "c_latin1.json").write_bytes(b'{"camera": {"h_m": 3}} \xe9')
    for folder, names in (("prev", ("tracks.parquet", "verdicts.csv", "spectra.png",
                                    "overlay.mp4")),
                          ("cnt", ("mot.txt", "mot_velocity.txt", "tracks.parquet",
                                   "verdicts.csv", "counts.json"))):
        (d / folder).mkdir()
        for n in names:
            (d / folder / n).write_bytes(f"old {n}".encode())
    (d / "out.json").write_text('{"old": true}\n')
    (d / "a_dir").mkdir()
    (d / "blocker").write_text("a file where a folder is needed")
    return d


@pytest.fixture
def work(data, tmp_path):
    w = tmp_path / "w"
    shutil.copytree(data, w)
    os.mkfifo(w / "ff")
    old = os.getcwd()
    os.chdir(w)
    yield w
    os.chdir(old)


def _read(path) -> bytes:
    with open(path, "rb") as f:
        return f.read()


def snapshot(root) -> dict:
    """Every entry under `root`: kind, and the bytes of regular files."""
    out = {}
    for dirpath, dirs, files in os.walk(root):
        for n in dirs + files:
            p = os.path.join(dirpath, n)
            m = os.lstat(p).st_mode
            kind = "dir" if stat.S_ISDIR(m) else "fifo" if stat.S_ISFIFO(m) else "file"
            out[os.path.relpath(p, root)] = (kind, _read(p) if kind == "file" else None)
    return out


R, F = "rhythmjax", "rhythmjax-fit"
V = ["--no-camera-check", "-q"]
# (case id, program, argv, words the one line must hold); exit 2, nothing changed on disk
FILE_CASES = [
    # configs: ranges, huge numbers, nesting (issue 17) and the formats' basics
    ("config-5000-digit-int", R, ["config", "-c", "c_5000.json"],
     ["c_5000.json line 1 col 20", "5000 digits"]),
    ("config-401-digit-int", R, ["config", "-c", "c_401.json"], ["c_401.json line 2", "401"]),
    ("config-deep-nesting", R, ["config", "-c", "c_deep.json"], ["c_deep.json", "nested"]),
    ("config-deep-value", R, ["config", "-c", "c_deep_value.json"],
     ["c_deep_value.json", "camera.h_m"]),
    ("config-timeout-1e300", R, ["config", "-c", "c_timeout.json"],
     ["c_timeout.json", "thresholds.predict_timeout_s"]),
    ("config-timeout-1e6", R, ["config", "-c", "c_timeout_day.json"],
     ["c_timeout_day.json", "predict_timeout_s", "<= 86400"]),
    ("config-n-samples-1e9", R, ["config", "-c", "c_nsamples.json"],
     ["c_nsamples.json", "thresholds.n_samples", "<= 100000"]),
    ("config-window-1e6", R, ["config", "-c", "c_window.json"],
     ["c_window.json", "thresholds.window_s"]),
    ("config-uc-1e300", R, ["config", "-c", "c_uc.json"], ["c_uc.json", "camera.uc_px"]),
    ("config-vc-1e7", R, ["config", "-c", "c_vc.json"], ["c_vc.json", "camera.vc_px"]),
    ("config-h-1e200", R, ["config", "-c", "c_h.json"], ["c_h.json", "camera.h_m"]),
    ("config-30-digit-int", R, ["config", "-c", "c_bigint.json"], ["c_bigint.json", "h_m"]),
    ("config-fps-1e9", R, ["config", "-c", "c_fps.json"], ["c_fps.json", "camera.fps"]),
    ("config-width-1e7", R, ["config", "-c", "c_width.json"],
     ["c_width.json", "image_width_px"]),
    ("config-hop-over-n", R, ["config", "-c", "c_hop.json"],
     ["c_hop.json", "window_hop_samples"]),
    ("config-nan", R, ["config", "-c", "c_nan.json"], ["c_nan.json line 1", "NaN"]),
    ("config-duplicate", R, ["config", "-c", "c_dup.json"], ["c_dup.json", "duplicate"]),
    ("config-unknown-key", R, ["config", "-c", "c_unknown.json"], ["c_unknown.json", "h_m"]),
    ("config-string", R, ["config", "-c", "c_string.json"], ["c_string.json", "camera.h_m"]),
    ("config-bool", R, ["config", "-c", "c_bool.json"], ["c_bool.json", "camera.h_m"]),
    ("config-theta-95", R, ["config", "-c", "c_theta.json"], ["c_theta.json", "theta_deg"]),
    ("config-top-list", R, ["config", "-c", "c_list.json"], ["c_list.json", "object"]),
    ("config-syntax", R, ["config", "-c", "c_syntax.json"], ["c_syntax.json line 1"]),
    ("config-empty", R, ["config", "-c", "c_empty.json"], ["c_empty.json", "empty"]),
    ("config-long-list", R, ["config", "-c", "c_longlist.json"], ["c_longlist.json", "r_std"]),
    ("config-not-utf8", R, ["config", "-c", "c_latin1.json"], ["c_latin1.json", "UTF-8"]),
    ("config-missing", R, ["config", "-c", "nope.json"], ["nope.json", "no such file"]),
    ("config-is-dir", R, ["config", "-c", "a_dir"], ["a_dir", "directory"]),
    ("config-bad-keeps-old-output", R, ["config", "-c", "c_uc.json", "-o", "out.json"],
     ["c_uc.json", "uc_px"]),
    # outputs: the input, a FIFO, a device, a folder, a missing folder, a wrong suffix
    ("config-out-is-input", R, ["config", "-c", "ok.json", "-o", "ok.json"],
     ["ok.json", "is the input"]),
    ("config-out-fifo", R, ["config", "-o", "ff"], ["ff", "not a regular file"]),
    ("config-out-devnull", R, ["config", "-o", os.devnull], [os.devnull, "not a regular"]),
    ("config-out-dir", R, ["config", "-o", "a_dir"], ["a_dir", "directory"]),
    ("config-out-no-dir", R, ["config", "-o", "nowhere/c.json"], ["nowhere", "does not exist"]),
    ("simulate-out-txt", R, ["simulate", "-o", "x.txt"], ["x.txt", ".csv or .parquet"]),
    ("simulate-out-fifo", R, ["simulate", "-o", "ff"], ["ff", ".csv or .parquet"]),
    ("simulate-out-dir", R, ["simulate", "-o", "a_dir"], ["a_dir"]),
    ("classify-out-is-input", R, ["classify", "t.csv", "-o", "t.csv"], ["t.csv", "is the input"]),
    ("classify-out-is-input-via-dots", R, ["classify", "t.csv", "-o", "a_dir/../t.csv"],
     ["is the input"]),
    ("classify-out-txt", R, ["classify", "t.csv", "-o", "x.txt"], ["x.txt", ".csv or .parquet"]),
    ("classify-out-dir", R, ["classify", "t.csv", "-o", "a_dir"], ["a_dir"]),
    ("classify-out-no-dir", R, ["classify", "t.csv", "-o", "nowhere/v.csv"], ["nowhere"]),
    ("classify-bad-config", R, ["classify", "t.csv", "-c", "c_timeout.json", "-o", "v.csv"],
     ["c_timeout.json", "predict_timeout_s"]),
    # tracks: frame 1e20 names the file, line and column
    ("classify-frame-1e20", R, ["classify", "f20.csv"], ["f20.csv line 3", "'frame'", "1e20"]),
    ("classify-frame-10^20", R, ["classify", "f20b.csv"], ["f20b.csv line 3", "'frame'"]),
    ("classify-frame-1e20-parquet", R, ["classify", "f20.parquet"],
     ["f20.parquet row 2", "'frame'"]),
    ("classify-missing", R, ["classify", "nope.csv"], ["nope.csv", "no such file"]),
    ("classify-config-as-tracks", R, ["classify", "ok.json"], ["ok.json"]),
    # the video verbs: outputs checked before any work, the previous set kept
    ("track-out-txt", R, ["track", "v.avi", "-o", "x.txt"] + V, ["x.txt", ".csv or .parquet"]),
    ("track-out-fifo", R, ["track", "v.avi", "-o", "ff"] + V, ["ff"]),
    ("track-out-is-video", R, ["track", "v.avi", "-o", "v.avi"] + V, ["v.avi"]),
    ("track-overlay-is-video", R, ["track", "v.avi", "-o", "t2.csv", "--overlay", "v.avi"] + V,
     ["v.avi", "is the input"]),
    ("track-overlay-suffix", R, ["track", "v.avi", "-o", "t2.csv", "--overlay", "o.mkv"] + V,
     ["o.mkv", "extension"]),
    ("track-bad-config", R, ["track", "v.avi", "-o", "t2.csv", "-c", "c_uc.json"] + V,
     ["c_uc.json", "uc_px"]),
    ("run-out-holds-the-input", R, ["run", "prev/overlay.mp4", "-o", "prev"] + V,
     ["overlay.mp4", "is the input"]),
    ("run-out-is-a-file", R, ["run", "v.avi", "-o", "blocker/sub"] + V, ["blocker"]),
    ("run-bad-config-keeps-set", R, ["run", "v.avi", "-o", "prev", "-c", "c_nsamples.json"] + V,
     ["c_nsamples.json", "n_samples"]),
    ("run-bad-config-new-dir", R, ["run", "v.avi", "-o", "new", "-c", "c_deep.json"] + V,
     ["c_deep.json", "nested"]),
    ("run-missing-video", R, ["run", "nope.avi", "-o", "prev"] + V, ["nope.avi"]),
    ("count-bad-config-keeps-set", R, ["count", "v.avi", "-o", "cnt", "-c", "c_h.json"] + V,
     ["c_h.json", "h_m"]),
    ("count-min-frames-0", R, ["count", "v.avi", "-o", "cnt", "--min-frames", "0"] + V,
     ["--min-frames", ">= 1"]),
    ("count-max-pedestrians-0", R, ["count", "v.avi", "-o", "cnt", "--max-pedestrians", "0"] + V,
     ["--max-pedestrians", ">= 1"]),
    ("count-overlay-is-video", R, ["count", "v.avi", "-o", "cnt", "--overlay", "v.avi"] + V,
     ["v.avi", "is the input"]),
    ("rhythm-bad-config-keeps-set", R, ["rhythm", "v.avi", "--boxes", "b.txt", "-o", "prev",
                                        "-c", "c_width.json"] + V, ["c_width.json"]),
    ("rhythm-out-holds-boxes", R, ["rhythm", "v.avi", "--boxes", "prev/verdicts.csv", "-o",
                                   "prev"] + V, ["verdicts.csv", "is the input"]),
    ("demo-out-is-a-file", R, ["demo", "-o", "blocker", "-q"], ["blocker"]),
    # rhythmjax-fit: the output checked before the fit
    ("fit-noise-out-dir", F, ["noise", "t.csv", "-o", "a_dir"], ["a_dir", "directory"]),
    ("fit-noise-out-no-dir", F, ["noise", "t.csv", "-o", "nowhere/c.json"], ["nowhere"]),
    ("fit-noise-out-is-input", F, ["noise", "t.csv", "-o", "t.csv"], ["is the input"]),
    ("fit-noise-out-fifo", F, ["noise", "t.csv", "-o", "ff"], ["ff", "not a regular"]),
    ("fit-walking-out-is-config", F, ["walking", "t.csv", "-c", "ok.json", "-o", "ok.json"],
     ["ok.json", "is the input"]),
    ("fit-camera-out-dir", F, ["camera", "t.csv", "-o", "a_dir"], ["a_dir"]),
    ("fit-footprints-out-fifo", F, ["footprints", "--boxes", "b.txt", "-o", "ff"], ["ff"]),
    ("fit-noise-bad-config", F, ["noise", "t.csv", "-c", "c_5000.json", "-o", "n.json"],
     ["c_5000.json", "digits"]),
]

ARG_CASES = [  # (case id, program, argv, the argument named)
    ("classify-chunk-0", R, ["classify", "t.csv", "--chunk", "0"], "--chunk"),
    ("classify-chunk-negative", R, ["classify", "t.csv", "--chunk", "-3"], "--chunk"),
    ("classify-chunk-huge", R, ["classify", "t.csv", "--chunk", "9" * 40], "--chunk"),
    ("simulate-seed-negative", R, ["simulate", "-o", "s.csv", "--seed", "-1"], "--seed"),
    ("simulate-walkers-negative", R, ["simulate", "-o", "s.csv", "--walkers", "-1"],
     "--walkers"),
    ("simulate-cars-text", R, ["simulate", "-o", "s.csv", "--cars", "two"], "--cars"),
    ("demo-frames-0", R, ["demo", "-o", "d", "--frames", "0"], "--frames"),
    ("demo-walkers-0", R, ["demo", "-o", "d", "--walkers", "0"], "--walkers"),
    ("demo-seed-negative", R, ["demo", "-o", "d", "--seed", "-4"], "--seed"),
    ("run-fps-1e-6", R, ["run", "v.avi", "-o", "prev", "--fps", "1e-6"], "--fps"),
    ("run-fps-1e9", R, ["run", "v.avi", "-o", "prev", "--fps", "1e9"], "--fps"),
    ("run-fps-nan", R, ["run", "v.avi", "-o", "prev", "--fps", "nan"], "--fps"),
    ("track-max-objects-0", R, ["track", "v.avi", "-o", "t2.csv", "--max-objects", "0"],
     "--max-objects"),
    ("count-fps-0", R, ["count", "v.avi", "-o", "cnt", "--fps", "0"], "--fps"),
    ("rhythm-fps-1e9", R, ["rhythm", "v.avi", "--boxes", "b.txt", "-o", "prev", "--fps", "1e9"],
     "--fps"),
    ("fit-walking-max-iter-0", F, ["walking", "t.csv", "-o", "w.json", "--max-iter", "0"],
     "--max-iter"),
    ("fit-noise-max-gap-0", F, ["noise", "t.csv", "-o", "n.json", "--max-gap-frames", "0"],
     "--max-gap-frames"),
    ("fit-noise-max-steps-0", F, ["noise", "t.csv", "-o", "n.json", "--max-steps", "0"],
     "--max-steps"),
    ("fit-walking-test-fraction", F, ["walking", "t.csv", "-o", "w.json", "--test-fraction",
                                      "1.5"], "--test-fraction"),
    ("fit-walking-seed-negative", F, ["walking", "t.csv", "-o", "w.json", "--seed", "-1"],
     "--seed"),
]


def _call(prog, argv) -> int:
    try:
        return (main if prog == R else fit_main)(argv)
    except SystemExit as e:
        return e.code


@pytest.mark.parametrize("prog, argv, words", [c[1:] for c in FILE_CASES],
                         ids=[c[0] for c in FILE_CASES])
def test_bad_input_one_line_exit_2_nothing_changed(work, capsys, prog, argv, words):
    before = snapshot(work)
    code = _call(prog, argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err, err
    assert code == 2, err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1, err
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert snapshot(work) == before


@pytest.mark.parametrize("prog, argv, arg", [c[1:] for c in ARG_CASES],
                         ids=[c[0] for c in ARG_CASES])
def test_bad_argument_refused_by_argparse(work, capsys, prog, argv, arg):
    before = snapshot(work)
    code = _call(prog, argv)
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err, err
    assert f"error: argument {arg}" in err.strip().splitlines()[-1], err
    assert snapshot(work) == before


def test_the_corpus_is_large_enough():
    ids = [c[0] for c in FILE_CASES + ARG_CASES]
    assert len(ids) == len(set(ids)) and len(ids) >= 90


def test_config_at_its_limits_is_written_without_null(tmp_path, capsys):
    """The largest accepted values stay finite through float32: `rhythmjax config` never writes
    null (issue 17: "uc_px": null)."""
    edge = tmp_path / "edge.json"
    edge.write_text('{"camera": {"uc_px": 100000, "h_m": 1e6, "fps": 1000}, "thresholds": '
                    '{"predict_timeout_s": 86400, "n_samples": 100000, "range_min_m": 3, '
                    '"range_max_m": 1e12}}')
    assert main(["config", "-c", str(edge)]) == 0
    out = capsys.readouterr().out
    assert "null" not in out and "Infinity" not in out
    assert main(["config", "-c", str(edge), "-o", str(tmp_path / "c2.json"), "-q"]) == 0
    assert "null" not in (tmp_path / "c2.json").read_text()
