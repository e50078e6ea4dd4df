"""`track_frames`: the rhythm paper's online tracker over a frame source."""

from __future__ import annotations

from ..model.params import Config
from ..vision.frames import drive_frames
from .options import TrackerOptions
from .tracker import OnlineTracker


__all__ = ["track_frames"]


def track_frames(cfg: Config, frames, *, n_frames: int | None = None, on_frame=None,
                 progress: bool = True, options: TrackerOptions | None = None):
    """Run the online tracker over `(index, t s, gray or None)` items; returns (tracks,
    verdicts, objs, tracker) as `OnlineTracker.finish` (plus the tracker). `on_frame(gray,
    index, snapshot)`, when given, is called after each decoded frame with
    `OnlineTracker.snapshot()` (the command line draws its overlay there)."""
    tracker = OnlineTracker(cfg, options)
    draw = None if on_frame is None else \
        (lambda frame, index: on_frame(frame, index, tracker.snapshot()))
    drive_frames(frames, tracker.update, draw, n_frames=n_frames, progress=progress,
                 desc="track")
    tracks, verdicts, objs = tracker.finish()
    return tracks, verdicts, objs, tracker
