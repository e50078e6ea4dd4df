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
    for name, text in BAD_CONFIGS.items():
        (d / name).write_text(text)
    _bad_tables(d, cols, lines)
    _bad_other_inputs(d, cols)
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


BAD_CONFIGS = {  # one key out of range each (or of the wrong kind)
    "k_h_neg.json": '{"camera": {"h_m": -1}}',
    "k_h_zero.json": '{"camera": {"h_m": 0}}',
    "k_theta_0.json": '{"camera": {"theta_deg": 0}}',
    "k_theta_neg.json": '{"camera": {"theta_deg": -10}}',
    "k_f_neg.json": '{"camera": {"f_m": -0.01}}',
    "k_a_zero.json": '{"camera": {"a_px_per_m": 0}}',
    "k_fps_zero.json": '{"camera": {"fps": 0}}',
    "k_fps_neg.json": '{"camera": {"fps": -15}}',
    "k_img_h_zero.json": '{"camera": {"image_height_px": 0}}',
    "k_img_w_float.json": '{"camera": {"image_width_px": 512.5}}',
    "k_range_swap.json": '{"thresholds": {"range_min_m": 20, "range_max_m": 3}}',
    "k_range_neg.json": '{"thresholds": {"range_min_m": -3}}',
    "k_timeout_neg.json": '{"thresholds": {"predict_timeout_s": -1}}',
    "k_n_small.json": '{"thresholds": {"n_samples": 2}}',
    "k_order_big.json": '{"thresholds": {"n_samples": 64, "ar_order": 63}}',
    "k_order_zero.json": '{"thresholds": {"ar_order": 0}}',
    "k_hop_neg.json": '{"thresholds": {"window_hop_samples": -1}}',
    "k_section.json": '{"camera": 3}',
    "k_unknown_section.json": '{"cameras": {"h_m": 3}}',
    "k_null.json": '{"camera": {"h_m": null}}',
    "k_inf.json": '{"camera": {"h_m": Infinity}}',
    "k_big_exp.json": '{"camera": {"h_m": 1e999}}',
}


def _write_lines(path, lines) -> None:
    path.write_text("\n".join(lines) + "\n")


def _bad_tables(d, cols, lines) -> None:
    """Tracks files damaged one way each (CSV from t.csv's lines, Parquet from its columns)."""
    head, rows = lines[0], lines[1:]
    names = head.replace('"', "").split(",")

    def cell(k: int, col: str, value: str) -> list[str]:
        out = list(rows)
        r = out[k].split(",")
        r[names.index(col)] = value
        out[k] = ",".join(r)
        return [head] + out

    drop = lambda col: [",".join(x for i, x in enumerate(ln.split(",")) if i != names.index(col))
                        for ln in lines]
    csvs = {
        "m_no_intensity.csv": drop("intensity"),
        "m_no_u.csv": drop("u"),
        "m_no_frame.csv": drop("frame"),
        "m_semicolon.csv": [ln.replace(",", ";") for ln in lines],
        "m_extra_field.csv": [head] + rows[:3] + [rows[3] + ",7"] + rows[4:],
        "m_extra_first.csv": [head, rows[0] + ",7"] + rows[1:],
        "m_truncated.csv": [head] + rows[:-1] + [",".join(rows[-1].split(",")[:4])],
        "m_text_u.csv": cell(2, "u", "1O2"),
        "m_inf_u.csv": cell(2, "u", "inf"),
        "m_minus_inf_v.csv": cell(4, "v", "-inf"),
        "m_huge_width.csv": cell(4, "width_px", "1e308"),
        "m_neg_width.csv": cell(5, "width_px", "-3"),
        "m_neg_intensity.csv": cell(5, "intensity", "-1"),
        "m_empty_id.csv": cell(3, "track_id", ""),
        "m_empty_frame.csv": cell(3, "frame", ""),
        "m_text_frame.csv": cell(3, "frame", "abc"),
        "m_frame_3_5.csv": cell(3, "frame", "3.5"),
        "m_empty_t.csv": cell(3, "t", ""),
        "m_nan_t.csv": cell(3, "t", "nan"),
        "m_dup_frame.csv": cell(3, "frame", rows[2].split(",")[1]) if False else
        [head] + rows[:3] + [rows[2]] + rows[3:],
        "m_t_back.csv": cell(6, "t", "0.01"),
        "m_label.csv": cell(1, "label", '"walker"'),
        "m_label_change.csv": cell(7, "label", '"dog"'),
        "m_empty.csv": [],
        "m_header_typo.csv": [head.replace("intensity", "intensty")] + rows,
    }
    for name, ls in csvs.items():
        if ls:
            _write_lines(d / name, ls)
        else:
            (d / name).write_bytes(b"")
    scaled = lambda x, k: str(float(x) * k) if x else x
    ms = [head] + [",".join(scaled(x, 1000) if i == 2 else x
                            for i, x in enumerate(r.split(","))) for r in rows]
    _write_lines(d / "m_millis.csv", ms)
    un = [head] + [",".join(scaled(x, 1e-3) if i in (3, 4) else x
                            for i, x in enumerate(r.split(","))) for r in rows]
    _write_lines(d / "m_normalised.csv", un)
    (d / "m_binary.csv").write_bytes(np.random.default_rng(1).integers(
        0, 256, 3000, dtype=np.uint8).tobytes())
    (d / "m_tracks.xlsx").write_bytes(b"PK\x03\x04 not really a workbook")
    (d / "m_tracks.txt").write_text(head + "\n" + rows[0] + "\n")
    # Parquet
    import pyarrow as pa
    import pyarrow.parquet as pq

    base = {k: np.asarray(v) for k, v in cols.items()}

    def parquet(name, change):
        c = dict(base)
        change(c)
        pq.write_table(pa.table(c), d / name)

    parquet("p_no_v.parquet", lambda c: c.pop("v"))
    parquet("p_u_string.parquet", lambda c: c.__setitem__("u", c["u"].astype(str)))
    parquet("p_frame_float.parquet", lambda c: c.__setitem__(
        "frame", np.where(np.arange(len(c["frame"])) == 3, 3.5, c["frame"])))
    parquet("p_null_id.parquet", lambda c: c.__setitem__(
        "track_id", pa.array([None if i == 2 else str(x) for i, x in enumerate(c["track_id"])])))
    parquet("p_dup_frame.parquet", lambda c: c.__setitem__(
        "frame", np.where(np.arange(len(c["frame"])) == 3, c["frame"][2], c["frame"])))
    parquet("p_inf_v.parquet", lambda c: c.__setitem__(
        "v", np.where(np.arange(len(c["v"])) == 4, np.inf, c["v"])))
    parquet("p_t_nan.parquet", lambda c: c.__setitem__(
        "t", np.where(np.arange(len(c["t"])) == 4, np.nan, c["t"])))
    parquet("p_label_bad.parquet", lambda c: c.__setitem__(
        "label", np.where(np.arange(len(c["label"])) == 0, "cat", c["label"])))
    good = (d / "t.parquet").read_bytes()
    (d / "p_truncated.parquet").write_bytes(good[: len(good) // 2])
    (d / "p_csv_text.parquet").write_text((d / "t.csv").read_text())
    (d / "p_empty.parquet").write_bytes(b"")


def _bad_other_inputs(d, cols) -> None:
    """Footprints, MOT boxes, calibrations and videos that are not usable."""
    fp = {k: np.asarray(cols[k]) for k in ("u", "v", "x", "y")}
    write_table(d / "fp_ok.csv", fp, ["u", "v", "x", "y"])
    fl = (d / "fp_ok.csv").read_text().splitlines()
    _write_lines(d / "fp_no_y.csv", [",".join(ln.split(",")[:3]) for ln in fl])
    _write_lines(d / "fp_text_x.csv", fl[:3] + ["1,2,abc,4"] + fl[4:])
    _write_lines(d / "fp_inf_u.csv", fl[:2] + ["inf,2,3,4"] + fl[3:])
    _write_lines(d / "fp_extra.csv", fl[:2] + ["1,2,3,4,5"] + fl[3:])
    mot = "1,1,10,10,20,40,1,-1,-1,-1\n2,1,12,10,20,40,1,-1,-1,-1\n"
    (d / "b_fields.txt").write_text(mot + "3,1,12,10\n")
    (d / "b_text.txt").write_text(mot + "3,1,1x2,10,20,40,1,-1,-1,-1\n")
    (d / "b_frame0.txt").write_text("0,1,10,10,20,40,1,-1,-1,-1\n" + mot)
    (d / "b_neg_w.txt").write_text(mot + "3,1,12,10,-20,40,1,-1,-1,-1\n")
    (d / "b_empty.txt").write_text("")
    (d / "b_id_frac.txt").write_text(mot + "3,1.5,12,10,20,40,1,-1,-1,-1\n")
    (d / "cal_broken.xml").write_text("<Camera><Geometry width='512'")
    (d / "cal_no_intr.xml").write_text("<Camera name='c'><Geometry width='512' height='512'/>"
                                       "</Camera>")
    (d / "cal_empty.yaml").write_text("")
    (d / "cal_no_k.json").write_text('{"dist": [0, 0, 0, 0, 0]}')
    (d / "cal_k_shape.json").write_text('{"camera_matrix": [[800, 0], [0, 800]]}')
    (d / "H_short.txt").write_text("1 0 0\n0 1 0\n")
    (d / "H_text.txt").write_text("1 0 0\n0 one 0\n0 0 1\n")
    (d / "H_singular.txt").write_text("1 0 0\n1 0 0\n0 0 0\n")
    (d / "vid_text.avi").write_text("this is a text file, not a video\n" * 20)
    (d / "vid_empty.mp4").write_bytes(b"")
    (d / "vid_noise.mp4").write_bytes(np.random.default_rng(2).integers(
        0, 256, 5000, dtype=np.uint8).tobytes())
    (d / "frames_empty").mkdir()
    w = cv2.VideoWriter(str(d / "one.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (128, 96),
                        False)
    w.write(np.zeros((96, 128), np.uint8))
    w.release()


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
    ("count-set-unknown-field", R, ["count", "v.avi", "-o", "cnt", "--set",
                                    "appearance.enabld=true"] + V, ["--set", "'enabld'"]),
    ("count-set-refused-value", R, ["count", "v.avi", "-o", "cnt", "--set",
                                    "stitch.max_dv_mps=-1"] + V, ["--set", "max_dv_mps"]),
    ("run-set-bad-value", R, ["run", "v.avi", "-o", "prev", "--set", "max_objects=two"] + V,
     ["--set", "max_objects=two", "whole number"]),
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

def _config_cases():
    words = {"k_h_neg.json": "h_m", "k_h_zero.json": "h_m", "k_theta_0.json": "theta_deg",
             "k_theta_neg.json": "theta_deg", "k_f_neg.json": "f_m",
             "k_a_zero.json": "a_px_per_m", "k_fps_zero.json": "fps", "k_fps_neg.json": "fps",
             "k_img_h_zero.json": "image_height_px", "k_img_w_float.json": "image_width_px",
             "k_range_swap.json": "range_m", "k_range_neg.json": "range_min_m",
             "k_timeout_neg.json": "predict_timeout_s", "k_n_small.json": "n_samples",
             "k_order_big.json": "ar_order", "k_order_zero.json": "ar_order",
             "k_hop_neg.json": "window_hop_samples", "k_section.json": "camera",
             "k_unknown_section.json": "cameras", "k_null.json": "h_m",
             "k_inf.json": "Infinity", "k_big_exp.json": "h_m"}
    out = [(f"config-{n[2:-5].replace('_', '-')}", R, ["config", "-c", n], [n, w])
           for n, w in words.items()]
    # the same checks from the verbs that read a config (before any work)
    out += [("classify-config-theta-0", R, ["classify", "t.csv", "-c", "k_theta_0.json", "-o",
                                            "v.csv"], ["k_theta_0.json", "theta_deg"]),
            ("fit-camera-config-range", F, ["camera", "fp_ok.csv", "-c", "k_range_swap.json",
                                            "--image-size", "512x512", "-o", "c2.json"],
             ["k_range_swap.json", "range"]),
            ("run-config-ar-order", R, ["run", "v.avi", "-o", "prev", "-c",
                                             "k_order_big.json"] + V, ["k_order_big.json"])]
    return out


# tracks files, damaged one way each: (file, words beside the file name)
TABLE_FILES = [
    ("m_no_intensity.csv", ["'intensity'"]), ("m_no_u.csv", ["'u'"]),
    ("m_no_frame.csv", ["'frame'"]), ("m_semicolon.csv", ["';'"]),
    ("m_extra_field.csv", ["line 5"]), ("m_extra_first.csv", ["line 2"]),
    ("m_truncated.csv", ["line"]), ("m_text_u.csv", ["line 4", "'u'", "1O2"]),
    ("m_inf_u.csv", ["line 4", "'u'"]), ("m_minus_inf_v.csv", ["line 6", "'v'"]),
    ("m_huge_width.csv", ["line 6", "'width_px'"]), ("m_neg_width.csv", ["line 7", "width_px"]),
    ("m_neg_intensity.csv", ["line 7", "intensity"]), ("m_empty_id.csv", ["line 5", "track_id"]),
    ("m_empty_frame.csv", ["line 5", "frame"]), ("m_text_frame.csv", ["line 5", "frame"]),
    ("m_frame_3_5.csv", ["line 5", "frame"]), ("m_empty_t.csv", ["line 5", "'t'"]),
    ("m_nan_t.csv", ["line 5", "t"]), ("m_dup_frame.csv", ["appears twice"]),
    ("m_t_back.csv", ["line 8", "t"]), ("m_label.csv", ["line 3", "walker"]),
    ("m_label_change.csv", ["line 9", "label"]), ("m_empty.csv", ["empty"]),
    ("m_header_typo.csv", ["'intensity'"]), ("m_millis.csv", ["milliseconds"]),
    ("m_normalised.csv", ["normalised"]), ("m_binary.csv", []), ("m_tracks.xlsx", [".xlsx"]),
    ("m_tracks.txt", [".txt"]), ("p_no_v.parquet", ["'v'"]), ("p_u_string.parquet", ["'u'"]),
    ("p_frame_float.parquet", ["row 4", "frame"]), ("p_null_id.parquet", ["row 3", "track_id"]),
    ("p_dup_frame.parquet", ["appears twice"]), ("p_inf_v.parquet", ["row 5", "'v'"]),
    ("p_t_nan.parquet", ["row 5", "'t'"]), ("p_label_bad.parquet", ["row 1", "cat"]),
    ("p_truncated.parquet", ["Parquet"]), ("p_csv_text.parquet", ["Parquet"]),
    ("p_empty.parquet", []),
]
TABLE_CASES = [(f"classify-{n.replace('.', '-').replace('_', '-')}", R,
                ["classify", n, "-o", "prev/verdicts.csv"], [n] + w) for n, w in TABLE_FILES]
# the same reader behind the other verbs (a sample)
TABLE_CASES += [
    (f"fit-noise-{n[:-4].replace('_', '-')}", F, ["noise", n, "-o", "n.json"], [n] + w)
    for n, w in TABLE_FILES[:8]]
TABLE_CASES += [
    ("fit-walking-label", F, ["walking", "m_label.csv", "-o", "w.json"], ["m_label.csv",
                                                                          "walker"]),
    ("fit-walking-parquet-truncated", F, ["walking", "p_truncated.parquet", "-o", "w.json"],
     ["p_truncated.parquet"]),
    ("rhythm-boxes-csv-no-u", R, ["rhythm", "v.avi", "--boxes", "m_no_u.csv", "-o", "prev"] + V,
     ["m_no_u.csv", "'u'"]),
    ("rhythm-boxes-csv-dup-frame", R, ["rhythm", "v.avi", "--boxes", "m_dup_frame.csv", "-o",
                                       "prev"] + V, ["m_dup_frame.csv", "twice"]),
]

HC = ["--homography-convention", "image-uv", "--image-size", "512x512", "-o", "cam.json"]
OTHER_CASES = [
    # footprints
    ("fit-camera-footprints-no-y", F, ["camera", "fp_no_y.csv", "-o", "c2.json"],
     ["fp_no_y.csv", "'y'"]),
    ("fit-camera-footprints-text", F, ["camera", "fp_text_x.csv", "-o", "c2.json"],
     ["fp_text_x.csv", "line 4", "'x'"]),
    ("fit-camera-footprints-inf", F, ["camera", "fp_inf_u.csv", "-o", "c2.json"],
     ["fp_inf_u.csv", "line 3", "'u'"]),
    ("fit-camera-footprints-extra", F, ["camera", "fp_extra.csv", "-o", "c2.json"],
     ["fp_extra.csv", "line 3"]),
    ("fit-camera-footprints-missing", F, ["camera", "nope.csv", "-o", "c2.json"],
     ["nope.csv", "no such file"]),
    # MOT boxes
    ("rhythm-mot-fields", R, ["rhythm", "v.avi", "--boxes", "b_fields.txt", "-o", "prev"] + V,
     ["b_fields.txt", "line 3"]),
    ("rhythm-mot-text", R, ["rhythm", "v.avi", "--boxes", "b_text.txt", "-o", "prev"] + V,
     ["b_text.txt", "line 3", "1x2"]),
    ("rhythm-mot-frame-0", R, ["rhythm", "v.avi", "--boxes", "b_frame0.txt", "-o", "prev"] + V,
     ["b_frame0.txt", "line 1"]),
    ("rhythm-mot-negative-width", R, ["rhythm", "v.avi", "--boxes", "b_neg_w.txt", "-o",
                                      "prev"] + V, ["b_neg_w.txt", "line 3"]),
    ("rhythm-mot-empty", R, ["rhythm", "v.avi", "--boxes", "b_empty.txt", "-o", "prev"] + V,
     ["b_empty.txt"]),
    ("rhythm-mot-id-fraction", R, ["rhythm", "v.avi", "--boxes", "b_id_frac.txt", "-o",
                                   "prev"] + V, ["b_id_frac.txt", "line 3"]),
    ("rhythm-mot-missing", R, ["rhythm", "v.avi", "--boxes", "nope.txt", "-o", "prev"] + V,
     ["nope.txt", "no such file"]),
    ("fit-footprints-mot-text", F, ["footprints", "--boxes", "b_text.txt", "-o", "fp.csv"],
     ["b_text.txt", "line 3"]),
    # calibrations
    ("camera-tsai-broken-xml", R, ["camera", "--tsai", "cal_broken.xml", "-o", "cam.json"],
     ["cal_broken.xml"]),
    ("camera-tsai-no-intrinsics", R, ["camera", "--tsai", "cal_no_intr.xml", "-o", "cam.json"],
     ["cal_no_intr.xml"]),
    ("camera-tsai-missing", R, ["camera", "--tsai", "nope.xml", "-o", "cam.json"],
     ["nope.xml", "no such file"]),
    ("camera-opencv-empty", R, ["camera", "--opencv", "cal_empty.yaml", "-o", "cam.json"],
     ["cal_empty.yaml"]),
    ("camera-opencv-no-k", R, ["camera", "--opencv", "cal_no_k.json", "-o", "cam.json"],
     ["cal_no_k.json"]),
    ("camera-opencv-k-shape", R, ["camera", "--opencv", "cal_k_shape.json", "-o", "cam.json"],
     ["cal_k_shape.json"]),
    ("camera-homography-short", R, ["camera", "--homography", "H_short.txt"] + HC,
     ["H_short.txt"]),
    ("camera-homography-text", R, ["camera", "--homography", "H_text.txt"] + HC,
     ["H_text.txt", "line 2", "'one'"]),
    ("camera-homography-singular", R, ["camera", "--homography", "H_singular.txt"] + HC,
     ["H_singular.txt", "singular"]),
    # videos that do not open
    ("run-video-text", R, ["run", "vid_text.avi", "-o", "prev"] + V,
     ["vid_text.avi", "not a readable video"]),
    ("run-video-empty", R, ["run", "vid_empty.mp4", "-o", "prev"] + V,
     ["vid_empty.mp4", "0 bytes"]),
    ("run-video-noise", R, ["run", "vid_noise.mp4", "-o", "prev"] + V, ["vid_noise.mp4"]),
    ("run-video-one-frame", R, ["run", "one.avi", "-o", "prev"] + V, ["one.avi", "frame"]),
    ("run-frames-empty-folder", R, ["run", "frames_empty", "-o", "prev", "--fps", "15"] + V,
     ["frames_empty"]),
    ("track-video-text", R, ["track", "vid_text.avi", "-o", "t2.csv"] + V, ["vid_text.avi"]),
    ("count-video-noise", R, ["count", "vid_noise.mp4", "-o", "cnt"] + V, ["vid_noise.mp4"]),
    ("rhythm-video-empty", R, ["rhythm", "vid_empty.mp4", "--boxes", "b.txt", "-o", "prev"] + V,
     ["vid_empty.mp4"]),
    ("camera-video-text", R, ["camera", "--hfov-deg", "60", "--height", "3", "--tilt", "10",
                              "--video", "vid_text.avi", "-o", "cam.json"], ["vid_text.avi"]),
    # output paths
    ("classify-out-fifo", R, ["classify", "t.csv", "-o", "ff"], ["ff"]),
    ("classify-out-devnull", R, ["classify", "t.csv", "-o", os.devnull], [os.devnull]),
    ("classify-out-in-a-file", R, ["classify", "t.csv", "-o", "blocker/v.csv"], ["blocker"]),
    ("simulate-out-no-dir", R, ["simulate", "-o", "nowhere/s.csv"], ["nowhere"]),
    ("simulate-out-is-config", R, ["simulate", "-o", "t.csv", "-c", "t.csv"], ["t.csv"]),
    ("track-out-no-dir", R, ["track", "v.avi", "-o", "nowhere/t.csv"] + V, ["nowhere"]),
    ("track-overlay-no-dir", R, ["track", "v.avi", "-o", "t2.csv", "--overlay",
                                 "nowhere/o.mp4"] + V, ["nowhere"]),
    ("run-out-fifo", R, ["run", "v.avi", "-o", "ff"] + V, ["ff"]),
    ("count-out-is-a-file", R, ["count", "v.avi", "-o", "blocker/sub"] + V, ["blocker"]),
    ("demo-out-fifo", R, ["demo", "-o", "ff", "-q"], ["ff"]),
    # a scene that cannot be placed says why (it ran for hours)
    ("demo-walkers-100000", R, ["demo", "-o", "prev", "--walkers", "100000", "-q"],
     ["cannot place 100000 walkers", "512x512", "about 141 walkers fit"]),
    ("demo-walkers-1000-few-frames", R, ["demo", "-o", "d", "--walkers", "1000", "--frames",
                                         "20", "-q"], ["cannot place 1000 walkers"]),
    ("camera-out-txt", R, ["camera", "--hfov-deg", "60", "--height", "3", "--tilt", "10",
                           "--image-size", "512x512", "-o", "a_dir"], ["a_dir"]),
    ("fit-walking-out-devnull", F, ["walking", "t.csv", "-o", os.devnull], [os.devnull]),
]
FILE_CASES += _config_cases() + TABLE_CASES + OTHER_CASES

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
    assert len(ids) == len(set(ids)) and len(ids) >= 150


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
