"""Video out: `open_writer` opens an output video before any processing; it is written to a
temp file that keeps the suffix and is renamed over the target on `close()` (nothing
half-written). Split from `vision.video` (which re-exports it)."""

from __future__ import annotations

import math
import os
from typing import Any

import cv2
import numpy as np

from ..io.atomic import atomic_path
from ..io.errors import BadInput, PathLike


WRITER_FOURCC = {".mp4": "mp4v", ".m4v": "mp4v", ".mov": "mp4v", ".avi": "MJPG",
                 ".webm": "VP80"}  # VP8 WebM: plays in browsers (the report), ~30x slower to write
FFMPEG_LOG_LEVEL = "8"  # AV_LOG_FATAL: FFmpeg's own lines ("[mjpeg @ 0x..] overread 8") off


def quiet_ffmpeg() -> None:
    """Keep FFmpeg's log lines off stderr while OpenCV reads and writes videos, so a damaged
    file gives the user our one line (frames read of frames announced, or why it does not
    open), not decoder chatter. OpenCV's FFmpeg backend takes its level from the environment
    variable OPENCV_FFMPEG_LOGLEVEL when it first opens a file (cv2.utils.logging does not
    reach it; measured with opencv-python 5.0); a value the user set is kept, so
    OPENCV_FFMPEG_LOGLEVEL=32 shows them again."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", FFMPEG_LOG_LEVEL)


class VideoWriter:
    """An output video written atomically; see `open_writer`. `write(frame)` takes (H, W) or
    (H, W, 3) uint8 of exactly the size given; `close()` commits, `abort()` removes the temp file.
    As a context manager it commits on success and aborts on an exception."""

    def __init__(self, path: str, fps: float | int, size: tuple[int, int]):
        self.path = path
        suffix = os.path.splitext(path)[1].lower()
        if suffix not in WRITER_FOURCC:
            raise BadInput(path, f"cannot write video: unknown extension '{suffix}' (use .mp4 "
                           "with mp4v, .avi with MJPG or .webm with VP8)")
        f = float(fps)
        if not math.isfinite(f) or f <= 0:
            raise BadInput(path, f"cannot write video at fps {fps!r}: need a positive frame rate")
        w, h = (int(s) for s in size)
        if w <= 0 or h <= 0:
            raise BadInput(path, f"cannot write video of size {w}x{h}")
        self.size, self.fourcc, self.n_written = (w, h), WRITER_FOURCC[suffix], 0
        self._cm = atomic_path(path)  # BadInput now if the directory cannot be written
        self.temp_path: str | None = self._cm.__enter__()
        quiet_ffmpeg()
        self._vw: Any = cv2.VideoWriter(self.temp_path, cv2.VideoWriter_fourcc(*self.fourcc), f,
                                        (w, h), True)
        if not self._vw.isOpened():
            self.abort()
            raise BadInput(path, f"cannot write video: codec '{self.fourcc}' did not open (use "
                           "mp4v/.mp4, MJPG/.avi or VP8/.webm)")

    def write(self, frame: np.ndarray) -> None:
        """Append one frame: (H, W) grey or (H, W, 3) BGR uint8 of the writer's size (checked)."""
        if self._vw is None:
            raise ValueError(f"{self.path}: writer is closed")
        w, h = self.size
        if frame.dtype != np.uint8 or frame.shape not in ((h, w), (h, w, 3)):
            raise ValueError(f"{self.path}: frame {frame.shape} {frame.dtype} does not match the "
                             f"writer's ({h}, {w}[, 3]) uint8")
        self._vw.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR) if frame.ndim == 2 else frame)
        self.n_written += 1

    def close(self) -> None:
        """Finish the file and rename it over `path`."""
        if self._vw is None:
            return
        self._vw.release()
        self._vw = None
        self._cm.__exit__(None, None, None)
        self.temp_path = None

    def abort(self) -> None:
        """Stop and remove the temp file; `path` is left as it was."""
        if self._vw is not None:
            self._vw.release()
            self._vw = None
        if self.temp_path is not None:
            err = RuntimeError("video writing aborted")
            self._cm.__exit__(RuntimeError, err, None)
            self.temp_path = None

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def open_writer(path: PathLike, fps: float | int, size: tuple[int, int]) -> VideoWriter:
    """Open an output video of `size` = (width, height) px at `fps` frames/s before any processing:
    .mp4/.m4v/.mov with mp4v, .avi with MJPG, .webm with VP8 (browsers play it). Raises
    `BadInput` naming `path` if the directory, the extension or the codec cannot be written."""
    return VideoWriter(os.fspath(path), fps, size)
