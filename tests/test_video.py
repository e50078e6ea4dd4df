"""Video I/O: files and frame folders written at test time (RELIABILITY.md section 3, items 1-6, 10,
13, 15)."""

from __future__ import annotations

import math
import os

import cv2
import numpy as np
import pytest

from rhythmjax.io import BadInput
from rhythmjax.vision.video import open_video, open_writer, to_gray_u8


H, W = 48, 64


def _frames(n: int, seed: int = 0) -> list[np.ndarray]:
    """BGR uint8 frames with a bright square moving right 3 px per frame."""
    rng = np.random.default_rng(seed)
    bg = rng.integers(40, 90, (H, W, 3), dtype=np.uint8)
    out = []
    for k in range(n):
        f = bg.copy()
        cv2.rectangle(f, (5 + 3 * k, 10), (15 + 3 * k, 30), (200, 220, 240), -1)
        out.append(f)
    return out


def _write_avi(path, n: int, fps: float = 15.0) -> None:
    vw = cv2.VideoWriter(os.fspath(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (W, H))
    assert vw.isOpened()
    for f in _frames(n):
        vw.write(f)
    vw.release()


def _bad(path, **kw) -> str:
    with pytest.raises(BadInput) as e:
        open_video(path, **kw)
    return str(e.value)


def test_avi_frames_fps_and_grey(tmp_path):
    p = tmp_path / "walk.avi"
    _write_avi(p, 12, fps=15.0)
    src = open_video(p)
    assert (src.fps, src.width, src.height, src.fourcc) == (15.0, W, H, "MJPG")
    got = list(src)
    assert [i for i, _, _ in got] == list(range(12))
    assert [t for _, t, _ in got] == pytest.approx([k / 15.0 for k in range(12)])
    assert all(f.shape == (H, W) and f.dtype == np.uint8 for _, _, f in got)
    assert src.n_frames_read == 12 and src.bad_frames == [] and src.notes == []
    # MJPG is lossy: the square's grey level is near cv2's conversion of the drawn colour
    want = cv2.cvtColor(_frames(12)[4], cv2.COLOR_BGR2GRAY)
    assert np.abs(got[4][2].astype(int) - want).mean() < 4
    # a second pass restarts from frame 0
    assert [i for i, _, _ in src] == list(range(12))


def test_fps_override(tmp_path):
    p = tmp_path / "walk.avi"
    _write_avi(p, 4, fps=10.0)
    src = open_video(p, fps=7.0)
    assert src.fps == 7.0 and src.fps_container == 10.0
    assert src.notes == ["fps 7 used; the file says 10"]
    assert [t for _, t, _ in src] == pytest.approx([0, 1 / 7, 2 / 7, 3 / 7])
    for bad in (0, -1, math.nan, math.inf):
        assert "need a positive frame rate" in _bad(p, fps=bad)


def _write_folder(d, frames, ext=".png") -> None:
    d.mkdir()
    for k, f in enumerate(frames):
        assert cv2.imwrite(str(d / f"frame_{k + 1}{ext}"), f)


def test_folder_natural_sort_and_conversions(tmp_path):
    rng = np.random.default_rng(1)
    bgr = rng.integers(0, 256, (H, W, 3), dtype=np.uint8)
    bgra = np.dstack([bgr, rng.integers(0, 256, (H, W), dtype=np.uint8)])
    g16 = rng.integers(0, 65536, (H, W), dtype=np.uint16)
    bgr16 = rng.integers(0, 65536, (H, W, 3), dtype=np.uint16)
    grey = rng.integers(0, 256, (H, W), dtype=np.uint8)
    frames = [bgr, bgra, g16, bgr16, grey] * 3  # 15 frames: frame_10 must follow frame_9
    d = tmp_path / "frames"
    _write_folder(d, frames)
    src = open_video(d, fps=25)
    assert src.is_folder and src.n_frames == 15 and src.fps == 25.0
    got = [f for _, _, f in src]
    w = np.array([0.114, 0.587, 0.299])  # B, G, R weights
    ref = [np.rint(bgr @ w), np.rint(bgr @ w), np.rint(g16.astype(float) * 255 / 65535),
           np.rint((bgr16 @ w) * 255 / 65535), grey]
    for k, f in enumerate(got):
        assert f.dtype == np.uint8 and f.shape == (H, W)
        assert np.abs(f.astype(float) - ref[k % 5]).max() <= 1, k
    assert np.array_equal(got[2], ((g16.astype(np.uint32) * 255 + 32767) // 65535))
    assert np.array_equal(got[4], grey) and np.array_equal(got[14], grey)


def test_to_gray_rejects_unknown_layouts():
    with pytest.raises(ValueError, match="dtype"):
        to_gray_u8(np.zeros((4, 4), np.float32))
    with pytest.raises(ValueError, match="shape"):
        to_gray_u8(np.zeros((4, 4, 2), np.uint8))
    assert to_gray_u8(np.full((4, 4, 1), 7, np.uint8)).shape == (4, 4)


def test_corrupt_jpeg_in_the_middle(tmp_path):
    d = tmp_path / "frames"
    _write_folder(d, _frames(6), ext=".jpg")
    (d / "frame_4.jpg").write_bytes((d / "frame_4.jpg").read_bytes()[:20] + b"\x00garbage")
    src = open_video(d, fps=15)
    got = list(src)
    assert len(got) == 6 and src.n_frames_read == 6
    assert got[3][2] is None and all(f is not None for k, (_, _, f) in enumerate(got) if k != 3)
    assert src.bad_frames == [3] and "frame 3 (frame_4.jpg)" in src.notes[0]


def test_truncated_stream_stops_and_reports(tmp_path):
    p = tmp_path / "walk.avi"
    _write_avi(p, 30)
    data = p.read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    src = open_video(cut)
    assert src.n_frames == 30
    n = sum(1 for _ in src)
    assert 2 <= n < 30 and src.n_frames_read == n
    assert src.notes == [f"read {n} of 30 frames announced"]
    assert sum(1 for _ in src) == n and len(src.notes) == 1  # a second pass, same report


def test_missing_and_empty_inputs(tmp_path):
    assert _bad(tmp_path / "walk.mp4").endswith("walk.mp4: no such file")
    (tmp_path / "empty").mkdir()
    assert "is a directory with no frames" in _bad(tmp_path / "empty", fps=10)
    z = tmp_path / "x.mp4"
    z.write_bytes(b"")
    assert _bad(z).endswith("x.mp4: not a readable video (0 bytes)")
    t = tmp_path / "notes.avi"
    t.write_text("this is a text file, not a video\n" * 20)
    assert "not a readable video (OpenCV/FFMPEG could not open it)" in _bad(t)
    r = tmp_path / "noise.mp4"
    r.write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    msg = _bad(r)
    assert "(OpenCV/FFMPEG could not open it)" in msg and "truncated" in msg


def test_one_frame_and_folder_without_fps(tmp_path):
    p = tmp_path / "one.avi"
    _write_avi(p, 1)
    assert _bad(p).endswith("video has 1 frame; need >= 2")
    d = tmp_path / "one"
    _write_folder(d, _frames(1))
    assert _bad(d, fps=10).endswith("video has 1 frame; need >= 2")
    d2 = tmp_path / "two"
    _write_folder(d2, _frames(2))
    assert "no frame rate" in _bad(d2)


def test_first_frame_fails_to_decode_names_fourcc(tmp_path):
    # An MJPG avi whose JPEG payloads are overwritten: the container opens, no frame decodes.
    p = tmp_path / "flat.avi"
    vw = cv2.VideoWriter(str(p), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (W, H))
    for k in range(5):
        vw.write(np.full((H, W, 3), 40 * k, np.uint8))
    vw.release()
    data = bytearray(p.read_bytes())
    i = data.find(b"\xff\xd8")
    while i != -1:
        data[i: i + 200] = bytes(200)
        i = data.find(b"\xff\xd8", i + 200)
    bad = tmp_path / "nocodec.avi"
    bad.write_bytes(bytes(data))
    cap = cv2.VideoCapture(str(bad))
    opened, ok = cap.isOpened(), cap.read()[0]
    cap.release()
    if not opened or ok:
        pytest.skip("this OpenCV build does not produce the open-but-undecodable case")
    assert "no frame decodes (fourcc 'MJPG'" in _bad(bad)


def test_absurd_container_fps(tmp_path, monkeypatch):
    p = tmp_path / "walk.avi"
    _write_avi(p, 3)
    real = cv2.VideoCapture

    class Liar:
        def __init__(self, *a):
            self._c = real(*a)

        def get(self, prop):
            return math.nan if prop == cv2.CAP_PROP_FPS else self._c.get(prop)

        def __getattr__(self, name):
            return getattr(self._c, name)

    monkeypatch.setattr(cv2, "VideoCapture", Liar)
    assert "frame rate in the file is nan" in _bad(p)
    assert open_video(p, fps=12).fps == 12.0


@pytest.mark.parametrize("ext", [".avi", ".mp4"])
def test_writer_roundtrip_atomic(tmp_path, ext):
    out = tmp_path / f"overlay{ext}"
    with open_writer(out, 15, (W, H)) as vw:
        assert vw.temp_path.endswith(ext) and os.path.dirname(vw.temp_path) == str(tmp_path)
        assert not out.exists()
        for f in _frames(5):
            vw.write(f)
        vw.write(cv2.cvtColor(f, cv2.COLOR_BGR2GRAY))
    assert out.exists() and os.listdir(tmp_path) == [out.name]
    src = open_video(out)
    assert sum(1 for _ in src) == 6 and (src.width, src.height) == (W, H)


def test_writer_failures_leave_nothing(tmp_path):
    out = tmp_path / "overlay.avi"
    with pytest.raises(RuntimeError), open_writer(out, 15, (W, H)) as vw:
        vw.write(_frames(1)[0])
        raise RuntimeError("processing failed")
    assert os.listdir(tmp_path) == []
    vw = open_writer(out, 15, (W, H))
    with pytest.raises(ValueError, match="does not match"):
        vw.write(np.zeros((H + 1, W, 3), np.uint8))
    with pytest.raises(ValueError, match="does not match"):
        vw.write(np.zeros((H, W), np.float32))
    vw.abort()
    assert os.listdir(tmp_path) == []
    with pytest.raises(BadInput, match="unknown extension '.xyz'"):
        open_writer(tmp_path / "o.xyz", 15, (W, H))
    with pytest.raises(BadInput, match="does not exist"):
        open_writer(tmp_path / "nodir" / "o.avi", 15, (W, H))
    with pytest.raises(BadInput, match="positive frame rate"):
        open_writer(out, 0, (W, H))
    assert os.listdir(tmp_path) == []


def test_ffmpeg_lines_kept_off_stderr(tmp_path):
    """A truncated MJPEG AVI: FFmpeg's own '[mjpeg @ ...] overread' line is not printed (in a
    fresh process: FFmpeg's level is fixed when OpenCV first opens a file)."""
    import subprocess
    import sys

    p = tmp_path / "walk.avi"
    _write_avi(p, 30)
    data = p.read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: int(len(data) * 0.6) + 37])  # a frame cut in the middle
    code = ("import os, sys; os.environ.pop('OPENCV_FFMPEG_LOGLEVEL', None)\n"
            "from rhythmjax.vision.video import open_video\n"
            f"src = open_video({str(cut)!r}); n = sum(1 for _ in src); print(n, src.notes)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "of 30 frames announced" in r.stdout
    assert "overread" not in r.stderr + r.stdout and "mjpeg" not in r.stderr, r.stderr
