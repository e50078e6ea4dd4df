"""Outputs replaced as a whole (issue 17): `io.OutputSet`, SIGINT and SIGTERM in the middle of a
run (subprocesses), what a short or partly unreadable video says, and the words of a failed
`rhythmjax-fit`."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from fit.cli import failure
from rhythmjax.cli.common import reading_check
from rhythmjax.io import BadInput, OutputSet, Terminated, atomic_write, raise_on_sigterm
from rhythmjax.vision.video import open_video


def _files(d) -> dict:
    out = {}
    for n in sorted(os.listdir(d)):
        with open(os.path.join(d, n), "rb") as f:
            out[n] = f.read()
    return out


def _old_set(d, names) -> dict:
    os.makedirs(d, exist_ok=True)
    for n in names:
        with open(os.path.join(d, n), "wb") as f:
            f.write(f"old {n}".encode())
    return _files(d)


NAMES = ("a.csv", "b.png", "c.mp4")


def test_a_set_is_renamed_in_only_when_the_block_succeeds(tmp_path):
    old = _old_set(tmp_path, NAMES + ("stale.mp4",))
    paths = [tmp_path / n for n in NAMES]
    for boom in (RuntimeError("disk full"), KeyboardInterrupt(), Terminated("SIGTERM")):
        with pytest.raises(type(boom)):
            with OutputSet(paths) as outs:
                for p in paths[:2]:
                    with open(outs.path(p), "w") as f:
                        f.write("new")
                raise boom
        assert _files(tmp_path) == old  # the old set whole, no temp file
    with OutputSet(paths, drop=[tmp_path / "stale.mp4"]) as outs:
        for p in paths:
            with open(outs.path(p), "w") as f:
                f.write(f"new {p.name}")
    assert _files(tmp_path) == {n: f"new {n}".encode() for n in NAMES}


def test_a_writer_that_wrote_nothing_fails_the_set_and_a_made_folder_goes(tmp_path):
    d = tmp_path / "new"
    os.mkdir(d)
    with pytest.raises(FileNotFoundError):
        with OutputSet([d / "a.csv", d / "b.csv"], made=d) as outs:
            with open(outs.path(d / "a.csv"), "w") as f:
                f.write("x")
    assert not d.exists()


@pytest.mark.parametrize("bad, words", [
    ("input", "is the input"), ("fifo", "not a regular file"), ("twice", "two of the outputs"),
    ("dir", "directory"), ("missing-dir", "does not exist")])
def test_a_set_is_refused_before_any_work(tmp_path, bad, words):
    src = tmp_path / "in.csv"
    src.write_text("x")
    os.mkfifo(tmp_path / "ff")
    (tmp_path / "sub").mkdir()
    paths = {"input": [tmp_path / "sub" / ".." / "in.csv"], "fifo": [tmp_path / "ff"],
             "twice": [tmp_path / "o.csv", tmp_path / "sub/../o.csv"],
             "dir": [tmp_path / "sub"], "missing-dir": [tmp_path / "no" / "o.csv"]}[bad]
    with pytest.raises(BadInput, match=words):
        OutputSet(paths, inputs=[src])
    assert sorted(os.listdir(tmp_path)) == ["ff", "in.csv", "sub"]


# SIGINT raises KeyboardInterrupt in the child as in a terminal: a test run started in the
# background of a non-interactive shell (`pytest &`) inherits SIGINT ignored, and a Python
# started so keeps ignoring it (as a command run with `&` should).
MAIN = ("import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
        "from rhythmjax.cli.main import main; sys.exit(main())")


def _popen(args) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env)


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupted_demo_keeps_the_previous_set_whole(tmp_path, sig, code):
    """Killed while it writes its overlay: exit 130/143, one line, the old five files as they
    were and no temp file."""
    out = tmp_path / "out"
    old = _old_set(out, ("tracks.parquet", "verdicts.csv", "spectra.png", "truth.csv",
                         "overlay.mp4"))
    p = _popen([sys.executable, "-c", MAIN, "demo", "-o", str(out), "--frames",
                "400", "--walkers", "1", "-q"])
    t0 = time.monotonic()
    while not any(".tmp" in n for n in os.listdir(out)):
        assert p.poll() is None and time.monotonic() - t0 < 120, p.communicate()
        time.sleep(0.05)
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert _files(out) == old


WRITER = """
import sys, time
from rhythmjax.io import atomic_write, raise_on_sigterm
raise_on_sigterm()
with atomic_write(sys.argv[1], "w") as f:
    print("writing", flush=True)
    time.sleep(60)
"""


def test_sigterm_while_writing_leaves_no_temp_file(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    p = _popen([sys.executable, "-c", WRITER, str(target)])
    assert p.stdout.readline().strip() == "writing"
    p.send_signal(signal.SIGTERM)
    p.communicate(timeout=30)
    assert p.returncode != 0
    assert os.listdir(tmp_path) == ["out.csv"] and target.read_text() == "old\n"


def test_atomic_write_removes_its_temp_file_on_terminated(tmp_path):
    with pytest.raises(Terminated):
        with atomic_write(tmp_path / "o.csv", "w") as f:
            f.write("x")
            raise Terminated("SIGTERM")
    assert os.listdir(tmp_path) == []


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")  # the drop itself
@pytest.mark.parametrize("sig, exc", [(signal.SIGTERM, Terminated),
                                        (signal.SIGINT, KeyboardInterrupt)])
def test_an_interrupt_python_dropped_still_stops_the_commit(tmp_path, sig, exc):
    """A signal whose handler runs inside a finaliser (as in JAX's garbage-collector callback,
    seen in a full test run: the demo then finished and exit 0) has its exception printed and
    dropped by Python; the set must still not be renamed in, and the interrupt comes back."""
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGINT, signal.default_int_handler)

    class Finalised:
        def __del__(self):
            os.kill(os.getpid(), sig)
            time.sleep(0.05)  # the handler runs here, inside __del__: its exception is dropped

    target = tmp_path / "o.csv"
    target.write_text("old\n")
    try:
        raise_on_sigterm()
        Finalised()  # collected at once
        with pytest.raises(exc):
            with OutputSet([target]) as out:
                with open(out.path(target), "w") as f:
                    f.write("new\n")
        assert os.listdir(tmp_path) == ["o.csv"] and target.read_text() == "old\n"
        with OutputSet([target]) as out:  # delivered once: the next set commits
            with open(out.path(target), "w") as f:
                f.write("new\n")
        assert target.read_text() == "new\n"
    finally:
        for s, h in before.items():
            signal.signal(s, h)


@pytest.fixture(scope="module")
def videos(tmp_path_factory):
    d = tmp_path_factory.mktemp("short")
    path = str(d / "full.avi")
    w = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (64, 48), False)
    rng = np.random.default_rng(0)
    for _ in range(40):
        w.write(rng.integers(0, 255, (48, 64), np.uint8))
    w.release()
    with open(path, "rb") as f:
        data = f.read()
    with open(d / "half.avi", "wb") as f:
        f.write(data[: len(data) // 2])
    folder = d / "frames"
    folder.mkdir()
    for i in range(6):
        size = (48, 64) if i != 2 else (40, 64)
        cv2.imwrite(str(folder / f"{i:03d}.png"), rng.integers(0, 255, size, np.uint8))
    (folder / "004.png").write_bytes(b"not a png")
    return d


@pytest.mark.parametrize("name, words", [
    ("full.avi", None),
    ("half.avi", "of 40 frames announced"),
    ("frames", "2 frame(s) skipped (frame 2 (002.png): size 64x40, not 64x48; skipped; 1 more)"),
])
def test_a_short_or_partly_unreadable_video_says_so_in_one_line(videos, capsys, name, words):
    path = str(videos / name)
    with open_video(path, fps=15.0) as src:
        n = sum(1 for _ in src)
    lost = src.shortfall()
    assert (lost is None) if words is None else (words in lost), lost
    args = SimpleNamespace(video=path, strict=False)
    reading_check(args, src)
    err = capsys.readouterr().err
    assert err == ("" if words is None else f"warning: {path}: {lost}\n")
    if words is not None:
        with pytest.raises(BadInput, match="--strict"):
            reading_check(SimpleNamespace(video=path, strict=True), src)
    assert n >= 6


def test_a_reader_that_stops_early_is_not_called_short(videos):
    with open_video(str(videos / "full.avi")) as src:
        for i, _t, _f in src:
            if i == 5:
                break
    assert src.shortfall() is None


@pytest.mark.parametrize("success, result, reasons, said", [
    (False, "max steps reached", [], "the solver failed (max steps reached)"),
    (False, "", ["se of h_m 40 %"], "the solver failed (no result code); also se of h_m 40 %"),
    (True, "successful", ["r_corr at its bound 0.99"],
     "the solver converged but the fit is ill-determined: r_corr at its bound 0.99"),
])
def test_a_failed_fit_says_what_failed_without_contradiction(success, result, reasons, said):
    r = SimpleNamespace(success=success, result=result, reasons=reasons,
                        ill_determined=bool(reasons))
    text = failure(r)
    assert text == said
    assert not (success is False and "successful" in text)


def test_dropped_interrupts_are_not_printed(monkeypatch):
    """An interrupt raised where Python drops exceptions (a garbage-collector callback) is
    pending for the outputs and not printed as "Exception ignored"; any other unraisable
    exception still reaches the previous hook."""
    import types

    from rhythmjax.io import atomic

    seen, handlers = [], {}
    monkeypatch.setattr(sys, "unraisablehook", lambda u: seen.append(u.exc_value))
    monkeypatch.setattr(signal, "signal", lambda s, h: handlers.setdefault(s, h))
    atomic.raise_on_sigterm()
    with pytest.raises(atomic.Terminated) as mine:
        handlers[signal.SIGTERM](signal.SIGTERM, None)
    other = ValueError("other")
    sys.unraisablehook(types.SimpleNamespace(exc_value=mine.value))
    sys.unraisablehook(types.SimpleNamespace(exc_value=other))
    assert seen == [other]
    atomic.raise_on_sigterm()  # forgets the pending interrupt
