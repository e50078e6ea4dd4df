"""The rhythm paper's verdicts of a counting run's tracks (`judge_tracks`): the batch classifier
over the tracks table alone, so a saved run can be judged again."""

from __future__ import annotations

import numpy as np

from ..io.files import CANDIDATE_COLUMNS, Tracks, to_batch
from ..model.batch import classify_tracks
from ..track.looks import height_looks
from ..track.options import SizeOptions
from .options import VerdictOptions


__all__ = ["judge_tracks"]


def judge_tracks(cfg, tracks: dict, candidates: bool = False,
                 twice_pace_heights: float = VerdictOptions.twice_pace_heights,
                 twice_pace_edge: bool = VerdictOptions.twice_pace_edge,
                 min_height_heights: float = VerdictOptions.min_height_heights,
                 stride_peak: bool = VerdictOptions.stride_peak) -> dict[str, np.ndarray]:
    """The rhythm paper's verdicts of a counting run's tracks (`tracks_table`, ids 1.. in
    order, at least one track): `model.batch.classify_tracks` over the tracks cut at gaps longer
    than the PREDICT time-out, with `candidates` the candidate windows B. Columns: track_id,
    verdict, reason, pace_hz, stride_m, ratio, speed_mps, n_samples (and candidate), and
    window_frame, the deciding window's first frame (-1: none). `twice_pace_heights` > 0:
    rule 37 on each window, from the tracks' top rows `v_top` (`track.twice.
    batch_second_look`; `VerdictOptions`' defaults), with the rows at the image's edge where
    `twice_pace_edge` (column top_at_edge). `min_height_heights` > 0: rule 26 after it on each
    window judged Pedestrian (`track.size.batch_size_look`). `stride_peak`: rule 56 with rule
    37's height (`track.twice`). Depends on nothing but the
    tracks, so a saved run can be judged again (`benchmarks/reclassify_dumps.py`)."""
    n = cfg.thresholds.n
    tr = Tracks(path="<count>", track_id=tracks["track_id"].astype(str).astype(object),
                frame=tracks["frame"], t=tracks["t"], u=tracks["u"], v=tracks["v"],
                width_px=tracks["width_px"], intensity=tracks["intensity"],
                line=np.arange(len(tracks["frame"])), fps=cfg.camera.fps,
                v_top=tracks.get("v_top"), u_top=tracks.get("u_top"),
                top_at_edge=tracks.get("top_at_edge"),
                candidates=np.stack([tracks[c] for c in CANDIDATE_COLUMNS], axis=1)
                if candidates else None)
    gap = max(1, round(float(cfg.thresholds.predict_timeout) * cfg.camera.fps))
    batch = to_batch(tr, max_gap_frames=gap, min_len=n)
    size = SizeOptions(twice_pace_heights=twice_pace_heights, twice_pace_edge=twice_pace_edge,
                       min_height_heights=min_height_heights, stride_peak=stride_peak)
    verdicts = classify_tracks(cfg, batch, progress=False,
                               second_look=height_looks(cfg, batch, size))
    # the deciding window's first frame (-1: none; the spectra): its batch row's time
    w = np.asarray(verdicts["window_row"], np.int64)
    b = np.arange(len(w))
    first = tracks["frame"][np.r_[0, np.flatnonzero(np.diff(tracks["track_id"])) + 1]]
    dt_frames = (batch.t[b, np.maximum(w, 0)] - batch.t[:, 0]) * float(cfg.camera.fps)
    window_frame = np.where(w >= 0, first + np.round(dt_frames).astype(np.int64), -1)
    keep = ("track_id", "verdict", "reason", "pace_hz", "stride_m", "ratio", "speed_mps",
            "n_samples") + (("candidate",) if candidates else ())  # the deciding window B
    out = {k: verdicts[k] for k in keep}
    out["track_id"] = out["track_id"].astype(np.int64)
    out["window_frame"] = window_frame
    return out
