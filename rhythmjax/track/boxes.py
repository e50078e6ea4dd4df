"""The rhythm signal behind any tracker: I(k) of window B at the feet of given boxes (Sec. 4.1).

A detector and tracker of the user's choice gives, per object and frame, a box (MOTChallenge
text) or a foot point and width (the tracks format). Here each box becomes a tracks row:

- the foot point (u, v) px is the box's bottom centre (`foot_points`), in the library's pixel
  convention (pixel centres at integers; a box edge at e spans pixel columns e .. e + w - 1);
- width_px is the box width (the width gate (10) reads it);
- v_top is the box's top row and top_at_edge 1 where that row is the image's first
  (`top_rows`): the object goes on above the view. Rules 37 and 26 (`track.looks`) read the
  object's height from them, as they do from the tracker's moving regions;
- I(k) (grey levels) is the sum over window B of the absolute difference D = |I_k - I_(k-1)| of
  successive 8-bit grey frames (`vision.detect.window_b_intensity`, as the online tracker
  computes it): W px wide and W/5 px high, its bottom row at the foot row v, where W is the
  paper's "average human width in the image": the mean walker width (`WidthModel.mean`, 0.5 m)
  at the foot point's ground distance through the camera (3) (`vision.detect.walker_width_px`).

With candidate windows B (`offsets`, in W: `io.files.WINDOW_CANDIDATES`; the tracker's
`body.window_candidates`) I(k) is summed again in window B moved by each offset, NaN exactly
where the main I(k) is.

No sample (I = NaN) where the tracker would take none: the first frame, a frame that does not
decode or whose predecessor does not, a duplicated frame (D = 0 everywhere), a global change
(more than half the pixels with D > the motion threshold), and a foot point outside the image.
Pure functions on NumPy arrays and the `(index, t, gray)` stream of `vision.video.open_video`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from ..io import BadInput, Tracks
from ..model.params import Config
from ..vision import detect, stabilise
from ..vision.window_b import window_b_across, window_b_candidates
from .options import MotionOptions


__all__ = ["BoxSignal", "box_intensities", "check_in_image", "foot_points", "top_rows",
           "tracks_from_mot", "window_widths"]


def foot_points(left, top, width, height, scale: float = 1.0) -> tuple[np.ndarray | np.floating,
                                                                     np.ndarray | np.floating]:
    """Bottom centre (u, v) px of boxes (left, top, width, height) px given at `scale` times
    smaller resolution: the box edges are scaled first, then u = L + w/2 - 0.5 (the centre
    between the first and the last column, pixel centres at integers) and v = T + h - 1 (the
    box's last row). Arrays in, float64 arrays out."""
    L, T, w, h = (np.asarray(a, np.float64) * scale for a in (left, top, width, height))
    return L + w / 2 - 0.5, T + h - 1.0


def top_rows(top, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(v_top px, top_at_edge) of boxes whose top edge is `top` px at `scale` times smaller
    resolution: v_top = the scaled top (the box's first row), top_at_edge 1.0 where that row is
    the image's first (scaled top < 1 px: the box was cut by the image's edge or goes on above
    it; v_top NaN there, as the tracker records such a row), else 0.0. Float64 arrays."""
    T = np.asarray(top, np.float64) * scale
    edge = T < 1.0
    return np.where(edge, np.nan, T), edge.astype(np.float64)


def tracks_from_mot(mot: dict, path: str, *, fps: float, frame_base: int = 1,
                    scale: float = 1.0) -> Tracks:
    """The tracks (io.Tracks, sorted by id then frame) of MOT boxes `mot` (`io.mot.read_mot`
    columns, with `line` from `read_mot_numbered`): track_id = the MOT id, frame = the MOT frame
    - `frame_base` (the video's 0-based index), t = frame / fps (s), (u, v) = `foot_points`,
    width_px = the scaled box width, (v_top, top_at_edge) = `top_rows`, intensity NaN (to be
    measured). The MOT x, y, z columns are ignored. Raises BadInput (file and line) for a frame
    before the video's first and for two boxes of one id in one frame."""
    frame = np.asarray(mot["frame"], np.int64) - int(frame_base)
    line = np.asarray(mot["line"], np.int64)
    bad = np.flatnonzero(frame < 0)
    if bad.size:
        raise BadInput(path, f"frame {int(mot['frame'][bad[0]])} is before the video's first "
                       f"(frames are {frame_base}-based here; see --frame-base)",
                       line=int(line[bad[0]]), column="frame")
    ids = np.asarray(mot["id"], np.int64)
    order = np.lexsort((frame, ids))
    same = (np.diff(ids[order]) == 0) & (np.diff(frame[order]) == 0)
    if np.any(same):
        k = order[np.flatnonzero(same)[0] + 1]
        raise BadInput(path, f"a second box for id {int(ids[k])} in frame {int(mot['frame'][k])}",
                       line=int(line[k]))
    u, v = foot_points(mot["bb_left"], mot["bb_top"], mot["bb_width"], mot["bb_height"], scale)
    v_top, at_edge = top_rows(mot["bb_top"], scale)
    tid = np.asarray([str(i) for i in ids[order]], dtype=object)
    f = frame[order]
    return Tracks(path=path, track_id=tid, frame=f, t=f / float(fps), u=u[order], v=v[order],
                  width_px=np.asarray(mot["bb_width"], np.float64)[order] * scale,
                  intensity=np.full(len(f), np.nan), line=line[order], unit="line",
                  fps=float(fps), v_top=v_top[order], top_at_edge=at_edge[order])


def check_in_image(tracks: Tracks, width: int, height: int, mot: dict | None = None,
                   scale: float = 1.0) -> None:
    """Raise BadInput (file and line) for the first box that lies wholly outside the
    width x height image (a wrong --box-scale or video): for MOT boxes (`mot`, the columns
    `tracks` were made from) the box itself; for tracks rows the box bottom, width_px wide at
    the foot point, must reach into the image (columns) and the foot row must not be above it."""
    if mot is not None:
        L, T, w, h = (np.asarray(mot[c], np.float64) * scale
                      for c in ("bb_left", "bb_top", "bb_width", "bb_height"))
        out = (L + w <= 0) | (L >= width) | (T + h <= 0) | (T >= height)
        lines = np.asarray(mot["line"], np.int64)
    else:
        hw = np.nan_to_num(tracks.width_px) / 2
        u, v = tracks.u, tracks.v
        out = np.isfinite(u) & np.isfinite(v) & (
            (u + hw < -0.5) | (u - hw > width - 0.5) | (v < -0.5))
        lines = tracks.line
    bad = np.flatnonzero(out)
    if bad.size:
        k = int(bad[0])
        raise BadInput(tracks.path, f"the box lies outside the {width}x{height} image (wrong "
                       f"video, or boxes at another resolution: see --box-scale)",
                       line=int(lines[k]) if tracks.unit == "line" else None,
                       row=int(lines[k]) if tracks.unit != "line" else None)


def window_widths(cfg: Config, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """W px per row: the mean walker width at the foot point's ground distance (camera (3));
    NaN on or above the horizon and where u or v is NaN."""
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    W = np.full(u.shape, np.nan)
    ok = np.isfinite(u) & np.isfinite(v)
    if np.any(ok):
        W[ok] = detect.walker_width_px(cfg.camera, cfg.width, u[ok], v[ok])
    return W


@dataclass(frozen=True)
class BoxSignal:
    """I(k) per row (grey levels; NaN = no sample), the frames read from the video, and the
    frames that gave no sample: `glitch` (duplicate or global change) and `bad` (not decoded).
    `candidates`: (rows, K) float64, I(k) of window B moved down by each offset, then across
    by each of `box_intensities`' `across` (NaN exactly where `intensity` is); None when
    neither was asked for."""

    intensity: np.ndarray
    n_frames: int
    glitch: list[int]
    bad: list[int]
    candidates: np.ndarray | None = None


def box_intensities(frames: Iterable, frame: np.ndarray, u: np.ndarray, v: np.ndarray,
                    W: np.ndarray, *, motion: MotionOptions = MotionOptions(),
                    offsets: Sequence[float] = (), across: Sequence[float] = (),
                    mean: bool = False) -> BoxSignal:
    """I(k) of window B for rows (frame, u, v, W) (0-based frame index, px) over the
    `(index, t, gray | None)` stream `frames`, one pass, holding two frames: the sum of
    D = |gray_k - gray_(k-1)| over W x W/5 px ending at the foot row (`window_b_intensity`).
    NaN for the first frame, a frame or predecessor that is None, a duplicate or global-change
    frame (`motion`: the online tracker's thresholds), a foot point outside the image and a
    non-finite W. Rows at frames the stream never reaches stay NaN (the caller checks). Camera
    shake is compensated as in the tracker (`motion.stabilise`, `vision.stabilise.Stabiliser`),
    on the frames with rows to sample (a fixed camera's D is unchanged). `offsets` (walker widths
    W, negative: up): also I(k) of window B moved down by offset x W px, per offset
    (`vision.window_b.window_b_candidates`), then per offset of `across` window B moved right by
    offset x W px (rule 50b, `window_b_across`), as `BoxSignal.candidates`. `mean`: each I(k) the
    mean of D over its window (grey levels per pixel; the tracker's `body.window_per_pixel`,
    rule 35)."""
    frame = np.asarray(frame, np.int64)
    out = np.full(frame.shape, np.nan)
    offsets, across = tuple(float(o) for o in offsets), tuple(float(o) for o in across)
    n_cand = len(offsets) + len(across)
    cand = np.full(frame.shape + (n_cand,), np.nan) if n_cand else None
    order = np.argsort(frame, kind="stable")
    fs = frame[order]
    cuts = np.flatnonzero(np.r_[True, fs[1:] != fs[:-1]]) if len(fs) else np.zeros(0, np.int64)
    rows = {int(fs[c]): order[c:e] for c, e in zip(cuts, np.r_[cuts[1:], len(fs)])}
    last = int(fs[-1]) if len(fs) else -1
    prev, n, glitch, bad = None, 0, [], []
    steady = None if not motion.stabilise else stabilise.Stabiliser(
        min_shift_px=motion.stabilise_min_shift_px, screen_px=motion.stabilise_screen_px)
    for index, _t, gray in frames:
        n = index + 1
        if gray is None:
            bad.append(index)
        here = rows.get(index)
        if here is not None and gray is not None and prev is not None:
            D = detect.frame_difference(
                prev if steady is None else steady.align(prev, gray), gray)
            changed = int(np.count_nonzero(D > motion.diff_threshold))
            if detect.is_duplicate(D) or detect.is_global_change(
                    D, motion.diff_threshold, motion.global_change_fraction, changed=changed):
                glitch.append(index)
            else:
                H, Wd = D.shape
                for r in here:
                    if -0.5 <= u[r] < Wd - 0.5 and -0.5 <= v[r] < H - 0.5 and \
                            math.isfinite(W[r]) and W[r] > 0:
                        out[r] = detect.window_b_intensity(D, float(u[r]), float(v[r]),
                                                           float(W[r]), mean=mean)
                        if cand is not None:
                            at = (D, float(u[r]), float(v[r]), float(W[r]))
                            cand[r] = window_b_candidates(*at, offsets, mean=mean) + \
                                window_b_across(*at, across, mean=mean)
        prev = gray
        if index >= last:
            break
    return BoxSignal(out, n, glitch, bad, cand)
