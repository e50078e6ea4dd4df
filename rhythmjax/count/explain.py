"""Unjudged tracks that another track explains (issue 16 item 4; `ExplainOptions`).

The counting rule (`counting.COUNT_RULE`) counts a track too short to judge (unclassified, not
too fast) as a walker. On PETS09-S2L1 most of the overcount is such tracks on a person who is
already counted (docs/rules.md, "Unjudged tracks explained by another track"). With
`explain.enabled` an unclassified track B is not counted when a stronger track A explains it:

- A explains B only when A is counted itself (so the object keeps one count) and is stronger
  than B: judged pedestrian, or unclassified with more measured rows than B (equal: the lower
  id); of a set of fragments of one walker the strongest always stays counted;
- duplicate: A is measured in at least `duplicate_fraction` of B's measured frames with its
  ground point within `duplicate_widths` body widths (`width.mean` m) of B's,
      #{f in F_B : f in F_A, |p_A(f) - p_B(f)| <= d_dup} >= duplicate_fraction |F_B|;     (E1)
- continuation: B starts after A's last measured frame, within `max_gap_s`, close enough for
  a walker to have covered the distance in the gap, or (with `precedes`) ends before A's
  first the same way:
      0 < g <= max_gap_s,  |p_B(first) - p_A(last)| <= r0 + speed_mps g                    (E2)
  (g s: the gap, r0 = `continue_widths` body widths, p: ground points of measured rows, m).

A track explained is reported (`explained_by`: A's id, 0 for none; `explained_as`: "duplicate"
| "continues" | "precedes" | "") and left out of `walkers` (counted as `explained`); the range
walkers_low .. walkers_high is unchanged. Only the ground points of measured rows are used, so the
rule can be re-applied to a saved tracks table (`benchmarks/diag_count_unjudged.py`).
"""

from __future__ import annotations

import numpy as np


__all__ = ["explain_tracks", "measured_points"]


def measured_points(tracks: dict, track_ids) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per id of `track_ids`, (frames (n,) int, ground points (n, 2) m) of its measured rows
    ("observe" state, finite x_est, y_est) in the tracks table `tracks`, sorted by frame."""
    tid = np.asarray(tracks["track_id"])
    ok = (np.asarray(tracks["state"]).astype(str) == "observe") & \
        np.isfinite(tracks["x_est"]) & np.isfinite(tracks["y_est"])
    out = []
    for i in track_ids:
        m = ok & (tid == i)
        fr = np.asarray(tracks["frame"])[m].astype(np.int64)
        xy = np.stack([np.asarray(tracks["x_est"])[m], np.asarray(tracks["y_est"])[m]], 1)
        o = np.argsort(fr, kind="stable")
        out.append((fr[o], xy[o]))
    return out


def _duplicate(fa, pa, fb, pb, d_max: float, fraction: float) -> bool:
    """(E1): B's measured frames in which A is measured within d_max m, at least `fraction` of
    them."""
    if not len(fb):
        return False
    _, ia, ib = np.intersect1d(fa, fb, assume_unique=True, return_indices=True)
    near = np.hypot(*(pa[ia] - pb[ib]).T) <= d_max
    return int(near.sum()) >= fraction * len(fb)


def _continues(f_end, p_end, f_start, p_start, fps: float, r0: float, speed: float,
               max_gap_s: float) -> bool:
    """(E2) for a track ending at (f_end, p_end) and a later one starting at (f_start,
    p_start)."""
    g = float(f_start - f_end) / fps
    return bool(0 < g <= max_gap_s) and float(np.hypot(*(p_start - p_end))) <= r0 + speed * g


def explain_tracks(points, verdicts, counted, fps: float, opt, body_width_m: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(explained_by (B,) int: 1 + the index of the track that explains each track, 0 for
    none; explained_as (B,) object: "duplicate" | "continues" | "precedes" | "") for tracks
    with measured `points` (`measured_points`), verdicts ("pedestrian" | "non-pedestrian" |
    "unclassified") and `counted` flags (`counting.counted`, before this rule), at `fps`
    frames/s; `opt` an `ExplainOptions`, body width in m. Only counted unclassified tracks can
    be explained, only by stronger counted tracks (module doc): duplicates (E1) first (the
    first such track), then the continuation (E2) nearest on the ground."""
    v = [str(x) for x in verdicts]
    cnt = np.asarray(counted, bool)
    n = np.asarray([len(f) for f, _ in points])
    B = len(v)
    by = np.zeros(B, np.int64)
    how = np.full(B, "", dtype=object)
    if not opt.enabled:
        return by, how
    judged = np.asarray([w != "unclassified" for w in v])
    d_dup = opt.duplicate_widths * body_width_m
    r0 = opt.continue_widths * body_width_m
    for b in range(B):
        if judged[b] or not cnt[b] or not n[b]:
            continue
        fb, pb = points[b]
        stronger = [a for a in range(B) if a != b and n[a] and cnt[a] and
                    (judged[a] or n[a] > n[b] or (n[a] == n[b] and a < b))]
        dup = [a for a in stronger if _duplicate(*points[a], fb, pb, d_dup,
                                                 opt.duplicate_fraction)]
        if dup:
            by[b], how[b] = dup[0] + 1, "duplicate"
            continue
        best = (np.inf, 0, "")
        for a in stronger:
            fa, pa = points[a]
            if _continues(fa[-1], pa[-1], fb[0], pb[0], fps, r0, opt.speed_mps, opt.max_gap_s):
                d = float(np.hypot(*(pb[0] - pa[-1])))
                best = min(best, (d, a + 1, "continues"))
            if opt.precedes and _continues(fb[-1], pb[-1], fa[0], pa[0], fps, r0,
                                           opt.speed_mps, opt.max_gap_s):
                d = float(np.hypot(*(pa[0] - pb[-1])))
                best = min(best, (d, a + 1, "precedes"))
        by[b], how[b] = best[1], best[2]
    return by, how
