"""Video in and out: a file OpenCV decodes, or a folder of numbered frames (RELIABILITY.md
section 3, items 1-6, 10, 13, 15).

`open_video` checks the input before any work and yields `(index, t, frame)`: the 0-based frame
index, its time t = index / fps in s, and the frame as 8-bit grey (H, W) uint8, or None for a frame
of a folder that fails to decode (a missing measurement; recorded in `bad_frames`). Conversion to
grey is explicit (BGR, BGRA, 16-bit or grey in; see `to_gray_u8`). The pipeline sees grey only;
with `keep_colour` set, the source also keeps each frame's decoded BGR (no second decode) for the
annotated video to draw on, until `colour(index)` takes it. Writing video is
`vision.video_out` (`open_writer`), re-exported here.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterator
from typing import Any

import cv2
import numpy as np

from ..io.errors import BadInput, PathLike
from .video_out import (
    WRITER_FOURCC as WRITER_FOURCC,
    VideoWriter as VideoWriter,
    open_writer as open_writer,
    quiet_ffmpeg,
)


FRAME_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff")
MAX_FPS = 1000.0  # a container frame rate above this (or 0, NaN) is taken as absurd
_TRUNCATED_HINT = ("; if the recording was interrupted the file is probably truncated ('moov atom "
                   "not found'): re-mux or repair it (e.g. ffmpeg -i in.mp4 -c copy out.mp4)")


def to_gray_u8(frame: np.ndarray) -> np.ndarray:
    """8-bit grey (H, W) uint8 from a grey (H, W) / (H, W, 1), BGR (H, W, 3) or BGRA (H, W, 4)
    frame of uint8 or uint16. BGR(A) -> grey with OpenCV's weights (0.114 B + 0.587 G + 0.299 R,
    alpha ignored); 16 bit -> 8 bit as round(g * 255 / 65535). Anything else: ValueError."""
    if frame.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"unsupported frame dtype {frame.dtype} (need uint8 or uint16)")
    if frame.ndim == 3 and frame.shape[2] == 1:
        frame = frame[:, :, 0]
    if frame.ndim == 3 and frame.shape[2] == 3:
        frame = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    elif frame.ndim == 3 and frame.shape[2] == 4:
        frame = cv2.cvtColor(frame, cv2.COLOR_BGRA2GRAY)
    elif frame.ndim != 2:
        raise ValueError(f"unsupported frame shape {frame.shape}")
    if frame.dtype == np.uint16:
        frame = ((frame.astype(np.uint32) * 255 + 32767) // 65535).astype(np.uint8)
    return np.ascontiguousarray(frame)


CHROMA_LEVELS = 8  # a pixel whose B, G, R spread over more than this many grey levels is coloured
CHROMA_SHARE = 0.005  # ... and a frame with more than this share of such pixels is a colour one
# (grey content coded as colour, e.g. MJPG, decodes with channels up to 2 levels apart)


def colour_bgr(frame: np.ndarray) -> np.ndarray | None:
    """The BGR (H, W, 3) uint8 of a decoded 8-bit BGR or BGRA frame (alpha dropped; BGR as it
    is, no copy); None for grey or 16-bit."""
    if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] not in (3, 4):
        return None
    return frame if frame.shape[2] == 3 else cv2.cvtColor(frame, cv2.COLOR_BGRA2BGR)


def has_colour(frame: np.ndarray) -> bool:
    """Whether a decoded frame shows colour: 8-bit BGR(A) with more than CHROMA_SHARE of its
    pixels' channels spread over more than CHROMA_LEVELS grey levels (grey content stored as
    BGR is not colour)."""
    bgr = colour_bgr(frame)
    if bgr is None:
        return False
    spread = bgr.max(axis=2) - bgr.min(axis=2)
    return bool(np.mean(spread > CHROMA_LEVELS) > CHROMA_SHARE)


def _natural_key(name: str) -> list[Any]:
    return [(0, int(t), "") if t.isdigit() else (1, 0, t.lower()) for t in re.split(r"(\d+)", name)]


def _fourcc_text(code: float) -> str:
    c = int(code) if math.isfinite(code) else 0
    s = "".join(chr((c >> 8 * i) & 0xFF) for i in range(4))
    return s if c and s.isprintable() else f"0x{c:08x}"


def _check_fps(path: str, fps: float | int | None) -> float | None:
    if fps is None:
        return None
    f = float(fps)
    if not math.isfinite(f) or f <= 0:
        raise BadInput(path, f"--fps {fps!r}: need a positive frame rate (frames/s)")
    return f


class VideoSource:
    """A checked video or frame folder; iterate for `(index, t_s, gray_uint8 | None)`.

    Attributes: `path`, `fps` (frames/s used for t), `fps_container` (the file's, NaN for a folder),
    `width`, `height` (px), `fourcc` ("" for a folder), `is_folder`, `n_frames` (announced by the
    container, or the number of files; may lie), `n_frames_read` (frames yielded so far, None
    frames included), `bad_frames` (indices yielded as None), `notes` (warnings for the run
    summary, e.g. ``read 18 of 30 frames announced``), `is_colour` (the first frame shows colour:
    `has_colour`). Iterating again restarts from frame 0.
    Set `keep_colour` before iterating to keep each yielded frame's BGR (a colour source only)
    until `colour(index)` takes it (the overlay, once per frame, bounds the memory to the
    frames read ahead of it).
    A video file's stream ends at the first frame OpenCV fails to read (it cannot skip one, and
    truncation looks the same); a folder yields None for an undecodable or wrongly sized frame.
    """

    def __init__(self, path: str, fps: float | int | None = None):
        self.path = path
        self.bad_frames: list[int] = []
        self.notes: list[str] = []
        self.n_frames_read = 0
        self.pass_ended = False
        self.keep_colour = False
        self.is_colour = False
        self._colour: dict[int, np.ndarray] = {}
        self._kept: np.ndarray | None = None
        self._cap: Any = None
        self._first: list[np.ndarray] = []
        self._first_bgr: list[np.ndarray | None] = []
        override = _check_fps(path, fps)
        if not os.path.exists(path):
            raise BadInput(path, "no such file")
        self.is_folder = os.path.isdir(path)
        if self.is_folder:
            self._open_folder(override)
        else:
            self._open_file(override)
        self._n_open_notes = len(self.notes)

    # -- opening ---------------------------------------------------------------------------------
    def _open_folder(self, override: float | None) -> None:
        names = [n for n in os.listdir(self.path) if n.lower().endswith(FRAME_SUFFIXES)
                 and not n.startswith(".") and os.path.isfile(os.path.join(self.path, n))]
        if not names:
            raise BadInput(self.path, "is a directory with no frames "
                           "(.jpg, .jpeg, .png, .bmp, .tif)")
        self._files = [os.path.join(self.path, n) for n in sorted(names, key=_natural_key)]
        self.n_frames = len(self._files)
        if self.n_frames < 2:
            raise BadInput(self.path, "video has 1 frame; need >= 2")
        first = self._read_image(self._files[0], colour=True)
        self.is_colour = self._kept is not None and has_colour(self._kept)
        if first is None:
            raise BadInput(self._files[0], "first frame of the folder does not decode")
        self.height, self.width = first.shape
        self.fourcc, self.fps_container = "", math.nan
        if override is None:
            raise BadInput(self.path, "a folder of frames has no frame rate; give fps= (--fps)")
        self.fps = override

    def _open_file(self, override: float | None) -> None:
        size = os.path.getsize(self.path)
        if size == 0:
            raise BadInput(self.path, "not a readable video (0 bytes)")
        quiet_ffmpeg()
        cap = cv2.VideoCapture(self.path)
        if not cap.isOpened():
            cap.release()
            hint = _TRUNCATED_HINT if self.path.lower().endswith((".mp4", ".mov", ".m4v")) else ""
            raise BadInput(self.path,
                           f"not a readable video (OpenCV/FFMPEG could not open it){hint}")
        self._cap = cap
        try:
            self._check_file(override)
        except BaseException:
            self.close()
            raise

    def _check_file(self, override: float | None) -> None:
        cap = self._cap
        self.fourcc = _fourcc_text(cap.get(cv2.CAP_PROP_FOURCC))
        n = cap.get(cv2.CAP_PROP_FRAME_COUNT)
        self.n_frames = int(n) if math.isfinite(n) and n > 0 else None
        frames = []
        for _ in range(2):
            ok, f = cap.read()
            if not ok or f is None:
                break
            frames.append(self._convert(f, len(frames)))
            self._first_bgr.append(colour_bgr(f))
            if len(frames) == 1:
                self.is_colour = has_colour(f)
        if not frames:
            raise BadInput(self.path, f"the container opens but no frame decodes (fourcc "
                           f"'{self.fourcc}'; codec missing from this OpenCV build?)")
        if len(frames) < 2:
            raise BadInput(self.path, "video has 1 frame; need >= 2")
        self._first = frames
        self.height, self.width = frames[0].shape
        self.fps_container = float(cap.get(cv2.CAP_PROP_FPS))
        good = math.isfinite(self.fps_container) and 0 < self.fps_container <= MAX_FPS
        if override is None and not good:
            raise BadInput(self.path, f"frame rate in the file is {self.fps_container!r} "
                           "(0, NaN or absurd); give fps= (--fps)")
        self.fps = override if override is not None else self.fps_container
        if good and abs(self.fps - self.fps_container) > 0.01 * self.fps_container:
            self.notes.append(f"fps {self.fps:g} used; the file says {self.fps_container:g}")

    def _convert(self, frame: np.ndarray, index: int) -> np.ndarray:
        try:
            return to_gray_u8(frame)
        except ValueError as e:
            raise BadInput(self.path, f"frame {index}: {e}") from None

    def _read_image(self, file: str, colour: bool = False) -> np.ndarray | None:
        """The grey frame of an image file (None: it does not decode); with `colour`, its BGR
        (`colour_bgr`) in `_kept`."""
        img = cv2.imread(file, cv2.IMREAD_UNCHANGED)  # no implicit conversion; see to_gray_u8
        self._kept = None if img is None or not colour else colour_bgr(img)
        if img is None:
            return None
        return self._convert(img, 0)

    def _keep(self, index: int, bgr: np.ndarray | None) -> None:
        if self.keep_colour and bgr is not None:
            self._colour[index] = bgr

    def colour(self, index: int) -> np.ndarray | None:
        """The BGR (H, W, 3) uint8 of frame `index` of this pass, taken (forgotten, with any
        older frame not taken); None for a grey source, without `keep_colour`, or a frame not
        decoded."""
        bgr = self._colour.pop(index, None)
        for k in [k for k in self._colour if k < index]:
            del self._colour[k]
        return bgr

    # -- reading ---------------------------------------------------------------------------------
    def __iter__(self) -> Iterator[tuple[int, float, np.ndarray | None]]:
        self.n_frames_read = 0
        self.bad_frames = []
        self.notes = self.notes[:self._n_open_notes]  # a new pass reports its own reading
        self.pass_ended = False
        self._colour = {}
        frames = self._folder_frames() if self.is_folder else self._file_frames()
        for i, frame in enumerate(frames):
            self.n_frames_read = i + 1
            yield i, i / self.fps, frame
        self.pass_ended = True  # not when the reader stopped early

    def _folder_frames(self) -> Iterator[np.ndarray | None]:
        for i, file in enumerate(self._files):
            img = self._read_image(file, colour=self.keep_colour and self.is_colour)
            if img is not None and img.shape != (self.height, self.width):
                self.notes.append(f"frame {i} ({os.path.basename(file)}): size {img.shape[1]}x"
                                  f"{img.shape[0]}, not {self.width}x{self.height}; skipped")
                img = None
            elif img is None:
                self.notes.append(f"frame {i} ({os.path.basename(file)}) does not decode; skipped")
            if img is None:
                self.bad_frames.append(i)
            else:
                self._keep(i, self._kept)
            yield img

    def _file_frames(self) -> Iterator[np.ndarray]:
        first, self._first = self._first, []
        first_bgr, self._first_bgr = self._first_bgr, []
        if not first:  # a second pass: reopen
            self.close()
            self._cap = cv2.VideoCapture(self.path)
        for i, (gray, bgr) in enumerate(zip(first, first_bgr)):
            if self.is_colour:
                self._keep(i, bgr)
            yield gray
        i = len(first)
        while self._cap is not None:
            ok, f = self._cap.read()  # never loop on the header's frame count
            if not ok or f is None:
                break
            gray = self._convert(f, i)
            if self.keep_colour and self.is_colour:
                self._keep(i, colour_bgr(f))
            yield gray
            i += 1
        n = self.n_frames_read
        if self.n_frames is not None and n < self.n_frames:
            self.notes.append(f"read {n} of {self.n_frames} frames announced")
        self.close()

    def shortfall(self) -> str | None:
        """What the last pass lost, in one line: frames read of frames announced (a truncated or
        partly unreadable file), frames skipped and why (the first reason, then a count); None
        when every announced frame was read and used (a pass the reader stopped early is not
        judged short)."""
        parts = []
        n, announced = self.n_frames_read, self.n_frames
        if self.pass_ended and announced is not None and n < announced:
            parts.append(f"read {n} of {announced} frames announced (the file ends or stops "
                         f"decoding after frame {n - 1})")
        if self.bad_frames:
            why = [x for x in self.notes if x.endswith("skipped")]
            more = f"; {len(why) - 1} more" if len(why) > 1 else ""
            parts.append(f"{len(self.bad_frames)} frame(s) skipped"
                         + (f" ({why[0]}{more})" if why else ""))
        return "; ".join(parts) or None

    def close(self) -> None:
        """Release the capture (also done when iteration ends)."""
        if self._cap is not None:
            self._cap.release()
            self._cap = None

    def __enter__(self) -> VideoSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_video(path: PathLike, *, fps: float | int | None = None) -> VideoSource:
    """Open and check a video file or a folder of numbered frames (natural sort of .jpg, .jpeg,
    .png, .bmp, .tif); `fps` (frames/s, > 0) overrides the container's and is required for a
    folder. Reads the first two frames now; raises `BadInput` with a one-line reason."""
    return VideoSource(os.fspath(path), fps)

