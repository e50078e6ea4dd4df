"""Feeding frames to an online tracker: `drive_frames` runs `update` on every item a frame source
yields, with a progress bar on a terminal, and hands each decoded frame to an optional callback
(the command line draws its overlay there)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable

import numpy as np


__all__ = ["drive_frames", "progress_bar"]


def progress_bar(total: int | None, enabled: bool, desc: str):
    """A tqdm bar on stderr when `enabled` and stderr is a terminal, else None."""
    if enabled and sys.stderr.isatty():
        from tqdm import tqdm

        return tqdm(total=total or None, unit="frame", desc=desc, file=sys.stderr)
    return None


def drive_frames(frames: Iterable[tuple[int, float, np.ndarray | None]],
                 update: Callable[[int, float, np.ndarray | None], None],
                 on_frame: Callable[[np.ndarray, int], None] | None = None, *,
                 n_frames: int | None = None, progress: bool = True, desc: str = "") -> None:
    """Feed every `(index, t s, gray or None)` item to `update(index, t, gray)`, then, for a
    decoded frame (not None), call `on_frame(gray, index)` when given; a progress bar of
    `n_frames` on a terminal when `progress`."""
    bar = progress_bar(n_frames, progress, desc)
    try:
        for index, t, frame in frames:
            update(index, t, frame)
            if on_frame is not None and frame is not None:
                on_frame(frame, index)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
